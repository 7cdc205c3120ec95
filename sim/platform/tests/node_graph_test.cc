// The node graph's semantics on small hand-built graphs: keep-last QoS, one job at a time per
// executor, immediate functional results published at the job's end, timers, the zero-copy limits,
// mapping and transport from a scenario's config, determinism with jitter.
#include "sim/platform/node_graph.h"

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "sim/core/config.h"
#include "sim/platform/tests/free_transport_profile.h"

namespace autonomsim::sim {
namespace {

using std::chrono::milliseconds;
using ::testing::ElementsAre;
using ::testing::HasSubstr;

// Free transports (job times are the nodes' own work): "source", "slow" (95 ms) and "sink".
PlatformProfile FreeTransportProfile(int cores = 1) {
  PlatformProfile p = testing::FreeTransportProfile(cores);
  p.components["slow"] = ComponentCost{.sw = SwCost{.work_s = 0.095}};
  p.components["sink"] = ComponentCost{.sw = SwCost{}};
  return p;
}

struct Counter {
  int value{0};
};

// A graph on its own kernel, platform and metrics.
struct Rig {
  explicit Rig(PlatformProfile profile, const RngStreams* rng = nullptr)
      : platform(kernel, std::move(profile), &metrics), graph(platform, &metrics, rng) {}
  Kernel kernel;
  RunMetrics metrics;
  Platform platform;
  NodeGraph graph;
};

TEST(NodeGraph, KeepLastDropsTheOldestAtTheDepth) {
  // A source every 30 ms into a node whose jobs take 95 ms, depth 3. Hand-computed: jobs take
  // frames 0 (0-95 ms), 1 (95-190), 4 (190-285), 7 (285-380), 10 (380-); frames 2, 3, 5, 6, 8, 9
  // are pushed out of the queue.
  Rig rig(FreeTransportProfile());
  auto topic = rig.graph.AddTopic<int>({.name = "/frames", .type = {"Frame", 64, true}});
  int next = 0;
  AddSourceNode(rig.graph, NodeSpec{.name = "source"}, topic, kZeroTime, milliseconds(30),
                [&next](Time) { return next++; });
  std::vector<int> taken;
  std::vector<Time> taken_at;
  const NodeId slow = rig.graph.AddNode(NodeSpec{.name = "slow"});
  rig.graph.AddSubscription<int>(slow, topic, [&](const int& frame, Time, Outbox&) {
    taken.push_back(frame);
    taken_at.push_back(rig.kernel.Now());
  });
  rig.kernel.RunUntil(milliseconds(400));

  EXPECT_THAT(taken, ElementsAre(0, 1, 4, 7, 10));
  EXPECT_THAT(taken_at, ElementsAre(milliseconds(0), milliseconds(95), milliseconds(190),
                                    milliseconds(285), milliseconds(380)));
  const MetricsReport report = BuildReport(rig.metrics, milliseconds(400));
  const NodeReport* n = report.FindNode("slow");
  ASSERT_NE(n, nullptr);
  EXPECT_EQ(n->drops, 6u);
  EXPECT_EQ(n->arrivals, 14u);  // frames 0..13 (13 at 390 ms)
  EXPECT_EQ(n->jobs, 4u);       // 10's job is still running at 400 ms
  EXPECT_DOUBLE_EQ(n->turnaround_ms.p50, 95.0);
  EXPECT_EQ(rig.graph.queued(slow), 3u);  // 11, 12, 13
  EXPECT_EQ(report.FindTopic("/frames")->drops, 6u);
}

TEST(NodeGraph, OneJobAtATimePerExecutor) {
  // Two subscriptions of one node get a message each at t = 0: the second job starts when the
  // first ends, although the platform has cores to spare.
  Rig rig(FreeTransportProfile(4));
  auto a = rig.graph.AddTopic<int>({.name = "/a", .type = {"A", 8, true}});
  auto b = rig.graph.AddTopic<int>({.name = "/b", .type = {"B", 8, true}});
  AddSourceNode(rig.graph, NodeSpec{.name = "source"}, a, kZeroTime, milliseconds(1000),
                [](Time) { return 1; });
  const NodeId other =
      rig.graph.AddNode(NodeSpec{.name = "source_b", .cost = ComponentCost{.sw = SwCost{}}});
  const PublisherId<int> pub_b = rig.graph.AddPublisher(other, b);
  rig.graph.AddTimer(other, kZeroTime, milliseconds(1000),
                     [pub_b](Time now, Outbox& out) { out.Publish(pub_b, 2, now); });
  std::vector<std::pair<int, Time>> starts;
  const NodeId slow = rig.graph.AddNode(NodeSpec{.name = "slow"});
  auto record = [&](const int& v, Time, Outbox&) { starts.emplace_back(v, rig.kernel.Now()); };
  rig.graph.AddSubscription<int>(slow, a, record);
  rig.graph.AddSubscription<int>(slow, b, record);
  rig.kernel.RunUntil(milliseconds(150));
  ASSERT_EQ(starts.size(), 2u);
  EXPECT_EQ(starts[0], std::make_pair(1, Time{0}));
  EXPECT_EQ(starts[1], std::make_pair(2, Time{milliseconds(95)}));
  EXPECT_TRUE(rig.graph.busy(slow));
}

struct DoubleParams {
  int factor{2};
};
struct DoubleState {
  int calls{0};
};
int DoubleStep(const DoubleParams& p, const int& in, DoubleState* s) {
  ++s->calls;
  return in * p.factor;
}

TEST(NodeGraph, ComponentRunsAtOnceAndPublishesAtTheJobsEndWithTheSensorStamp) {
  PlatformProfile profile = FreeTransportProfile(2);
  profile.components["double"] = ComponentCost{.sw = SwCost{.work_s = 0.040}};
  Rig rig(profile);
  auto in = rig.graph.AddTopic<int>({.name = "/in", .type = {"I", 8, true}});
  auto out = rig.graph.AddTopic<int>({.name = "/out", .type = {"I", 8, true}});
  AddSourceNode(rig.graph, NodeSpec{.name = "source"}, in, milliseconds(10), milliseconds(100),
                [](Time now) { return static_cast<int>(now / milliseconds(1)); });
  auto state = std::make_shared<DoubleState>();
  AddComponentNode(rig.graph, NodeSpec{.name = "double"}, in, out, DoubleParams{}, state,
                   DoubleStep);
  struct Seen {
    int value;
    Time stamp;
    Time at;
  };
  std::vector<Seen> seen;
  const NodeId sink = rig.graph.AddNode(NodeSpec{.name = "sink"});
  rig.graph.AddSubscription<int>(sink, out, [&](const int& v, Time stamp, Outbox&) {
    seen.push_back({v, stamp, rig.kernel.Now()});
  });

  rig.kernel.RunUntil(milliseconds(45));
  EXPECT_EQ(state->calls, 1);  // ran when its job started (10 ms), before the output exists
  EXPECT_TRUE(seen.empty());
  rig.kernel.RunUntil(milliseconds(250));
  ASSERT_EQ(seen.size(), 3u);
  EXPECT_EQ(seen[0].value, 20);
  EXPECT_EQ(seen[0].stamp, milliseconds(10));  // the sensor time
  EXPECT_EQ(seen[0].at, milliseconds(50));     // 10 ms + 40 ms of work
  EXPECT_EQ(seen[2].value, 420);
  const MetricsReport report = BuildReport(rig.metrics, milliseconds(250));
  EXPECT_DOUBLE_EQ(report.FindTopic("/out")->latency_ms.max, 40.0);
  // 3 jobs of 40 ms of one core in 250 ms
  EXPECT_NEAR(report.FindNode("double")->cpu_percent, 100.0 * 0.120 / 0.250, 1e-9);
}

// A tap sees each message at its publication, with its stamp, and changes nothing: the subscriber
// gets the same messages at the same instants with and without it, and the node's CPU is the same.
TEST(NodeGraph, ATapSeesEveryPublishedMessageAndChangesNothing) {
  struct Seen {
    int value;
    Time stamp;
    Time at;
    bool operator==(const Seen&) const = default;
  };
  const auto run = [](bool tapped, std::vector<Seen>* tap_seen) {
    PlatformProfile profile = FreeTransportProfile(2);
    profile.components["double"] = ComponentCost{.sw = SwCost{.work_s = 0.040}};
    Rig rig(profile);
    auto in = rig.graph.AddTopic<int>({.name = "/in", .type = {"I", 8, true}});
    auto out = rig.graph.AddTopic<int>({.name = "/out", .type = {"I", 8, true}});
    AddSourceNode(rig.graph, NodeSpec{.name = "source"}, in, milliseconds(10), milliseconds(100),
                  [](Time now) { return static_cast<int>(now / milliseconds(1)); });
    AddComponentNode(rig.graph, NodeSpec{.name = "double"}, in, out, DoubleParams{},
                     std::make_shared<DoubleState>(), DoubleStep);
    std::vector<Seen> seen;
    const NodeId sink = rig.graph.AddNode(NodeSpec{.name = "sink"});
    rig.graph.AddSubscription<int>(sink, out, [&](const int& v, Time stamp, Outbox&) {
      seen.push_back({v, stamp, rig.kernel.Now()});
    });
    if (tapped) {
      EXPECT_TRUE(rig.graph.Tap<int>("/out", [tap_seen](const int& v, Time stamp, Time now) {
        tap_seen->push_back({v, stamp, now});
      }));
      EXPECT_FALSE(rig.graph.Tap<int>("/nothing", [](const int&, Time, Time) {}));
      EXPECT_THROW(rig.graph.Tap<double>("/out", [](const double&, Time, Time) {}),
                   std::invalid_argument);
    }
    rig.kernel.RunUntil(milliseconds(250));
    const MetricsReport report = BuildReport(rig.metrics, milliseconds(250));
    return std::pair(seen, report.FindNode("double")->cpu_percent);
  };
  std::vector<Seen> tapped_seen;
  const auto plain = run(false, nullptr);
  const auto tapped = run(true, &tapped_seen);
  EXPECT_EQ(plain, tapped);
  // published at 50, 150, 250 ms (10 ms + 40 ms of work, every 100 ms), stamped with the frame's
  // time: the zero-copy subscriber gets them after the free transport's latency of 0
  EXPECT_EQ(tapped_seen, (std::vector<Seen>{{20, milliseconds(10), milliseconds(50)},
                                            {220, milliseconds(110), milliseconds(150)},
                                            {420, milliseconds(210), milliseconds(250)}}));
}

TEST(NodeGraph, OptionalOutputPublishesOnlyWhenSet) {
  Rig rig(FreeTransportProfile(2));
  auto in = rig.graph.AddTopic<int>({.name = "/in", .type = {"I", 8, true}});
  auto out = rig.graph.AddTopic<int>({.name = "/odd", .type = {"I", 8, true}});
  int next = 0;
  AddSourceNode(rig.graph, NodeSpec{.name = "source"}, in, kZeroTime, milliseconds(10),
                [&next](Time) { return next++; });
  AddComponentNode(rig.graph, NodeSpec{.name = "odd", .cost = ComponentCost{.sw = SwCost{}}}, in,
                   out, 0, std::make_shared<int>(0),
                   [](const int&, const int& v, int*) -> std::optional<int> {
                     if (v % 2 == 1) return v;
                     return std::nullopt;
                   });
  std::vector<int> odd;
  const NodeId sink = rig.graph.AddNode(NodeSpec{.name = "sink"});
  rig.graph.AddSubscription<int>(sink, out,
                                 [&odd](const int& v, Time, Outbox&) { odd.push_back(v); });
  rig.kernel.RunUntil(milliseconds(55));
  EXPECT_THAT(odd, ElementsAre(1, 3, 5));
}

TEST(NodeGraph, TimerTicksWhileItsJobWaitsAreCoalescedAndCounted) {
  PlatformProfile profile = FreeTransportProfile();
  profile.components["ticker"] = ComponentCost{.sw = SwCost{.work_s = 0.025}};
  Rig rig(profile);
  const NodeId ticker = rig.graph.AddNode(NodeSpec{.name = "ticker"});
  int runs = 0;
  rig.graph.AddTimer(ticker, kZeroTime, milliseconds(10), [&runs](Time, Outbox&) { ++runs; });
  rig.kernel.RunUntil(milliseconds(99));
  // Ticks every 10 ms, jobs of 25 ms: jobs run 0-25 (tick 0), 25-50 (tick 10), 50-75 (tick 30),
  // 75-100 (tick 50); the ticks at 20, 40, 60, 70, 90 find one already waiting; 80 waits.
  EXPECT_EQ(runs, 4);
  const MetricsReport report = BuildReport(rig.metrics, milliseconds(99));
  const NodeReport* n = report.FindNode("ticker");
  EXPECT_EQ(n->timer_overruns, 5u);
}

TEST(NodeGraph, AHeldJobFinishesAtItsReleaseOrItsTimeout) {
  // "holder" takes 10 ms per message and then holds its job (a callback waiting in tf2's
  // canTransform) for at most 50 ms; "releaser" releases it at 30 ms. Frames at 0 and 100 ms: the
  // first job runs 0-10 ms and finishes at the release (30 ms); the second runs 100-110 ms and
  // finishes at its timeout (150 ms). A frame arriving while held waits in the queue.
  PlatformProfile profile = FreeTransportProfile();
  profile.components["holder"] = ComponentCost{.sw = SwCost{.work_s = 0.010}};
  profile.components["releaser"] = ComponentCost{.sw = SwCost{}};
  profile.components["sink"] = ComponentCost{.sw = SwCost{}};
  Rig rig(profile);
  auto in = rig.graph.AddTopic<int>({.name = "/in", .type = {"I", 8, true}});
  auto out = rig.graph.AddTopic<int>({.name = "/out", .type = {"I", 8, true}});
  int next = 0;
  AddSourceNode(rig.graph, NodeSpec{.name = "source"}, in, kZeroTime, milliseconds(100),
                [&next](Time) { return next++; });
  const NodeId holder = rig.graph.AddNode(NodeSpec{.name = "holder"});
  const auto publisher = rig.graph.AddPublisher(holder, out);
  std::vector<int> timeouts;
  rig.graph.AddSubscription<int>(holder, in, [&](const int& v, Time stamp, Outbox& outbox) {
    outbox.Publish(publisher, v, stamp);
    rig.graph.HoldJob(holder, milliseconds(50), [&timeouts, v] { timeouts.push_back(v); });
    EXPECT_THROW(rig.graph.HoldJob(holder, milliseconds(50), {}), std::logic_error);
  });
  const NodeId releaser = rig.graph.AddNode(NodeSpec{.name = "releaser"});
  rig.graph.AddTimer(releaser, milliseconds(30), milliseconds(1000),
                     [&](Time, Outbox&) { rig.graph.ReleaseJob(holder); });
  std::vector<std::pair<int, Time>> seen;
  const NodeId sink = rig.graph.AddNode(NodeSpec{.name = "sink"});
  rig.graph.AddSubscription<int>(
      sink, out, [&](const int& v, Time, Outbox&) { seen.emplace_back(v, rig.kernel.Now()); });

  rig.kernel.RunUntil(milliseconds(29));
  EXPECT_TRUE(rig.graph.held(holder));
  EXPECT_TRUE(seen.empty());
  rig.kernel.RunUntil(milliseconds(199));
  EXPECT_FALSE(rig.graph.held(holder));
  EXPECT_THAT(seen, ElementsAre(std::pair<int, Time>{0, milliseconds(30)},
                                std::pair<int, Time>{1, milliseconds(150)}));
  EXPECT_THAT(timeouts, ElementsAre(1));
  EXPECT_THROW(rig.graph.HoldJob(holder, milliseconds(50), {}), std::logic_error);  // no job
  const MetricsReport report = BuildReport(rig.metrics, milliseconds(199));
  EXPECT_DOUBLE_EQ(report.FindNode("holder")->turnaround_ms.max, 50.0);  // 100-150 ms
  // the wait takes no CPU: two jobs of 10 ms in 199 ms
  EXPECT_NEAR(report.FindNode("holder")->cpu_percent, 100.0 * 0.020 / 0.199, 1e-9);
}

TEST(NodeGraph, ZeroCopyNeedsFixedSizeTypesAndFittingChunks) {
  Rig rig(FreeTransportProfile());
  try {
    rig.graph.AddTopic<int>({.name = "/var", .type = {"Var", 100, false}});
    FAIL() << "expected a ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_THAT(e.what(), HasSubstr("fixed-size"));
    EXPECT_THAT(e.what(), HasSubstr("/var"));
  }
  EXPECT_NO_THROW(rig.graph.AddTopic<int>(
      {.name = "/var_dds", .type = {"Var", 100, false}, .transport = Transport::kDds}));
  try {
    rig.graph.AddTopic<int>({.name = "/huge", .type = {"Huge", 4096, true}});
    FAIL() << "expected a ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_THAT(e.what(), HasSubstr("fits no shared-memory chunk"));
  }
}

TEST(NodeGraph, ZeroCopyAllowsAtMost127SubscribersPerTopic) {
  PlatformProfile profile = FreeTransportProfile();
  Rig rig(profile);
  auto topic = rig.graph.AddTopic<int>({.name = "/many", .type = {"I", 8, true}});
  auto dds = rig.graph.AddTopic<int>(
      {.name = "/many_dds", .type = {"I", 8, true}, .transport = Transport::kDds});
  for (int i = 0; i < 127; ++i) {
    const NodeId n = rig.graph.AddNode(
        NodeSpec{.name = "s" + std::to_string(i), .cost = ComponentCost{.sw = SwCost{}}});
    rig.graph.AddSubscription<int>(n, topic, [](const int&, Time, Outbox&) {});
    rig.graph.AddSubscription<int>(n, dds, [](const int&, Time, Outbox&) {});
  }
  const NodeId extra =
      rig.graph.AddNode(NodeSpec{.name = "extra", .cost = ComponentCost{.sw = SwCost{}}});
  EXPECT_NO_THROW(rig.graph.AddSubscription<int>(extra, dds, [](const int&, Time, Outbox&) {}));
  try {
    rig.graph.AddSubscription<int>(extra, topic, [](const int&, Time, Outbox&) {});
    FAIL() << "expected a ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_THAT(e.what(), HasSubstr("at most 127 subscribers"));
  }
}

TEST(NodeGraph, ANinthLoanIsACountedFailureNotASilentSend) {
  Rig rig(FreeTransportProfile());
  auto topic = rig.graph.AddTopic<int>({.name = "/burst", .type = {"I", 8, true}});
  const NodeId burst = rig.graph.AddNode(NodeSpec{.name = "source"});
  const PublisherId<int> pub = rig.graph.AddPublisher(burst, topic);
  // Nine messages in one job: nine loans held at once before the job publishes.
  rig.graph.AddTimer(burst, kZeroTime, std::chrono::seconds(1), [pub](Time now, Outbox& out) {
    for (int i = 0; i < 9; ++i) out.Publish(pub, i, now);
  });
  std::vector<int> got;
  const NodeId slow = rig.graph.AddNode(NodeSpec{.name = "slow"});
  rig.graph.AddSubscription<int>(slow, topic,
                                 [&got](const int& v, Time, Outbox&) { got.push_back(v); });
  rig.kernel.RunUntil(milliseconds(300));
  // The eight sent arrive at once: 0 is taken, depth 3 keeps 5, 6, 7; the ninth never left.
  EXPECT_THAT(got, ElementsAre(0, 5, 6, 7));
  const MetricsReport report = BuildReport(rig.metrics, milliseconds(300));
  EXPECT_EQ(report.FindNode("source")->loan_failures, 1u);
  EXPECT_EQ(report.FindTopic("/burst")->loan_failures, 1u);
  EXPECT_EQ(report.FindTopic("/burst")->published, 8u);
  EXPECT_EQ(report.FindNode("slow")->drops, 4u);
  EXPECT_EQ(rig.graph.loans_held(pub.index), 0);
}

TEST(NodeGraph, ExhaustedMempoolIsACountedLoanFailure) {
  PlatformProfile profile = FreeTransportProfile();
  profile.zero_copy.mempools = {{.chunk_bytes = 64, .chunks = 2}};
  profile.components["stuck"] = ComponentCost{.sw = SwCost{.work_s = 10.0}};
  Rig rig(profile);
  auto topic = rig.graph.AddTopic<int>({.name = "/t", .type = {"I", 8, true}, .depth = 5});
  int next = 0;
  AddSourceNode(rig.graph, NodeSpec{.name = "source"}, topic, kZeroTime, milliseconds(10),
                [&next](Time) { return next++; });
  // The subscriber holds sample 0 in its (long) job and sample 1 in its queue: both chunks are in
  // use, so the source's further loans fail until one comes back.
  AddSinkNode(rig.graph, NodeSpec{.name = "stuck"}, topic);
  rig.kernel.RunUntil(milliseconds(55));
  const MetricsReport report = BuildReport(rig.metrics, milliseconds(55));
  EXPECT_EQ(report.FindTopic("/t")->published, 2u);
  EXPECT_EQ(report.FindNode("source")->loan_failures, 4u);  // ticks at 20, 30, 40, 50 ms
  EXPECT_EQ(rig.platform.chunk_pools()->in_use(0), 2);
}

TEST(NodeGraph, ScenarioMappingAndTransportApplyByName) {
  PlatformProfile profile = FreeTransportProfile(2);
  profile.components["work"] =
      ComponentCost{.sw = SwCost{.work_s = 0.030}, .hw = HwCost{.compute_s = 0.005}};
  PlatformConfig config;
  config.mapping["work"] = NodeMappingConfig{.target = Target::kHw, .slot = 1};
  config.transport["/in"] = TopicTransportConfig{.transport = Transport::kDds, .depth = 1};
  Rig rig(profile);
  rig.graph.ApplyConfig(config);
  auto in = rig.graph.AddTopic<int>({.name = "/in", .type = {"I", 8, true}});
  auto out = rig.graph.AddTopic<int>({.name = "/out", .type = {"I", 8, true}});
  EXPECT_EQ(rig.graph.topic_spec(in.index).transport, Transport::kDds);
  EXPECT_EQ(rig.graph.topic_spec(in.index).depth, 1);
  EXPECT_EQ(rig.graph.topic_spec(out.index).transport, Transport::kZeroCopy);
  AddSourceNode(rig.graph, NodeSpec{.name = "source"}, in, kZeroTime, milliseconds(100),
                [](Time) { return 0; });
  AddComponentNode(rig.graph, NodeSpec{.name = "work"}, in, out, DoubleParams{},
                   std::make_shared<DoubleState>(), DoubleStep);
  EXPECT_NO_THROW(rig.graph.CheckConfigUsed());
  rig.kernel.RunUntil(milliseconds(50));
  const MetricsReport report = BuildReport(rig.metrics, milliseconds(50));
  EXPECT_EQ(report.FindNode("work")->mapping, "hw:slot1");
  // hardware: 5 ms in the fabric + 16 bytes at 1 GB/s; the DDS take and publish of 8-byte
  // messages cost nothing in this profile
  EXPECT_NEAR(report.FindNode("work")->turnaround_ms.p50, 5.000016, 1e-6);

  PlatformConfig typo;
  typo.mapping["wrok"] = NodeMappingConfig{};
  Rig other(profile);
  other.graph.ApplyConfig(typo);
  other.graph.AddNode(NodeSpec{.name = "work"});
  try {
    other.graph.CheckConfigUsed();
    FAIL() << "expected a ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_THAT(e.what(), HasSubstr("platform.mapping.wrok"));
  }
}

TEST(NodeGraph, MappingErrorsAreConfigErrors) {
  PlatformProfile profile = FreeTransportProfile();
  profile.components["hw_only"] = ComponentCost{.hw = HwCost{.compute_s = 0.001}};
  Rig rig(profile);
  EXPECT_THROW(rig.graph.AddNode(NodeSpec{.name = "hw_only"}), ConfigError);  // no sw cost
  EXPECT_THROW(rig.graph.AddNode(NodeSpec{.name = "missing"}), ConfigError);  // no cost at all
  rig.graph.AddNode(
      NodeSpec{.name = "a", .mapping = {.target = Target::kHw, .slot = 0, .cost = "hw_only"}});
  try {
    rig.graph.AddNode(
        NodeSpec{.name = "b", .mapping = {.target = Target::kHw, .slot = 0, .cost = "hw_only"}});
    FAIL() << "expected a ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_THAT(e.what(), HasSubstr("already serves node 'a'"));
  }
  EXPECT_THROW(rig.graph.AddNode(NodeSpec{
                   .name = "c", .mapping = {.target = Target::kHw, .slot = 7, .cost = "hw_only"}}),
               ConfigError);
}

// A small pipeline with jittered costs on 2 cores; returns per node its job count and turnaround
// min, p50, p95, p99 and max.
std::vector<double> JitteredRun(std::uint64_t seed) {
  PlatformProfile profile = FreeTransportProfile(2);
  profile.components["slow"] =
      ComponentCost{.sw = SwCost{.work_s = 0.020, .max_parallelism = 1.5, .jitter = 0.3}};
  profile.components["other"] = ComponentCost{.sw = SwCost{.work_s = 0.015, .jitter = 0.2}};
  RngStreams rng(seed);
  Rig rig(profile, &rng);
  auto a = rig.graph.AddTopic<int>({.name = "/a", .type = {"I", 8, true}});
  auto b = rig.graph.AddTopic<int>({.name = "/b", .type = {"I", 8, true}});
  AddSourceNode(rig.graph, NodeSpec{.name = "source"}, a, kZeroTime, milliseconds(20),
                [](Time) { return 1; });
  AddComponentNode(rig.graph, NodeSpec{.name = "slow"}, a, b, DoubleParams{},
                   std::make_shared<DoubleState>(), DoubleStep);
  AddSinkNode(rig.graph, NodeSpec{.name = "other"}, b);
  rig.kernel.RunUntil(std::chrono::seconds(2));
  std::vector<double> all;
  for (const auto& n : rig.metrics.nodes()) {
    const Stats s = n.turnaround.ComputeStats();
    all.insert(all.end(), {static_cast<double>(s.count), s.min, s.p50, s.p95, s.p99, s.max});
  }
  return all;
}

TEST(NodeGraph, DeterministicWithThePlatformAndJitterOn) {
  const std::vector<double> first = JitteredRun(7);
  const std::vector<double> second = JitteredRun(7);
  ASSERT_EQ(first.size(), 3u * 6u);
  EXPECT_GT(first[0] + first[6] + first[12], 150.0);  // timed jobs of the three nodes
  EXPECT_EQ(first, second);                           // bit for bit
  EXPECT_NE(first, JitteredRun(8));
}

TEST(Board, BuildsFromAScenarioConfigAndWritesNodesCsvTraceAndSummary) {
  // The closed loop's way in: a board per car from the scenario's `platform:` section.
  PlatformConfig config;
  config.profile = "platforms/zcu104.yaml";
  config.mapping["point_cloud"] = NodeMappingConfig{.target = Target::kHw, .slot = 0};
  config.transport["/points"] = TopicTransportConfig{.transport = Transport::kDds};
  Kernel kernel;
  RngStreams rng(1);
  Board board(kernel, "car0", config, "scenarios", &rng, milliseconds(500));
  NodeGraph& graph = board.graph();
  auto depth = graph.AddTopic<int>({.name = "/depth", .type = msg::Image640mono()});
  auto points = graph.AddTopic<int>({.name = "/points", .type = msg::PointCloud640()});
  AddSourceNode(graph, NodeSpec{.name = "camera", .mapping = {.cost = "camera_publisher"}}, depth,
                kZeroTime, FromSeconds(1.0 / 30.0), [](Time) { return 0; });
  AddComponentNode(graph, NodeSpec{.name = "point_cloud"}, depth, points, DoubleParams{},
                   std::make_shared<DoubleState>(), DoubleStep);
  AddSinkNode(graph, NodeSpec{.name = "obstacle_detection"}, points);
  board.Finish();
  kernel.RunUntil(std::chrono::seconds(3));

  const BoardReport report = board.Report(std::chrono::seconds(3));
  EXPECT_EQ(report.report.FindNode("point_cloud")->mapping, "hw:slot0");
  EXPECT_NE(report.report.FindNode("nav2_controller"), nullptr);  // a background load
  EXPECT_EQ(report.report.FindTopic("/points")->transport, "dds");
  EXPECT_NEAR(report.report.FindTopic("/points")->rate_hz, 30.0, 0.5);
  EXPECT_EQ(report.report.cpu_load_percent.size(), 3u);

  const std::string csv = NodesCsv({report});
  EXPECT_THAT(csv, ::testing::StartsWith("board,node,mapping,jobs,input_hz,rate_hz,"));
  EXPECT_THAT(csv, HasSubstr("\ncar0,point_cloud,hw:slot0,"));
  EXPECT_THAT(csv, HasSubstr("loan_failures,timer_overruns,callbacks\n"));
  // topics.csv (issue 34): per-topic latency and DDS counts, empty where a topic has none
  const std::string topics = TopicsCsv({report});
  EXPECT_THAT(topics, ::testing::StartsWith("board,topic,transport,bytes,depth,published,rate_hz,"
                                            "latency_count,latency_min_ms,"));
  const TopicReport& dds = *report.report.FindTopic("/points");
  ASSERT_TRUE(dds.dds.has_value());
  EXPECT_THAT(topics, HasSubstr(fmt::format("\ncar0,/points,dds,{},{},{},", dds.bytes, dds.depth,
                                            dds.published)));
  EXPECT_THAT(topics,
              HasSubstr(fmt::format(
                  ",{},{},{},{},{},{},{},{}\n", dds.dds->samples_written, dds.dds->write_timeouts,
                  dds.dds->samples_delivered, dds.dds->samples_lost, dds.dds->datagrams_sent,
                  dds.dds->datagrams_retransmitted, dds.dds->datagrams_dropped, dds.dds->nacks)));
  const std::size_t depth_row = topics.find("\ncar0,/depth,zero_copy,");
  ASSERT_NE(depth_row, std::string::npos) << topics;
  EXPECT_EQ(topics.substr(topics.find('\n', depth_row + 1) - 8, 9), ",,,,,,,,\n");

  const nlohmann::json summary = ReportJson(report.report);
  for (const char* key : {"cpu_percent", "cpu_demand_percent", "cpu_load_percent", "load_bin_s",
                          "nodes", "topics", "window_s", "cores"}) {
    EXPECT_TRUE(summary.contains(key)) << key;
  }
  EXPECT_TRUE(summary["nodes"][0]["turnaround_ms"].contains("p95"));

  const nlohmann::json trace = nlohmann::json::parse(TraceJson({{"car0", &board.metrics()}}));
  ASSERT_TRUE(trace["traceEvents"].is_array());
  std::set<std::string> phases;
  bool slot_span = false;
  for (const auto& e : trace["traceEvents"]) {
    phases.insert(e["ph"].get<std::string>());
    ASSERT_TRUE(e.contains("pid"));
    if (e["ph"] == "X") {
      ASSERT_TRUE(e.contains("tid") && e.contains("ts") && e.contains("dur"));
      EXPECT_GE(e["dur"].get<double>(), 0.0);
      if (e["name"] == "point_cloud" && e["pid"] == 13) slot_span = true;  // car0's slots
    }
  }
  EXPECT_EQ(phases, (std::set<std::string>{"M", "X", "C"}));
  EXPECT_TRUE(slot_span);

  PlatformConfig typo = config;
  typo.transport["/pionts"] = TopicTransportConfig{};
  Kernel other_kernel;
  Board other(other_kernel, "car1", typo, "scenarios", &rng);
  EXPECT_THROW(other.Finish(), ConfigError);
  PlatformConfig missing;
  missing.profile = "platforms/nope.yaml";
  EXPECT_THROW(Board(other_kernel, "car2", missing, "scenarios", &rng), ConfigError);
}

// Trace spans are in whole microseconds, both ends rounded down: spans that follow each other on a
// track stay apart (a viewer nests overlapping ones), however their nanoseconds fall.
TEST(NodeMetrics, TraceSpansInWholeMicrosecondsNeverOverlapTheNext) {
  using detail::ToWholeMicroseconds;
  EXPECT_EQ(ToWholeMicroseconds(400, 1600).ts_us, 0);
  EXPECT_EQ(ToWholeMicroseconds(400, 1600).dur_us, 1);
  EXPECT_EQ(ToWholeMicroseconds(1600, 2900).ts_us, 1);
  EXPECT_EQ(ToWholeMicroseconds(1600, 2900).dur_us, 1);
  EXPECT_EQ(ToWholeMicroseconds(1100, 1900).dur_us, 0);  // under a microsecond
  EXPECT_EQ(ToWholeMicroseconds(123456789000, 123456790999).dur_us, 1);
  std::uint64_t state = 42;  // a fixed LCG: back-to-back spans of 1 ns to 1 s
  std::int64_t at_ns = 0;
  std::int64_t previous_end_us = 0;
  for (int k = 0; k < 100000; ++k) {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    const std::int64_t length_ns = static_cast<std::int64_t>((state >> 11) % (1ull << (k % 30)));
    const detail::WholeMicroseconds us = ToWholeMicroseconds(at_ns, at_ns + length_ns);
    ASSERT_GE(us.ts_us, previous_end_us) << k;
    ASSERT_GE(us.dur_us, 0);
    ASSERT_LE(std::abs(us.ts_us * 1000 - at_ns), 999);
    ASSERT_LE(std::abs((us.ts_us + us.dur_us) * 1000 - (at_ns + length_ns)), 999);
    previous_end_us = us.ts_us + us.dur_us;
    at_ns += length_ns;
  }
}

// Issue 34, item 1: the busy-cores counter was an event at every change, 60 % of a trace that then
// covered 47 of the default run's 200 s. It is now the mean over each period, written when it
// changes. Hand-computed with 10 ms periods: 1 core for 4 ms, idle to 25 ms, 2 cores to 50 ms.
TEST(NodeMetrics, TheBusyCounterIsTheMeanOfEachPeriodWrittenWhenItChanges) {
  RunMetrics metrics(MetricsOptions{.trace_busy_period = milliseconds(10)});
  metrics.AddBusy(kZeroTime, kZeroTime + milliseconds(4), 1.0);
  metrics.BusyChanged(kZeroTime + milliseconds(4), 0.0);  // only with a zero period
  metrics.AddBusy(kZeroTime + milliseconds(4), kZeroTime + milliseconds(25), 0.0);
  metrics.AddBusy(kZeroTime + milliseconds(25), kZeroTime + milliseconds(50), 2.0);
  metrics.AddBusy(kZeroTime + milliseconds(50), kZeroTime + milliseconds(51), 0.0);  // stays open
  std::vector<std::pair<std::int64_t, double>> counter;
  for (const RunMetrics::TraceEvent& e : metrics.trace_events()) {
    ASSERT_EQ(e.phase, 'C');
    counter.emplace_back(e.ts_ns, e.value);
  }
  EXPECT_THAT(counter, ElementsAre(std::pair<std::int64_t, double>{0, 0.4},
                                   std::pair<std::int64_t, double>{10'000'000, 0.0},
                                   std::pair<std::int64_t, double>{20'000'000, 1.0},
                                   std::pair<std::int64_t, double>{30'000'000, 2.0}));
  // a zero period: a value at every change, as before
  RunMetrics every(MetricsOptions{.trace_busy_period = Duration::zero()});
  every.AddBusy(kZeroTime, kZeroTime + milliseconds(4), 1.0);
  every.BusyChanged(kZeroTime + milliseconds(4), 0.0);
  every.BusyChanged(kZeroTime + milliseconds(5), 0.0);
  every.BusyChanged(kZeroTime + milliseconds(6), 2.0);
  EXPECT_EQ(every.trace_events().size(), 2u);
}

// The receive threads' spans are in the trace only when asked (trace_receive).
TEST(NodeMetrics, ReceiveThreadSpansOnlyWhenAsked) {
  for (const bool receive : {false, true}) {
    RunMetrics metrics(MetricsOptions{.trace_receive = receive});
    const int node = metrics.AddNode("n", "sw");
    metrics.Span(TraceLane::kReceive, node, "dds receive", kZeroTime, kZeroTime + milliseconds(1));
    metrics.Span(TraceLane::kExecutor, node, "n", kZeroTime + milliseconds(1),
                 kZeroTime + milliseconds(2));
    EXPECT_EQ(metrics.trace_events().size(), receive ? 2u : 1u);
    const std::string trace = TraceJson({{"car0", &metrics}});
    EXPECT_EQ(trace.find("DDS receive threads") != std::string::npos, receive);
    EXPECT_EQ(trace.find("\"n receive\"") != std::string::npos, receive);
  }
}

// A subscription with its own cost (a callback that only keeps the message) costs that instead of
// the node's: a 95 ms node takes a message on its caching subscription in 1 ms. Hand-computed:
// frames at 0, 30, 60 ms each take 1 ms, one after the other, never queueing.
TEST(NodeGraph, ACachingSubscriptionCostsItsOwnCost) {
  Rig rig(FreeTransportProfile());
  auto topic = rig.graph.AddTopic<int>({.name = "/frames", .type = {"Frame", 64, true}});
  int next = 0;
  AddSourceNode(rig.graph, NodeSpec{.name = "source"}, topic, kZeroTime, milliseconds(30),
                [&next](Time) { return next++; });
  const NodeId slow = rig.graph.AddNode(NodeSpec{.name = "slow"});
  std::vector<Time> taken_at;
  rig.graph.AddSubscription<int>(
      slow, topic, [&](const int&, Time, Outbox&) { taken_at.push_back(rig.kernel.Now()); },
      SubscriptionOptions{.cost = SwCost{.work_s = 0.001}});
  rig.kernel.RunUntil(milliseconds(70));
  EXPECT_THAT(taken_at, ElementsAre(milliseconds(0), milliseconds(30), milliseconds(60)));
  const MetricsReport report = BuildReport(rig.metrics, milliseconds(70));
  const NodeReport* n = report.FindNode("slow");
  ASSERT_NE(n, nullptr);
  EXPECT_EQ(n->drops, 0u);
  // Issue 34: a caching callback is not the node's own work (nodes.csv gave planner_server 23 Hz,
  // its plans are 1 Hz): counted as a callback, outside jobs and rate_hz
  EXPECT_EQ(n->callbacks, 3u);
  EXPECT_EQ(n->jobs, 0u);
  EXPECT_EQ(n->rate_hz, 0.0);
  EXPECT_GT(n->cpu_percent, 0.0);  // its cost still counts
}

TEST(NodeGraph, ACachingSubscriptionNeedsASoftwareNode) {
  PlatformProfile profile = FreeTransportProfile();
  profile.components["hw_node"] = ComponentCost{.hw = HwCost{.compute_s = 0.001}};
  Rig rig(profile);
  auto topic = rig.graph.AddTopic<int>({.name = "/frames", .type = {"Frame", 64, true}});
  const NodeId node = rig.graph.AddNode(
      NodeSpec{.name = "hw_node", .mapping = NodeMappingConfig{.target = Target::kHw, .slot = 0}});
  EXPECT_THROW(rig.graph.AddSubscription<int>(
                   node, topic, [](const int&, Time, Outbox&) {},
                   SubscriptionOptions{.cost = SwCost{.work_s = 0.001}}),
               ConfigError);
}

// A background load stands in for the nodes it names: a graph that runs one of them gets no load.
TEST(NodeGraph, ABackgroundLoadIsLeftOutWhereItsNodesRun) {
  PlatformProfile profile = FreeTransportProfile();
  profile.background = {{.name = "planning", .cpu_percent = 10.0, .replaced_by = {"slow"}},
                        {.name = "drivers", .cpu_percent = 5.0, .replaced_by = {"other"}}};
  Rig rig(profile);
  rig.graph.AddNode(NodeSpec{.name = "slow"});
  AddBackgroundLoads(rig.graph, rig.platform.profile(), kZeroTime);
  EXPECT_FALSE(rig.graph.HasNode("planning"));
  EXPECT_TRUE(rig.graph.HasNode("drivers"));
}

// ---- DDS topics: the datagram mechanism (sim/platform/dds_link.h) in the graph ----

// Hand-picked DDS costs on four otherwise free cores (no contention): a write, a receive.
PlatformProfile DdsCostProfile() {
  PlatformProfile p = FreeTransportProfile(4);
  p.dds.write = {.fixed = std::chrono::microseconds(10),
                 .copies = 2,
                 .per_datagram = std::chrono::microseconds(5),
                 .per_fragment = std::chrono::microseconds(1)};
  p.dds.receive = {.fixed = std::chrono::microseconds(20),
                   .copies = 2,
                   .per_datagram = std::chrono::microseconds(3),
                   .per_fragment = std::chrono::microseconds(2)};
  p.dds.latency = std::chrono::microseconds(50);
  return p;
}

TEST(NodeGraph, ASmallDdsSampleIsWrittenOnceAndCostsEachReaderWhatDdsCostSays) {
  // 1000 B (one datagram of one fragment) every 10 ms to two subscribers. One write serves both
  // readers; each reader's receive thread pays the receive side. Hand-computed:
  // write 10 + 2 x 1000 B / 1 GB/s + 5 + 1 = 18 us; receive 20 + 2 + 3 + 2 = 27 us; the
  // subscriber's job starts 50 us (the executor's wake-up) after that.
  const PlatformProfile profile = DdsCostProfile();
  Rig rig(profile);
  auto topic = rig.graph.AddTopic<int>(
      {.name = "/fix", .type = {"Fix", 1000, false}, .transport = Transport::kDds});
  AddSourceNode(rig.graph, NodeSpec{.name = "source"}, topic, kZeroTime, milliseconds(10),
                [](Time) { return 7; });
  std::vector<Time> taken_at;
  for (const char* name : {"sink", "sink2"}) {
    const NodeId sink = rig.graph.AddNode(NodeSpec{.name = name, .mapping = {.cost = "sink"}});
    rig.graph.AddSubscription<int>(sink, topic, [&](const int& v, Time, Outbox&) {
      EXPECT_EQ(v, 7);
      taken_at.push_back(rig.kernel.Now());
    });
  }
  rig.kernel.RunUntil(milliseconds(995));  // 100 samples, all through

  const TransportCost cost = DdsCost(profile, 1000);
  EXPECT_DOUBLE_EQ(cost.publish_core_s, 18e-6);
  EXPECT_DOUBLE_EQ(cost.receive_core_s, 27e-6);
  ASSERT_EQ(taken_at.size(), 200u);
  const Time first = kZeroTime + FromSeconds(cost.publish_core_s) +
                     FromSeconds(cost.receive_core_s) + std::chrono::microseconds(50);
  EXPECT_LE(std::chrono::abs(taken_at[0] - first), std::chrono::nanoseconds(2));
  EXPECT_EQ(taken_at[0], taken_at[1]);  // both readers at once
  const auto& nodes = rig.metrics.nodes();
  EXPECT_NEAR(nodes[0].cpu_core_s, 100 * cost.publish_core_s, 1e-9);  // once, not per reader
  for (std::size_t i : {1u, 2u}) {
    EXPECT_NEAR(nodes[i].receive_core_s, 100 * cost.receive_core_s, 1e-9) << nodes[i].name;
  }
  const std::optional<DdsLinkStats> stats = rig.graph.dds_stats("/fix");
  ASSERT_TRUE(stats.has_value());
  EXPECT_EQ(stats->samples_written, 100);
  EXPECT_EQ(stats->datagrams_sent, 100);
  EXPECT_EQ(stats->samples_delivered, 200);  // summed over the two readers
  EXPECT_EQ(stats->datagrams_dropped, 0);
  EXPECT_FALSE(rig.graph.dds_stats("/nope").has_value());
}

// A keep-all topic whose reader cannot take its 3000 B datagrams (a 2000 B socket): the first
// sample stays unacknowledged in the WHC, above its 1500 B high-water mark, so the second write
// blocks (max_blocking unset: for good) and with it the publisher's job: its timer ticks overrun
// and it publishes nothing more. Keep-last, the same writer is never throttled.
TEST(NodeGraph, AKeepAllWriteBlockedAtTheHighWaterMarkHoldsThePublishersJob) {
  auto run = [](History history) {
    PlatformProfile profile = DdsCostProfile();
    profile.dds.whc_high_bytes = 1500;
    profile.dds.whc_low_bytes = 500;
    profile.dds.receive_buffer_bytes = 1000;  // doubled by the kernel: 2000 B
    profile.dds.host_rmem_max_bytes = 1000;
    auto rig = std::make_unique<Rig>(profile);
    PlatformConfig config;
    config.transport["/big"] =
        TopicTransportConfig{.transport = Transport::kDds, .history = history};
    rig->graph.ApplyConfig(config);
    auto topic = rig->graph.AddTopic<int>({.name = "/big", .type = {"Big", 3000, false}});
    const NodeId source = AddSourceNode(rig->graph, NodeSpec{.name = "source"}, topic, kZeroTime,
                                        milliseconds(10), [](Time) { return 1; });
    AddSinkNode(rig->graph, NodeSpec{.name = "sink"}, topic);
    rig->kernel.RunUntil(milliseconds(500));
    EXPECT_EQ(rig->graph.queued(source), 0u);
    return std::make_pair(std::move(rig), source);
  };
  const auto [keep_all, source] = run(History::kKeepAll);
  EXPECT_TRUE(keep_all->graph.busy(source));  // its second write still waits
  const RunMetrics::NodeData& blocked = keep_all->metrics.nodes()[0];
  EXPECT_EQ(blocked.jobs, 1u);
  EXPECT_GT(blocked.timer_overruns, 40u);
  EXPECT_EQ(keep_all->graph.dds_stats("/big")->samples_written, 1);
  EXPECT_EQ(keep_all->metrics.nodes()[1].jobs, 0u);  // the sink never got it

  const auto [keep_last, unused] = run(History::kKeepLast);
  EXPECT_EQ(keep_last->metrics.nodes()[0].jobs, 50u);
  EXPECT_EQ(keep_last->metrics.nodes()[0].timer_overruns, 0u);
}

// The ZCU104 profile's point cloud over DDS at 30 fps: 366 datagrams per cloud against a socket
// buffer of 2 x 212 992 B. Reliable: overflow, NACKs and repairs, fewer clouds than offered, all
// counted in summary.json; best effort (the topic's own setting): every cloud lost.
TEST(Board, APointCloudOverDdsOverflowsTheSocketAndTheSummaryCountsIt) {
  auto run = [](std::optional<Reliability> reliability) {
    PlatformConfig config;
    config.profile = "platforms/zcu104.yaml";
    config.background_loads = false;
    config.transport["/points"] =
        TopicTransportConfig{.transport = Transport::kDds, .reliability = reliability};
    Kernel kernel;
    RngStreams rng(1);
    Board board(kernel, "car0", config, "scenarios", &rng, milliseconds(1000));
    NodeGraph& graph = board.graph();
    auto points = graph.AddTopic<int>({.name = "/points", .type = msg::PointCloud640()});
    AddSourceNode(graph, NodeSpec{.name = "camera", .mapping = {.cost = "camera_publisher"}},
                  points, kZeroTime, FromSeconds(1.0 / 30.0), [](Time) { return 0; });
    AddSinkNode(graph, NodeSpec{.name = "probe", .mapping = {.cost = "fps_probe"}}, points,
                SubscriptionOptions{.loaned = false});
    board.Finish();
    kernel.RunUntil(std::chrono::seconds(6));
    return board.Report(std::chrono::seconds(6));
  };
  const BoardReport reliable = run(std::nullopt);  // the profile's: reliable
  const NodeReport* probe = reliable.report.FindNode("probe");
  ASSERT_NE(probe, nullptr);
  EXPECT_GT(probe->rate_hz, 1.0);
  EXPECT_LT(probe->rate_hz, 28.0);
  const TopicReport* topic = reliable.report.FindTopic("/points");
  ASSERT_TRUE(topic->dds.has_value());
  EXPECT_GT(topic->dds->datagrams_dropped, 0);
  EXPECT_GT(topic->dds->nacks, 0);
  EXPECT_GT(topic->dds->datagrams_retransmitted, 0);
  const nlohmann::json summary = ReportJson(reliable.report);
  EXPECT_EQ(summary["topics"][0]["dds"]["datagrams_dropped"], topic->dds->datagrams_dropped);

  const BoardReport best_effort = run(Reliability::kBestEffort);
  EXPECT_EQ(best_effort.report.FindNode("probe")->jobs, 0u);
  EXPECT_GT(best_effort.report.FindTopic("/points")->dds->samples_lost, 150);
  EXPECT_EQ(best_effort.report.FindTopic("/points")->dds->nacks, 0);
}

}  // namespace
}  // namespace autonomsim::sim
