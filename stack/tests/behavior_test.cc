#include "stack/behavior.h"

#include <gtest/gtest.h>

#include <stdexcept>

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
  // 0.5 m before the loop's end (s = 15.5 of 16): goals at s = 16.5 → (0.5, 0) and 17.5
  const BehaviorOutput out = StepBehavior(params, Square(), At(0.0, Vec2(0.0, 0.5)), &state);
  ASSERT_EQ(out.goals.size(), 2u);
  EXPECT_NEAR(out.goals[0].x(), 0.5, 1e-9);
  EXPECT_NEAR(out.goals[1].x(), 1.5, 1e-9);
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

TEST(BehaviorTest, WaitsAtTheIntersectionUntilItIsFree) {
  BehaviorState state;
  BehaviorInput input = At(0.0, Vec2(1.0, 0.0));
  input.intersection_free = false;
  BehaviorOutput out = StepBehavior({}, Straight(10.0), input, &state);
  EXPECT_EQ(out.mode, BehaviorMode::kIntersectionWait);
  EXPECT_TRUE(out.hold);
  EXPECT_FALSE(out.goals.empty());  // the planner keeps planning while the car waits
  input.now = FromSeconds(0.333);
  input.intersection_free = true;
  out = StepBehavior({}, Straight(10.0), input, &state);
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
  EXPECT_EQ(StepBehavior(safe, Straight(10.0), input, &safe_state).mode, BehaviorMode::kDrive);
}

TEST(BehaviorTest, APatientCarWaitingInLineNearAnIntersectionNeverUsesUpItsRetries) {
  for (const bool patient : {false, true}) {
    const BehaviorParams params{
        .recovery_wait = std::chrono::seconds(5), .max_retries = 2, .patient_in_queue = patient};
    BehaviorState state;
    BehaviorInput input = At(10.0, Vec2(1.0, 0.0));
    input.near_intersection = true;
    BehaviorMode last = BehaviorMode::kDrive;
    // blocked for 60 s: retry every 5 s
    for (double t = 10.0; t <= 70.0; t += 1.0 / 3.0) {
      input.now = FromSeconds(t);
      input.collision_ahead = true;
      last = StepBehavior(params, Straight(10.0), input, &state).mode;
    }
    EXPECT_EQ(last == BehaviorMode::kFailed, !patient) << "patient_in_queue " << patient;
    EXPECT_EQ(state.retries, patient ? 0 : 2);
  }
  // away from intersections a patient car still fails
  const BehaviorParams params{
      .recovery_wait = std::chrono::seconds(5), .max_retries = 2, .patient_in_queue = true};
  BehaviorState state;
  BehaviorInput input = At(10.0, Vec2(1.0, 0.0));
  BehaviorMode last = BehaviorMode::kDrive;
  for (double t = 10.0; t <= 70.0; t += 1.0 / 3.0) {
    input.now = FromSeconds(t);
    input.collision_ahead = true;
    last = StepBehavior(params, Straight(10.0), input, &state).mode;
  }
  EXPECT_EQ(last, BehaviorMode::kFailed);
}

TEST(BehaviorTest, ACollisionAheadClearsTheCostmapsWaitsAndRetries) {
  const BehaviorParams params{.recovery_wait = std::chrono::seconds(5), .max_retries = 2};
  BehaviorState state;
  BehaviorInput input = At(10.0, Vec2(1.0, 0.0));
  input.collision_ahead = true;
  BehaviorOutput out = StepBehavior(params, Straight(10.0), input, &state);
  EXPECT_EQ(out.mode, BehaviorMode::kRecovery);
  EXPECT_TRUE(out.clear_costmaps);
  EXPECT_TRUE(out.hold);
  EXPECT_EQ(out.retries, 1);
  // while waiting: held, the costmaps cleared only once (the held controller reports no collision)
  input.collision_ahead = false;
  input.now = FromSeconds(14.9);
  out = StepBehavior(params, Straight(10.0), input, &state);
  EXPECT_EQ(out.mode, BehaviorMode::kRecovery);
  EXPECT_FALSE(out.clear_costmaps);
  // after the wait: retry
  input.now = FromSeconds(15.0);
  out = StepBehavior(params, Straight(10.0), input, &state);
  EXPECT_EQ(out.mode, BehaviorMode::kDrive);
  EXPECT_FALSE(out.hold);
  // still blocked: a second recovery, then the navigation fails for good
  input.collision_ahead = true;
  input.now = FromSeconds(15.3);
  out = StepBehavior(params, Straight(10.0), input, &state);
  EXPECT_EQ(out.retries, 2);
  input.now = FromSeconds(20.3);
  input.collision_ahead = false;
  out = StepBehavior(params, Straight(10.0), input, &state);
  EXPECT_EQ(out.mode, BehaviorMode::kDrive);
  input.now = FromSeconds(20.6);
  input.collision_ahead = true;
  out = StepBehavior(params, Straight(10.0), input, &state);
  EXPECT_EQ(out.mode, BehaviorMode::kFailed);
  EXPECT_TRUE(out.hold);
  EXPECT_TRUE(out.goals.empty());
  input.collision_ahead = false;
  input.now = FromSeconds(60.0);
  EXPECT_EQ(StepBehavior(params, Straight(10.0), input, &state).mode, BehaviorMode::kFailed);
}

