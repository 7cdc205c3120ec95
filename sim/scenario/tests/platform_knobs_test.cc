// The platform's what-if knobs (issue 8), as a scenario's `platform:` fields: a per-node cost
// scale, a per-node cost distribution replacing the profile's cost, and the CPU core count.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <tuple>
#include <vector>

#include "sim/core/config.h"
#include "sim/platform/node_graph.h"
#include "sim/platform/platform.h"
#include "sim/platform/tests/free_transport_profile.h"
#include "sim/scenario/scenario.h"

namespace autonomsim::sim {
namespace {

using std::chrono::milliseconds;
using ::testing::HasSubstr;

// A profile whose transports are free and instantaneous, so a job's turnaround is its own work:
// "work" costs 30 ms in software, or 5 ms in the fabric plus its memory transfers.
PlatformProfile TestProfile(int cores = 2) {
  PlatformProfile p = testing::FreeTransportProfile(cores);
  p.components["work"] =
      ComponentCost{.sw = SwCost{.work_s = 0.030}, .hw = HwCost{.compute_s = 0.005}};
  return p;
}

int Identity(const int&, const int& in, void*) { return in; }

// A source every 100 ms into "work" (jobs never overlap), on a board built from `config`;
// returns the turnaround statistics of "work"'s jobs, in ms.
Stats WorkTurnarounds(const PlatformConfig& config, std::uint64_t seed = 1, int* cores = nullptr) {
  Kernel kernel;
  RngStreams rng(seed);
  PlatformConfig c = config;
  c.background_loads = false;
  c.trace = false;
  Board board(kernel, "car0", c, TestProfile(), &rng);
  NodeGraph& graph = board.graph();
  auto in = graph.AddTopic<int>({.name = "/in", .type = {"I", 8, true}});
  auto out = graph.AddTopic<int>({.name = "/out", .type = {"I", 8, true}});
  AddSourceNode(graph, NodeSpec{.name = "source"}, in, kZeroTime, milliseconds(100),
                [](Time) { return 0; });
  AddComponentNode(graph, NodeSpec{.name = "work"}, in, out, 0, std::shared_ptr<void>(), Identity);
  board.Finish();
  kernel.RunUntil(std::chrono::seconds(5) + milliseconds(50));
  if (cores) *cores = board.platform().cpu().cores();
  for (const auto& n : board.metrics().nodes()) {
    if (n.name == "work") return n.turnaround.ComputeStats();
  }
  return {};
}

TEST(PlatformKnobs, CostScaleMultipliesSoftwareWorkAndHardwareFabricTime) {
  PlatformConfig sw;
  EXPECT_NEAR(WorkTurnarounds(sw).min, 30.0, 1e-6);
  EXPECT_NEAR(WorkTurnarounds(sw).max, 30.0, 1e-6);
  sw.cost_scale["work"] = 2.5;
  const Stats scaled = WorkTurnarounds(sw);
  ASSERT_EQ(scaled.count, 50u);  // the 51st job (at 5 s) still runs at 5.05 s
  EXPECT_NEAR(scaled.min, 75.0, 1e-6);
  EXPECT_NEAR(scaled.max, 75.0, 1e-6);

  PlatformConfig hw;
  hw.mapping["work"] = NodeMappingConfig{.target = Target::kHw, .slot = 1};
  // 5 ms of fabric + 16 bytes over the memory interface at 1 GB/s
  EXPECT_NEAR(WorkTurnarounds(hw).max, 5.000016, 1e-6);
  hw.cost_scale["work"] = 4.0;
  EXPECT_NEAR(WorkTurnarounds(hw).min, 4 * 5.000016, 1e-6);
}

TEST(PlatformKnobs, CostOverrideReplacesTheCostWithASeededDraw) {
  PlatformConfig fixed;
  fixed.cost_override["work"] =
      CostDistributionConfig{.distribution = CostDistribution::kFixed, .value_s = 0.012};
  EXPECT_NEAR(WorkTurnarounds(fixed).min, 12.0, 1e-6);
  EXPECT_NEAR(WorkTurnarounds(fixed).max, 12.0, 1e-6);
  fixed.cost_scale["work"] = 2.0;  // applies on top of the override
  EXPECT_NEAR(WorkTurnarounds(fixed).min, 24.0, 1e-6);
  EXPECT_NEAR(WorkTurnarounds(fixed).max, 24.0, 1e-6);

  PlatformConfig uniform;
  uniform.cost_override["work"] = CostDistributionConfig{
      .distribution = CostDistribution::kUniform, .min_s = 0.010, .max_s = 0.020};
  const Stats a = WorkTurnarounds(uniform, 7);
  ASSERT_EQ(a.count, 51u);
  EXPECT_GE(a.min, 10.0 - 1e-6);
  EXPECT_LE(a.max, 20.0 + 1e-6);
  EXPECT_GT(a.max - a.min, 5.0);
  const Stats again = WorkTurnarounds(uniform, 7);  // same seed, same draws
  EXPECT_EQ(std::tie(a.min, a.p50, a.max, a.mean),
            std::tie(again.min, again.p50, again.max, again.mean));
  EXPECT_NE(a.mean, WorkTurnarounds(uniform, 8).mean);

  PlatformConfig lognormal;
  lognormal.cost_override["work"] = CostDistributionConfig{
      .distribution = CostDistribution::kLognormal, .mean_s = 0.020, .stddev_s = 0.005};
  const Stats l = WorkTurnarounds(lognormal, 3);
  EXPECT_GT(l.min, 0.0);
  EXPECT_NEAR(l.mean, 20.0, 2.5);  // 51 draws: the sample mean within ~3 standard errors
}

TEST(PlatformKnobs, DrawsFollowTheirDistributions) {
  Rng rng(11);
  const CostDistributionConfig normal{
      .distribution = CostDistribution::kNormal, .mean_s = 0.0, .stddev_s = 1.0};
  int zeros = 0;
  for (int i = 0; i < 1000; ++i) {
    const double x = DrawCostSeconds(normal, rng);
    EXPECT_GE(x, 0.0);  // truncated at 0
    zeros += x == 0.0;
  }
  EXPECT_GT(zeros, 400);
  EXPECT_LT(zeros, 600);
  const CostDistributionConfig logn{
      .distribution = CostDistribution::kLognormal, .mean_s = 2.0, .stddev_s = 1.0};
  double sum = 0.0, sum2 = 0.0;
  const int n = 20000;
  for (int i = 0; i < n; ++i) {
    const double x = DrawCostSeconds(logn, rng);
    sum += x;
    sum2 += x * x;
  }
  const double m = sum / n;
  EXPECT_NEAR(m, 2.0, 0.05);
  EXPECT_NEAR(std::sqrt(sum2 / n - m * m), 1.0, 0.05);
}

TEST(PlatformKnobs, CoresOverrideTheProfile) {
  PlatformConfig config;
  int cores = 0;
  WorkTurnarounds(config, 1, &cores);
  EXPECT_EQ(cores, 2);
  config.cores = 3;
  WorkTurnarounds(config, 1, &cores);
  EXPECT_EQ(cores, 3);
}

TEST(PlatformKnobs, UnknownNodeNamesAreConfigErrors) {
  for (const std::string field : {"cost_scale", "cost_override"}) {
    PlatformConfig config;
    if (field == "cost_scale") {
      config.cost_scale["wrok"] = 2.0;
    } else {
      config.cost_override["wrok"] = CostDistributionConfig{.value_s = 0.01};
    }
    try {
      WorkTurnarounds(config);
      FAIL() << "expected a ConfigError for " << field;
    } catch (const ConfigError& e) {
      EXPECT_THAT(e.what(), HasSubstr("platform." + field + ".wrok: no node of that name"));
      EXPECT_THAT(e.what(), HasSubstr("work"));
    }
  }
}

TEST(PlatformKnobs, BadValuesAreConfigErrorsNamingTheKey) {
  const ConfigSource source{"test.yaml", {}};
  auto read = [&](const std::string& yaml) {
    return ReadConfig<PlatformConfig>(YAML::Load(yaml), source, "platform");
  };
  EXPECT_NO_THROW(
      read("{cores: 2, cost_scale: {lane_planner: 2.0}, cost_override: {poly_fit: "
           "{distribution: normal, mean_s: 0.01, stddev_s: 0.002}}}"));
  const std::vector<std::pair<std::string, std::string>> bad = {
      {"{cores: 0}", "cores must be >= 1"},
      {"{cost_scale: {a: 0}}", "cost_scale.a must be finite and > 0"},
      {"{cost_override: {a: {distribution: uniform, min_s: 2, max_s: 1}}}", "min_s must be <="},
      {"{cost_override: {a: {distribution: gamma, value_s: 1}}}", "distribution must be"},
      // a closed set read as its names: they are listed, a typo is named
      {"{cost_override: {a: {distribution: lognormla, mean_s: 1, stddev_s: 1}}}",
       "distribution must be 'fixed', 'uniform', 'normal' or 'lognormal', got 'lognormla' (did "
       "you mean 'lognormal'?)"},
      {"{cost_override: {a: {distribution: fixed}}}", "needs value_s"},
      {"{cost_override: {a: {distribution: fixed, value_s: 1, mean_s: 2}}}", "takes no mean_s"},
  };
  for (const auto& [yaml, message] : bad) {
    try {
      read(yaml);
      FAIL() << "expected a ConfigError for " << yaml;
    } catch (const ConfigError& e) {
      EXPECT_THAT(e.what(), HasSubstr(message)) << yaml;
    }
  }
}

TEST(PlatformKnobs, AScenarioReachesThemByOverride) {
  const LoadedScenario loaded = LoadScenario(
      "scenarios/lab_two_cars.yaml",
      {"cars[0].platform.cost_scale.lane_planner=2.0", "cars[0].platform.cores=2",
       "cars[1].platform.cost_override.poly_fit={distribution: fixed, value_s: 0.01}"});
  EXPECT_EQ(loaded.scenario.cars[0].platform.cost_scale.at("lane_planner"), 2.0);
  EXPECT_EQ(loaded.scenario.cars[0].platform.cores, 2);
  EXPECT_EQ(*loaded.scenario.cars[1].platform.cost_override.at("poly_fit").value_s, 0.01);
  EXPECT_NE(loaded.sha256, LoadScenario("scenarios/lab_two_cars.yaml").sha256);
}

}  // namespace
}  // namespace autonomsim::sim
