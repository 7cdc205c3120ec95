// The closed loop as a whole: determinism, independence of runs, and the behaviour the scenarios
// rely on (parking after laps, safety under message loss, stopping for an obstacle).
#include "sim/loop/simulation.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <thread>

#include "sim/mqtt/mqtt_process.h"  // TempDir
#include "sim/results/expectations.h"
#include "sim/results/outputs.h"
#include "vehicle/tests/gl_available.h"

namespace autonomsim::sim {
namespace {

constexpr const char* kDefault = "scenarios/lab_two_cars_oracle.yaml";

std::string ReadFile(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

TEST(SimulationTest, SameScenarioAndSeedGiveBitIdenticalResults) {
  const LoadedScenario scenario = LoadScenario(kDefault);
  const RunRecord a = RunScenario(scenario);
  const RunRecord b = RunScenario(LoadScenario(kDefault));
  ASSERT_GT(a.events.size(), 20u);
  ASSERT_GT(a.trajectory.size(), 1000u);
  EXPECT_EQ(TrajectoryCsv(a), TrajectoryCsv(b));
  EXPECT_EQ(EventsJsonl(a), EventsJsonl(b));
  EXPECT_EQ(ResultSha256(a), ResultSha256(b));
  EXPECT_EQ(a.kernel_events, b.kernel_events);
}

// The result hashes of two runs of `scenario` on two threads at once.
std::array<std::string, 2> ShasOnTwoThreads(const LoadedScenario& scenario) {
  std::array<std::string, 2> sha;
  std::thread t1([&] { sha[0] = ResultSha256(RunScenario(scenario)); });
  std::thread t2([&] { sha[1] = ResultSha256(RunScenario(scenario)); });
  t1.join();
  t2.join();
  return sha;
}

TEST(SimulationTest, RunsOnTwoThreadsAtOnceMatchASequentialRun) {
  const LoadedScenario scenario = LoadScenario(kDefault);
  const std::string sequential = ResultSha256(RunScenario(scenario));
  EXPECT_THAT(ShasOnTwoThreads(scenario), ::testing::Each(sequential));
}

// The GL camera backend in the loop: deterministic like the ray caster, also with two runs on two
// threads at once (a context each); its frames are the cameras' (the stack drives on them).
TEST(SimulationTest, TheGlCameraBackendGivesTheSameResultTwiceAndOnTwoThreads) {
  AUTONOMSIM_REQUIRE_GL();
  const std::vector<std::string> gl{"camera_backend=gl", "duration_s=2.5", "expect=[]"};
  const LoadedScenario scenario = LoadScenario("scenarios/lab_two_cars.yaml", gl);
  const RunRecord a = RunScenario(scenario);
  ASSERT_GT(a.trajectory.size(), 100u);
  const std::string sequential = ResultSha256(a);
  EXPECT_EQ(ResultSha256(RunScenario(scenario)), sequential);
  EXPECT_THAT(ShasOnTwoThreads(scenario), ::testing::Each(sequential));
  // the cars drove: the stack read the GL frames
  double fastest_mps = 0.0;
  for (const TrajectorySample& s : a.trajectory) fastest_mps = std::max(fastest_mps, s.speed_mps);
  EXPECT_GT(fastest_mps, 0.2);
  try {
    LoadScenario("scenarios/lab_two_cars.yaml", {"camera_backend=vulkan"});
    ADD_FAILURE() << "an unknown camera backend was accepted";
  } catch (const ConfigError& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("camera_backend must be 'raycast'"));
  }
}

// A run streamed into its folder (RunFolder, what `run`, `check --out` and sweeps do) gives the
// same files, hash and verdicts as the same run kept in memory.
TEST(SimulationTest, AStreamedRunWritesWhatARunInMemoryWrites) {
  const LoadedScenario scenario = LoadScenario("scenarios/static_obstacle.yaml", {"v2i.loss=0.2"});
  const TempDir dir("simulation_test");
  const RunRecord memory = RunScenario(scenario);
  WriteRunFolder(scenario, memory, EvaluateExpectations(scenario.scenario, memory), 0.0,
                 dir.path() / "memory");

  RunFolder folder(dir.path() / "streamed");
  Simulation simulation(scenario, folder.store());
  simulation.Run();
  const RunRecord& streamed = simulation.record();
  EXPECT_TRUE(streamed.events.empty());
  EXPECT_TRUE(streamed.trajectory.empty());
  EXPECT_EQ(ResultSha256(streamed), ResultSha256(memory));
  const auto verdicts = EvaluateExpectations(scenario.scenario, streamed);
  const auto expected = EvaluateExpectations(scenario.scenario, memory);
  ASSERT_EQ(verdicts.size(), expected.size());
  for (std::size_t i = 0; i < verdicts.size(); ++i)
    EXPECT_EQ(verdicts[i].detail, expected[i].detail);
  folder.Complete(scenario, streamed, verdicts, 0.0);
  for (const char* file : {"trajectory.csv", "events.jsonl", "track.png"}) {
    EXPECT_EQ(ReadFile(dir.path() / "streamed" / file), ReadFile(dir.path() / "memory" / file))
        << file;
  }
  EXPECT_FALSE(std::filesystem::exists(dir.path() / "memory" / "nodes.csv"));
}

// A streamed run writes its boards' trace into the folder as it makes it (issue 38: a 10-car
// minute's trace is ~47 MB of text, which the run held whole beside its events); the file is the
// in-memory run's trace_json, byte for byte.
TEST(SimulationTest, AStreamedRunWritesItsTraceIntoTheFolderNotIntoTheRecord) {
  const LoadedScenario scenario =
      LoadScenario(kDefault, {"cars[1].perception.enabled=true", "duration_s=3", "expect=[]"});
  const TempDir dir("simulation_test");
  const RunRecord memory = RunScenario(scenario);
  ASSERT_NE(memory.trace_json.find("\"traceEvents\""), std::string::npos);

  RunFolder folder(dir.path() / "streamed");
  Simulation simulation(scenario, folder.store());
  simulation.Run();
  const RunRecord& streamed = simulation.record();
  EXPECT_TRUE(streamed.trace_json.empty());
  folder.Complete(scenario, streamed, {}, 0.0);
  EXPECT_EQ(ReadFile(dir.path() / "streamed" / "trace.json"), memory.trace_json);
}

TEST(SimulationTest, TheSeedChangesTheRun) {
  // the V2I delays are drawn from seeded streams, so another seed moves the grant times
  const std::string a = ResultSha256(RunScenario(LoadScenario(kDefault, {}, 1)));
  const std::string b = ResultSha256(RunScenario(LoadScenario(kDefault, {}, 2)));
  EXPECT_NE(a, b);
}

TEST(SimulationTest, TheDefaultScenarioDrivesBothCarsThroughBothIntersections) {
  const LoadedScenario scenario = LoadScenario(kDefault);
  const RunRecord record = RunScenario(scenario);
  for (const CarMetrics& car : record.cars) {
    EXPECT_GE(car.laps, 3) << "car " << car.id;
    std::set<int> crossed;
    for (const Event& e : record.events) {
      if (e.type == EventKind::kEnter && e.car == car.id) crossed.insert(e.intersection);
    }
    EXPECT_EQ(crossed, (std::set<int>{0, 1})) << "car " << car.id;
  }
  // they did meet: somebody had to wait for a grant at least once
  EXPECT_GT(record.server.denials, 0u);
  for (const ExpectationResult& r : EvaluateExpectations(scenario.scenario, record)) {
    EXPECT_TRUE(r.passed) << r.name << ": " << r.detail;
  }
}

TEST(SimulationTest, ACarParksAfterItsLaps) {
  const RunRecord record = RunScenario(LoadScenario(kDefault, {"cars[1].laps=1"}));
  const auto parked = std::find_if(record.events.begin(), record.events.end(), [](const Event& e) {
    return e.type == EventKind::kParked && e.car == 1;
  });
  ASSERT_NE(parked, record.events.end());
  EXPECT_EQ(record.cars[1].laps, 1);
  const TrajectorySample& last = record.trajectory.back();
  ASSERT_EQ(last.car, 1);
  EXPECT_LT(std::abs(last.speed_mps), 1e-3);
}

TEST(SimulationTest, LostMessagesDelayCarsButNeverBreakTheIntersectionRules) {
  const LoadedScenario scenario = LoadScenario(kDefault, {"v2i.loss=0.3"});
  const RunRecord record = RunScenario(scenario);
  EXPECT_GT(record.v2i.lost, 10u);
  for (const ExpectationResult& r : EvaluateExpectations(scenario.scenario, record)) {
    if (r.name == "intersection_mutex" || r.name == "no_entry_without_grant" ||
        r.name == "no_collision") {
      EXPECT_TRUE(r.passed) << r.name << ": " << r.detail;
    }
  }
}

TEST(SimulationTest, TheServerCountersAreWhatItsEventsAddUpTo) {
  // a lossy link and a short lease: lost keepalives let leases expire
  const RunRecord record = RunScenario(LoadScenario(
      kDefault, {"v2i.loss=0.5", "traffic_lights.lease_s=1.5", "duration_s=120", "expect=[]"}));
  std::map<EventKind, std::uint64_t> count;
  std::set<int> intersections;
  ForEachEvent(record, [&](const Event& e) {
    ++count[e.type];
    if (e.type == EventKind::kGrant || e.type == EventKind::kDenied ||
        e.type == EventKind::kLeaseExpired || e.type == EventKind::kRequest) {
      EXPECT_GE(e.intersection, 0) << EventJsonLine(e);
      intersections.insert(e.intersection);
    }
  });
  EXPECT_EQ(count[EventKind::kRequest], record.server.requests);
  EXPECT_EQ(count[EventKind::kGrant], record.server.grants);
  EXPECT_EQ(count[EventKind::kDenied], record.server.denials);
  EXPECT_EQ(count[EventKind::kFree], record.server.frees);
  EXPECT_EQ(count[EventKind::kLeaseExpired], record.server.lease_expiries);
  // the run exercised all of them, at both intersections
  EXPECT_GT(record.server.lease_expiries, 0u);
  EXPECT_GT(record.server.denials, 0u);
  EXPECT_EQ(intersections, (std::set<int>{0, 1}));
  // renewals are requests, not grants: a holder renews every second
  EXPECT_GT(record.server.requests, record.server.grants + record.server.denials);
}

TEST(SimulationTest, TheOracleStopsForAnObstacleAndDrivesOnWhenItIsGone) {
  const LoadedScenario scenario = LoadScenario("scenarios/static_obstacle.yaml");
  const RunRecord record = RunScenario(scenario);
  // while the box is there (5 s to 25 s), car 1 comes to a stop; after it, it moves again
  double min_speed_while_present = 1e9, max_speed_after = 0.0;
  for (const TrajectorySample& s : record.trajectory) {
    if (s.car != 1) continue;
    const double t = ToSeconds(s.t);
    if (t > 20 && t < 25) min_speed_while_present = std::min(min_speed_while_present, s.speed_mps);
    if (t > 27 && t < 30) max_speed_after = std::max(max_speed_after, s.speed_mps);
  }
  EXPECT_LT(min_speed_while_present, 0.01);
  EXPECT_GT(max_speed_after, 0.3);
  ASSERT_TRUE(record.cars[1].min_obstacle_gap_m.has_value());
  EXPECT_GE(*record.cars[1].min_obstacle_gap_m, 0.10);
  EXPECT_EQ(record.cars[1].collisions, 0);
}

TEST(SimulationTest, WithoutTheGroundTruthStopTheCarHitsTheObstacle) {
  // the same scenario with the oracle's obstacle stop disabled: the expectation must catch it
  const LoadedScenario scenario =
      LoadScenario("scenarios/static_obstacle.yaml", {"cars[1].oracle.obstacle_stop_gap_m=0"});
  const RunRecord record = RunScenario(scenario);
  EXPECT_GT(record.cars[1].collisions, 0);
  bool caught = false;
  for (const ExpectationResult& r : EvaluateExpectations(scenario.scenario, record)) {
    if (r.name == "no_collision") caught = !r.passed;
  }
  EXPECT_TRUE(caught);
}

}  // namespace
}  // namespace autonomsim::sim

