#include "stack/controller_server.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <memory>
#include <optional>
#include <stdexcept>
#include <vector>

namespace autonomsim::stack {
namespace {

using world::Vec2;

constexpr double kTol = 1e-12;

// One intersection whose area is the square 1.5 < x < 2.5, -0.5 < y < 0.5 of the map.
std::vector<world::IntersectionSpec> OneIntersection() {
  world::IntersectionSpec i;
  i.area = world::Box{.x_min_m = 1.5, .x_max_m = 2.5, .y_min_m = -0.5, .y_max_m = 0.5};
  return {i};
}

// A driving cycle at (x, y), heading +x, standing still, with odometry stamped 10 s.
ControllerServerInput DriveAt(double x_m, double y_m) {
  return ControllerServerInput{.hold = false,
                               .odometry_stamp = FromSeconds(10.0),
                               .X_map_base = world::Pose2{x_m, y_m, 0.0}};
}

struct Server {
  ControllerServerParams params;
  std::vector<world::IntersectionSpec> intersections{OneIntersection()};
  ControllerServerState state;

  ControllerServerOutput Step(const ControllerServerInput& input) {
    return StepControllerServer(params, intersections, input, &state);
  }
};

TEST(ControllerServerTest, AHoldSendsOneZeroVelocityThenNothing) {
  Server s;
  ControllerServerInput input = DriveAt(0.0, 0.0);
  input.hold = true;
  ControllerServerOutput out = s.Step(input);
  ASSERT_TRUE(out.cmd_vel.has_value());
  EXPECT_EQ(out.cmd_vel->speed_mps, 0.0);
  EXPECT_EQ(out.cmd_vel->yaw_rate_rad_per_s, 0.0);
  EXPECT_EQ(out.cmd_vel_stamp, FromSeconds(10.0));
  EXPECT_EQ(out.controller, ActiveController::kNone);
  // The status goes out every cycle, all false while held.
  EXPECT_FALSE(out.status.collision_ahead);
  EXPECT_FALSE(out.status.follow_path);
  EXPECT_EQ(out.status_stamp, FromSeconds(10.0));
  out = s.Step(input);
  EXPECT_FALSE(out.cmd_vel.has_value());
  EXPECT_EQ(out.controller, ActiveController::kNone);
  // Driving again, then a new hold: its zero velocity goes out once more.
  input.hold = false;
  EXPECT_TRUE(s.Step(input).cmd_vel.has_value());
  input.hold = true;
  EXPECT_TRUE(s.Step(input).cmd_vel.has_value());
  EXPECT_FALSE(s.Step(input).cmd_vel.has_value());
  // Before the behaviour's first output the server holds.
  EXPECT_TRUE(ControllerServerInput{}.hold);
}

TEST(ControllerServerTest, LaneControllerOutsideTheZonesOnTheLanePoints) {
  Server s;
  // Far to near, as the detector sends them. The nearest at range >= 0.6 m is (0.6, 0.3) at
  // 0.671 m: κ = 2·0.3 / 0.45 = 4/3 1/m, radius 0.75 m < 0.9 m slows to 0.25·(1 − 0.15/0.9), but
  // not below the 0.25 m/s minimum; |0.6 − 0.671| < 0.1 m: no approach scaling.
  // v = 0.25 m/s, ω = v·κ = 1/3 rad/s.
  const std::vector<Vec2> points{Vec2(1.5, 0.2), Vec2(0.6, 0.3), Vec2(0.4, 0.1)};
  ControllerServerInput input = DriveAt(0.0, 0.0);
  input.lanes = ControllerLanes{.points_base = points, .valid = true, .stamp = FromSeconds(9.9)};
  ControllerServerOutput out = s.Step(input);
  EXPECT_EQ(out.controller, ActiveController::kLaneController);
  ASSERT_TRUE(out.cmd_vel.has_value());
  EXPECT_NEAR(out.cmd_vel->speed_mps, 0.25, kTol);
  EXPECT_NEAR(out.cmd_vel->yaw_rate_rad_per_s, 1.0 / 3.0, kTol);
  // The twist carries the camera frame's stamp, the status the odometry's.
  EXPECT_EQ(out.cmd_vel_stamp, FromSeconds(9.9));
  EXPECT_EQ(out.status_stamp, FromSeconds(10.0));
  EXPECT_FALSE(out.status.follow_path);
  EXPECT_FALSE(out.status.collision_ahead);

  // Invalid lanes: (0, 0), still stamped with the frame that said so.
  input.lanes->valid = false;
  out = s.Step(input);
  EXPECT_EQ(out.cmd_vel->speed_mps, 0.0);
  EXPECT_EQ(out.cmd_vel->yaw_rate_rad_per_s, 0.0);
  EXPECT_EQ(out.cmd_vel_stamp, FromSeconds(9.9));

  // No lane points yet: (0, 0) on the odometry's stamp, the LaneController still selected.
  input.lanes.reset();
  out = s.Step(input);
  EXPECT_EQ(out.controller, ActiveController::kLaneController);
  EXPECT_EQ(out.cmd_vel->speed_mps, 0.0);
  EXPECT_EQ(out.cmd_vel_stamp, FromSeconds(10.0));
}

TEST(ControllerServerTest, FollowPathInsideAnIntersectionOnThePlan) {
  Server s;
  // The car at (2, 0) inside the area. The path's closest point is (2.1, 0) (index 1); the
  // carrot is the first at range >= 0.6 m, (3.0, 0) at 1.0 m: κ = 0, approach scaling
  // v = 0.25·(1 − 0.4/0.6) = 1/12 m/s (above the 0.05 m/s floor).
  const std::vector<Vec2> path{Vec2(1.7, 0.0), Vec2(2.1, 0.0), Vec2(2.4, 0.0), Vec2(3.0, 0.0),
                               Vec2(3.6, 0.0)};
  const std::vector<Vec2> lanes{Vec2(0.6, 0.3)};
  ControllerServerInput input = DriveAt(2.0, 0.0);
  input.path = ControllerPath{.points_map = path, .id = 7};
  input.lanes = ControllerLanes{.points_base = lanes, .valid = true, .stamp = FromSeconds(9.9)};
  ControllerServerOutput out = s.Step(input);
  EXPECT_EQ(out.controller, ActiveController::kFollowPath);
  ASSERT_TRUE(out.cmd_vel.has_value());
  EXPECT_NEAR(out.cmd_vel->speed_mps, 0.25 / 3.0, kTol);
  EXPECT_EQ(out.cmd_vel->yaw_rate_rad_per_s, 0.0);
  EXPECT_EQ(out.cmd_vel_stamp, FromSeconds(10.0));  // the lanes' stamp is not used
  EXPECT_TRUE(out.status.follow_path);
  EXPECT_FALSE(out.status.collision_ahead);
  EXPECT_EQ(s.state.follower.path_id, 7u);
  EXPECT_EQ(s.state.follower.begin, 1u);

  // No successful plan yet: (0, 0), FollowPath still selected, its pruning state untouched.
  Server fresh;
  input.path.reset();
  out = fresh.Step(input);
  EXPECT_EQ(out.controller, ActiveController::kFollowPath);
  EXPECT_EQ(out.cmd_vel->speed_mps, 0.0);
  EXPECT_TRUE(out.status.follow_path);
  EXPECT_FALSE(fresh.state.follower.path_id.has_value());
}

// Beyond the lab's: stack.controller_selector.follow_path_without_line. The lab's LaneController
// has the origin for a carrot when no lane point lies beyond the lookahead and stands
// (lane_controller.cpp:343-362); with the option FollowPath drives on the plan on such a cycle.
TEST(ControllerServerTest, WithoutALineTheOptionFollowsThePlanInstead) {
  // The car at (0, 0) outside the zones; the same plan as above, shifted: its carrot (0.6, 0)
  // is at 0.6 m, κ = 0, no approach scaling (the goal is 1.6 m away): v = 0.25 m/s.
  const std::vector<Vec2> path{Vec2(0.0, 0.0), Vec2(0.3, 0.0), Vec2(0.6, 0.0), Vec2(1.6, 0.0)};
  const std::vector<Vec2> lanes{Vec2(0.6, 0.3)};
  ControllerServerInput input = DriveAt(0.0, 0.0);
  input.path = ControllerPath{.points_map = path, .id = 3};
  input.lanes = ControllerLanes{.points_base = lanes, .valid = false, .stamp = FromSeconds(9.9)};

  Server lab;  // the lab's: invalid lanes stop the car
  ControllerServerOutput out = lab.Step(input);
  EXPECT_EQ(out.controller, ActiveController::kLaneController);
  EXPECT_EQ(out.cmd_vel->speed_mps, 0.0);

  Server safe;
  safe.params.follow_path_without_line = true;
  out = safe.Step(input);
  EXPECT_EQ(out.controller, ActiveController::kFollowPath);
  EXPECT_TRUE(out.status.follow_path);
  EXPECT_NEAR(out.cmd_vel->speed_mps, 0.25, kTol);
  EXPECT_EQ(out.cmd_vel->yaw_rate_rad_per_s, 0.0);
  EXPECT_EQ(out.cmd_vel_stamp, FromSeconds(10.0));  // the odometry's: no lane frame was used

  // Valid lanes but no point beyond the lookahead: no carrot either.
  const std::vector<Vec2> near{Vec2(0.3, 0.1)};
  input.lanes = ControllerLanes{.points_base = near, .valid = true, .stamp = FromSeconds(9.9)};
  EXPECT_EQ(safe.Step(input).controller, ActiveController::kFollowPath);
  // No lane message yet: the plan too.
  input.lanes.reset();
  EXPECT_EQ(safe.Step(input).controller, ActiveController::kFollowPath);

  // A line in view: the LaneController again, on the lane points and their stamp.
  input.lanes = ControllerLanes{.points_base = lanes, .valid = true, .stamp = FromSeconds(9.9)};
  out = safe.Step(input);
  EXPECT_EQ(out.controller, ActiveController::kLaneController);
  EXPECT_NEAR(out.cmd_vel->yaw_rate_rad_per_s, 1.0 / 3.0, kTol);
  EXPECT_EQ(out.cmd_vel_stamp, FromSeconds(9.9));

  // No plan yet: the LaneController's stop stands.
  input.lanes->valid = false;
  input.path.reset();
  out = safe.Step(input);
  EXPECT_EQ(out.controller, ActiveController::kLaneController);
  EXPECT_EQ(out.cmd_vel->speed_mps, 0.0);
}

// LETHAL beyond x_m in the map, FREE before it.
CostQuery WallBeyond(double x_m) {
  return [x_m](const Vec2& p_map) { return p_map.x() > x_m ? kLethalObstacle : kFreeSpace; };
}

TEST(ControllerServerTest, ACollisionAheadStopsAndIsReported) {
  // Each controller checks with its own collision model: FollowPath here with the footprint,
  // the LaneController with the lab's centre point (its default).
  // FollowPath from (2, 0) at 1/12 m/s (as above) against a wall beyond x = 2.3 m: the arc is
  // tested every 0.05 m, and the first pose ahead puts the footprint's front (+0.265 m) at
  // 2.315 m.
  const std::vector<Vec2> path{Vec2(1.7, 0.0), Vec2(2.1, 0.0), Vec2(2.4, 0.0), Vec2(3.0, 0.0),
                               Vec2(3.6, 0.0)};
  Server s;
  s.params.follow_path.collision.model = CollisionModel::kFootprint;
  ControllerServerInput input = DriveAt(2.0, 0.0);
  input.path = ControllerPath{.points_map = path, .id = 1};
  input.cell_cost = WallBeyond(2.3);
  ControllerServerOutput out = s.Step(input);
  EXPECT_EQ(out.cmd_vel->speed_mps, 0.0);
  EXPECT_TRUE(out.status.failed);
  EXPECT_TRUE(out.status.collision_ahead);
  EXPECT_TRUE(out.status.follow_path);
  // The action aborted (nav2_controller.cpp:395-398): silent, and still failed, until the
  // behaviour starts a new one, even when the way is clear again.
  input.cell_cost = {};
  out = s.Step(input);
  EXPECT_FALSE(out.cmd_vel.has_value());
  EXPECT_TRUE(out.status.failed);
  EXPECT_EQ(out.status.attempt, 0u);

  // The LaneController (a new action) from (1.2, 0), outside the area, straight at 0.25 m/s:
  // within the 1 s horizon the centre point reaches 1.2 + 0.25 = 1.45 m (the footprint's front
  // would reach 1.715 m). A wall beyond 1.5 m is clear of it, one beyond 1.44 m is not.
  const std::vector<Vec2> lanes{Vec2(0.6, 0.0)};
  input = DriveAt(1.2, 0.0);
  input.attempt = 1;
  input.lanes = ControllerLanes{.points_base = lanes, .valid = true, .stamp = FromSeconds(9.9)};
  input.cell_cost = WallBeyond(1.5);
  out = s.Step(input);
  EXPECT_FALSE(out.status.failed);
  EXPECT_EQ(out.status.attempt, 1u);
  EXPECT_FALSE(out.status.collision_ahead);
  EXPECT_NEAR(out.cmd_vel->speed_mps, 0.25, kTol);
  input.cell_cost = WallBeyond(1.44);
  out = s.Step(input);
  EXPECT_TRUE(out.status.collision_ahead);
  EXPECT_FALSE(out.status.follow_path);
  EXPECT_EQ(out.cmd_vel->speed_mps, 0.0);
  EXPECT_EQ(out.cmd_vel_stamp, FromSeconds(9.9));
}

// Galactic's SimpleProgressChecker (simple_progress_checker.cpp:63-92) with the car's 0.5 m in
// 10 s (nav2_car_params.yaml:67-70), reset by a new FollowPath action (nav2_controller.cpp:357):
// a car that stands, e.g. because its LaneController sees no line, fails its action after 10 s.
TEST(ControllerServerTest, ACarThatDoesNotMoveHalfAMetreInTenSecondsFailsItsAction) {
  Server s;
  ControllerServerInput input = DriveAt(1.2, 0.0);
  input.lanes = ControllerLanes{.valid = false};  // no line: (0, 0)
  for (int i = 0; i <= 200; ++i) {                // 10 s at 20 Hz, standing
    input.now = FromSeconds(0.05 * i);
    const ControllerServerOutput out = s.Step(input);
    EXPECT_FALSE(out.status.failed) << input.now.count();
  }
  input.now = FromSeconds(10.05);
  ControllerServerOutput out = s.Step(input);
  EXPECT_TRUE(out.status.failed);
  EXPECT_FALSE(out.status.collision_ahead);
  ASSERT_TRUE(out.cmd_vel.has_value());
  EXPECT_EQ(out.cmd_vel->speed_mps, 0.0);
  // a new action starts the check again
  input.attempt = 1;
  input.now = FromSeconds(10.1);
  EXPECT_FALSE(s.Step(input).status.failed);
  // moving more than 0.5 m from the baseline renews it: 0.06 m per 1 s, never failing
  for (int i = 1; i <= 400; ++i) {
    input.now = FromSeconds(10.1 + 0.05 * i);
    input.X_map_base = world::Pose2{1.2 + 0.003 * i, 0.0, 0.0};
    EXPECT_FALSE(s.Step(input).status.failed) << i;
  }
}

TEST(ControllerServerTest, LocalCostmapCostGoesThroughMapToOdom) {
  // A 10 × 10 grid of 0.1 m cells at the odom origin, lethal in cell (3, 4): odom point
  // (0.35, 0.45). With map→odom = (1, 2, 90°) that point is at (1 − 0.45, 2 + 0.35) in the map.
  auto costmap = std::make_shared<Costmap2D>(10, 10, 0.1, Vec2(0.0, 0.0));
  costmap->SetCost(3, 4, kLethalObstacle);
  costmap->SetCost(2, 4, kInscribedInflatedObstacle);
  const CostQuery cost = LocalCostmapCost(costmap, world::Pose2{1.0, 2.0, 1.5707963267948966});
  EXPECT_EQ(cost(Vec2(0.55, 2.35)), kLethalObstacle);
  EXPECT_EQ(cost(Vec2(0.55, 2.25)), kInscribedInflatedObstacle);  // odom (0.25, 0.45)
  EXPECT_EQ(cost(Vec2(0.55, 2.55)), kFreeSpace);                  // odom (0.55, 0.45)
  EXPECT_EQ(cost(Vec2(5.0, 5.0)), std::nullopt);                  // outside the grid
}

// The controller leaves the collision check out on a costmap CanCollide says no pose can collide
// on (issue 38): there, the check says "no collision" for every pose, under either model.
TEST(ControllerServerTest, NoPoseCollidesOnACostmapThatCannotCollide) {
  auto costmap = std::make_shared<Costmap2D>(40, 40, 0.05, Vec2(0.0, 0.0));
  for (std::size_t i = 0; i < costmap->costs().size(); ++i) {
    costmap->mutable_costs()[i] = static_cast<std::uint8_t>((i * 37) % kInscribedInflatedObstacle);
  }
  ASSERT_FALSE(CanCollide(*costmap));
  const CostQuery cost = LocalCostmapCost(costmap, world::Pose2{});
  for (const CollisionModel model : {CollisionModel::kCentre, CollisionModel::kFootprint}) {
    CollisionCheckParams params;
    params.model = model;
    for (int k = 0; k < 50; ++k) {
      const world::Pose2 X{0.1 + 0.035 * k, 1.9 - 0.03 * k, 0.4 * k};
      EXPECT_FALSE(IsCollisionImminent(params, X, 0.5, 0.3, cost)) << k;
    }
  }
  // one cell at each of the costs a model collides on: the check is needed again
  for (const std::uint8_t c : {kInscribedInflatedObstacle, kLethalObstacle, kNoInformation}) {
    Costmap2D one = *costmap;
    one.SetCost(20, 20, c);
    EXPECT_TRUE(CanCollide(one)) << int{c};
  }
}

TEST(ControllerServerTest, ParamsValidateBothControllers) {
  ControllerServerParams params;
  EXPECT_NO_THROW(params.Validate());
  params.follow_path.collision.step_m = -1.0;
  EXPECT_THROW(params.Validate(), std::invalid_argument);
  params = {};
  params.lane_controller.pursuit.lookahead_dist_m = -1.0;
  EXPECT_THROW(params.Validate(), std::invalid_argument);
}

}  // namespace
}  // namespace autonomsim::stack
