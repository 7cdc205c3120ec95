// The node graph, ROS 2 style: typed topics with the real message sizes, publishers, subscriptions
// with keep-last QoS (drop the oldest at the depth, counted), timers, and one executor per node
// (one job at a time; messages wait in their subscription's queue).
//
// A job is one callback run. When a node's executor starts one:
//   1. it takes the input and runs the callback now: the functional result (what the pure
//      component computes) is exact and immediate;
//   2. it asks the platform how long the job takes: take cost, then the node's compute (software
//      on the shared cores, or hardware in its slot plus its delegate thread), then the publish
//      cost of what it publishes, each at the platform's current load;
//   3. at the job's completion the outputs are published through their topics' transports,
//      stamped with the sensor time they derive from (end-to-end latency = publish - stamp).
// Build the graph (topics, nodes, publishers, subscriptions, timers) before running the kernel.
#pragma once

#include <cstdint>
#include <deque>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <type_traits>
#include <typeindex>
#include <utility>
#include <vector>

#include "sim/core/kernel.h"
#include "sim/core/random.h"
#include "sim/platform/dds_link.h"
#include "sim/platform/node_metrics.h"
#include "sim/platform/platform.h"
#include "sim/platform/platform_profile.h"

namespace autonomsim::sim {

// A message type's name, its size on the wire and whether it is fixed-size (only fixed-size types
// can use zero-copy shared memory).
struct MessageType {
  std::string name;
  std::int64_t bytes{0};
  bool fixed_size{true};
};

// The AutonomROS message types (reference §8 "Message sizes"; §3–§5 for their layout).
namespace msg {
inline MessageType Image640rgb() { return {"Image640rgb", 921600, true}; }       // 640*480*3
inline MessageType Image640mono() { return {"Image640mono", 614400, true}; }     // 640*480*2
inline MessageType PointCloud640() { return {"PointCloud640", 4915200, true}; }  // 640*480*16
inline MessageType Grid234() { return {"Grid234", 240, true}; }                  // 234 + 6 pad
inline MessageType LanePoints() { return {"LanePoints", 248, true}; }            // 30*8 + 8
}  // namespace msg

// Transport (dds, zero_copy) is in platform_profile.h, where a scenario names it.

struct TopicSpec {
  std::string name;
  MessageType type;
  Transport transport{Transport::kZeroCopy};
  int depth{3};  // keep-last history per subscription (reference §8: DDS history depth 3)
};

struct NodeSpec {
  std::string name;
  NodeMappingConfig mapping;  // sw, or hw in a slot; a scenario's mapping entry replaces it
  // The node's cost; if not given, the profile's components entry mapping.cost (default: name).
  std::optional<ComponentCost> cost;
};

struct SubscriptionOptions {
  bool loaned{true};  // zero-copy: takes the loaned sample (false: gets a copy, paid per byte)
  // A callback that costs this instead of the node's own cost, e.g. one that only keeps the
  // latest message for the node's timer (ROS 2 nodes often do). Software nodes only.
  std::optional<SwCost> cost;
};

template <class T>
struct TopicId {
  int index{-1};
};
template <class T>
struct PublisherId {
  int index{-1};
};
struct NodeId {
  int index{-1};
};

// A platform config entry (`field`: mapping, cost_scale, cost_override or transport) that names
// no node or topic of the board: a ConfigError its caller can place at the scenario's key.
struct UnknownPlatformName : ConfigError {
  UnknownPlatformName(std::string field_, std::string name_, const std::string& message)
      : ConfigError("platform." + field_ + "." + name_ + ": " + message),
        field(std::move(field_)),
        name(std::move(name_)),
        detail(message) {}
  std::string field;
  std::string name;
  std::string detail;  // the message without the key
};

class NodeGraph;

namespace detail {
// A published sample, shared by every subscription it reaches (read-only).
struct EnvelopeBase {
  virtual ~EnvelopeBase() = default;
  Time stamp{0};
  std::int64_t bytes{0};
  std::shared_ptr<ChunkLease> chunk;  // zero-copy: its shared-memory chunk
};
template <class T>
struct Envelope : EnvelopeBase {
  explicit Envelope(T v) : value(std::move(v)) {}
  T value;
};
}  // namespace detail

// What a callback publishes; sent when its job completes.
class Outbox {
 public:
  // `stamp`: the sensor time the value derives from. `bytes`: the message size if it differs from
  // the topic type's (variable-size types).
  template <class T>
  void Publish(PublisherId<T> publisher, T value, Time stamp,
               std::optional<std::int64_t> bytes = std::nullopt);