namespace autonomsim::sim {
namespace {

TEST(SimulationBoardTest, OnlyACarWithNodesToRunGetsABoardAndItsCamerasPublishAtTheirRate) {
  const LoadedScenario scenario =
      LoadScenario(kDefault, {"cars[1].perception.enabled=true", "duration_s=6", "expect=[]"});
  ASSERT_FALSE(scenario.cars[0].profile.has_value());
  ASSERT_TRUE(scenario.cars[1].profile.has_value());
  EXPECT_EQ(scenario.cars[1].profile->name, "zcu104");
  EXPECT_TRUE(scenario.resolved.contains("platforms"));
  const RunRecord record = RunScenario(scenario);
  ASSERT_EQ(record.boards.size(), 1u);
  EXPECT_EQ(record.boards[0].board, "car1");
  for (const char* camera : {"color_camera", "depth_camera"}) {
    const NodeReport* node = record.boards[0].report.FindNode(camera);
    ASSERT_NE(node, nullptr) << camera;
    EXPECT_NEAR(node->rate_hz, 30.0, 0.5) << camera;  // reference §2: both cameras at 30 fps
  }
  EXPECT_NE(record.trace_json.find("\"traceEvents\""), std::string::npos);
}

TEST(SimulationBoardTest, ABoardsProfileThatCannotBeLoadedIsAnErrorAtTheCarsKey) {
  try {
    LoadScenario(kDefault,
                 {"cars[0].perception.enabled=true", "cars[0].platform.profile=nope.yaml"});
    FAIL() << "no error";
  } catch (const ConfigError& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("cars[0].platform.profile"));
    EXPECT_THAT(e.what(), ::testing::HasSubstr("nope.yaml"));
  }
}

// Issue 15: a mapping that names no node of the board is an error at the car's key (it named
// neither file, line nor car).
TEST(SimulationBoardTest, AMappingNamingNoNodeIsAnErrorAtTheCarsKey) {
  const LoadedScenario scenario =
      LoadScenario(kDefault, {"cars[1].perception.enabled=true", "duration_s=1", "expect=[]",
                              "cars[1].platform.mapping.lane_detektion.target=sw"});
  try {
    Simulation simulation(scenario);
    FAIL() << "no error";
  } catch (const ConfigError& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("--set cars[1].platform.mapping.lane_detektion"));
    EXPECT_THAT(e.what(), ::testing::HasSubstr("no node of that name (nodes: color_camera"));
  }
}

