// The scenario loader: a valid file resolves; broken files and overrides fail with messages that
// name the file, the line and the key.
#include "sim/scenario/scenario.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "sim/mqtt/mqtt_process.h"  // TempDir
#include "sim/scenario/tests/scenario_file.h"

namespace autonomsim::sim {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

using testing::ScenarioFile;

const char* kValid = R"(name: valid
seed: 3
duration_s: 10
track: tracks/lab.yaml
cars:
  - id: 0
    route: south_loop
    start: real_car
  - id: 1
    route: inner_loop
    start_s_m: 2.0
expect:
  - no_collision:
  - completes: {car: 0, laps: 1}
)";

std::string Replace(std::string text, const std::string& from, const std::string& to) {
  const std::size_t at = text.find(from);
  if (at == std::string::npos) throw std::logic_error("test fixture: '" + from + "' not found");
  return text.replace(at, from.size(), to);
}

TEST(ScenarioTest, AValidFileResolvesRoutesStartsAndHash) {
  ScenarioFile file("valid", kValid);
  const LoadedScenario loaded = LoadScenario(file.path());
  EXPECT_EQ(loaded.scenario.name, "valid");
  EXPECT_EQ(loaded.scenario.seed, 3u);
  ASSERT_EQ(loaded.cars.size(), 2u);
  EXPECT_EQ(loaded.cars[0].route.name, "south_loop");
  EXPECT_TRUE(loaded.cars[1].route.cyclic);
  EXPECT_NEAR(loaded.cars[0].start_pose.x_m, 0.96, 1e-12);  // the named pose, reference §1
  EXPECT_NEAR(loaded.cars[1].start_s_m, 2.0, 1e-12);
  EXPECT_EQ(loaded.sha256.size(), 64u);
  // every default is in the resolved form
  EXPECT_TRUE(loaded.resolved["scenario"]["cars"][0]["vehicle"].contains("mass_kg"));
  EXPECT_DOUBLE_EQ(loaded.resolved["scenario"]["v2i"]["latency_s"].get<double>(), 0.02);
}

TEST(ScenarioTest, TheHashFollowsTheResolvedScenarioNotTheText) {
  ScenarioFile a("hash_a", kValid);
  // the same scenario with a comment and a default spelled out
  ScenarioFile b("hash_b", std::string("# a comment\n") +
                               Replace(kValid, "seed: 3", "seed: 3\nphysics: {step_s: 0.002}"));
  ScenarioFile c("hash_c", Replace(kValid, "seed: 3", "seed: 4"));
  EXPECT_EQ(LoadScenario(a.path()).sha256, LoadScenario(b.path()).sha256);
  EXPECT_NE(LoadScenario(a.path()).sha256, LoadScenario(c.path()).sha256);
  EXPECT_EQ(LoadScenario(a.path(), {}, 4).sha256, LoadScenario(c.path()).sha256);
  // a limit decides whether the scenario loads, not what it does: the hash stays, the resolved
  // scenario records it
  const LoadedScenario raised = LoadScenario(a.path(), {"limits.grid_cells=50000000"});
  EXPECT_EQ(raised.sha256, LoadScenario(a.path()).sha256);
  EXPECT_EQ(raised.resolved["scenario"]["limits"]["grid_cells"].get<std::uint64_t>(), 50000000u);
}

TEST(ScenarioTest, OverridesReachAnyField) {
  ScenarioFile file("overrides", kValid);
  const LoadedScenario loaded = LoadScenario(
      file.path(),
      {"cars[1].oracle.speed_mps=0.3", "cars[0].laps=2", "v2i.loss=0.1", "duration_s=20"});
  EXPECT_DOUBLE_EQ(loaded.scenario.cars[1].oracle.speed_mps, 0.3);
  EXPECT_EQ(loaded.scenario.cars[0].laps, 2);
  EXPECT_DOUBLE_EQ(loaded.scenario.v2i.loss, 0.1);
  EXPECT_EQ(loaded.scenario.duration, std::chrono::seconds(20));
}

struct BrokenCase {
  std::string name;
  std::string text;
  std::vector<std::string> overrides;
  std::vector<std::string> expected;  // substrings of the error message
};

class BrokenScenarioTest : public ::testing::TestWithParam<BrokenCase> {};

