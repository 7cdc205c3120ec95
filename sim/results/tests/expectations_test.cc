// Expectation verdicts on hand-made run records: no simulation involved.
#include "sim/results/expectations.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace autonomsim::sim {
namespace {

using ::testing::HasSubstr;

Event At(double t_s, EventKind type, int car, int intersection = -1) {
  Event e;
  e.t = FromSeconds(t_s);
  e.type = type;
  e.car = car;
  e.intersection = intersection;
  return e;
}

Event Enter(double t_s, int car, int intersection, bool granted) {
  Event e = At(t_s, EventKind::kEnter, car, intersection);
  e.granted = granted;
  return e;
}

// An expectation as the loader would hand it over: validated.
template <class Expectation>
ExpectClause Clause(Expectation expectation) {
  expectation.Validate();
  return expectation;
}

// An `expect:` entry read from YAML, as the loader reads it.
ExpectClause Read(const std::string& yaml) {
  return ReadConfig<ExpectClause>(YAML::Load(yaml), ConfigSource{"test.yaml", {}});
}

ExpectationResult Judge(const ExpectClause& clause, const RunRecord& record,
                        const std::vector<ObstacleConfig>& obstacles = {}) {
  Scenario scenario;
  scenario.expect = {clause};
  scenario.obstacles = obstacles;
  return EvaluateExpectations(scenario, record).at(0);
}

RunRecord TwoCars() {
  RunRecord r;
  r.sim_duration = std::chrono::seconds(100);
  r.cars.resize(2);
  r.cars[0].id = 0;
  r.cars[1].id = 1;
  return r;
}

// Car `car` standing at (1, 1) from `from_s` to `to_s` (20 Hz), then driving on to the end.
void StandThenDrive(RunRecord* r, int car, double from_s, double to_s) {
  for (double t = 0.0; t < ToSeconds(r->sim_duration); t += 0.05) {
    TrajectorySample s;
    s.t = FromSeconds(t);
    s.car = car;
    s.x_m = 1.0;
    s.y_m = 1.0;
    s.speed_mps = (t >= from_s && t < to_s) ? 0.0 : 0.25;
    r->trajectory.push_back(s);
  }
}

TEST(ExpectationsTest, NoGridlockFlagsAStandstillOverTheBoundUnlessARedLightHoldsTheCar) {
  const ExpectClause clause = Clause(NoGridlockExpect{.max_s = 30.0});
  {  // 40 s still at a stop zone of intersection 0 while car 1 holds it: a red light
    RunRecord r = TwoCars();
    StandThenDrive(&r, 0, 10.0, 50.0);
    r.events = {At(5, EventKind::kGrant, 1, 0), At(10, EventKind::kWait, 0, 0),
                At(49, EventKind::kFree, 1, 0), At(49, EventKind::kGrant, 0, 0),
                At(49.1, EventKind::kGo, 0, 0)};
    EXPECT_TRUE(Judge(clause, r).passed) << Judge(clause, r).detail;
  }
  {  // the same wait, but nobody holds intersection 0 after t = 12 s (a lost request, or the
     // lab's client that never asks again): 37 s unexcused
    RunRecord r = TwoCars();
    StandThenDrive(&r, 0, 10.0, 50.0);
    r.events = {At(5, EventKind::kGrant, 1, 0), At(10, EventKind::kWait, 0, 0),
                At(12, EventKind::kFree, 1, 0), At(49.1, EventKind::kGo, 0, 0)};
    const ExpectationResult result = Judge(clause, r);
    EXPECT_FALSE(result.passed);
    EXPECT_THAT(result.detail, HasSubstr("car 0 stood still from t=12.0 s"));
  }
  {  // a car that stands without waiting for anything (navigation failed), 31 s
    RunRecord r = TwoCars();
    StandThenDrive(&r, 1, 60.0, 91.0);
    EXPECT_FALSE(Judge(clause, r).passed);
    EXPECT_TRUE(Judge(Clause(NoGridlockExpect{.max_s = 31.5}), r).passed);
    EXPECT_TRUE(Judge(Clause(NoGridlockExpect{.car = 0, .max_s = 30.0}), r).passed);
  }
  {  // parked after its laps: excused to the end
    RunRecord r = TwoCars();
    StandThenDrive(&r, 1, 40.0, 100.0);
    r.events = {At(40, EventKind::kParked, 1)};
    EXPECT_TRUE(Judge(clause, r).passed);
  }
}

TEST(ExpectationsTest, MaxWaitJudgesEachWaitAndAnUnfinishedOneRunsToTheEnd) {
  RunRecord r = TwoCars();
  r.events = {At(10, EventKind::kWait, 0, 0), At(14, EventKind::kGo, 0, 0),
              At(20, EventKind::kWait, 1, 1), At(30, EventKind::kGo, 1, 1),
              At(95, EventKind::kWait, 0, 1)};
  EXPECT_TRUE(Judge(Clause(MaxWaitExpect{.max_s = 10.0}), r).passed);
  const ExpectationResult tight = Judge(Clause(MaxWaitExpect{.max_s = 9.0}), r);
  EXPECT_FALSE(tight.passed);
  EXPECT_THAT(tight.detail, HasSubstr("car 1 waited 10.0 s at intersection 1"));
  EXPECT_TRUE(Judge(Clause(MaxWaitExpect{.max_s = 9.0, .intersection = 0}), r).passed);
  EXPECT_TRUE(Judge(Clause(MaxWaitExpect{.car = 0, .max_s = 5.0}), r).passed);
  EXPECT_FALSE(Judge(Clause(MaxWaitExpect{.car = 0, .max_s = 4.5}), r).passed);
}

TEST(ExpectationsTest, AFailureIsPinnedToItsFirstViolationsInstantAndCar) {
  RunRecord r = TwoCars();
  Event hit = At(4, EventKind::kCollision, 1);
  hit.other_car = 0;
  r.events = {At(10, EventKind::kWait, 0, 0), At(14, EventKind::kGo, 0, 0), hit,
              Enter(20, 0, 1, false)};
  const ExpectationResult collision = Judge(Clause(NoCollisionExpect{}), r);
  EXPECT_EQ(collision.at_s, 4.0);
  EXPECT_EQ(collision.car, 1);
  const ExpectationResult entry = Judge(Clause(NoEntryWithoutGrantExpect{}), r);
  EXPECT_EQ(entry.at_s, 20.0);
  EXPECT_EQ(entry.car, 0);
  const ExpectationResult wait = Judge(Clause(MaxWaitExpect{.max_s = 3.0}), r);
  EXPECT_EQ(wait.at_s, 13.0);  // the wait began at 10 s and passed 3 s at 13 s
  EXPECT_EQ(wait.car, 0);
  for (int i = 0; i < 100; ++i) {
    TrajectorySample s;
    s.t = FromSeconds(i * 0.5);
    s.car = 1;
    s.lateral_error_m = i == 30 ? -0.3 : 0.01;
    r.trajectory.push_back(s);
  }
  r.cars[1].max_lateral_error_m = 0.3;
  const ExpectationResult lateral = Judge(Clause(MaxLateralErrorExpect{.max_m = 0.2}), r);
  EXPECT_EQ(lateral.at_s, 15.0);
  EXPECT_EQ(lateral.car, 1);
  const ExpectationResult laps = Judge(Clause(CompletesExpect{.laps = 1, .within_s = 60.0}), r);
  EXPECT_EQ(laps.at_s, 60.0);  // the deadline the first car missed
  EXPECT_EQ(laps.car, 0);
  // a pass has no instant
  EXPECT_FALSE(Judge(Clause(IntersectionMutexExpect{}), r).at_s.has_value());
}

TEST(ExpectationsTest, MinThroughputCountsEntriesPerMinutePerIntersection) {
  RunRecord r = TwoCars();  // 100 s
  r.events = {At(1, EventKind::kRequest, 0, 1)};
  for (int k = 0; k < 5; ++k) r.events.push_back(Enter(10.0 + k, k % 2, 0, true));
  // intersection 0: 5 in 100 s = 3/min; intersection 1: asked for, never entered
  EXPECT_TRUE(Judge(Clause(MinThroughputExpect{.intersection = 0, .per_minute = 3.0}), r).passed);
  EXPECT_FALSE(Judge(Clause(MinThroughputExpect{.intersection = 0, .per_minute = 3.1}), r).passed);
  const ExpectationResult all = Judge(Clause(MinThroughputExpect{.per_minute = 1.0}), r);
  EXPECT_FALSE(all.passed);
  EXPECT_THAT(all.detail, HasSubstr("intersection 1: 0 crossings"));
}

TEST(ExpectationsTest, IntersectionMutexReplaysEntriesAndExits) {
  RunRecord r = TwoCars();
  r.events = {Enter(1, 0, 0, true),          At(2, EventKind::kExit, 0, 0), Enter(2.5, 1, 0, true),
              At(3, EventKind::kExit, 1, 0), Enter(3.5, 0, 1, true),        Enter(3.6, 1, 0, true)};
  EXPECT_TRUE(Judge(Clause(IntersectionMutexExpect{}), r).passed);

  r.events.push_back(Enter(3.7, 0, 0, true));  // car 1 is still in intersection 0
  const ExpectationResult verdict = Judge(Clause(IntersectionMutexExpect{}), r);
  EXPECT_FALSE(verdict.passed);
  EXPECT_THAT(verdict.detail, HasSubstr("car 0 entered intersection 0 at t=3.700 s while car 1"));
  EXPECT_EQ(verdict.name, "intersection_mutex");
}

TEST(ExpectationsTest, NoEntryWithoutGrantLooksAtEveryEntryOfTheCarsConcerned) {
  RunRecord r = TwoCars();
  r.events = {Enter(1, 0, 0, true), Enter(2, 1, 1, false)};
  EXPECT_FALSE(Judge(Clause(NoEntryWithoutGrantExpect{}), r).passed);
  EXPECT_TRUE(Judge(Clause(NoEntryWithoutGrantExpect{.car = 0}), r).passed);
  EXPECT_THAT(Judge(Clause(NoEntryWithoutGrantExpect{.car = 1}), r).detail,
              HasSubstr("1 of 1 entries without grant"));
}

TEST(ExpectationsTest, NoCollisionCountsBothCarsOfACarCarContact) {
  RunRecord r = TwoCars();
  Event hit = At(4, EventKind::kCollision, 0);
  hit.other_car = 1;
  r.events = {hit};
  EXPECT_FALSE(Judge(Clause(NoCollisionExpect{.car = 1}), r).passed);
  EXPECT_THAT(Judge(Clause(NoCollisionExpect{}), r).detail,
              HasSubstr("car 0 hit car 1 at t=4.000 s"));
  r.events.clear();
  EXPECT_TRUE(Judge(Clause(NoCollisionExpect{}), r).passed);
}

// Issue 34: recovers_within took a car standing before an obstacle, which a fault happened to
// overlap, for a car that did not recover. A standstill that begins with an obstacle in the car's
// way is not the fault's; the same standstill with the box behind the car still fails.
TEST(ExpectationsTest, RecoversWithinDoesNotJudgeACarHeldByAnObstacle) {
  RunRecord r = TwoCars();
  StandThenDrive(&r, 0, 10.0, 60.0);  // at (1, 1), heading +x
  StandThenDrive(&r, 1, 200.0, 200.0);
  Event begin = At(12.0, EventKind::kFaultBegin, -1);
  begin.fault = FaultKind::kV2iPartition;
  Event end = At(15.0, EventKind::kFaultEnd, -1);
  end.fault = FaultKind::kV2iPartition;
  r.events = {begin, end};
  const ExpectClause clause = Clause(RecoversWithinExpect{.max_s = 5.0});
  const ObstacleConfig ahead{.name = "box", .x_m = 1.6, .y_m = 1.0};
  const ObstacleConfig behind{.name = "box", .x_m = 0.4, .y_m = 1.0};
  const ExpectationResult held = Judge(clause, r, {ahead});
  EXPECT_TRUE(held.passed) << held.detail;
  EXPECT_THAT(held.detail, HasSubstr("1 standstill(s) before an obstacle not judged"));
  const ExpectationResult stuck = Judge(clause, r, {behind});
  EXPECT_FALSE(stuck.passed);
  EXPECT_THAT(stuck.detail, HasSubstr("car 0 stood still from t=10.0 s to t=60.0 s"));
  // a box that is gone by then holds nobody
  ObstacleConfig gone = ahead;
  gone.disappear_s = 5.0;
  EXPECT_FALSE(Judge(clause, r, {gone}).passed);
}

TEST(ExpectationsTest, CompletesNeedsTheLapsByTheDeadline) {
  RunRecord r = TwoCars();
  r.cars[0].laps = 3;
  r.cars[0].lap_times_s = {30, 60, 90};
  r.cars[1].laps = 2;
  r.cars[1].lap_times_s = {40, 80};
  EXPECT_TRUE(Judge(Clause(CompletesExpect{.car = 0, .laps = 3}), r).passed);
  EXPECT_FALSE(Judge(Clause(CompletesExpect{.car = 0, .laps = 3, .within_s = 89}), r).passed);
  const ExpectationResult both = Judge(Clause(CompletesExpect{.laps = 3}), r);
  EXPECT_FALSE(both.passed);
  EXPECT_THAT(both.detail, HasSubstr("car 1: 2 lap(s) by 100.0 s"));
  EXPECT_EQ(both.name, "completes(laps=3)");
  // a deadline past the end (a warning at load) is judged on the run's time, and says so
  const ExpectationResult cut = Judge(Clause(CompletesExpect{.laps = 3, .within_s = 150}), r);
  EXPECT_THAT(cut.detail, HasSubstr("car 1: 2 lap(s) by the run's end at 100.0 s"));
}

TEST(ExpectationsTest, MaxLateralErrorAndMinObstacleGapCompareWithTheirBounds) {
  RunRecord r = TwoCars();
  r.cars[0].max_lateral_error_m = 0.04;
  r.cars[1].max_lateral_error_m = 0.12;
  EXPECT_FALSE(Judge(Clause(MaxLateralErrorExpect{.max_m = 0.1}), r).passed);
  EXPECT_TRUE(Judge(Clause(MaxLateralErrorExpect{.car = 0, .max_m = 0.1}), r).passed);

  EXPECT_TRUE(Judge(Clause(MinObstacleGapExpect{.min_m = 0.1}), r).passed);  // none came near
  r.cars[1].min_obstacle_gap_m = 0.05;
  EXPECT_FALSE(Judge(Clause(MinObstacleGapExpect{.min_m = 0.1}), r).passed);
  EXPECT_TRUE(Judge(Clause(MinObstacleGapExpect{.min_m = 0.05}), r).passed);
}

RunRecord WithBoard() {
  RunRecord r = TwoCars();
  BoardReport board{.board = "car1"};
  board.report.cores = 4;
  board.report.cpu_demand_percent = 480.0;
  board.report.cpu_percent = 399.0;
  NodeReport lanes;
  lanes.name = "lane_detection";
  lanes.rate_hz = 17.2;
  lanes.drops = 2556;
  board.report.nodes.push_back(lanes);
  r.boards.push_back(board);
  return r;
}

TEST(ExpectationsTest, NodeRateJudgesTheNodeOnTheCarsBoard) {
  const RunRecord r = WithBoard();
  const ExpectationResult slow =
      Judge(Clause(NodeRateExpect{.car = 1, .node = "lane_detection", .max_hz = 20.0}), r);
  EXPECT_TRUE(slow.passed);
  EXPECT_THAT(slow.detail, HasSubstr("17.2 Hz, 2556 dropped"));
  EXPECT_FALSE(
      Judge(Clause(NodeRateExpect{.car = 1, .node = "lane_detection", .min_hz = 29.0}), r).passed);
  const ExpectationResult missing =
      Judge(Clause(NodeRateExpect{.car = 0, .node = "lane_detection", .min_hz = 1.0}), r);
  EXPECT_FALSE(missing.passed);
  EXPECT_THAT(missing.detail, HasSubstr("car 0 runs no node 'lane_detection'"));
}

TEST(ExpectationsTest, CpuDemandJudgesTheBoardsDemand) {
  const RunRecord r = WithBoard();
  EXPECT_TRUE(Judge(Clause(CpuDemandExpect{.car = 1, .min_percent = 400.0}), r).passed);
  const ExpectationResult low = Judge(Clause(CpuDemandExpect{.car = 1, .max_percent = 400.0}), r);
  EXPECT_FALSE(low.passed);
  EXPECT_THAT(low.detail, HasSubstr("CPU demand 480 %, load 399 % of 4 cores"));
  EXPECT_FALSE(Judge(Clause(CpuDemandExpect{.car = 0, .min_percent = 1.0}), r).passed);
}

TEST(ExpectationsTest, NodeRateAndCpuDemandNeedTheirKeys) {
  EXPECT_THROW(Read("node_rate: {car: 1, max_hz: 20}"), ConfigError);
  EXPECT_THROW(Read("node_rate: {car: 1, node: x}"), ConfigError);
  EXPECT_THROW(Read("cpu_demand: {min_percent: 400}"), ConfigError);
  EXPECT_THROW(Read("completes: {laps: 1, max_hz: 2}"), ConfigError);
  EXPECT_THROW(Read("{completes: {laps: 1}, no_collision: {}}"), ConfigError);
  EXPECT_THAT([] { Read("no_colision: {}"); },
              ::testing::ThrowsMessage<ConfigError>(HasSubstr("did you mean 'no_collision'")));
  EXPECT_THAT([] { Read("cpu_demand: {min_percent: 400}"); },
              ::testing::ThrowsMessage<ConfigError>(HasSubstr("cpu_demand needs car")));
  EXPECT_TRUE(std::holds_alternative<NodeRateExpect>(
      Read("node_rate: {car: 1, node: lane_detection, min_hz: 1}")));
}

}  // namespace
}  // namespace autonomsim::sim