// driver: stack — the stack's nodes run on the car's board, in place of the background loads that
// stand in for them, at the real rates, and they drive the car.
TEST(SimulationStackTest, TheStacksNodesDriveTheCarFromItsBoard) {
  const RunRecord record =
      RunScenario(LoadScenario("scenarios/stack_obstacle.yaml", {"duration_s=12", "expect=[]"}));
  ASSERT_EQ(record.boards.size(), 1u);
  const MetricsReport& board = record.boards[0].report;
  const std::vector<std::pair<const char*, double>> rates = {
      {"ekf_filter_node", 20.0}, {"controller_server", 20.0}, {"carcontroller", 30.0},
      {"bt_navigator", 100.0},   {"local_costmap", 5.0},      {"vehicle_communication", 10.0}};
  for (const auto& [name, hz] : rates) {
    const NodeReport* node = board.FindNode(name);
    ASSERT_NE(node, nullptr) << name;
    EXPECT_NEAR(static_cast<double>(node->timer_ticks) / 12.0, hz, 0.1 * hz) << name;
    // No tick overruns. (Before the depth driver carried the sheet's load, its 21.7 ms before
    // each publish, the first obstacle grid came before the first transform at or before its
    // time and waited out its 1 s in canTransform, holding the local costmap
    // (obstacle_layer.cpp:46): the update's ticks at 0.4-1.0 s overran.)
    EXPECT_EQ(node->timer_overruns, 0u) << name;
  }
  for (const char* replaced :
       {"nav2_controller", "nav2_planning", "localization_ekf", "vehicle_io"}) {
    EXPECT_EQ(board.FindNode(replaced), nullptr) << replaced;
  }
  // The camera drivers run as the cameras' nodes with the sheet's load (reference §8: AstraSDK
  // 60-70 %, Cam2Image 20-30 %), not as a background load.
  EXPECT_EQ(board.FindNode("camera_drivers"), nullptr);
  ASSERT_NE(board.FindNode("depth_camera"), nullptr);
  ASSERT_NE(board.FindNode("color_camera"), nullptr);
  EXPECT_NEAR(board.FindNode("depth_camera")->cpu_percent, 65.0, 5.0);
  EXPECT_NEAR(board.FindNode("color_camera")->cpu_percent, 25.0, 5.0);
  const CarMetrics& car = record.cars[0];
  ASSERT_TRUE(car.stack.has_value());
  EXPECT_GT(car.distance_m, 1.5);  // 12 s at up to 0.25 m/s, a stop at the intersection
  EXPECT_GT(car.stack->control_cycles, 150u);
  ASSERT_TRUE(car.stack->max_localization_error_m.has_value());  // the EKF estimated
  EXPECT_LT(*car.stack->max_localization_error_m, 0.1);          // with the pose fix
  EXPECT_LT(car.max_lateral_error_m, 0.2);  // as the shipped scenarios (lab_two_cars.yaml)
}