 private:
  friend class NodeGraph;
  struct Pending {
    int publisher;
    std::shared_ptr<detail::EnvelopeBase> message;
    bool dropped{false};  // its loan failed
    bool refused{false};  // its DDS write failed after max_blocking: nothing was sent
  };
  explicit Outbox(const NodeGraph* graph) : graph_(graph) {}
  const NodeGraph* graph_;
  std::vector<Pending> pending_;
};

class NodeGraph {
 public:
  // `rng` provides the jitter streams ("<rng_prefix>platform/<node>"); needed only if a cost has
  // jitter.
  NodeGraph(Platform& platform, RunMetrics* metrics, const RngStreams* rng = nullptr,
            std::string rng_prefix = "");
  NodeGraph(const NodeGraph&) = delete;
  NodeGraph& operator=(const NodeGraph&) = delete;

  // A scenario's per-node mapping and per-topic transport, applied to nodes and topics added
  // afterwards (by name).
  void ApplyConfig(const PlatformConfig& config);
  // UnknownPlatformName if a mapping or transport entry of the config named no node or topic.
  void CheckConfigUsed() const;

  // ConfigError for a zero-copy topic whose type is not fixed-size or fits no shared-memory chunk.
  template <class T>
  TopicId<T> AddTopic(TopicSpec spec) {
    return TopicId<T>{AddTopicImpl(std::move(spec), typeid(T))};
  }
  // ConfigError for an unknown cost, a node without the cost for its mapping, a bad slot.
  NodeId AddNode(NodeSpec spec);
  template <class T>
  PublisherId<T> AddPublisher(NodeId node, TopicId<T> topic) {
    return PublisherId<T>{AddPublisherImpl(node.index, topic.index)};
  }
  // `handler(value, stamp, outbox)` runs as one job per message. ConfigError when a zero-copy
  // topic would get more subscribers than the platform allows.
  template <class T>
  void AddSubscription(NodeId node, TopicId<T> topic,
                       std::function<void(const T&, Time, Outbox&)> handler,
                       SubscriptionOptions options = {}) {
    AddSubscriptionImpl(
        node.index, topic.index,
        [handler = std::move(handler)](const detail::EnvelopeBase& message, Outbox& out) {
          const auto& typed = static_cast<const detail::Envelope<T>&>(message);
          handler(typed.value, typed.stamp, out);
        },
        options);
  }
  // `handler(now, outbox)` runs as one job per tick from `first` on; a tick that comes while the
  // previous one still waits for the executor is coalesced and counted as an overrun.
  void AddTimer(NodeId node, Time first, Duration period,
                std::function<void(Time, Outbox&)> handler);

  // A job that blocks in its callback until something outside its node's executor happens (a
  // thread waiting on a condition, tf2's canTransform with a timeout). Called from the handler of
  // `node`'s running job: that job does not finish (its outputs wait with it) and the node starts
  // nothing (messages queue, timer ticks wait or count as overruns) until ReleaseJob(node), or
  // until `timeout` after now, when `on_timeout` runs and the job is released. The job's own cost
  // is unchanged: the wait itself takes no CPU. std::logic_error outside a running job or when it
  // already holds.
  void HoldJob(NodeId node, Duration timeout, std::function<void()> on_timeout);
  // Ends the hold of `node`'s job (nothing if it holds none): the job finishes at once if its
  // work is done (after the current event), else when it is.
  void ReleaseJob(NodeId node);
  bool held(NodeId node) const;

  // Faults (sim/loop/faults.h), by node name; std::invalid_argument for a name not on the graph.
  // Hang: the node's executor blocks: its running job does not finish (its outputs wait with it)
  // and no job starts; messages still queue (keep-last drops counted) and timer ticks count as
  // overruns. ResumeNode ends the hang: the held job finishes then, and the node catches up.
  // Crash: the node is gone for the rest of the run: a running job's outputs are never published,
  // its queues are emptied (zero-copy loans returned) and nothing reaches it any more.
  void HangNode(const std::string& name);
  void ResumeNode(const std::string& name);
  void CrashNode(const std::string& name);
  // Remap (a `remap` fault): the node runs in `target` from its next job on (a running job
  // finishes where it started); to hw it takes a slot from the slot executor. ConfigError where
  // it cannot: no cost of that kind in the profile, hw without slot_policy executor or without
  // bitstream_bytes. CheckRemap only says whether it can.
  void CheckRemap(const std::string& name, Target target);
  void RemapNode(const std::string& name, Target target);

