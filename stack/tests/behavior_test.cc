#include "stack/behavior.h"

#include <gtest/gtest.h>

#include <stdexcept>
#include <utility>
#include <vector>

namespace autonomsim::stack {
namespace {

using world::Vec2;

world::Polyline Straight(double length_m) {
  return world::Polyline({Vec2(0.0, 0.0), Vec2(length_m, 0.0)}, false);
}

world::Polyline Square() {  // a 4 m × 4 m loop, counter-clockwise
  return world::Polyline({Vec2(0, 0), Vec2(4, 0), Vec2(4, 4), Vec2(0, 4), Vec2(0, 0)}, true);
}

BehaviorInput At(double seconds, Vec2 p) {
  return BehaviorInput{.now = FromSeconds(seconds), .p_map = p};
}

TEST(BehaviorTest, GoalsRunAlongTheRouteAheadNearestFirst) {
  const BehaviorParams params{.waypoint_spacing_m = 0.5, .waypoint_horizon_m = 2.0};
  BehaviorState state;
  const BehaviorOutput out = StepBehavior(params, Straight(10.0), At(0.0, Vec2(1.0, 0.2)), &state);
  EXPECT_EQ(out.mode, BehaviorMode::kDrive);
  EXPECT_FALSE(out.hold);
  ASSERT_EQ(out.goals.size(), 4u);
  for (std::size_t i = 0; i < out.goals.size(); ++i) {
    EXPECT_NEAR(out.goals[i].x(), 1.5 + 0.5 * static_cast<double>(i), 1e-9);
    EXPECT_NEAR(out.goals[i].y(), 0.0, 1e-9);
  }
}

TEST(BehaviorTest, GoalsWrapAroundALoop) {
  const BehaviorParams params{.waypoint_spacing_m = 1.0, .waypoint_horizon_m = 2.0};
  BehaviorState state;
  // 0.5 m before the loop's end (s = 15.5 of 16): the stations at s = 16 → (0, 0) and 17
  const BehaviorOutput out = StepBehavior(params, Square(), At(0.0, Vec2(0.0, 0.5)), &state);
  ASSERT_EQ(out.goals.size(), 2u);
  EXPECT_NEAR(out.goals[0].x(), 0.0, 1e-9);
  EXPECT_NEAR(out.goals[1].x(), 1.0, 1e-9);
}

// The goals are the route's stations, not points at a distance from the car: two ticks 0.2 m
// apart share the stations both see, bit for bit (so the planner node plans a leg between two of
// them once), and the horizon adds the next station once the car has moved past a quarter of it.
TEST(BehaviorTest, GoalsAreTheRoutesStationsSoTwoTicksShareThem) {
  const BehaviorParams params{.waypoint_spacing_m = 0.5, .waypoint_horizon_m = 2.0};
  BehaviorState state;
  const BehaviorOutput a = StepBehavior(params, Straight(10.0), At(0.0, Vec2(1.1, 0.1)), &state);
  const BehaviorOutput b = StepBehavior(params, Straight(10.0), At(0.1, Vec2(1.3, 0.1)), &state);
  ASSERT_EQ(a.goals.size(), 4u);  // (1.1, 3.1]: 1.5 2.0 2.5 3.0
  ASSERT_EQ(b.goals.size(), 4u);  // (1.3, 3.3]: the same
  EXPECT_EQ(a.goals, b.goals);
  EXPECT_NEAR(a.goals[0].x(), 1.5, 1e-12);
  EXPECT_NEAR(a.goals[3].x(), 3.0, 1e-12);
  const BehaviorOutput c = StepBehavior(params, Straight(10.0), At(0.2, Vec2(1.6, 0.1)), &state);
  ASSERT_EQ(c.goals.size(), 4u);  // (1.6, 3.6]: 2.0 .. 3.5
  EXPECT_EQ(std::vector<Vec2>(c.goals.begin(), c.goals.end() - 1),
            std::vector<Vec2>(a.goals.begin() + 1, a.goals.end()));
  EXPECT_NEAR(c.goals.back().x(), 3.5, 1e-12);
}

TEST(BehaviorTest, TheEndOfAnOpenRouteIsTheLastGoalThenItIsDone) {
  const BehaviorParams params{.waypoint_spacing_m = 0.5, .waypoint_horizon_m = 2.0};
  BehaviorState state;
  BehaviorOutput out = StepBehavior(params, Straight(3.0), At(0.0, Vec2(1.8, 0.0)), &state);
  ASSERT_FALSE(out.goals.empty());
  EXPECT_NEAR(out.goals.back().x(), 3.0, 1e-9);
  out = StepBehavior(params, Straight(3.0), At(1.0, Vec2(2.7, 0.0)), &state);
  EXPECT_EQ(out.mode, BehaviorMode::kDone);
  EXPECT_TRUE(out.hold);
  EXPECT_TRUE(out.goals.empty());
}

// The lab's behaviour tree (code/ros_ws/src/nav2_local/behavior_tree/drive_to_pose_test.xml) on
// Nav2 Galactic's nodes, ticked every 10 ms (nav2_car_params.yaml:7, bt_loop_duration).
class TreeRun {
 public:
  explicit TreeRun(BehaviorParams params = {}, world::Polyline route = Straight(100.0))
      : params_(params), route_(std::move(route)) {}