// Issue 34, item 5: what-if tweaks on a shipped scenario without copying it. A car's start is by
// name or by arc length: --set of one replaces the file's other (it was "give at most one of start
// or start_s_m"); KEY=null removes a key, so its default applies (it was refused); a deadline past
// a shortened end is a warning (it was an error), as a fault after the end is.
TEST(ScenarioTest, ASetReplacesTheStartsOtherFormAndNullRemovesAKey) {
  ScenarioFile file("what_if", Replace(kValid, "laps: 1}", "laps: 1, within_s: 8}"));
  const LoadedScenario by_arc = LoadScenario(file.path(), {"cars[0].start_s_m=3"});
  EXPECT_NEAR(by_arc.cars[0].start_s_m, 3.0, 1e-12);
  EXPECT_FALSE(by_arc.scenario.cars[0].start.has_value());
  const LoadedScenario by_name = LoadScenario(file.path(), {"cars[1].start=inner_north"});
  EXPECT_EQ(by_name.scenario.cars[1].start, "inner_north");
  EXPECT_FALSE(by_name.scenario.cars[1].start_s_m.has_value());

  const LoadedScenario unset = LoadScenario(file.path(), {"cars[0].start=null"});
  EXPECT_FALSE(unset.scenario.cars[0].start.has_value());
  EXPECT_FALSE(unset.scenario.cars[0].start_s_m.has_value());
  const LoadedScenario no_deadline = LoadScenario(file.path(), {"expect[1].completes.within_s=~"});
  EXPECT_EQ(no_deadline.scenario.expect.size(), 2u);
  EXPECT_EQ(ExpectedWithin_s(no_deadline.scenario.expect[1]), std::nullopt);
  const LoadedScenario one_fewer = LoadScenario(file.path(), {"expect[0]=null"});
  ASSERT_EQ(one_fewer.scenario.expect.size(), 1u);
  EXPECT_EQ(KindOf(one_fewer.scenario.expect[0]), ExpectKind::kCompletes);
  // null on a key the file does not have removes nothing, and a required key's absence is the
  // loader's usual error
  EXPECT_NO_THROW(LoadScenario(file.path(), {"cars[0].oracle.speed_mps=null"}));
  EXPECT_THROW(LoadScenario(file.path(), {"cars[0].route=null"}), ConfigError);

  const LoadedScenario shortened = LoadScenario(file.path(), {"duration_s=5"});
  ASSERT_EQ(shortened.warnings.size(), 1u);
  EXPECT_THAT(shortened.warnings[0],
              HasSubstr("expect[1].completes.within_s: within_s 8 s is past the run's end "
                        "(duration_s 5 s): it is judged on the run's 5 s"));
  EXPECT_TRUE(LoadScenario(file.path()).warnings.empty());
}

TEST_P(BrokenScenarioTest, FailsNamingFileLineAndKey) {
  const BrokenCase& c = GetParam();
  ScenarioFile file(c.name, c.text);
  try {
    LoadScenario(file.path(), c.overrides);
    FAIL() << "loaded a broken scenario";
  } catch (const ConfigError& e) {
    for (const std::string& part : c.expected) {
      EXPECT_THAT(e.what(), HasSubstr(part));
    }
  }
}

std::string F(const std::string& name) { return "scenarios/.test_" + name + ".yaml"; }