  // A tap on the topic named `name`: `tap(value, stamp, now)` for every message a node publishes
  // on it, at the instant it is published (its job's completion; a node that crashed, a loan that
  // failed and a DDS write refused after max_blocking publish nothing), before any transport. (A
  // node that crashes between its DDS writes: the samples it wrote reach their readers, the tap
  // sees none of them.) A tap is not a subscriber: it costs
  // nothing on the platform, delays nothing and changes nothing in the run (a recorder,
  // sim/results/mcap_recording.h). False when the graph has no topic of that name;
  // std::invalid_argument when it has one of another type than T.
  template <class T>
  bool Tap(const std::string& name, std::function<void(const T&, Time stamp, Time now)> tap) {
    return TapImpl(name, typeid(T),
                   [tap = std::move(tap)](const detail::EnvelopeBase& message, Time now) {
                     const auto& typed = static_cast<const detail::Envelope<T>&>(message);
                     tap(typed.value, typed.stamp, now);
                   });
  }
  const TopicSpec& topic_spec(int topic) const;
  const std::string& node_name(NodeId node) const;
  bool HasNode(const std::string& name) const;
  std::vector<std::string> node_names() const;  // in the order they were added
  bool busy(NodeId node) const;
  // Messages waiting in the node's subscriptions.
  std::size_t queued(NodeId node) const;
  int loans_held(int publisher) const;
  // A DDS topic's links summed (every publisher to every subscription), over the whole run;
  // nothing for a zero-copy topic or an unknown name.
  std::optional<DdsLinkStats> dds_stats(const std::string& topic) const;
  Platform& platform() { return platform_; }

 private:
  friend class Outbox;
  struct QueuedMessage {
    Time arrival;
    std::shared_ptr<const detail::EnvelopeBase> message;
  };
  struct Subscription {
    int node;
    int topic;
    bool loaned;
    std::optional<SwCost> cost;
    std::function<void(const detail::EnvelopeBase&, Outbox&)> handler;
    std::deque<QueuedMessage> queue;
  };
  struct Timer {
    int node;
    std::function<void(Time, Outbox&)> handler;
    bool pending{false};
    Time fired_at{0};
  };
  struct Topic {
    TopicSpec spec;
    int metrics_index{-1};
    std::vector<int> subscriptions;
    std::vector<int> publishers;
    std::optional<int> pool;                   // zero-copy chunk pool
    DdsLinkParams dds;                         // DDS: the profile's settings with the topic's own
    std::type_index value_type{typeid(void)};  // what its messages carry (AddTopic's T)
    std::vector<std::function<void(const detail::EnvelopeBase&, Time)>> taps;  // Tap
  };
  // A DDS publisher's writer and its readers (the topic's subscriptions): the link, and per
  // reader the samples on their way by sequence number until they are delivered or lost.
  struct DdsWriter {
    std::unique_ptr<DdsLink> link;
    std::vector<int> subscriptions;  // by reader
    std::vector<std::deque<std::pair<std::int64_t, std::shared_ptr<const detail::EnvelopeBase>>>>
        in_flight;  // by reader
  };
  struct Publisher {
    int node;
    int topic;
    int loans_held{0};
    std::unique_ptr<DdsWriter> dds;  // DDS, once the topic has a subscription
  };
  struct Job {
    explicit Job(const NodeGraph* graph) : out(graph) {}
    Time start{0};
    Outbox out;
    std::shared_ptr<const detail::EnvelopeBase> input;  // held until the job ends
    double take_core_s{0.0};
    double compute_core_s{0.0};  // software work, or the delegate's CPU for hardware
    Duration fabric{0};          // hardware only
    double max_parallelism{1.0};
    double publish_core_s{0.0};   // zero-copy publishes; DDS writes are the links' CPU jobs
    double write_core_s{0.0};     // the DDS writes' first transmissions (the job's nominal cost)
    bool own_cost{false};         // a subscription's own cost, not the node's
    std::size_t write_output{0};  // the DDS writes, one after another as on the node's thread
    bool hw{false};               // its node's mapping when it started (CostJob)
  };
  struct Node {
    std::string name;
    NodeMappingConfig mapping;
    bool hw{false};  // mapping.target == "hw", decided once
    ComponentCost cost;
    int metrics_index{-1};
    std::optional<Rng> rng;
    double cost_scale{1.0};                               // PlatformConfig::cost_scale
    std::optional<CostDistributionConfig> cost_override;  // PlatformConfig::cost_override
    std::optional<Rng> override_rng;
    std::vector<int> subscriptions;
    std::vector<int> timers;
    std::optional<Job> job;  // the running job
    // DDS: the receive sockets of its subscriptions, by capacity (a topic that asks for its own
    // receive buffer gets a socket of its own, as a reader in a participant of its own would)
    std::map<std::int64_t, std::unique_ptr<DdsSocket>> sockets;
    // HoldJob: the running job waits beyond its work until ReleaseJob or hold_timeout
    bool held{false};
    EventId hold_timeout;
    // faults
    bool hung{false};
    bool finish_held{false};  // its job ended while hung or held: it finishes when both end
    bool crashed{false};
  };
  Node& NodeNamed(const std::string& name);