// Where the car stops before stack_obstacle.yaml's box depends on the collision check's model:
// the lab's centre point against INSCRIBED cells (lane_controller.cpp:364-443) reaches ~0.35 m
// ahead of base_link, only ~0.09 m beyond the bumper, and the braking after the stop (~0.15 m: the
// PID's integral term, then the 1 s watchdog) carries the car into the box; the footprint against
// LETHAL cells reaches 0.515 m and stops the car 0.30 m short of it; the lab's recovery then
// clears the local costmap and retries at once (drive_to_pose_test.xml:17-33), each restart runs
// FollowPath for one tick before the gate's RateController halts it, and with the PID's integral
// term the car creeps on to 0.05-0.10 m short of the box, where it waits out the RoundRobin's 5 s.
TEST(SimulationStackTest, TheCollisionModelDecidesWhetherTheCarStopsBeforeTheBox) {
  auto run = [](const char* model) {
    const std::string m = model;
    return RunScenario(LoadScenario(
        "scenarios/stack_obstacle.yaml",
        {"duration_s=27", "expect=[]", "cars[0].stack.follow_path.collision.model=" + m,
         // the collision check alone: without the ultrasonic stop the scenario sets since issue 31
         "cars[0].stack.emergency_stop.enabled=false",
         "cars[0].stack.lane_controller.collision.model=" + m,
         // the gaps below were measured with our lane detection (issue 31: with the lab's,
         // which the preset sets, footprint stops the car 0.108 m short of the box)
         "cars[0].perception.lane_detection.hw_pixel_classes=non_zero",
         "cars[0].perception.lane_detection.hw_no_line=white_below_min",
         "cars[0].perception.lane_detection.hw_truncate_points=false",
         "cars[0].perception.lane_detection.hw_valid_overwrite=false",
         "cars[0].perception.lane_detection.projection=ideal",
         // the gaps were measured with straight wheels on Nav2's zero twist. With the lab's held
         // steering (issue 33, stack/cruise_control.h) the footprint run's car, 3 degrees off the
         // box's axis after its stops, restarts at 24.9 s from a just-cleared local costmap and
         // hits the box at 25.6 s; the shipped scenario, with its ultrasonic stop, stays clear
         // under both presets (0.137 m and 0.419 m)
         "cars[0].stack.cruise_control.hold_steering_on_zero_command=false"}));
  };
  const RunRecord lab = run("centre");
  const RunRecord safe = run("footprint");
  ASSERT_TRUE(lab.cars[0].min_obstacle_gap_m && safe.cars[0].min_obstacle_gap_m);
  EXPECT_EQ(lab.cars[0].collisions, 1);
  EXPECT_EQ(*lab.cars[0].min_obstacle_gap_m, 0.0);
  EXPECT_EQ(safe.cars[0].collisions, 0);
  EXPECT_GT(*safe.cars[0].min_obstacle_gap_m, 0.03);
  EXPECT_LT(*safe.cars[0].min_obstacle_gap_m, 0.15);  // well short of the first stop's 0.30 m
}

