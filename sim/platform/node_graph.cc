#include "sim/platform/node_graph.h"

#include <algorithm>
#include <stdexcept>

#include "sim/core/config.h"

namespace autonomsim::sim {
namespace {

// One software job's core-seconds by its cost entry, before jitter and what-if knobs.
double SwWorkSeconds(const SwCost& sw, std::int64_t in_bytes, std::int64_t out_bytes) {
  return sw.work_s + 1e-9 * sw.work_ns_per_input_byte * static_cast<double>(in_bytes) +
         1e-9 * sw.work_ns_per_output_byte * static_cast<double>(out_bytes);
}

}  // namespace

NodeGraph::NodeGraph(Platform& platform, RunMetrics* metrics, const RngStreams* rng,
                     std::string rng_prefix)
    : platform_(platform),
      kernel_(platform.kernel()),
      metrics_(metrics),
      rng_(rng),
      rng_prefix_(std::move(rng_prefix)) {}

void NodeGraph::ApplyConfig(const PlatformConfig& config) {
  mapping_config_ = config.mapping;
  transport_config_ = config.transport;
  cost_scale_config_ = config.cost_scale;
  cost_override_config_ = config.cost_override;
}

void NodeGraph::CheckConfigUsed() const {
  auto check_nodes = [this](const std::vector<std::string>& names, const std::string& field) {
    for (const std::string& name : names) {
      if (HasNode(name)) continue;
      std::string known;
      for (const Node& n : nodes_) known += (known.empty() ? "" : ", ") + n.name;
      throw UnknownPlatformName(field, name, "no node of that name (nodes: " + known + ")");
    }
  };
  auto keys = [](const auto& map) {
    std::vector<std::string> out;
    for (const auto& [key, unused] : map) out.push_back(key);
    return out;
  };
  check_nodes(keys(mapping_config_), "mapping");
  check_nodes(keys(cost_scale_config_), "cost_scale");
  check_nodes(keys(cost_override_config_), "cost_override");
  for (const auto& entry : transport_config_) {
    const std::string& name = entry.first;  // not a structured binding: clang < 16 can't capture it
    const bool found = std::any_of(topics_.begin(), topics_.end(),
                                   [&name](const Topic& t) { return t.spec.name == name; });
    if (!found) {
      std::string known;
      for (const Topic& t : topics_) known += (known.empty() ? "" : ", ") + t.spec.name;
      throw UnknownPlatformName("transport", name, "no topic of that name (topics: " + known + ")");
    }
  }
}

int NodeGraph::AddTopicImpl(TopicSpec spec, std::type_index value_type) {
  if (const auto it = transport_config_.find(spec.name); it != transport_config_.end()) {
    spec.transport = it->second.transport;
    if (it->second.depth) spec.depth = *it->second.depth;
  }
  if (spec.depth < 1) {
    throw ConfigError("topic '" + spec.name + "': depth must be >= 1, got " +
                      std::to_string(spec.depth));
  }
  for (const Topic& t : topics_) {
    if (t.spec.name == spec.name) throw ConfigError("topic '" + spec.name + "' added twice");
  }
  Topic topic{.spec = spec, .value_type = value_type};
  if (spec.transport == Transport::kDds) {
    const auto it = transport_config_.find(spec.name);
    topic.dds = DdsLinkParamsFor(
        platform_.profile(), it != transport_config_.end() ? it->second : TopicTransportConfig{},
        spec.depth);
  }
  if (spec.transport == Transport::kZeroCopy) {
    if (!spec.type.fixed_size) {
      throw ConfigError("topic '" + spec.name +
                        "': zero_copy (Iceoryx) carries fixed-size types "
                        "only, and '" +
                        spec.type.name + "' is not fixed-size; use dds");
    }
    topic.pool = platform_.chunk_pools()->PoolFor(spec.type.bytes);
    if (!topic.pool) {
      throw ConfigError("topic '" + spec.name + "': a " + spec.type.name + " (" +
                        std::to_string(spec.type.bytes) +
                        " bytes) fits no shared-memory chunk of the platform's mempools");
    }
  }
  if (metrics_) {
    topic.metrics_index = metrics_->AddTopic(spec.name, std::string(ToName(spec.transport)),
                                             spec.type.bytes, spec.depth);
  }
  topics_.push_back(std::move(topic));
  return static_cast<int>(topics_.size()) - 1;
}

// static: the node owns its slot for the run; executor: its bitstream must be known, and a slot
// it names holds the bitstream at t = 0.
void NodeGraph::PlaceInSlot(const NodeSpec& spec, const HwCost& cost,
                            const std::string& cost_name) {
  SlotExecutor* executor = platform_.slot_executor();
  const FpgaSlot& slot = *spec.mapping.slot;
  if (!executor) {
    if (slot.any()) {
      throw ConfigError("node '" + spec.name +
                        "' is mapped to slot any, which needs platform.slot_policy: executor (with "
                        "static, each hardware node owns a slot: give its number)");
    }
    platform_.fpga().Claim(*slot.index, spec.name);
    return;
  }
  if (cost.bitstream_bytes <= 0) {
    throw ConfigError("node '" + spec.name + "' runs in hardware under slot_policy executor, but " +
                      "components." + cost_name + ".hw of profile '" + platform_.profile().name +
                      "' gives no bitstream_bytes (what a slot loads to serve it)");
  }
  if (slot.any()) return;
  try {
    executor->Preload(*slot.index, spec.name);
  } catch (const std::invalid_argument& e) {
    throw ConfigError("node '" + spec.name + "' is mapped to FPGA " + e.what());
  }
}

NodeId NodeGraph::AddNode(NodeSpec spec) {
  if (const auto it = mapping_config_.find(spec.name); it != mapping_config_.end()) {
    spec.mapping = it->second;
  }
  for (const Node& n : nodes_) {
    if (n.name == spec.name) throw ConfigError("node '" + spec.name + "' added twice");
  }
  const std::string cost_name = spec.mapping.cost.value_or(spec.name);
  ComponentCost cost = spec.cost ? *spec.cost : platform_.profile().Component(cost_name);
  const bool hw = spec.mapping.target == Target::kHw;
  if (hw && !cost.hw) {
    throw ConfigError("node '" + spec.name + "' is mapped to hw, but components." + cost_name +
                      " of profile '" + platform_.profile().name + "' has no 'hw' cost");
  }
  if (!hw && !cost.sw) {
    throw ConfigError("node '" + spec.name + "' is mapped to sw, but components." + cost_name +
                      " of profile '" + platform_.profile().name + "' has no 'sw' cost");
  }
  if (hw) PlaceInSlot(spec, *cost.hw, cost_name);

  Node node{.name = spec.name, .mapping = spec.mapping, .hw = hw, .cost = cost};
  const double jitter = hw ? cost.hw->jitter : cost.sw->jitter;
  if (jitter > 0.0) {
    if (rng_ == nullptr) {
      throw std::logic_error("node '" + spec.name +
                             "' has a jittered cost but the graph has no "
                             "random streams");
    }
    node.rng.emplace(rng_->Stream(rng_prefix_ + "platform/" + spec.name));
  }
  if (const auto it = cost_scale_config_.find(spec.name); it != cost_scale_config_.end()) {
    node.cost_scale = it->second;
  }
  if (const auto it = cost_override_config_.find(spec.name); it != cost_override_config_.end()) {
    if (rng_ == nullptr) {
      throw std::logic_error("node '" + spec.name +
                             "' has a cost_override but the graph has no random streams");
    }
    node.cost_override = it->second;
    node.override_rng.emplace(
        rng_->Stream(rng_prefix_ + "platform/" + spec.name + "/cost_override"));
  }
  const std::string mapping = hw ? "hw:slot" + ToString(*spec.mapping.slot) : std::string("sw");
  node.metrics_index =
      metrics_ ? metrics_->AddNode(spec.name, mapping) : static_cast<int>(nodes_.size());
  nodes_.push_back(std::move(node));
  return NodeId{static_cast<int>(nodes_.size()) - 1};
}

int NodeGraph::AddPublisherImpl(int node, int topic) {
  if (node < 0 || node >= static_cast<int>(nodes_.size()) || topic < 0 ||
      topic >= static_cast<int>(topics_.size())) {
    throw std::out_of_range("NodeGraph::AddPublisher: no such node or topic");
  }
  publishers_.push_back(Publisher{.node = node, .topic = topic});
  const int index = static_cast<int>(publishers_.size()) - 1;
  Topic& t = topics_[static_cast<std::size_t>(topic)];
  t.publishers.push_back(index);
  if (t.spec.transport == Transport::kDds) {
    for (int s : t.subscriptions) AddDdsReader(index, s);
  }
  return index;
}

void NodeGraph::AddSubscriptionImpl(
    int node, int topic, std::function<void(const detail::EnvelopeBase&, Outbox&)> handler,
    SubscriptionOptions options) {
  Topic& t = topics_.at(static_cast<std::size_t>(topic));
  Node& n = nodes_.at(static_cast<std::size_t>(node));
  const int limit = platform_.profile().zero_copy.max_subscribers;
  if (t.spec.transport == Transport::kZeroCopy &&
      static_cast<int>(t.subscriptions.size()) >= limit) {
    throw ConfigError("topic '" + t.spec.name + "': node '" + n.name + "' would be subscriber " +
                      std::to_string(t.subscriptions.size() + 1) + ", but zero_copy (Iceoryx) " +
                      "allows at most " + std::to_string(limit) + " subscribers per topic");
  }
  if (options.cost && n.hw) {
    throw ConfigError("node '" + n.name + "': a subscription with its own cost needs a software " +
                      "node, but the node is mapped to hw");
  }
  subscriptions_.push_back(Subscription{.node = node,
                                        .topic = topic,
                                        .loaned = options.loaned,
                                        .cost = options.cost,
                                        .handler = std::move(handler)});
  const int index = static_cast<int>(subscriptions_.size()) - 1;
  t.subscriptions.push_back(index);
  n.subscriptions.push_back(index);
  if (t.spec.transport == Transport::kDds) {
    for (int p : t.publishers) AddDdsReader(p, index);
  }
}

void NodeGraph::AddDdsReader(int publisher, int subscription) {
  Publisher& pub = publishers_[static_cast<std::size_t>(publisher)];
  const Topic& topic = topics_[static_cast<std::size_t>(pub.topic)];
  DdsSocket& socket =
      SocketFor(subscriptions_[static_cast<std::size_t>(subscription)].node, topic.dds);
  const std::size_t reader = pub.dds ? pub.dds->subscriptions.size() : 0;
  DdsLink::Delivered delivered = [this, publisher, reader](std::int64_t seq) {
    DdsDelivered(publisher, reader, seq);
  };
  if (!pub.dds) {
    pub.dds = std::make_unique<DdsWriter>();
    pub.dds->link = std::make_unique<DdsLink>(kernel_, platform_.cpu(), topic.dds, Owner(pub.node),
                                              socket, std::move(delivered));
  } else {
    pub.dds->link->AddReader(socket, std::move(delivered));
  }
  pub.dds->subscriptions.push_back(subscription);
  pub.dds->in_flight.emplace_back();
}

DdsSocket& NodeGraph::SocketFor(int node, const DdsLinkParams& params) {
  const std::int64_t capacity = params.SocketCapacityBytes();
  std::unique_ptr<DdsSocket>& socket = nodes_[static_cast<std::size_t>(node)].sockets[capacity];
  if (socket) return *socket;
  socket = std::make_unique<DdsSocket>(kernel_, platform_.cpu(), Owner(node), capacity,
                                       params.sched_slice);
  socket->OnBatchDone([this, node](Time start, double core_s) {
    if (!metrics_) return;
    const int owner = Owner(node);
    metrics_->ReceiveDone(owner, kernel_.Now(), core_s);
    metrics_->Span(TraceLane::kReceive, owner, "dds receive", start, kernel_.Now());
  });
  return *socket;
}

void NodeGraph::AddTimer(NodeId node, Time first, Duration period,
                         std::function<void(Time, Outbox&)> handler) {
  Node& n = nodes_.at(static_cast<std::size_t>(node.index));
  timers_.push_back(Timer{.node = node.index, .handler = std::move(handler)});
  const int index = static_cast<int>(timers_.size()) - 1;
  n.timers.push_back(index);
  kernel_.SchedulePeriodic(
      first, period, [this, index] { OnTimer(index); }, kPriorityPlatform);
}

void NodeGraph::CheckRemap(const std::string& name, Target target) {
  const Node& n = NodeNamed(name);
  const char* kind = target == Target::kHw ? "hw" : "sw";
  if ((target == Target::kHw && !n.cost.hw) || (target == Target::kSw && !n.cost.sw)) {
    throw ConfigError("node '" + name + "' has no " + kind + " cost in profile '" +
                      platform_.profile().name + "' (components." + n.mapping.cost.value_or(name) +
                      "." + kind + ")");
  }
  if (target == Target::kHw && !platform_.slot_executor()) {
    throw ConfigError("moving node '" + name +
                      "' to hw at run time needs platform.slot_policy: executor (a slot to "
                      "reconfigure for it)");
  }
  if (target == Target::kHw && n.cost.hw->bitstream_bytes <= 0) {
    throw ConfigError("node '" + name + "' has no bitstream_bytes in its hw cost (what a slot " +
                      "loads to serve it)");
  }
}

void NodeGraph::RemapNode(const std::string& name, Target target) {
  CheckRemap(name, target);
  Node& n = NodeNamed(name);
  n.hw = target == Target::kHw;
  n.mapping.target = target;
  n.mapping.slot = n.hw ? std::optional<FpgaSlot>(FpgaSlot::Any()) : std::nullopt;
  const double jitter = n.hw ? n.cost.hw->jitter : n.cost.sw->jitter;
  if (jitter > 0.0 && !n.rng && rng_ != nullptr) {  // its stream, by name as at the start
    n.rng.emplace(rng_->Stream(rng_prefix_ + "platform/" + name));
  }
}

NodeGraph::Node& NodeGraph::NodeNamed(const std::string& name) {
  for (Node& n : nodes_) {
    if (n.name == name) return n;
  }
  throw std::invalid_argument("no node '" + name + "' on the graph");
}

void NodeGraph::HoldJob(NodeId node, Duration timeout, std::function<void()> on_timeout) {
  Node& n = nodes_.at(static_cast<std::size_t>(node.index));
  if (!n.job || n.held) {
    throw std::logic_error("HoldJob: node '" + n.name + "' has no running job or already holds");
  }
  n.held = true;
  n.hold_timeout = kernel_.ScheduleIn(
      timeout,
      [this, node, on_timeout = std::move(on_timeout)] {
        if (on_timeout) on_timeout();
        ReleaseJob(node);
      },
      kPriorityPlatform);
}

void NodeGraph::ReleaseJob(NodeId node) {
  Node& n = nodes_.at(static_cast<std::size_t>(node.index));
  if (!n.held) return;
  n.held = false;
  kernel_.Cancel(n.hold_timeout);
  if (!n.finish_held || n.hung) return;  // it finishes when its work (or the hang) ends
  n.finish_held = false;
  // after the current event: the caller may be another node's handler
  kernel_.ScheduleIn(
      Duration{0}, [this, index = node.index] { FinishJob(index); }, kPriorityPlatform);
}

bool NodeGraph::held(NodeId node) const {
  return nodes_.at(static_cast<std::size_t>(node.index)).held;
}

void NodeGraph::HangNode(const std::string& name) {
  Node& n = NodeNamed(name);
  if (!n.crashed) n.hung = true;
}

void NodeGraph::ResumeNode(const std::string& name) {
  Node& n = NodeNamed(name);
  if (!n.hung) return;
  n.hung = false;
  const int node = static_cast<int>(&n - nodes_.data());
  if (n.held) return;  // its job still waits for ReleaseJob
  if (n.finish_held) {
    n.finish_held = false;
    FinishJob(node);  // and from there the node takes its next work
  } else {
    Kick(node);
  }
}

void NodeGraph::CrashNode(const std::string& name) {
  Node& n = NodeNamed(name);
  if (n.crashed) return;
  n.crashed = true;
  n.hung = false;
  if (n.held) {
    n.held = false;
    kernel_.Cancel(n.hold_timeout);
  }
  for (int s : n.subscriptions) subscriptions_[static_cast<std::size_t>(s)].queue.clear();
  for (int t : n.timers) timers_[static_cast<std::size_t>(t)].pending = false;
  if (n.finish_held) {
    n.finish_held = false;
    FinishJob(static_cast<int>(&n - nodes_.data()));  // returns its loans, publishes nothing
  }
}

std::vector<std::string> NodeGraph::node_names() const {
  std::vector<std::string> names;
  for (const Node& n : nodes_) names.push_back(n.name);
  return names;
}

bool NodeGraph::TapImpl(const std::string& name, std::type_index value_type,
                        std::function<void(const detail::EnvelopeBase&, Time)> tap) {
  for (Topic& topic : topics_) {
    if (topic.spec.name != name) continue;
    if (topic.value_type != value_type) {
      throw std::invalid_argument("Tap: topic '" + name + "' carries another type than " +
                                  value_type.name());
    }
    topic.taps.push_back(std::move(tap));
    return true;
  }
  return false;
}

const TopicSpec& NodeGraph::topic_spec(int topic) const {
  return topics_.at(static_cast<std::size_t>(topic)).spec;
}

bool NodeGraph::HasNode(const std::string& name) const {
  return std::any_of(nodes_.begin(), nodes_.end(), [&](const Node& n) { return n.name == name; });
}

const std::string& NodeGraph::node_name(NodeId node) const {
  return nodes_.at(static_cast<std::size_t>(node.index)).name;
}

bool NodeGraph::busy(NodeId node) const {
  return nodes_.at(static_cast<std::size_t>(node.index)).job.has_value();
}

std::size_t NodeGraph::queued(NodeId node) const {
  std::size_t n = 0;
  for (int s : nodes_.at(static_cast<std::size_t>(node.index)).subscriptions) {
    n += subscriptions_[static_cast<std::size_t>(s)].queue.size();
  }
  return n;
}

std::optional<DdsLinkStats> NodeGraph::dds_stats(const std::string& topic) const {
  for (const Topic& t : topics_) {
    if (t.spec.name != topic) continue;
    if (t.spec.transport != Transport::kDds) return std::nullopt;
    DdsLinkStats sum;
    for (int p : t.publishers) {
      if (const auto& writer = publishers_[static_cast<std::size_t>(p)].dds) {
        sum += writer->link->stats();
      }
    }
    return sum;
  }
  return std::nullopt;
}

int NodeGraph::loans_held(int publisher) const {
  return publishers_.at(static_cast<std::size_t>(publisher)).loans_held;
}

TransportCost NodeGraph::CostOf(const Topic& topic, std::int64_t bytes, bool loaned_take) const {
  return topic.spec.transport == Transport::kDds
             ? DdsCost(platform_.profile(), bytes)
             : ZeroCopyCost(platform_.profile(), bytes, loaned_take);
}

double NodeGraph::Jitter(Node& node, double jitter) {
  if (jitter <= 0.0) return 1.0;
  return 1.0 + node.rng->Uniform(-jitter, jitter);
}

void NodeGraph::OnTimer(int timer) {
  Timer& t = timers_[static_cast<std::size_t>(timer)];
  if (nodes_[static_cast<std::size_t>(t.node)].crashed) return;
  const int owner = Owner(t.node);
  if (metrics_) metrics_->TimerFired(owner, kernel_.Now());
  if (t.pending) {
    if (metrics_) metrics_->TimerOverrun(owner, kernel_.Now());
    return;
  }
  t.pending = true;
  t.fired_at = kernel_.Now();
  Kick(t.node);
}

void NodeGraph::Kick(int node) {
  const Node& n = nodes_[static_cast<std::size_t>(node)];
  if (n.job || n.hung || n.crashed) return;
  for (int t : n.timers) {
    if (timers_[static_cast<std::size_t>(t)].pending) return StartJob(node);
  }
  for (int s : n.subscriptions) {
    if (!subscriptions_[static_cast<std::size_t>(s)].queue.empty()) return StartJob(node);
  }
}

void NodeGraph::StartJob(int node) {
  Node& n = nodes_[static_cast<std::size_t>(node)];
  const NextWork work = OldestWork(n);
  if (work.timer < 0 && work.subscription < 0) return;
  // the functional result, now; then the loans its outputs take, then what the job costs
  n.job.emplace(this);
  Job& job = *n.job;
  job.start = kernel_.Now();
  const TakenInput in = TakeInput(work, &job);
  const std::int64_t out_bytes = LoanOutputs(n, &job);
  CostJob(n, in, out_bytes, &job);
  if (job.take_core_s > 0.0) {
    platform_.cpu().Start(Owner(node), job.take_core_s, 1.0, [this, node] { RunCompute(node); });
  } else {
    RunCompute(node);
  }
}

NodeGraph::NextWork NodeGraph::OldestWork(const Node& n) const {
  // The oldest pending work first; at equal times timers before subscriptions, each in the order
  // they were added.
  NextWork work;
  Time oldest = Time::max();
  for (int t : n.timers) {
    const Timer& tm = timers_[static_cast<std::size_t>(t)];
    if (tm.pending && tm.fired_at < oldest) {
      oldest = tm.fired_at;
      work.timer = t;
    }
  }
  for (int s : n.subscriptions) {
    const Subscription& sub = subscriptions_[static_cast<std::size_t>(s)];
    if (!sub.queue.empty() && sub.queue.front().arrival < oldest) {
      oldest = sub.queue.front().arrival;
      work.subscription = s;
      work.timer = -1;
    }
  }
  return work;
}

NodeGraph::TakenInput NodeGraph::TakeInput(const NextWork& work, Job* job) {
  TakenInput in;
  if (work.subscription >= 0) {
    Subscription& sub = subscriptions_[static_cast<std::size_t>(work.subscription)];
    if (sub.cost) {
      in.callback_cost = &*sub.cost;
      job->own_cost = true;
    }
    job->input = std::move(sub.queue.front().message);
    sub.queue.pop_front();
    in.bytes = job->input->bytes;
    const Topic& topic = topics_[static_cast<std::size_t>(sub.topic)];
    job->take_core_s = CostOf(topic, in.bytes, sub.loaned).take_core_s;
    sub.handler(*job->input, job->out);
  } else {
    Timer& tm = timers_[static_cast<std::size_t>(work.timer)];
    tm.pending = false;
    tm.handler(tm.fired_at, job->out);
  }
  return in;
}

std::int64_t NodeGraph::LoanOutputs(const Node& n, Job* job) {
  // Zero-copy outputs are loaned now (as the real nodes borrow before they compute); a loan that
  // fails (the publisher's loan limit, or no free chunk) is counted and its message is not sent.
  std::int64_t out_bytes = 0;
  for (Outbox::Pending& p : job->out.pending_) {
    Publisher& pub = publishers_[static_cast<std::size_t>(p.publisher)];
    const Topic& topic = topics_[static_cast<std::size_t>(pub.topic)];
    if (topic.spec.transport == Transport::kZeroCopy) {
      const bool loan_ok = pub.loans_held < platform_.profile().zero_copy.max_loans_per_publisher &&
                           platform_.chunk_pools()->Acquire(*topic.pool);
      if (!loan_ok) {
        p.dropped = true;
        if (metrics_) metrics_->LoanFailed(n.metrics_index, topic.metrics_index, kernel_.Now());
        continue;
      }
      ++pub.loans_held;
      p.message->chunk = std::make_shared<ChunkLease>(platform_.chunk_pools(), *topic.pool);
    }
    out_bytes += p.message->bytes;
    if (topic.spec.transport == Transport::kDds) {
      if (pub.dds)
        job->write_core_s += topic.dds.SampleCoreSeconds(topic.dds.write, p.message->bytes);
    } else {
      job->publish_core_s += CostOf(topic, p.message->bytes, true).publish_core_s;
    }
  }
  return out_bytes;
}

void NodeGraph::CostJob(Node& n, const TakenInput& in, std::int64_t out_bytes, Job* job) {
  job->hw = n.hw;  // the mapping when the job starts (a remap takes effect from the next)
  if (n.hw) {
    const HwCost& hw = *n.cost.hw;
    const double factor = Jitter(n, hw.jitter);
    const double compute_s = n.cost_override ? DrawCostSeconds(*n.cost_override, *n.override_rng)
                                             : hw.compute_s * factor;
    const Duration fabric =
        FromSeconds(compute_s) + platform_.fpga().TransferTime(in.bytes + out_bytes);
    job->fabric = n.cost_scale == 1.0 ? fabric : FromSeconds(ToSeconds(fabric) * n.cost_scale);
    job->compute_core_s = hw.delegate_cpu_s * factor;
  } else if (in.callback_cost) {  // a subscription's own cost: no what-if knob applies
    job->compute_core_s =
        SwWorkSeconds(*in.callback_cost, in.bytes, out_bytes) * Jitter(n, in.callback_cost->jitter);
    job->max_parallelism = in.callback_cost->max_parallelism;
  } else {
    const SwCost& sw = *n.cost.sw;
    const double work = n.cost_override
                            ? DrawCostSeconds(*n.cost_override, *n.override_rng)
                            : SwWorkSeconds(sw, in.bytes, out_bytes) * Jitter(n, sw.jitter);
    job->compute_core_s = work * n.cost_scale;
    job->max_parallelism = sw.max_parallelism;
  }
}

void NodeGraph::RunCompute(int node) {
  Node& n = nodes_[static_cast<std::size_t>(node)];
  const Job& job = *n.job;
  if (job.hw && platform_.slot_executor()) {
    platform_.slot_executor()->Submit(n.name, Owner(node), n.cost.hw->bitstream_bytes, job.fabric,
                                      job.compute_core_s, [this, node] { RunPublish(node); });
  } else if (job.hw) {
    platform_.RunHwJob(*n.mapping.slot->index, Owner(node), job.fabric, job.compute_core_s,
                       [this, node] { RunPublish(node); });
  } else if (job.compute_core_s > 0.0) {
    platform_.cpu().Start(Owner(node), job.compute_core_s, job.max_parallelism,
                          [this, node] { RunPublish(node); });
  } else {
    RunPublish(node);
  }
}

void NodeGraph::RunPublish(int node) {
  const Job& job = *nodes_[static_cast<std::size_t>(node)].job;
  if (job.publish_core_s > 0.0) {
    platform_.cpu().Start(Owner(node), job.publish_core_s, 1.0,
                          [this, node] { NextDdsWrite(node); });
  } else {
    NextDdsWrite(node);
  }
}

// The job's DDS outputs, one write call after another as the node's thread makes them; the job
// finishes when the last returns. A write that blocked for max_blocking and failed sends nothing.
void NodeGraph::NextDdsWrite(int node) {
  Node& n = nodes_[static_cast<std::size_t>(node)];
  Job& job = *n.job;
  const std::vector<Outbox::Pending>& pending = job.out.pending_;
  while (!n.crashed && job.write_output < pending.size()) {
    const Outbox::Pending& p = pending[job.write_output++];
    DdsWriter* writer = publishers_[static_cast<std::size_t>(p.publisher)].dds.get();
    if (p.dropped || writer == nullptr) continue;
    const std::int64_t seq = writer->link->next_seq();
    for (auto& queue : writer->in_flight) queue.emplace_back(seq, p.message);
    const std::size_t output = job.write_output - 1;
    writer->link->Write(p.message->bytes, [this, node, writer, seq, output](bool accepted) {
      if (!accepted) {
        for (auto& queue : writer->in_flight) {
          std::erase_if(queue, [seq](const auto& sample) { return sample.first == seq; });
        }
        Node& n_now = nodes_[static_cast<std::size_t>(node)];
        if (n_now.job) n_now.job->out.pending_[output].refused = true;
      }
      NextDdsWrite(node);
    });
    return;
  }
  FinishJob(node);
}

// A reader has the writer's sample `seq` whole: the older ones it still waits for are lost.
void NodeGraph::DdsDelivered(int publisher, std::size_t reader, std::int64_t seq) {
  DdsWriter& writer = *publishers_[static_cast<std::size_t>(publisher)].dds;
  auto& queue = writer.in_flight[reader];
  while (!queue.empty() && queue.front().first < seq) queue.pop_front();
  if (queue.empty() || queue.front().first != seq) return;
  std::shared_ptr<const detail::EnvelopeBase> message = std::move(queue.front().second);
  queue.pop_front();
  Enqueue(writer.subscriptions[reader], std::move(message));
}

void NodeGraph::FinishJob(int node) {
  Node& n = nodes_[static_cast<std::size_t>(node)];
  if (n.hung || n.held) {
    n.finish_held = true;
    return;
  }
  Job job = std::move(*n.job);
  n.job.reset();
  const Time now = kernel_.Now();
  for (Outbox::Pending& p : job.out.pending_) {
    if (p.dropped) continue;
    Publisher& pub = publishers_[static_cast<std::size_t>(p.publisher)];
    const Topic& topic = topics_[static_cast<std::size_t>(pub.topic)];
    if (topic.spec.transport == Transport::kZeroCopy) --pub.loans_held;
    if (n.crashed) continue;  // died before publishing: the loan goes back, nothing is sent
    if (metrics_) metrics_->Published(n.metrics_index, topic.metrics_index, now, p.message->stamp);
    if (!p.refused) {
      for (const auto& tap : topic.taps) tap(*p.message, now);
    }
    Distribute(topic, std::move(p.message));
  }
  if (n.crashed) return;
  if (metrics_) {
    metrics_->JobDone(n.metrics_index, job.start, now,
                      job.take_core_s + job.compute_core_s + job.publish_core_s + job.write_core_s,
                      !job.own_cost);
    metrics_->Span(TraceLane::kExecutor, n.metrics_index, n.name, job.start, now);
  }
  job.input.reset();  // the taken sample (and its chunk) is released here
  Kick(node);
}

// Zero-copy: the sample reaches every subscription after the transport's latency. (A DDS sample
// went into its links as the job wrote it: NextDdsWrite.)
void NodeGraph::Distribute(const Topic& topic,
                           std::shared_ptr<const detail::EnvelopeBase> message) {
  if (topic.spec.transport != Transport::kZeroCopy) return;
  for (int s : topic.subscriptions) {
    kernel_.ScheduleIn(
        platform_.profile().zero_copy.latency, [this, s, message] { Enqueue(s, message); },
        kPriorityPlatform);
  }
}

void NodeGraph::Enqueue(int subscription, std::shared_ptr<const detail::EnvelopeBase> message) {
  Subscription& sub = subscriptions_[static_cast<std::size_t>(subscription)];
  if (nodes_[static_cast<std::size_t>(sub.node)].crashed) return;
  const Topic& topic = topics_[static_cast<std::size_t>(sub.topic)];
  const int owner = Owner(sub.node);
  const Time now = kernel_.Now();
  if (metrics_) metrics_->Arrival(owner, topic.metrics_index, now);
  sub.queue.push_back(QueuedMessage{now, std::move(message)});
  if (static_cast<int>(sub.queue.size()) > topic.spec.depth) {
    sub.queue.pop_front();  // keep-last: the oldest goes
    if (metrics_) metrics_->Dropped(owner, topic.metrics_index, now);
  }
  Kick(sub.node);
}

void AddBackgroundLoads(NodeGraph& graph, const PlatformProfile& profile, Time first) {
  for (const BackgroundLoadConfig& load : profile.background) {
    const bool replaced = std::any_of(load.replaced_by.begin(), load.replaced_by.end(),
                                      [&](const std::string& node) { return graph.HasNode(node); });
    if (replaced) continue;
    SwCost sw{.work_s = load.cpu_percent / 100.0 * ToSeconds(load.period),
              .max_parallelism = load.max_parallelism};
    const NodeId node = graph.AddNode(NodeSpec{.name = load.name, .cost = ComponentCost{.sw = sw}});
    graph.AddTimer(node, first, load.period, [](Time, Outbox&) {});
  }
}

namespace {

MetricsOptions BoardMetricsOptions(const PlatformConfig& config, Time measure_from) {
  return {.measure_from = measure_from,
          .load_bin = config.load_bin,
          .trace = config.trace,
          .trace_max_events = static_cast<std::size_t>(config.trace_max_events),
          .trace_receive = config.trace_receive_threads,
          .trace_busy_period = config.trace_busy_period};
}

}  // namespace

Board::Board(Kernel& kernel, std::string name, const PlatformConfig& config,
             const std::filesystem::path& base_dir, const RngStreams* rng, Time measure_from)
    : Board(kernel, std::move(name), config, LoadPlatformProfile(base_dir / config.profile), rng,
            measure_from) {}

Board::Board(Kernel& kernel, std::string name, const PlatformConfig& config,
             PlatformProfile profile, const RngStreams* rng, Time measure_from)
    : name_(std::move(name)),
      config_(config),
      metrics_(BoardMetricsOptions(config, measure_from)),
      platform_(kernel, WithConfigOverrides(std::move(profile), config), &metrics_),
      graph_(platform_, &metrics_, rng, name_ + "/") {
  graph_.ApplyConfig(config_);
}

BoardReport Board::Report(Time end) const {
  BoardReport out{name_, BuildReport(metrics_, end)};
  if (const SlotExecutor* executor = platform_.slot_executor()) {
    out.report.slots = executor->Report();
  }
  for (TopicReport& topic : out.report.topics) topic.dds = graph_.dds_stats(topic.name);
  return out;
}

void Board::Finish(Time first) {
  if (config_.background_loads) AddBackgroundLoads(graph_, platform_.profile(), first);
  graph_.CheckConfigUsed();
}

}  // namespace autonomsim::sim
