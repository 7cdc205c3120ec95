// The platform model against hand-computed cases: processor sharing on N cores, CPU accounting,
// transport costs growing with bytes, FPGA slots, shared-memory chunks, the profile file.
#include "sim/platform/platform.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "sim/core/config.h"

namespace autonomsim::sim {
namespace {

using std::chrono::milliseconds;
using ::testing::HasSubstr;

// Runs `kernel` and returns when each of the started jobs finished, in seconds.
struct CpuRig {
  explicit CpuRig(int cores) : cpu(kernel, cores, &metrics) {
    metrics.AddNode("a", "sw");
    metrics.AddNode("b", "sw");
    metrics.AddNode("c", "sw");
  }
  void Start(int owner, double work, double parallelism) {
    const std::size_t i = done_s.size();
    done_s.push_back(-1.0);
    cpu.Start(owner, work, parallelism, [this, i] { done_s[i] = ToSeconds(kernel.Now()); });
  }
  Kernel kernel;
  RunMetrics metrics;
  Cpu cpu;
  std::vector<double> done_s;
};

constexpr double kNs = 1e-9;  // event times are whole nanoseconds, rounded up

TEST(Cpu, OneJobUsesAtMostItsParallelism) {
  CpuRig rig(4);
  rig.Start(0, 1.0, 1.0);  // 1 core-second on one core: 1 s, although 4 cores are free
  rig.kernel.RunUntil(std::chrono::seconds(5));
  EXPECT_NEAR(rig.done_s[0], 1.0, kNs);

  CpuRig half(4);
  half.Start(0, 1.0, 0.5);  // a job that can keep only half a core busy
  half.kernel.RunUntil(std::chrono::seconds(5));
  EXPECT_NEAR(half.done_s[0], 2.0, kNs);
}

TEST(Cpu, OversubscribedCoresAreSharedEqually) {
  // 3 jobs of 1 core-second on 2 cores: each gets 2/3 of a core, all end at 1.5 s.
  CpuRig rig(2);
  for (int i = 0; i < 3; ++i) rig.Start(i, 1.0, 1.0);
  EXPECT_NEAR(rig.cpu.busy_cores(), 2.0, 1e-12);
  rig.kernel.RunUntil(std::chrono::seconds(5));
  for (double t : rig.done_s) EXPECT_NEAR(t, 1.5, kNs);
}

TEST(Cpu, WaterFillingGivesTheRestToTheWideJob) {
  // 4 cores: B (1 core-s, p = 1) gets 1 core, A (2 core-s, p = 4) the other 3: A ends at 2/3 s;
  // then B, still limited to one core, ends at 1 s.
  CpuRig rig(4);
  rig.Start(0, 2.0, 4.0);
  rig.Start(1, 1.0, 1.0);
  EXPECT_NEAR(rig.cpu.busy_cores(), 4.0, 1e-12);
  rig.kernel.RunUntil(std::chrono::seconds(5));
  EXPECT_NEAR(rig.done_s[0], 2.0 / 3.0, kNs);
  EXPECT_NEAR(rig.done_s[1], 1.0, kNs);
}

TEST(Cpu, AnArrivalSlowsTheRunningJob) {
  // 1 core: A (1 core-s) alone from 0 to 0.5 s, then A and B (1 core-s) share it: A ends at 1.5 s,
  // B has done 0.5 by then and ends at 2.0 s.
  CpuRig rig(1);
  rig.Start(0, 1.0, 1.0);
  rig.kernel.ScheduleAt(milliseconds(500), [&rig] { rig.Start(1, 1.0, 1.0); });
  rig.kernel.RunUntil(std::chrono::seconds(5));
  EXPECT_NEAR(rig.done_s[0], 1.5, kNs);
  EXPECT_NEAR(rig.done_s[1], 2.0, kNs);
}

TEST(Cpu, ThreeWideJobsOnFourCores) {
  // A, B, C with p = 3, 2, 0.5 on 4 cores: water-filling gives C its 0.5, then A and B 1.75 each.
  CpuRig rig(4);
  rig.Start(0, 3.5, 3.0);
  rig.Start(1, 1.75, 2.0);
  rig.Start(2, 1.0, 0.5);
  EXPECT_NEAR(rig.cpu.share(1), 1.75, 1e-12);
  EXPECT_NEAR(rig.cpu.share(3), 0.5, 1e-12);
  rig.kernel.RunUntil(std::chrono::seconds(5));
  // B: 1.75 at 1.75 cores -> 1 s. A has 1.75 left at 3 cores -> 1 + 7/12 s. C: 0.5 per s -> 2 s.
  EXPECT_NEAR(rig.done_s[1], 1.0, kNs);
  EXPECT_NEAR(rig.done_s[0], 1.0 + 1.75 / 3.0, 2 * kNs);
  EXPECT_NEAR(rig.done_s[2], 2.0, 2 * kNs);
}

TEST(Cpu, AccountsBusyCoreSecondsPerOwnerAndOverTime) {
  CpuRig rig(2);
  rig.Start(0, 1.0, 1.0);
  rig.Start(1, 1.0, 2.0);  // both on 1 core each: 1 s
  rig.kernel.RunUntil(std::chrono::seconds(3));
  const MetricsReport report = BuildReport(rig.metrics, std::chrono::seconds(3));
  EXPECT_NEAR(report.cpu_percent, 100.0 * 2.0 / 3.0, 1e-6);  // 2 core-s in 3 s
  EXPECT_NEAR(report.nodes[0].cpu_percent, 100.0 / 3.0, 1e-6);
  EXPECT_NEAR(report.nodes[1].cpu_percent, 100.0 / 3.0, 1e-6);
  ASSERT_GE(report.cpu_load_percent.size(), 1u);
  EXPECT_NEAR(report.cpu_load_percent[0], 200.0, 1e-6);  // both cores busy in the first second
}

TEST(Metrics, LatencyOverTimeIsBinnedOverTheWholeRun) {
  MetricsOptions options;
  options.measure_from = std::chrono::seconds(1);  // the bins ignore the warm-up window
  RunMetrics metrics(options);
  const int topic = metrics.AddTopic("/cmd", "dds", 16, 3);
  using std::chrono::milliseconds;
  metrics.Published(0, topic, milliseconds(500), milliseconds(480));    // bin 0: 20 ms
  metrics.Published(0, topic, milliseconds(2100), milliseconds(2090));  // bin 2: 10 ms
  metrics.Published(0, topic, milliseconds(2900), milliseconds(2870));  // bin 2: 30 ms
  const MetricsReport report = BuildReport(metrics, std::chrono::seconds(3));
  const TopicReport& t = report.topics.at(0);
  EXPECT_EQ(t.published, 2u);  // the window's count
  ASSERT_EQ(t.latency_max_ms_per_bin.size(), 3u);
  EXPECT_NEAR(t.latency_max_ms_per_bin[0].value(), 20.0, 1e-9);
  EXPECT_FALSE(t.latency_max_ms_per_bin[1].has_value());  // nothing published in the second bin
  EXPECT_NEAR(t.latency_max_ms_per_bin[2].value(), 30.0, 1e-9);
  EXPECT_NEAR(t.latency_mean_ms_per_bin[2].value(), 20.0, 1e-9);
  const nlohmann::json json = ReportJson(report)["topics"][0]["latency_per_bin_ms"];
  EXPECT_TRUE(json["max"][1].is_null());
  EXPECT_NEAR(json["mean"][0].get<double>(), 20.0, 1e-9);
}

// Issue 34, item 3: a node without jobs and a topic never published had turnaround and latency
// statistics of 0 ms in summary.json, which a sweep tabled and plotted as measured.
TEST(Metrics, StatisticsOfNoSampleAreNullInTheJson) {
  RunMetrics metrics;
  const int idle = metrics.AddNode("idle", "sw");
  const int busy = metrics.AddNode("busy", "sw");
  metrics.AddTopic("/never", "dds", 16, 1);
  using std::chrono::milliseconds;
  metrics.JobDone(busy, milliseconds(100), milliseconds(104), 0.004);
  const nlohmann::json json = ReportJson(BuildReport(metrics, std::chrono::seconds(1)));
  const nlohmann::json& idle_turnaround = json["nodes"][idle]["turnaround_ms"];
  EXPECT_EQ(idle_turnaround["count"], 0);
  for (const char* statistic : {"min", "p50", "p95", "p99", "max"}) {
    EXPECT_TRUE(idle_turnaround[statistic].is_null()) << statistic;
    EXPECT_TRUE(json["topics"][0]["latency_ms"][statistic].is_null()) << statistic;
  }
  EXPECT_EQ(json["nodes"][busy]["turnaround_ms"]["count"], 1);
  EXPECT_NEAR(json["nodes"][busy]["turnaround_ms"]["p50"].get<double>(), 4.0, 0.01);
}

TEST(Cpu, RejectsNonsense) {
  CpuRig rig(1);
  EXPECT_THROW(rig.cpu.Start(0, -1.0, 1.0, [] {}), std::invalid_argument);
  EXPECT_THROW(rig.cpu.Start(0, 1.0, 0.0, [] {}), std::invalid_argument);
  EXPECT_THROW(rig.cpu.Start(0, std::nan(""), 1.0, [] {}), std::invalid_argument);
}

PlatformProfile SimpleProfile() {
  PlatformProfile p;
  p.name = "simple";
  p.cpu.memcpy_bytes_per_s = 1e9;  // 1 ns per byte and copy
  p.dds.max_message_bytes = 1000;
  p.dds.fragment_bytes = 100;
  p.dds.write = {.fixed = std::chrono::microseconds(10),
                 .copies = 2,
                 .per_datagram = std::chrono::microseconds(5),
                 .per_fragment = std::chrono::microseconds(1)};
  p.dds.receive = {.fixed = std::chrono::microseconds(10), .copies = 2};
  p.dds.take = {.copies = 1};
  p.zero_copy.publish = std::chrono::microseconds(20);
  p.zero_copy.take = std::chrono::microseconds(20);
  p.zero_copy.non_loaned_take_copies = 1;
  p.zero_copy.mempools = {{.chunk_bytes = 1 << 20, .chunks = 4}};
  return p;
}

TEST(Transport, DdsCostsGrowWithTheBytesOnBothSides) {
  const PlatformProfile p = SimpleProfile();
  // 2,500 B: 10 us + 2 copies (5 us) + 3 datagrams (15 us) + 25 fragments (25 us) = 55 us
  EXPECT_NEAR(DdsCost(p, 2500).publish_core_s, 55e-6, 1e-12);
  EXPECT_NEAR(DdsCost(p, 2500).receive_core_s, 15e-6, 1e-12);  // 10 us + 2 copies
  EXPECT_NEAR(DdsCost(p, 2500).take_core_s, 2.5e-6, 1e-12);
  double previous = 0.0;
  for (std::int64_t bytes : {240, 248, 614400, 921600, 4915200}) {
    const TransportCost c = DdsCost(p, bytes);
    EXPECT_GT(c.publish_core_s, previous);
    previous = c.publish_core_s;
  }
  // Ten times the bytes, about ten times the cost (the fixed part aside).
  const double small = DdsCost(p, 100000).publish_core_s - 10e-6;
  const double large = DdsCost(p, 1000000).publish_core_s - 10e-6;
  EXPECT_NEAR(large / small, 10.0, 1e-9);
}

TEST(Transport, ZeroCopyIsNearConstantUnlessTheSubscriberCopies) {
  const PlatformProfile p = SimpleProfile();
  EXPECT_EQ(ZeroCopyCost(p, 240, true).publish_core_s,
            ZeroCopyCost(p, 4915200, true).publish_core_s);
  EXPECT_EQ(ZeroCopyCost(p, 240, true).take_core_s, ZeroCopyCost(p, 4915200, true).take_core_s);
  EXPECT_EQ(ZeroCopyCost(p, 4915200, true).receive_core_s, 0.0);
  // without the loan API: one copy of 4,915,200 B at 1 GB/s on top
  EXPECT_NEAR(ZeroCopyCost(p, 4915200, false).take_core_s, 20e-6 + 4915200e-9, 1e-12);
}

TEST(Transport, TheZcu104ProfileMakesDdsDearerThanZeroCopyForEveryMessage) {
  const PlatformProfile p = LoadPlatformProfile("scenarios/platforms/zcu104.yaml");
  for (std::int64_t bytes : {240, 614400, 4915200}) {
    const TransportCost dds = DdsCost(p, bytes);
    const TransportCost zc = ZeroCopyCost(p, bytes, true);
    EXPECT_GT(dds.publish_core_s + dds.receive_core_s + dds.take_core_s,
              zc.publish_core_s + zc.take_core_s)
        << bytes;
  }
}

TEST(Fpga, OneHardwareNodePerSlot) {
  Kernel kernel;
  FpgaProfile profile{.slots = 3, .memif_bytes_per_s = 5e8};
  Fpga fpga(kernel, profile, nullptr);
  fpga.Claim(0, "point_cloud");
  try {
    fpga.Claim(0, "lane_planner");
    FAIL() << "expected a ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_THAT(e.what(), HasSubstr("already serves node 'point_cloud'"));
  }
  EXPECT_THROW(fpga.Claim(3, "x"), ConfigError);
  EXPECT_THROW(fpga.Claim(-1, "x"), ConfigError);
  EXPECT_EQ(fpga.TransferTime(1000000), milliseconds(2));  // 1 MB at 500 MB/s
}

TEST(Platform, AHardwareJobEndsWhenFabricAndDelegateAreBothDone) {
  Kernel kernel;
  PlatformProfile p = SimpleProfile();
  p.cpu.cores = 1;
  p.fpga.slots = 1;
  Platform platform(kernel, p, nullptr);
  platform.fpga().Claim(0, "hw");
  double fabric_first = -1.0;
  double delegate_first = -1.0;
  platform.RunHwJob(0, -1, milliseconds(10), 0.004,
                    [&] { fabric_first = ToSeconds(kernel.Now()); });
  kernel.RunUntil(milliseconds(100));
  EXPECT_NEAR(fabric_first, 0.010, kNs);
  // Now the delegate shares the only core with a 20 ms software job: its 4 ms at half a core
  // take 8 ms, longer than the 2 ms in the fabric, so the delegate decides when the job ends.
  platform.cpu().Start(-1, 0.020, 1.0, [] {});
  platform.RunHwJob(0, -1, milliseconds(2), 0.004,
                    [&] { delegate_first = ToSeconds(kernel.Now() - milliseconds(100)); });
  kernel.RunUntil(milliseconds(200));
  EXPECT_NEAR(delegate_first, 0.008, 2 * kNs);
}

TEST(ChunkPools, TheSmallestFittingChunkAndExhaustion) {
  ChunkPools pools({{.chunk_bytes = 1024, .chunks = 2}, {.chunk_bytes = 8 << 20, .chunks = 1}});
  EXPECT_EQ(pools.PoolFor(240), 0);
  EXPECT_EQ(pools.PoolFor(1024), 0);
  EXPECT_EQ(pools.PoolFor(4915200), 1);
  EXPECT_EQ(pools.PoolFor(9 << 20), std::nullopt);
  EXPECT_TRUE(pools.Acquire(1));
  EXPECT_FALSE(pools.Acquire(1));
  pools.Release(1);
  EXPECT_TRUE(pools.Acquire(1));
  EXPECT_THROW(pools.Release(0), std::logic_error);
}

TEST(Profile, TheZcu104ProfileLoadsAndNamesEveryComponentOfTableI) {
  const PlatformProfile p = LoadPlatformProfile("scenarios/platforms/zcu104.yaml");
  EXPECT_EQ(p.name, "zcu104");
  EXPECT_EQ(p.cpu.cores, 4);
  EXPECT_EQ(p.fpga.slots, 3);
  EXPECT_EQ(p.zero_copy.max_subscribers, 127);
  EXPECT_EQ(p.zero_copy.max_loans_per_publisher, 8);
  for (const char* name : {"astra_sdk", "cam2image", "camera_publisher", "fps_probe", "point_cloud",
                           "obstacle_detection", "lane_detection", "lane_planner", "poly_fit"}) {
    EXPECT_NO_THROW(p.Component(name)) << name;
  }
  EXPECT_TRUE(p.Component("point_cloud").hw.has_value());
  EXPECT_FALSE(p.Component("lane_detection").hw.has_value());
}

TEST(Profile, MistakesNameTheFileLineAndKey) {
  try {
    LoadPlatformProfile("scenarios/platforms/zcu104.yaml", {"cpu.coers=2"});
    FAIL() << "expected a ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_THAT(e.what(), HasSubstr("cpu.coers"));
    EXPECT_THAT(e.what(), HasSubstr("did you mean 'cores'"));
  }
  try {
    LoadPlatformProfile("scenarios/platforms/zcu104.yaml",
                        {"components.point_cloud.sw.max_parallelism=0"});
    FAIL() << "expected a ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_THAT(e.what(), HasSubstr("max_parallelism must be > 0"));
  }
  EXPECT_THROW(LoadPlatformProfile("scenarios/platforms/zcu104.yaml",
                                   {"zero_copy.mempools=[{chunk_bytes: 2048, chunks: 1}, "
                                    "{chunk_bytes: 1024, chunks: 1}]"}),
               ConfigError);
  try {
    LoadPlatformProfile("scenarios/platforms/zcu104.yaml", {"components.obstacle_detection={}"});
    FAIL() << "expected a ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_THAT(e.what(), HasSubstr("components.obstacle_detection"));
  }
}

TEST(Profile, PlatformConfigValidates) {
  const YAML::Node ok = YAML::Load(
      "profile: platforms/zcu104.yaml\n"
      "mapping: {point_cloud: {target: hw, slot: 0}}\n"
      "transport: {/points: {transport: dds, depth: 1}}\n");
  const PlatformConfig config = ReadConfig<PlatformConfig>(ok, ConfigSource{"s.yaml", {}});
  EXPECT_EQ(config.mapping.at("point_cloud").slot, 0);
  EXPECT_EQ(config.transport.at("/points").transport, Transport::kDds);
  // a DDS topic's own Cyclone settings, under the names `autonomsim transport --set dds.KEY` uses
  const PlatformConfig tuned = ReadConfig<PlatformConfig>(
      YAML::Load("transport: {/points: {transport: dds, reliability: best_effort, history: "
                 "keep_all, receive_buffer_bytes: 4194304, fragment_bytes: 65000, "
                 "max_message_bytes: 65500}}"),
      ConfigSource{"s.yaml", {}});
  const TopicTransportConfig& points = tuned.transport.at("/points");
  EXPECT_EQ(points.reliability, Reliability::kBestEffort);
  EXPECT_EQ(points.history, History::kKeepAll);
  EXPECT_EQ(points.receive_buffer_bytes, 4194304);
  EXPECT_EQ(points.fragment_bytes, 65000);
  EXPECT_EQ(points.max_message_bytes, 65500);
  for (const char* bad :
       {"mapping: {a: {target: fpga}}", "mapping: {a: {target: hw}}",
        "mapping: {a: {target: sw, slot: 1}}", "transport: {/x: {transport: shm}}",
        "transport: {/x: {depth: 0}}", "transport: {/x: {transport: dds, fragment_bytes: 0}}",
        "transport: {/x: {transport: dds, reliability: sometimes}}",
        // the DDS settings need a DDS topic
        "transport: {/x: {transport: zero_copy, reliability: best_effort}}"}) {
    EXPECT_THROW(ReadConfig<PlatformConfig>(YAML::Load(bad), ConfigSource{"s.yaml", {}}),
                 ConfigError)
        << bad;
  }
}

}  // namespace
}  // namespace autonomsim::sim