// Issue 33, item 1: car 1 stalls inside intersection 0 (6 s to 18 s) while car 0 waits for it, and
// the broker is away from 6.9 s to 11.9 s, so car 1's renewals cannot reach the server for more
// than a lease (5 s). Before, its lease ran out at 11.73 s, car 0 was granted at 12.19 s, drove in
// and hit car 1 at 15.4 s. The server's leases now pause while its broker is away: car 0 waits
// until car 1 has left and freed. The same under stack.preset safe.
TEST(SimulationFaultTest, ALeaseDoesNotRunOutWhileTheBrokerIsAway) {
  for (const char* preset : {"", "safe"}) {
    SCOPED_TRACE(preset);
    std::vector<std::string> overrides = {
        "duration_s=40",
        "faults=[car_stall: {car: 1, at_s: 6.0, for_s: 12}, broker_outage: {at_s: 6.9, for_s: 5}]",
        "expect=[no_collision: {}, intersection_mutex: {}, no_entry_without_grant: {}]"};
    if (*preset != '\0') overrides.push_back(std::string("stack.preset=") + preset);
    const LoadedScenario scenario = LoadScenario("scenarios/lab_two_cars_oracle.yaml", overrides);
    const RunRecord record = RunScenario(scenario);
    for (const ExpectationResult& r : EvaluateExpectations(scenario.scenario, record)) {
      EXPECT_TRUE(r.passed) << r.name << ": " << r.detail;
    }
    EXPECT_EQ(record.server.lease_expiries, 0u);
    for (const Event& e : record.events) {
      if (e.type == EventKind::kGrant && e.car == 0) {
        EXPECT_GT(ToSeconds(e.t), 18.0);  // after car 1 moved on
        break;
      }
    }
  }
}