INSTANTIATE_TEST_SUITE_P(
    Scenario, BrokenScenarioTest,
    ::testing::Values(
        BrokenCase{"unknown_key",
                   Replace(kValid, "duration_s: 10", "durration_s: 10"),
                   {},
                   {F("unknown_key") + ":3:1: durration_s: unknown key 'durration_s'",
                    "did you mean 'duration_s'?"}},
        BrokenCase{"wrong_type",
                   Replace(kValid, "duration_s: 10", "duration_s: fast"),
                   {},
                   {F("wrong_type") + ":3:13: duration_s: expected a number, got 'fast'"}},
        BrokenCase{
            "negative_duration",
            Replace(kValid, "duration_s: 10", "duration_s: -5"),
            {},
            {F("negative_duration") + ":3:13: duration_s: duration_s must be in (0, 86400]"}},
        BrokenCase{"car_id",
                   Replace(kValid, "id: 1", "id: 12"),
                   {},
                   {F("car_id") + ":9:9: cars[1].id: id must be a single digit"}},
        // issue 34: once at the top level, line 1; now at the second car's id, naming the first
        BrokenCase{
            "duplicate_car",
            Replace(kValid, "id: 1", "id: 0"),
            {},
            {F("duplicate_car") + ":9:9: cars[1].id: duplicate car id 0: cars[0] has it too"}},
        BrokenCase{"duplicate_obstacle",
                   std::string(kValid) + "obstacles:\n  - {name: b}\n  - {name: b, x_m: 1}\n",
                   {},
                   {F("duplicate_obstacle") +
                    ":17:12: obstacles[1].name: duplicate obstacle name 'b': obstacles[0] has it "
                    "too"}},
        BrokenCase{"unknown_route",
                   Replace(kValid, "route: inner_loop", "route: figure_nine"),
                   {},
                   {F("unknown_route") + ":10:12: cars[1].route:", "figure_nine", "south_loop"}},
        BrokenCase{"route_typo",
                   Replace(kValid, "route: inner_loop", "route: inner_lop"),
                   {},
                   {F("route_typo") + ":10:12: cars[1].route: unknown route 'inner_lop' (did you "
                                      "mean 'inner_loop'?); known routes: inner_loop, north_loop, "
                                      "outer_loop, south_loop"}},
        // issue 34: the start pose's error named neither the track's poses nor the closest
        BrokenCase{"unknown_start",
                   Replace(kValid, "start: real_car", "start: real_cra"),
                   {},
                   {F("unknown_start") + ":8:12: cars[0].start: unknown start pose 'real_cra' (did "
                                         "you mean 'real_car'?); known start poses: gazebo, "
                                         "inner_north, real_car"}},
        BrokenCase{"unknown_start_far_from_any",
                   Replace(kValid, "start: real_car", "start: pit_lane"),
                   {},
                   {"cars[0].start: unknown start pose 'pit_lane'; known start poses: gazebo, "
                    "inner_north, real_car"}},
        BrokenCase{"lanes_disconnected",
                   Replace(kValid, "route: inner_loop", "lanes: [outer_south, middle_west]"),
                   {},
                   {"cars[1].lanes:", "outer_south", "middle_west"}},
        BrokenCase{"start_off_route",
                   Replace(kValid, "start: real_car", "start: inner_north"),
                   {},
                   {F("start_off_route") + ":8:12: cars[0].start:", "is not on route"}},
        BrokenCase{"start_beyond_route",
                   Replace(kValid, "start_s_m: 2.0", "start_s_m: 99"),
                   {},
                   {"cars[1].start_s_m: start_s_m must be in [0, "}},
        // issue 34, item 7: two cars on one start pose (before: "car 1 hit car 0" at
        // t = 0.002 s); 0.4 m apart along the route, the 0.525 m cars still overlap
        BrokenCase{"overlapping_starts",
                   Replace(Replace(kValid, "route: inner_loop", "route: south_loop"),
                           "start_s_m: 2.0", "start: real_car"),
                   {},
                   {F("overlapping_starts") + ":11:12: cars[1].start: car 1 starts overlapping "
                                              "car 0 (at (0.96, -2.18) and (0.96, -2.18), 0.000 m "
                                              "apart, 0.525 m cars)"}},
        BrokenCase{"overlapping_along_the_route",
                   Replace(Replace(kValid, "route: inner_loop", "route: south_loop"),
                           "start: real_car", "start_s_m: 0.0"),
                   {"cars[1].start_s_m=0.4"},
                   {"cars[1].start_s_m: car 1 starts overlapping car 0", "0.400 m apart"}},
        BrokenCase{"route_and_lanes",
                   Replace(kValid, "route: inner_loop", "route: inner_loop\n    lanes: [inner]"),
                   {},
                   {"cars[1]: give exactly one of route or lanes"}},
        BrokenCase{"loss",
                   Replace(kValid, "seed: 3", "seed: 3\nv2i: {loss: 1.5}"),
                   {},
                   {F("loss") + ":3:13: v2i.loss: loss must be in [0, 1), got 1.5"}},
        BrokenCase{"expect_kind",
                   Replace(kValid, "- no_collision:", "- no_colision:"),
                   {},
                   {F("expect_kind") + ":13:5: expect[0].no_colision: unknown key",
                    "did you mean 'no_collision'?"}},
        BrokenCase{
            "expect_argument",
            Replace(kValid, "- no_collision:", "- no_collision: {laps: 3}"),
            {},
            {"expect[0].no_collision.laps: 'no_collision' takes no key 'laps' (its keys: car)"}},
        // issue 34 asked that a fault's unknown key list only its own kind's keys: it does (since
        // the reference's commit), this keeps it so
        BrokenCase{"fault_argument",
                   std::string(kValid) +
                       "faults:\n  - node_crash: {car: 0, node: lane_detection, for_s: 2}\n",
                   {},
                   {F("fault_argument") + ":16:48: faults[0].node_crash.for_s: 'node_crash' takes "
                                          "no key 'for_s' (its keys: at_s, car, node)"}},
        BrokenCase{"expect_two_kinds",
                   Replace(kValid, "- no_collision:", "- {no_collision: , intersection_mutex: }"),
                   {},
                   {"expect[0]: an expect entry names exactly one expectation"}},
        BrokenCase{"expect_unknown_car",
                   Replace(kValid, "{car: 0, laps: 1}", "{car: 5, laps: 1}"),
                   {},
                   {"expect[1]: no car with id 5"}},
        BrokenCase{"obstacle_times",
                   std::string(kValid) + "obstacles:\n  - {name: b, appear_s: 5, disappear_s: 2}\n",
                   {},
                   {F("obstacle_times") + ":16:41: obstacles[0].disappear_s: disappear_s must be "
                                          "after appear_s"}},
        // issue 34: a negative height was reported at length_m's line
        BrokenCase{"obstacle_negative_height",
                   std::string(kValid) + "obstacles:\n  - {name: b, height_m: -0.1}\n",
                   {},
                   {F("obstacle_negative_height") +
                    ":16:25: obstacles[0].height_m: height_m must be > 0, got -0.1"}},
        BrokenCase{"no_cars", "name: empty\ncars: []\n", {}, {"cars must not be empty"}},
        // issue 34: `run STUDY.yaml` said "unknown key 'scenario'"
        BrokenCase{"a_study",
                   "scenario: ../lab_two_cars.yaml\nrepeat: 3\n",
                   {},
                   {F("a_study") + ":1:11: scenario: this is a study file",
                    "run it with `autonomsim sweep " + F("a_study") + "`"}},
        BrokenCase{"yaml_syntax",
                   Replace(kValid, "seed: 3", "seed: [3"),
                   {},
                   {F("yaml_syntax") + ":", "YAML syntax error"}},
        BrokenCase{"missing_track",
                   Replace(kValid, "tracks/lab.yaml", "tracks/nope.yaml"),
                   {},
                   // issue 15 (fuzzing): once without the scenario's file, line and key
                   {F("missing_track") + ":4:8: track: scenarios/tracks/nope.yaml: no such file"}},
        BrokenCase{
            "set_unknown_key",
            kValid,
            {"cars[0].oracle.sped_mps=1"},
            {"--set cars[0].oracle.sped_mps: unknown key 'sped_mps'", "did you mean 'speed_mps'?"}},
        BrokenCase{"set_bad_value",
                   kValid,
                   {"cars[0].laps=many"},
                   {"--set cars[0].laps: expected an integer"}},
        BrokenCase{"set_index",
                   kValid,
                   {"cars[7].laps=1"},
                   {"--set cars[7].laps: index 7 is out of range"}},
        BrokenCase{"set_syntax", kValid, {"cars[0].laps"}, {"expected key=value"}},
        // issue 15: once a SIGABRT in Box2D, or accepted 9 m off a 5 m floor
        BrokenCase{"obstacle_far_away",
                   kValid,
                   {"obstacles=[{name: far, x_m: 1e39, y_m: 0.0}]"},
                   {"obstacles[0].x_m", "is off the track's floor (|x_m| <= 2.5 m)"}},
        BrokenCase{"obstacle_off_floor",
                   kValid,
                   {"obstacles=[{name: off, x_m: 0.0, y_m: 9.0}]"},
                   {"obstacles[0].y_m", "y_m 9 m is off the track's floor"}},
        BrokenCase{"obstacle_huge",
                   kValid,
                   {"obstacles=[{name: wall, x_m: 0.0, y_m: 0.0, length_m: 1e30}]"},
                   {"obstacles[0].length_m", "is larger than the track's floor"}},
        BrokenCase{"driver_unknown",
                   kValid,
                   {"cars[0].driver=autopilot"},
                   {"--set cars[0].driver", "driver must be 'oracle'", "or 'stack'"}},
        BrokenCase{"lane_thresholds_unknown",
                   kValid,
                   {"cars[0].perception.lane_detection.thresholds=real_cars"},
                   {"--set cars[0].perception.lane_detection.thresholds: thresholds must be "
                    "'simulation' or 'real_car', got 'real_cars' (did you mean 'real_car'?)"}},
        BrokenCase{
            "mapping_without_board",
            Replace(kValid, "start: real_car",
                    "start: real_car\n    platform: {mapping: {lane_detektion: {target: sw}}}"),
            {},
            {F("mapping_without_board") + ":9:",
             "cars[0].platform.mapping.lane_detektion: car 0 has no board"}},
        // issue 33, item 3: sizes beyond the limits were a std::bad_alloc with no location (a
        // track of size_m 100: 5 GB for a 3 s run); each is refused at its key, with the limit
        BrokenCase{"floor_raster_beyond_the_limit",
                   kValid,
                   {"limits.grid_cells=100000"},
                   {F("floor_raster_beyond_the_limit") +
                        ":4:8: track: the track's floor raster (size_m 5 m at 0.005 m per texel) "
                        "has 1 M cells; the limit is limits.grid_cells = 100000 (0.1 M)",
                    "raise limits.grid_cells"}},
        BrokenCase{"planner_map_beyond_the_limit",
                   kValid,
                   {"cars[1].stack.global_costmap.resolution_m=0.0001"},
                   {"--set cars[1].stack.global_costmap.resolution_m: car 1's planner map",
                    "has 10 G cells; the limit is limits.grid_cells = 16777216 (16.8 M)"}},
        BrokenCase{"camera_beyond_the_limit",
                   kValid,
                   {"cars[0].sensors.depth_camera.camera.width_px=8192",
                    "cars[0].sensors.depth_camera.camera.height_px=8192"},
                   {"cars[0].sensors.depth_camera.camera: car 0's depth_camera image (8192 × "
                    "8192 px) has 67.1 M cells"}},
        BrokenCase{"trajectory_beyond_the_limit",
                   kValid,
                   {"output.trajectory_period_s=1e-7"},
                   {"--set output.trajectory_period_s: trajectory.csv would have 200 M rows "
                    "(duration_s 10 s / trajectory_period_s 1e-07 s × 2 cars",
                    "limits.trajectory_rows = 20000000"}},
        BrokenCase{"limit_zero", kValid, {"limits.grid_cells=0"}, {"grid_cells must be >= 1"}},
        BrokenCase{"top_level_list_with_set",
                   "- a\n- b\n",
                   {"duration_s=3"},
                   {F("top_level_list_with_set") + ":1:1: (top level): expected a mapping"}},
        BrokenCase{"stack_without_perception",
                   kValid,
                   {"cars[0].driver=stack"},
                   {"cars[0]", "set perception.enabled: true"}}),
    [](const ::testing::TestParamInfo<BrokenCase>& param_info) { return param_info.param.name; });