  // One tick at t seconds. A blocked car's controller reports the running attempt as failed by a
  // collision ahead on the next tick (it runs at 20 Hz; the tick is 10 ms).
  BehaviorOutput Step(double t) {
    input_.now = FromSeconds(t);
    out_ = StepBehavior(params_, route_, input_, &state_);
    input_.plan_failed.reset();
    if (blocked && !out_.hold) input_.follow_path_failure = FollowPathFailure{out_.attempt, true};
    if (out_.recovery != RecoveryAction::kNone) actions.push_back(out_.recovery);
    return out_;
  }
  // Ticks every 10 ms from `from` up to `to` seconds; returns the last output.
  BehaviorOutput Run(double from, double to) {
    for (int i = 0; from + 0.01 * i <= to + 1e-9; ++i) Step(from + 0.01 * i);
    return out_;
  }

  BehaviorInput& input() { return input_; }
  const BehaviorState& state() const { return state_; }
  bool blocked{false};
  std::vector<RecoveryAction> actions;

 private:
  BehaviorParams params_;
  world::Polyline route_;
  BehaviorInput input_ = At(0.0, Vec2(1.0, 0.0));
  BehaviorState state_;
  BehaviorOutput out_;
};

// rate_controller.cpp:36-76: the first tick runs the child, FollowPath starts; for the rest of
// the RateController's period (hz=3, xml:19) it returns RUNNING and the ReactiveFallback halts
// FollowPath; after that its timer never restarts (only SUCCESS restarts it, and the Inverter
// never returns SUCCESS), so the gate is checked on every tick.
TEST(BehaviorTest, TheGateHaltsFollowPathForAThirdOfASecondAfterTheTreeStarts) {
  TreeRun tree;
  BehaviorOutput out = tree.Step(0.0);
  EXPECT_FALSE(out.hold);
  EXPECT_EQ(out.attempt, 1u);
  for (double t = 0.01; t < 0.33; t += 0.01) {
    out = tree.Step(t);
    EXPECT_TRUE(out.hold) << t;
    EXPECT_EQ(out.mode, BehaviorMode::kDrive);
  }
  out = tree.Step(0.34);
  EXPECT_FALSE(out.hold);
  EXPECT_EQ(out.attempt, 2u);  // a new FollowPath action
  out = tree.Run(0.35, 5.0);
  EXPECT_FALSE(out.hold);
  EXPECT_EQ(out.attempt, 2u);
}

// xml:21-24: not free, Wait(600) runs and FollowPath is halted within one 10 ms tick; free
// again, FollowPath runs on the next tick (our former 3 Hz tick held the car up to 0.33 s more).
TEST(BehaviorTest, WaitsAtTheIntersectionUntilItIsFreeWithinOneTick) {
  TreeRun tree;
  tree.Run(0.0, 1.0);
  tree.input().intersection_free = false;
  BehaviorOutput out = tree.Step(1.01);
  EXPECT_EQ(out.mode, BehaviorMode::kIntersectionWait);
  EXPECT_TRUE(out.hold);
  EXPECT_FALSE(out.goals.empty());  // the planner keeps planning while the car waits
  out = tree.Run(1.02, 4.0);
  EXPECT_EQ(out.mode, BehaviorMode::kIntersectionWait);
  tree.input().intersection_free = true;
  out = tree.Step(4.01);
  EXPECT_EQ(out.mode, BehaviorMode::kDrive);
  EXPECT_FALSE(out.hold);
}

TEST(BehaviorTest, AStalePermissionHoldsTheCarInAStopZoneOnlyWithTheTimeout) {
  // the client's last "free" is 2 s old: its node died
  BehaviorInput input = At(10.0, Vec2(1.0, 0.0));
  input.intersection_free = true;
  input.intersection_free_stamp = FromSeconds(8.0);
  input.in_stop_zone = true;
  BehaviorState lab_state;
  EXPECT_EQ(StepBehavior({}, Straight(10.0), input, &lab_state).mode, BehaviorMode::kDrive);
  const BehaviorParams safe{.intersection_free_timeout = std::chrono::seconds(1)};
  BehaviorState safe_state;
  BehaviorOutput out = StepBehavior(safe, Straight(10.0), input, &safe_state);
  EXPECT_EQ(out.mode, BehaviorMode::kIntersectionWait);
  EXPECT_TRUE(out.hold);
  // outside a stop zone the car drives on (it clears the intersection it is in)
  input.in_stop_zone = false;
  BehaviorState outside;
  EXPECT_EQ(StepBehavior(safe, Straight(10.0), input, &outside).mode, BehaviorMode::kDrive);
  // a fresh permission lets it go
  input.in_stop_zone = true;
  input.intersection_free_stamp = FromSeconds(9.5);
  input.now = FromSeconds(10.01);
  EXPECT_EQ(StepBehavior(safe, Straight(10.0), input, &safe_state).mode, BehaviorMode::kDrive);
}

// A car blocked for good (xml:5-45; recovery_node.cpp:18-100; round_robin_node.cpp:20-65): each
// failed FollowPath first clears the local costmap and retries at once (inner RecoveryNode, 1
// retry); its second failure runs the outer RoundRobin, which alternates "clear both costmaps"
// (instant) with Wait 5 s; six outer retries, then the navigation fails. Three waits: the lab's
// car gives up after ≈ 15 s of waiting (plus a third of a second of gate throttle per restart).
TEST(BehaviorTest, ABlockedCarRunsTheLabsRecoverySequenceThenFails) {
  TreeRun tree;
  tree.Run(0.0, 1.0);
  tree.blocked = true;
  double failed_at = -1.0;
  for (double t = 1.01; t < 60.0 && failed_at < 0.0; t += 0.01) {
    if (tree.Step(t).mode == BehaviorMode::kFailed) failed_at = t;
  }
  using A = RecoveryAction;
  const std::vector<A> expected{A::kClearLocal, A::kClearBoth, A::kClearLocal, A::kWait,
                                A::kClearLocal, A::kClearBoth, A::kClearLocal, A::kWait,
                                A::kClearLocal, A::kClearBoth, A::kClearLocal, A::kWait,
                                A::kClearLocal};
  EXPECT_EQ(tree.actions, expected);
  EXPECT_EQ(tree.state().retries, 6);
  // 15 s of waits and 13 restarts of ≈ 0.34 s each
  EXPECT_GT(failed_at - 1.0, 15.0 + 13 * 0.33);
  EXPECT_LT(failed_at - 1.0, 15.0 + 13 * 0.36);
  const BehaviorOutput out = tree.Run(failed_at + 0.01, failed_at + 30.0);
  EXPECT_EQ(out.mode, BehaviorMode::kFailed);
  EXPECT_TRUE(out.hold);
  EXPECT_TRUE(out.goals.empty());
}

// recovery_node.cpp:102-107: the outer count resets only when the navigation succeeds or is
// halted, which a car looping its route never does; recovery_reset_m (safe) resets it after
// driving that far.
TEST(BehaviorTest, TheRetryCountLastsTheWholeNavigationUnlessRecoveryResetIsSet) {
  for (const double reset_m : {0.0, 0.5}) {
    TreeRun tree(BehaviorParams{.recovery_reset_m = reset_m});
    tree.Run(0.0, 1.0);
    tree.blocked = true;
    tree.Run(1.01, 2.0);  // clear local, then clear both: retry 1
    ASSERT_EQ(tree.state().retries, 1);
    tree.blocked = false;
    for (int i = 0; i < 200; ++i) {  // 20 m in 20 s
      tree.input().p_map = Vec2(1.0 + 0.01 * i * 10.0, 0.0);
      tree.Run(2.0 + 0.1 * i, 2.0 + 0.1 * i + 0.09);
    }
    EXPECT_EQ(tree.state().retries, reset_m > 0.0 ? 0 : 1) << reset_m;
  }
}

// xml:9-15: a failed plan clears the global costmap and plans again while FollowPath keeps
// driving; a second failure in a row goes to the outer recovery; a good plan in between resets.
TEST(BehaviorTest, AFailedPlanClearsTheGlobalCostmapThenRecovers) {
  TreeRun tree;
  tree.Run(0.0, 1.0);
  tree.input().plan_failed = true;
  BehaviorOutput out = tree.Step(1.01);
  EXPECT_EQ(out.recovery, RecoveryAction::kClearGlobal);
  EXPECT_FALSE(out.hold);
  tree.input().plan_failed = false;
  tree.Run(1.02, 2.0);
  tree.input().plan_failed = true;
  EXPECT_EQ(tree.Step(2.01).recovery, RecoveryAction::kClearGlobal);  // reset by the good plan
  tree.Run(2.02, 3.0);
  tree.input().plan_failed = true;
  out = tree.Step(3.01);
  EXPECT_EQ(out.recovery, RecoveryAction::kClearBoth);
  EXPECT_EQ(out.retries, 1);
  EXPECT_TRUE(out.hold);
}

// The controller's failure of an attempt that has been halted since, or handled, starts nothing.
TEST(BehaviorTest, AFailureCountsOnlyForTheRunningAttemptAndOnlyOnce) {
  TreeRun tree;
  tree.Run(0.0, 1.0);
  const std::uint64_t attempt = tree.Step(1.01).attempt;
  tree.input().follow_path_failure = FollowPathFailure{attempt - 1, true};
  EXPECT_EQ(tree.Step(1.02).recovery, RecoveryAction::kNone);
  tree.input().follow_path_failure = FollowPathFailure{attempt, false};  // no progress
  EXPECT_EQ(tree.Step(1.03).recovery, RecoveryAction::kClearLocal);
  EXPECT_EQ(tree.Step(1.04).recovery, RecoveryAction::kNone);
}

// stack.behavior.queue_wait_s (safe: 2 s): a car waiting in line waits that long, not the
// RoundRobin's Wait 5 s (drive_to_pose_test.xml:42), before it tries again.
TEST(BehaviorTest, APatientCarWaitsQueueWaitInLine) {
  TreeRun tree(BehaviorParams{.patient_in_queue = true, .queue_wait = std::chrono::seconds(2)});
  tree.input().near_intersection = true;
  tree.Run(0.0, 1.0);
  tree.blocked = true;
  BehaviorOutput out = tree.Run(1.01, 1.02);
  ASSERT_EQ(out.recovery, RecoveryAction::kWaitInLine);
  EXPECT_EQ(tree.Run(1.03, 3.0).mode, BehaviorMode::kRecovery);
  tree.blocked = false;
  out = tree.Run(3.01, 3.03);
  EXPECT_EQ(out.mode, BehaviorMode::kDrive);
  EXPECT_EQ(out.retries, 0);
}

TEST(BehaviorTest, APatientCarWaitingInLineNearAnIntersectionNeverUsesUpItsRetries) {
  for (const bool patient : {false, true}) {
    TreeRun tree(BehaviorParams{.max_retries = 2, .patient_in_queue = patient});
    tree.input().near_intersection = true;
    tree.Run(0.0, 1.0);
    tree.blocked = true;  // 60 s in line
    const BehaviorOutput out = tree.Run(1.01, 61.0);
    EXPECT_EQ(out.mode == BehaviorMode::kFailed, !patient) << "patient_in_queue " << patient;
    EXPECT_EQ(tree.state().retries, patient ? 0 : 2);
  }
  // away from intersections a patient car still fails
  TreeRun tree(BehaviorParams{.max_retries = 2, .patient_in_queue = true});
  tree.Run(0.0, 1.0);
  tree.blocked = true;
  EXPECT_EQ(tree.Run(1.01, 61.0).mode, BehaviorMode::kFailed);
}

TEST(BehaviorTest, TheOperatorEndsTheMission) {
  BehaviorState state;
  BehaviorInput input = At(0.0, Vec2(1.0, 0.0));
  input.mission_done = true;
  const BehaviorOutput out = StepBehavior({}, Straight(10.0), input, &state);
  EXPECT_EQ(out.mode, BehaviorMode::kDone);
  EXPECT_TRUE(out.hold);
}

TEST(BehaviorTest, RejectsBadInputAndParams) {
  BehaviorState state;
  EXPECT_THROW(StepBehavior({}, Straight(10.0), At(0.0, Vec2(std::nan(""), 0.0)), &state),
               std::invalid_argument);
  EXPECT_THROW((BehaviorParams{.waypoint_spacing_m = 0.0}.Validate()), std::invalid_argument);
  EXPECT_THROW((BehaviorParams{.waypoint_spacing_m = 1.0, .waypoint_horizon_m = 0.5}.Validate()),
               std::invalid_argument);
  EXPECT_THROW((BehaviorParams{.max_retries = -1}.Validate()), std::invalid_argument);
  EXPECT_NO_THROW(BehaviorParams{}.Validate());
}

// Reference §6: FollowPath inside an intersection's area and stop zones (strict boxes, as the
// real cars test them), LaneController elsewhere.
TEST(BehaviorTest, FollowPathInsideIntersectionsAndStopZonesOnly) {
  world::IntersectionSpec i;
  i.area = world::Box{1.3, 2.6, -0.6, 0.6};
  i.stop_zones = {world::Box{2.0, 2.6, -1.4, -0.6}};
  const std::vector<world::IntersectionSpec> all{i};
  EXPECT_TRUE(UseFollowPath(all, Vec2(2.0, 0.0)));
  EXPECT_TRUE(UseFollowPath(all, Vec2(2.3, -1.0)));
  EXPECT_FALSE(UseFollowPath(all, Vec2(2.3, -1.5)));
  EXPECT_FALSE(UseFollowPath(all, Vec2(1.3, 0.0)));  // on the area's edge: outside (strict)
  EXPECT_FALSE(UseFollowPath({}, Vec2(2.0, 0.0)));
  // with a margin (stack.controller_selector.zone_margin_m, beyond the lab's): within it too
  EXPECT_TRUE(UseFollowPath(all, Vec2(2.3, -1.5), 0.3));
  EXPECT_TRUE(UseFollowPath(all, Vec2(1.3, 0.0), 0.3));
  EXPECT_FALSE(UseFollowPath(all, Vec2(2.3, -1.75), 0.3));
}

}  // namespace
}  // namespace autonomsim::stack
