// summary.json's one definition: the keys users' scripts read, pinned here by hand; what is
// written reads back as the same file; a file that lacks a key or has a wrong type says where.
#include "sim/results/summary.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "sim/core/config.h"
#include "sim/loop/simulation.h"

namespace autonomsim::sim {
namespace {

using ::testing::HasSubstr;

RunSummary HandMadeSummary() {
  RunSummary s;
  s.scenario = "demo";
  s.scenario_file = "scenarios/demo.yaml";
  s.seed = 42;
  s.scenario_sha256 = "ab";
  s.result_sha256 = "cd";
  s.sim_seconds = 10.0;
  s.wall_seconds = 0.5;
  s.real_time_factor = 20.0;
  s.kernel_events = 1234;
  s.expectations = {{.name = "no_collision", .passed = false, .detail = "car 1 hit obstacle a"}};
  s.passed = false;
  CarMetrics car;
  car.id = 1;
  car.route = "outer";
  car.route_length_m = 12.5;
  car.laps = 2;
  car.lap_times_s = {30.0, 61.5};
  car.collisions = 1;
  car.max_lateral_error_m = 0.125;
  car.rms_lateral_error_m = 0.0625;
  car.distance_m = 25.0;
  car.mean_speed_mps = 0.4;
  car.intersection_entries = 3;
  car.waits = 1;
  car.total_wait_s = 2.5;
  car.max_wait_s = 2.5;
  car.perception = PerceptionMetrics{.lane_frames = 300,
                                     .lane_valid_frames = 290,
                                     .lane_error_samples = 280,
                                     .lane_error_max_m = 0.05,
                                     .lane_error_rms_m = 0.02,
                                     .grid_frames = 100,
                                     .grid_obstacle_frames = 7};
  s.cars = {car};
  s.server = {
      .requests = 5, .grants = 4, .denials = 1, .frees = 3, .lease_expiries = 0, .malformed = 0};
  s.v2i = {.sent = 9, .delivered = 8, .lost = 1};
  s.platform = std::map<std::string, nlohmann::json>{{"car1", {{"cpu_percent", 150.0}}}};
  s.versions = {.autonomsim = "1", .box2d = "2.4.1", .opencv = "4.6.0", .compiler = "gcc"};
  s.preset_overrides = std::vector<PresetOverride>{{.key = "traffic_lights.policy",
                                                    .preset = "lab",
                                                    .preset_value = "original",
                                                    .value = "fifo"}};
  return s;
}

// The file as users' scripts know it (keys in the order nlohmann::json writes them: sorted).
constexpr char kHandMadeJson[] = R"({
  "cars": [
    {
      "collisions": 1,
      "distance_m": 25.0,
      "id": 1,
      "intersection_entries": 3,
      "lap_times_s": [
        30.0,
        61.5
      ],
      "laps": 2,
      "max_lateral_error_m": 0.125,
      "max_wait_s": 2.5,
      "mean_speed_mps": 0.4,
      "min_obstacle_gap_m": null,
      "perception": {
        "grid_frames": 100,
        "grid_obstacle_frames": 7,
        "lane_error_max_m": 0.05,
        "lane_error_rms_m": 0.02,
        "lane_error_samples": 280,
        "lane_frames": 300,
        "lane_valid_frames": 290
      },
      "rms_lateral_error_m": 0.0625,
      "route": "outer",
      "route_length_m": 12.5,
      "total_wait_s": 2.5,
      "waits": 1
    }
  ],
  "expectations": [
    {
      "detail": "car 1 hit obstacle a",
      "name": "no_collision",
      "passed": false
    }
  ],
  "kernel_events": 1234,
  "passed": false,
  "platform": {
    "car1": {
      "cpu_percent": 150.0
    }
  },
  "preset_overrides": [
    {
      "key": "traffic_lights.policy",
      "preset": "lab",
      "preset_value": "original",
      "value": "fifo"
    }
  ],
  "real_time_factor": 20.0,
  "result_sha256": "cd",
  "scenario": "demo",
  "scenario_file": "scenarios/demo.yaml",
  "scenario_sha256": "ab",
  "seed": 42,
  "server": {
    "denials": 1,
    "frees": 3,
    "grants": 4,
    "lease_expiries": 0,
    "malformed": 0,
    "requests": 5
  },
  "sim_seconds": 10.0,
  "v2i": {
    "delivered": 8,
    "lost": 1,
    "sent": 9
  },
  "versions": {
    "autonomsim": "1",
    "box2d": "2.4.1",
    "compiler": "gcc",
    "opencv": "4.6.0"
  },
  "wall_seconds": 0.5
})";

TEST(Summary, TheFileHasTheKeysUsersRead) {
  EXPECT_EQ(SummaryJson(HandMadeSummary()).dump(2), kHandMadeJson);
}

TEST(Summary, WhatIsWrittenReadsBackAsTheSameFile) {
  const nlohmann::json written = SummaryJson(HandMadeSummary());
  EXPECT_EQ(SummaryJson(ParseSummary(nlohmann::json::parse(written.dump()))), written);

  // a real run with boards, perception and stack metrics
  const LoadedScenario loaded =
      LoadScenario("scenarios/lab_two_cars.yaml", {"duration_s=1", "expect=[]"});
  Simulation simulation(loaded);
  simulation.Run();
  const nlohmann::json run = SummaryJson(Summarize(loaded, simulation.record(), {}, 0.0));
  EXPECT_TRUE(run.at("platform").is_object());
  EXPECT_TRUE(run.at("real_time_factor").is_null());  // no wall time measured
  // the default scenario's named departures from stack.preset lab: 6 per car and the server's
  EXPECT_EQ(run.at("preset_overrides").size(), 13u);
  EXPECT_EQ(SummaryJson(ParseSummary(nlohmann::json::parse(run.dump()))), run);
}