// Issue 34: a number in a message reads as the user wrote it ("got 65", not "got 65.000000").
TEST(ScenarioTest, AMessageWritesABadNumberAsTheUserWouldWriteIt) {
  ScenarioFile file("number_in_message", kValid);
  for (const auto& [key, value] :
       {std::pair{"color_stddev", "65"}, std::pair{"depth_stddev_per_m", "0.25"}}) {
    try {
      LoadScenario(file.path(),
                   {std::string("cars[0].sensors.color_camera.noise.") + key + "=" + value});
      FAIL() << key << ": no error";
    } catch (const ConfigError& e) {
      EXPECT_THAT(e.what(), ::testing::EndsWith(std::string(", got ") + value)) << key;
    }
  }
}

// Issue 15: a scenario kept outside scenarios/ finds the shipped track and profile.
TEST(ScenarioTest, AScenarioAnywhereFindsTheShippedTrackAndProfile) {
  const TempDir dir("scenario_test_");
  const fs::path file = dir.path() / "mine.yaml";
  std::ofstream(file) << kValid;
  const LoadedScenario loaded =
      LoadScenario(file, {"cars[0].perception.enabled=true", "duration_s=5"});
  EXPECT_EQ(loaded.cars.size(), 2u);
  EXPECT_TRUE(loaded.cars[0].profile.has_value());
  try {
    LoadScenario(file, {"track=tracks/nope.yaml"});
    FAIL() << "no error";
  } catch (const ConfigError& e) {
    EXPECT_THAT(e.what(), HasSubstr("--set track: "));
    EXPECT_THAT(e.what(), HasSubstr("/tracks/nope.yaml: no such file (nor "));
  }
}

TEST(ScenarioTest, AMissingFileIsAnError) {
  EXPECT_THROW(LoadScenario("scenarios/does_not_exist.yaml"), ConfigError);
}

TEST(ScenarioTest, EveryShippedScenarioLoads) {
  int count = 0;
  for (const auto& entry : fs::directory_iterator("scenarios")) {
    if (entry.path().extension() != ".yaml" || entry.path().filename().string()[0] == '.') {
      continue;
    }
    EXPECT_NO_THROW(LoadScenario(entry.path())) << entry.path();
    ++count;
  }
  EXPECT_GE(count, 3);
}

}  // namespace
}  // namespace autonomsim::sim