  int AddTopicImpl(TopicSpec spec, std::type_index value_type);
  void PlaceInSlot(const NodeSpec& spec, const HwCost& cost, const std::string& cost_name);
  bool TapImpl(const std::string& name, std::type_index value_type,
               std::function<void(const detail::EnvelopeBase&, Time)> tap);
  int AddPublisherImpl(int node, int topic);
  void AddSubscriptionImpl(int node, int topic,
                           std::function<void(const detail::EnvelopeBase&, Outbox&)> handler,
                           SubscriptionOptions options);
  TransportCost CostOf(const Topic& topic, std::int64_t bytes, bool loaned_take) const;

  void OnTimer(int timer);
  void Kick(int node);
  // A job's start: the oldest pending work, its input taken and handled (the functional result),
  // its zero-copy outputs loaned, and its cost set from the node's mapping.
  struct NextWork {
    int timer{-1};
    int subscription{-1};
  };
  struct TakenInput {
    std::int64_t bytes{0};
    const SwCost* callback_cost{nullptr};  // a subscription's own cost, if it has one
  };
  void StartJob(int node);
  NextWork OldestWork(const Node& n) const;
  TakenInput TakeInput(const NextWork& work, Job* job);
  std::int64_t LoanOutputs(const Node& n, Job* job);
  void CostJob(Node& n, const TakenInput& in, std::int64_t out_bytes, Job* job);
  void RunCompute(int node);
  void RunPublish(int node);
  void FinishJob(int node);
  void Distribute(const Topic& topic, std::shared_ptr<const detail::EnvelopeBase> message);
  void AddDdsReader(int publisher, int subscription);
  DdsSocket& SocketFor(int node, const DdsLinkParams& params);
  void NextDdsWrite(int node);
  void DdsDelivered(int publisher, std::size_t reader, std::int64_t seq);
  void Enqueue(int subscription, std::shared_ptr<const detail::EnvelopeBase> message);
  double Jitter(Node& node, double jitter);
  int Owner(int node) const { return nodes_[static_cast<std::size_t>(node)].metrics_index; }