TEST(Summary, EmptyOptionalsAreNullOrLeftOutAndNaNReadsBack) {
  RunSummary s = HandMadeSummary();
  s.real_time_factor.reset();
  s.cars[0].perception.reset();
  s.cars[0].min_obstacle_gap_m = 0.25;
  s.cars[0].max_wait_s = std::nan("");
  s.platform.reset();
  const nlohmann::json j = SummaryJson(s);
  EXPECT_TRUE(j.at("real_time_factor").is_null());
  EXPECT_FALSE(j.at("cars")[0].contains("perception"));
  EXPECT_FALSE(j.at("cars")[0].contains("stack"));
  EXPECT_FALSE(j.contains("platform"));
  EXPECT_EQ(j.at("cars")[0].at("min_obstacle_gap_m"), 0.25);
  const RunSummary back = ParseSummary(nlohmann::json::parse(j.dump()));
  EXPECT_FALSE(back.real_time_factor);
  EXPECT_FALSE(back.cars[0].perception);
  EXPECT_FALSE(back.platform);
  EXPECT_EQ(back.cars[0].min_obstacle_gap_m, 0.25);
  EXPECT_TRUE(std::isnan(back.cars[0].max_wait_s));  // JSON has no NaN: written as null
}

// Issue 34, item 3: car 1 of lab_two_cars.yaml, whose lane detector's results never reach 0.5 m
// on a straight, had lane_error_max_m 0.0 beside lane_error_samples 0, and a sweep drew it as a
// perfect detector. What was not measured is null, and reads back empty.
TEST(Summary, AMetricWithoutSamplesIsNullNotZero) {
  RunSummary s = HandMadeSummary();
  s.cars[0].perception = PerceptionMetrics{.lane_frames = 300, .lane_valid_frames = 120};
  s.cars[0].stack = StackMetrics{};  // no localization estimate yet
  const nlohmann::json j = SummaryJson(s);
  const nlohmann::json& perception = j.at("cars")[0].at("perception");
  EXPECT_EQ(perception.at("lane_error_samples"), 0);
  EXPECT_TRUE(perception.at("lane_error_max_m").is_null());
  EXPECT_TRUE(perception.at("lane_error_rms_m").is_null());
  EXPECT_TRUE(j.at("cars")[0].at("stack").at("max_localization_error_m").is_null());
  EXPECT_TRUE(j.at("cars")[0].at("stack").at("final_localization_error_m").is_null());
  const RunSummary back = ParseSummary(nlohmann::json::parse(j.dump()));
  EXPECT_FALSE(back.cars[0].perception->lane_error_max_m.has_value());
  EXPECT_FALSE(back.cars[0].stack->max_localization_error_m.has_value());
  // a file written before (0.0 with no sample) still reads, as the value it holds
  nlohmann::json old = j;
  old["cars"][0]["perception"]["lane_error_max_m"] = 0.0;
  EXPECT_EQ(ParseSummary(old).cars[0].perception->lane_error_max_m, 0.0);
}

TEST(Summary, ARealTimeRunsPacingIsUnderRealtimeAndOtherRunsHaveNoSuchKey) {
  EXPECT_FALSE(SummaryJson(HandMadeSummary()).contains("realtime"));
  RunSummary s = HandMadeSummary();
  s.realtime = RealTimeMetrics{.slice_s = 0.01,
                               .slices = 6000,
                               .late_slices = 3,
                               .pacing_max_lag_s = 0.025,
                               .pacing_mean_lag_s = 0.5e-5,
                               .messages_sent = 66,
                               .messages_received = 62};
  const nlohmann::json j = SummaryJson(s);
  EXPECT_EQ(j.at("realtime").dump(),
            R"({"late_slices":3,"messages_received":62,"messages_sent":66,)"
            R"("pacing_max_lag_s":0.025,"pacing_mean_lag_s":5e-06,"slice_s":0.01,"slices":6000})");
  EXPECT_EQ(SummaryJson(ParseSummary(nlohmann::json::parse(j.dump()))), j);
}

TEST(Summary, AMissingKeyOrAWrongTypeIsAnErrorNamingIt) {
  nlohmann::json j = SummaryJson(HandMadeSummary());
  j["cars"][0].erase("laps");
  try {
    ParseSummary(j);
    FAIL() << "no error";
  } catch (const ConfigError& e) {
    EXPECT_THAT(e.what(), HasSubstr("cars[0].laps: missing"));
  }
  j = SummaryJson(HandMadeSummary());
  j["server"]["grants"] = -1;
  try {
    ParseSummary(j);
    FAIL() << "no error";
  } catch (const ConfigError& e) {
    EXPECT_THAT(e.what(), HasSubstr("server.grants: expected a whole number"));
  }
  j = SummaryJson(HandMadeSummary());
  j["passed"] = "yes";
  EXPECT_THROW(ParseSummary(j), ConfigError);
  j = SummaryJson(HandMadeSummary());
  j["a key from a newer version"] = 1;
  EXPECT_NO_THROW(ParseSummary(j));
}

}  // namespace
}  // namespace autonomsim::sim