// Issue 33, item 1: the other paths by which a lease runs out while its holder stands inside: the
// holder's uplink partitioned, or the server restarted (it knows no holder). No server can tell a
// dead holder from a silent one, so the lease runs out and car 0 is granted (lease_expired, or
// the new server's first grant); with intersection_client.enter_only_if_clear (safe) car 0 waits
// at the stop line while its depth camera sees car 1 in the area, goes once car 1 has left, and
// nothing collides. Without it (the scenario as written) car 0 drives into car 1.
TEST(SimulationFaultTest, NoSecondCarEntersWhileAStalledHolderIsCutOffOrForgotten) {
  for (const char* fault : {"v2i_partition: {car: 1, direction: up, at_s: 6.9, for_s: 8}",
                            "v2i_partition: {car: 1, direction: both, at_s: 6.9, for_s: 8}",
                            "server_restart: {at_s: 6.9, for_s: 1}"}) {
    for (const bool guard : {false, true}) {
      SCOPED_TRACE(std::string(fault) + (guard ? ", guard" : ""));
      std::vector<std::string> overrides = {
          "duration_s=40",
          std::string("faults=[car_stall: {car: 1, at_s: 6.0, for_s: 12}, ") + fault + "]",
          "expect=[no_collision: {}, intersection_mutex: {}, no_gridlock: {}]"};
      if (guard) overrides.push_back("stack.preset=safe");
      const LoadedScenario scenario = LoadScenario("scenarios/lab_two_cars_oracle.yaml", overrides);
      const RunRecord record = RunScenario(scenario);
      const auto results = EvaluateExpectations(scenario.scenario, record);
      EXPECT_EQ(results[0].passed, guard) << results[0].detail;  // no_collision
      EXPECT_EQ(results[1].passed, guard) << results[1].detail;  // intersection_mutex
      if (!guard) continue;
      EXPECT_TRUE(results[2].passed) << results[2].detail;  // car 0 goes once the area is clear
      std::optional<double> car1_exit, car0_enter;
      for (const Event& e : record.events) {
        if (e.intersection != 0 || ToSeconds(e.t) < 6.0) continue;
        if (e.type == EventKind::kExit && e.car == 1 && !car1_exit) car1_exit = ToSeconds(e.t);
        if (e.type == EventKind::kEnter && e.car == 0 && !car0_enter) car0_enter = ToSeconds(e.t);
      }
      ASSERT_TRUE(car1_exit && car0_enter);
      EXPECT_GT(*car0_enter, *car1_exit);
    }
  }
}