  Platform& platform_;
  Kernel& kernel_;
  RunMetrics* metrics_;
  const RngStreams* rng_;
  std::string rng_prefix_;
  std::map<std::string, NodeMappingConfig> mapping_config_;
  std::map<std::string, TopicTransportConfig> transport_config_;
  std::map<std::string, double> cost_scale_config_;
  std::map<std::string, CostDistributionConfig> cost_override_config_;
  std::vector<Node> nodes_;
  std::vector<Topic> topics_;
  std::vector<Publisher> publishers_;
  std::vector<Subscription> subscriptions_;
  std::vector<Timer> timers_;
};

template <class T>
void Outbox::Publish(PublisherId<T> publisher, T value, Time stamp,
                     std::optional<std::int64_t> bytes) {
  auto message = std::make_shared<detail::Envelope<T>>(std::move(value));
  message->stamp = stamp;
  const int topic = graph_->publishers_.at(static_cast<std::size_t>(publisher.index)).topic;
  message->bytes = bytes ? *bytes : graph_->topic_spec(topic).type.bytes;
  pending_.push_back(Pending{.publisher = publisher.index, .message = std::move(message)});
}

// ---- The node boilerplate, written once ----

// A node around a pure component `Output step(const Params&, const Input&, State*)` (or one
// returning std::optional<Output>: nothing is published when it is empty). On every message of
// `in` it runs the step at once and publishes the result on `out` when the job completes, stamped
// with the input's sensor time. `state` is shared so that the caller can look at it.
template <class Input, class Output, class Params, class State, class Step>
NodeId AddComponentNode(NodeGraph& graph, NodeSpec spec, TopicId<Input> in, TopicId<Output> out,
                        Params params, std::shared_ptr<State> state, Step step,
                        SubscriptionOptions options = {}) {
  const NodeId node = graph.AddNode(std::move(spec));
  const PublisherId<Output> publisher = graph.AddPublisher(node, out);
  graph.AddSubscription<Input>(
      node, in,
      [params = std::move(params), state = std::move(state), step = std::move(step), publisher](
          const Input& input, Time stamp, Outbox& outbox) {
        auto result = step(params, input, state.get());
        if constexpr (std::is_same_v<decltype(result), std::optional<Output>>) {
          if (result) outbox.Publish(publisher, std::move(*result), stamp);
        } else {
          outbox.Publish(publisher, std::move(result), stamp);
        }
      },
      options);
  return node;
}

// A sensor-like source: every `period` from `first` it publishes `generate(now)` on `out`,
// stamped with the tick's time (the sensor sample time).
template <class Output, class Generate>
NodeId AddSourceNode(NodeGraph& graph, NodeSpec spec, TopicId<Output> out, Time first,
                     Duration period, Generate generate) {
  const NodeId node = graph.AddNode(std::move(spec));
  const PublisherId<Output> publisher = graph.AddPublisher(node, out);
  graph.AddTimer(node, first, period,
                 [generate = std::move(generate), publisher](Time now, Outbox& outbox) {
                   outbox.Publish(publisher, generate(now), now);
                 });
  return node;
}

// A subscriber that only consumes (a rate probe, a recorder).
template <class Input>
NodeId AddSinkNode(NodeGraph& graph, NodeSpec spec, TopicId<Input> in,
                   SubscriptionOptions options = {}) {
  const NodeId node = graph.AddNode(std::move(spec));
  graph.AddSubscription<Input>(
      node, in, [](const Input&, Time, Outbox&) {}, options);
  return node;
}

// The profile's background loads, each a periodic software job of its share of the cores (a node
// named after the load, so it shows in nodes.csv and the trace).
void AddBackgroundLoads(NodeGraph& graph, const PlatformProfile& profile, Time first);

// One compute board (one car's ZCU104) with its metrics and node graph: what a closed-loop run
// creates per car, on the run's kernel. Add the car's topics and nodes to graph(), call Finish(),
// run the kernel, then Report(end); nodes.csv, trace.json and summary.json come from
// sim/platform/node_metrics.h (NodesCsv, TraceJson, ReportJson). It must outlive every run of the
// kernel.
class Board {
 public:
  // Loads config.profile (relative to `base_dir`, the scenario's folder; ConfigError if unusable)
  // and applies config.mapping and config.transport to the nodes and topics added afterwards.
  // Jitter streams are "<name>/platform/<node>" of `rng`. Measurements start at `measure_from`.
  Board(Kernel& kernel, std::string name, const PlatformConfig& config,
        const std::filesystem::path& base_dir, const RngStreams* rng,
        Time measure_from = kZeroTime);
  Board(Kernel& kernel, std::string name, const PlatformConfig& config, PlatformProfile profile,
        const RngStreams* rng, Time measure_from = kZeroTime);
  Board(const Board&) = delete;
  Board& operator=(const Board&) = delete;

  // Adds the profile's background loads (if config.background_loads), first ticking at `first`,
  // and checks that every mapping and transport entry named a node or topic (ConfigError).
  void Finish(Time first = kZeroTime);

  const std::string& name() const { return name_; }
  NodeGraph& graph() { return graph_; }
  Platform& platform() { return platform_; }
  const RunMetrics& metrics() const { return metrics_; }
  const PlatformProfile& profile() const { return platform_.profile(); }
  // The metrics' report, its DDS topics with their links' counts.
  BoardReport Report(Time end) const;

 private:
  std::string name_;
  PlatformConfig config_;
  RunMetrics metrics_;
  Platform platform_;
  NodeGraph graph_;
};

}  // namespace autonomsim::sim
