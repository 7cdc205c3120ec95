// Expectation verdicts on hand-made run records: no simulation involved.
#include "sim/results/expectations.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace autonomsim::sim {
namespace {

using ::testing::HasSubstr;

Event At(double t_s, std::string type, int car, int intersection = -1) {
  Event e;
  e.t = FromSeconds(t_s);
  e.type = std::move(type);
  e.car = car;
  e.intersection = intersection;
  return e;
}

Event Enter(double t_s, int car, int intersection, bool granted) {
  Event e = At(t_s, "enter", car, intersection);
  e.granted = granted;
  return e;
}

ExpectClause Clause(const std::string& kind, ExpectArgs args = {}) {
  ExpectClause c;
  if (kind == "no_collision") c.no_collision = args;
  if (kind == "intersection_mutex") c.intersection_mutex = args;
  if (kind == "no_entry_without_grant") c.no_entry_without_grant = args;
  if (kind == "completes") c.completes = args;
  if (kind == "max_lateral_error") c.max_lateral_error = args;
  if (kind == "min_obstacle_gap") c.min_obstacle_gap = args;
  if (kind == "node_rate") c.node_rate = args;
  if (kind == "cpu_demand") c.cpu_demand = args;
  if (kind == "no_gridlock") c.no_gridlock = args;
  if (kind == "max_wait") c.max_wait = args;
  if (kind == "min_throughput") c.min_throughput = args;
  c.Validate();
  return c;
}

ExpectationResult Judge(const ExpectClause& clause, const RunRecord& record) {
  Scenario scenario;
  scenario.expect = {clause};
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
  const ExpectClause clause = Clause("no_gridlock", ExpectArgs{.max_s = 30.0});
  {  // 40 s still at a stop zone of intersection 0 while car 1 holds it: a red light
    RunRecord r = TwoCars();
    StandThenDrive(&r, 0, 10.0, 50.0);
    r.events = {At(5, "grant", 1, 0), At(10, "wait", 0, 0), At(49, "free", 1, 0),
                At(49, "grant", 0, 0), At(49.1, "go", 0, 0)};
    EXPECT_TRUE(Judge(clause, r).passed) << Judge(clause, r).detail;
  }
  {  // the same wait, but nobody holds intersection 0 after t = 12 s (a lost request, or the
     // lab's client that never asks again): 37 s unexcused
    RunRecord r = TwoCars();
    StandThenDrive(&r, 0, 10.0, 50.0);
    r.events = {At(5, "grant", 1, 0), At(10, "wait", 0, 0), At(12, "free", 1, 0),
                At(49.1, "go", 0, 0)};
    const ExpectationResult result = Judge(clause, r);
    EXPECT_FALSE(result.passed);
    EXPECT_THAT(result.detail, HasSubstr("car 0 stood still from t=12.0 s"));
  }
  {  // a car that stands without waiting for anything (navigation failed), 31 s
    RunRecord r = TwoCars();
    StandThenDrive(&r, 1, 60.0, 91.0);
    EXPECT_FALSE(Judge(clause, r).passed);
    EXPECT_TRUE(Judge(Clause("no_gridlock", ExpectArgs{.max_s = 31.5}), r).passed);
    EXPECT_TRUE(Judge(Clause("no_gridlock", ExpectArgs{.car = 0, .max_s = 30.0}), r).passed);
  }
  {  // parked after its laps: excused to the end
    RunRecord r = TwoCars();
    StandThenDrive(&r, 1, 40.0, 100.0);
    r.events = {At(40, "parked", 1)};
    EXPECT_TRUE(Judge(clause, r).passed);
  }
}

TEST(ExpectationsTest, MaxWaitJudgesEachWaitAndAnUnfinishedOneRunsToTheEnd) {
  RunRecord r = TwoCars();
  r.events = {At(10, "wait", 0, 0), At(14, "go", 0, 0), At(20, "wait", 1, 1), At(30, "go", 1, 1),
              At(95, "wait", 0, 1)};
  EXPECT_TRUE(Judge(Clause("max_wait", ExpectArgs{.max_s = 10.0}), r).passed);
  const ExpectationResult tight = Judge(Clause("max_wait", ExpectArgs{.max_s = 9.0}), r);
  EXPECT_FALSE(tight.passed);
  EXPECT_THAT(tight.detail, HasSubstr("car 1 waited 10.0 s at intersection 1"));
  EXPECT_TRUE(Judge(Clause("max_wait", ExpectArgs{.max_s = 9.0, .intersection = 0}), r).passed);
  EXPECT_TRUE(Judge(Clause("max_wait", ExpectArgs{.car = 0, .max_s = 5.0}), r).passed);
  EXPECT_FALSE(Judge(Clause("max_wait", ExpectArgs{.car = 0, .max_s = 4.5}), r).passed);
}

TEST(ExpectationsTest, AFailureIsPinnedToItsFirstViolationsInstantAndCar) {
  RunRecord r = TwoCars();
  Event hit = At(4, "collision", 1);
  hit.other_car = 0;
  r.events = {At(10, "wait", 0, 0), At(14, "go", 0, 0), hit, Enter(20, 0, 1, false)};
  const ExpectationResult collision = Judge(Clause("no_collision"), r);
  EXPECT_EQ(collision.at_s, 4.0);
  EXPECT_EQ(collision.car, 1);
  const ExpectationResult entry = Judge(Clause("no_entry_without_grant"), r);
  EXPECT_EQ(entry.at_s, 20.0);
  EXPECT_EQ(entry.car, 0);
  const ExpectationResult wait = Judge(Clause("max_wait", ExpectArgs{.max_s = 3.0}), r);
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
  const ExpectationResult lateral = Judge(Clause("max_lateral_error", {.max_m = 0.2}), r);
  EXPECT_EQ(lateral.at_s, 15.0);
  EXPECT_EQ(lateral.car, 1);
  const ExpectationResult laps = Judge(Clause("completes", {.laps = 1, .within_s = 60.0}), r);
  EXPECT_EQ(laps.at_s, 60.0);  // the deadline the first car missed
  EXPECT_EQ(laps.car, 0);
  // a pass has no instant
  EXPECT_FALSE(Judge(Clause("intersection_mutex"), r).at_s.has_value());
}

TEST(ExpectationsTest, MinThroughputCountsEntriesPerMinutePerIntersection) {
  RunRecord r = TwoCars();  // 100 s
  r.events = {At(1, "request", 0, 1)};
  for (int k = 0; k < 5; ++k) r.events.push_back(Enter(10.0 + k, k % 2, 0, true));
  // intersection 0: 5 in 100 s = 3/min; intersection 1: asked for, never entered
  EXPECT_TRUE(
      Judge(Clause("min_throughput", ExpectArgs{.intersection = 0, .per_minute = 3.0}), r).passed);
  EXPECT_FALSE(
      Judge(Clause("min_throughput", ExpectArgs{.intersection = 0, .per_minute = 3.1}), r).passed);
  const ExpectationResult all = Judge(Clause("min_throughput", ExpectArgs{.per_minute = 1.0}), r);
  EXPECT_FALSE(all.passed);
  EXPECT_THAT(all.detail, HasSubstr("intersection 1: 0 crossings"));
}

TEST(ExpectationsTest, IntersectionMutexReplaysEntriesAndExits) {
  RunRecord r = TwoCars();
  r.events = {Enter(1, 0, 0, true), At(2, "exit", 0, 0),    Enter(2.5, 1, 0, true),
              At(3, "exit", 1, 0),  Enter(3.5, 0, 1, true), Enter(3.6, 1, 0, true)};
  EXPECT_TRUE(Judge(Clause("intersection_mutex"), r).passed);

  r.events.push_back(Enter(3.7, 0, 0, true));  // car 1 is still in intersection 0
  const ExpectationResult verdict = Judge(Clause("intersection_mutex"), r);
  EXPECT_FALSE(verdict.passed);
  EXPECT_THAT(verdict.detail, HasSubstr("car 0 entered intersection 0 at t=3.700 s while car 1"));
  EXPECT_EQ(verdict.name, "intersection_mutex");
}

TEST(ExpectationsTest, NoEntryWithoutGrantLooksAtEveryEntryOfTheCarsConcerned) {
  RunRecord r = TwoCars();
  r.events = {Enter(1, 0, 0, true), Enter(2, 1, 1, false)};
  EXPECT_FALSE(Judge(Clause("no_entry_without_grant"), r).passed);
  EXPECT_TRUE(Judge(Clause("no_entry_without_grant", {.car = 0}), r).passed);
  EXPECT_THAT(Judge(Clause("no_entry_without_grant", {.car = 1}), r).detail,
              HasSubstr("1 of 1 entries without grant"));
}

TEST(ExpectationsTest, NoCollisionCountsBothCarsOfACarCarContact) {
  RunRecord r = TwoCars();
  Event hit = At(4, "collision", 0);
  hit.other_car = 1;
  r.events = {hit};
  EXPECT_FALSE(Judge(Clause("no_collision", {.car = 1}), r).passed);
  EXPECT_THAT(Judge(Clause("no_collision"), r).detail, HasSubstr("car 0 hit car 1 at t=4.000 s"));
  r.events.clear();
  EXPECT_TRUE(Judge(Clause("no_collision"), r).passed);
}

TEST(ExpectationsTest, CompletesNeedsTheLapsByTheDeadline) {
  RunRecord r = TwoCars();
  r.cars[0].laps = 3;
  r.cars[0].lap_times_s = {30, 60, 90};
  r.cars[1].laps = 2;
  r.cars[1].lap_times_s = {40, 80};
  EXPECT_TRUE(Judge(Clause("completes", {.car = 0, .laps = 3}), r).passed);
  EXPECT_FALSE(Judge(Clause("completes", {.car = 0, .laps = 3, .within_s = 89}), r).passed);
  const ExpectationResult both = Judge(Clause("completes", {.laps = 3}), r);
  EXPECT_FALSE(both.passed);
  EXPECT_THAT(both.detail, HasSubstr("car 1: 2 lap(s) by 100.0 s"));
  EXPECT_EQ(both.name, "completes(laps=3)");
}

TEST(ExpectationsTest, MaxLateralErrorAndMinObstacleGapCompareWithTheirBounds) {
  RunRecord r = TwoCars();
  r.cars[0].max_lateral_error_m = 0.04;
  r.cars[1].max_lateral_error_m = 0.12;
  EXPECT_FALSE(Judge(Clause("max_lateral_error", {.max_m = 0.1}), r).passed);
  EXPECT_TRUE(Judge(Clause("max_lateral_error", {.car = 0, .max_m = 0.1}), r).passed);

  EXPECT_TRUE(Judge(Clause("min_obstacle_gap", {.min_m = 0.1}), r).passed);  // none came near
  r.cars[1].min_obstacle_gap_m = 0.05;
  EXPECT_FALSE(Judge(Clause("min_obstacle_gap", {.min_m = 0.1}), r).passed);
  EXPECT_TRUE(Judge(Clause("min_obstacle_gap", {.min_m = 0.05}), r).passed);
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
      Judge(Clause("node_rate", {.car = 1, .node = "lane_detection", .max_hz = 20.0}), r);
  EXPECT_TRUE(slow.passed);
  EXPECT_THAT(slow.detail, HasSubstr("17.2 Hz, 2556 dropped"));
  EXPECT_FALSE(
      Judge(Clause("node_rate", {.car = 1, .node = "lane_detection", .min_hz = 29.0}), r).passed);
  const ExpectationResult missing =
      Judge(Clause("node_rate", {.car = 0, .node = "lane_detection", .min_hz = 1.0}), r);
  EXPECT_FALSE(missing.passed);
  EXPECT_THAT(missing.detail, HasSubstr("car 0 runs no node 'lane_detection'"));
}

TEST(ExpectationsTest, CpuDemandJudgesTheBoardsDemand) {
  const RunRecord r = WithBoard();
  EXPECT_TRUE(Judge(Clause("cpu_demand", {.car = 1, .min_percent = 400.0}), r).passed);
  const ExpectationResult low = Judge(Clause("cpu_demand", {.car = 1, .max_percent = 400.0}), r);
  EXPECT_FALSE(low.passed);
  EXPECT_THAT(low.detail, HasSubstr("CPU demand 480 %, load 399 % of 4 cores"));
  EXPECT_FALSE(Judge(Clause("cpu_demand", {.car = 0, .min_percent = 1.0}), r).passed);
}

TEST(ExpectationsTest, NodeRateAndCpuDemandNeedTheirKeys) {
  EXPECT_THROW(Clause("node_rate", {.car = 1, .max_hz = 20.0}), std::invalid_argument);
  EXPECT_THROW(Clause("node_rate", {.car = 1, .node = "x"}), std::invalid_argument);
  EXPECT_THROW(Clause("cpu_demand", {.min_percent = 400.0}), std::invalid_argument);
  EXPECT_THROW(Clause("completes", {.laps = 1, .max_hz = 2.0}), std::invalid_argument);
}

}  // namespace
}  // namespace autonomsim::sim