TEST(BehaviorTest, ProgressAfterARecoveryResetsTheRetries) {
  const BehaviorParams params{.recovery_wait = std::chrono::seconds(1), .recovery_reset_m = 0.5};
  BehaviorState state;
  BehaviorInput input = At(0.0, Vec2(1.0, 0.0));
  input.plan_failed = true;  // a failed plan recovers like a collision
  EXPECT_EQ(StepBehavior(params, Straight(10.0), input, &state).retries, 1);
  input.plan_failed = false;
  input.now = FromSeconds(1.0);
  EXPECT_EQ(StepBehavior(params, Straight(10.0), input, &state).mode, BehaviorMode::kDrive);
  input.now = FromSeconds(2.0);
  input.p_map = Vec2(1.4, 0.0);
  EXPECT_EQ(StepBehavior(params, Straight(10.0), input, &state).retries, 1);
  input.now = FromSeconds(3.0);
  input.p_map = Vec2(1.6, 0.0);
  EXPECT_EQ(StepBehavior(params, Straight(10.0), input, &state).retries, 0);
}

TEST(BehaviorTest, AFailedPlanCountsUntilTheNextReplyOrARecovery) {
  const BehaviorParams params{.recovery_wait = std::chrono::seconds(1)};
  BehaviorState state;
  BehaviorInput input = At(0.0, Vec2(1.0, 0.0));
  // A failed reply while the intersection is not free: the gate holds, the failure is kept ...
  input.intersection_free = false;
  input.plan_failed = true;
  EXPECT_EQ(StepBehavior(params, Straight(10.0), input, &state).mode,
            BehaviorMode::kIntersectionWait);
  EXPECT_TRUE(state.plan_failed);
  // ... and starts a recovery once the gate opens, with no new reply.
  input.intersection_free = true;
  input.plan_failed = std::nullopt;
  input.now = FromSeconds(0.333);
  BehaviorOutput out = StepBehavior(params, Straight(10.0), input, &state);
  EXPECT_EQ(out.mode, BehaviorMode::kRecovery);
  EXPECT_TRUE(out.clear_costmaps);
  EXPECT_EQ(out.retries, 1);
  EXPECT_FALSE(state.plan_failed);
  // After the 1 s wait, still no reply: the old failure does not start a second recovery.
  input.now = FromSeconds(1.4);
  out = StepBehavior(params, Straight(10.0), input, &state);
  EXPECT_EQ(out.mode, BehaviorMode::kDrive);
  EXPECT_EQ(out.retries, 1);
  // The newest reply counts: a failure held at the gate, then a success, drives on.
  input.intersection_free = false;
  input.plan_failed = true;
  input.now = FromSeconds(1.7);
  EXPECT_EQ(StepBehavior(params, Straight(10.0), input, &state).mode,
            BehaviorMode::kIntersectionWait);
  input.intersection_free = true;
  input.plan_failed = false;
  input.now = FromSeconds(2.0);
  out = StepBehavior(params, Straight(10.0), input, &state);
  EXPECT_EQ(out.mode, BehaviorMode::kDrive);
  EXPECT_EQ(out.retries, 1);
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