// The lab's intersection client as it runs (intersection_checker.cpp:69-105 and :120-223, lab
// commit 02c5ab4: one request, blocked until granted, free on the first tick outside every box)
// against the lab's server (vtl.py), stack-driven, nothing lost: car 1 crosses both intersections
// and nobody collides or shares an intersection. Car 0 reaches the right intersection while car 1
// holds it and is denied: it never asks again and stays blocked for the rest of the run, as the
// lab's car would (reference §7). (Car 1 frees in the 0.1 m gap before the left intersection's
// area and enters it unclaimed, the lab's weakness that release_margin_m fixes: not judged here.)
TEST(SimulationStackTest, TheLabsBlockingClientAndServerCrossWithoutCollisions) {
  const LoadedScenario scenario = LoadScenario(
      "scenarios/lab_two_cars.yaml",
      {"duration_s=60", "traffic_lights.policy=original",
       "cars[0].intersection_client.blocking=true", "cars[1].intersection_client.blocking=true",
       "expect=[{no_collision: {}}, {intersection_mutex: {}}]"});
  const RunRecord record = RunScenario(scenario);
  EXPECT_EQ(record.v2i.lost, 0u);
  for (const ExpectationResult& r : EvaluateExpectations(scenario.scenario, record)) {
    EXPECT_TRUE(r.passed) << r.name << ": " << r.detail;
  }
  std::map<int, std::set<int>> entered;
  std::map<int, std::map<EventKind, int>> count;
  for (const Event& e : record.events) {
    if (e.type == EventKind::kEnter) entered[e.car].insert(e.intersection);
    ++count[e.car][e.type];
  }
  EXPECT_EQ(entered[1], (std::set<int>{0, 1}));
  EXPECT_TRUE(entered[0].empty());
  EXPECT_EQ(count[0][EventKind::kRequest], 1);
  EXPECT_EQ(count[0][EventKind::kDenied], 1);
  EXPECT_EQ(count[0][EventKind::kFree], 0);
  EXPECT_EQ(record.server.requests, record.server.grants + record.server.denials);  // no renewals
}

// Without the fix (the real car) the estimate drifts with the IMU's heading; with it, it stays
// within the fix's noise.
TEST(SimulationStackTest, WithoutThePoseFixTheEstimateDrifts) {
  const RunRecord fixed =
      RunScenario(LoadScenario("scenarios/stack_obstacle.yaml", {"duration_s=40", "expect=[]"}));
  const RunRecord drifting = RunScenario(LoadScenario(
      "scenarios/stack_obstacle.yaml",
      {"duration_s=40", "expect=[]", "cars[0].stack.localization.use_pose_fix=false"}));
  ASSERT_TRUE(fixed.cars[0].stack && drifting.cars[0].stack);
  EXPECT_LT(fixed.cars[0].stack->final_localization_error_m.value(), 0.06);
  EXPECT_GT(drifting.cars[0].stack->final_localization_error_m.value(),
            2.0 * fixed.cars[0].stack->final_localization_error_m.value());
  EXPECT_EQ(drifting.boards[0].report.FindNode("pose_fix"), nullptr);
}

}  // namespace
}  // namespace autonomsim::sim
