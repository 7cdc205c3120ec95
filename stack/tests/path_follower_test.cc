#include "stack/path_follower.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <numbers>
#include <optional>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "stack/costmap.h"

namespace autonomsim::stack {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;
using world::Pose2;
using world::Vec2;

// Points along +x from x0_m to x1_m, 0.05 m apart (a planner's 0.05 m grid).
std::vector<Vec2> StraightPath(double x0_m, double x1_m, double y_m = 0.0) {
  std::vector<Vec2> path;
  const int n = static_cast<int>(std::lround((x1_m - x0_m) / 0.05));
  for (int i = 0; i <= n; ++i) path.emplace_back(x0_m + 0.05 * i, y_m);
  return path;
}

// A left-hand arc of radius r_m starting at the origin heading +x, points 0.01 m apart.
std::vector<Vec2> ArcPath(double r_m, double length_m) {
  std::vector<Vec2> path;
  const int n = static_cast<int>(std::lround(length_m / 0.01));
  for (int i = 0; i <= n; ++i) {
    const double a = 0.01 * i / r_m;
    path.emplace_back(r_m * std::sin(a), r_m * (1.0 - std::cos(a)));
  }
  return path;
}

// `cost` inside an axis-aligned box, FREE elsewhere.
CostQuery Obstacle(double x_min, double x_max, double y_min, double y_max,
                   std::uint8_t cost = kLethalObstacle) {
  return [=](const Vec2& p) -> std::optional<std::uint8_t> {
    const bool inside = p.x() >= x_min && p.x() <= x_max && p.y() >= y_min && p.y() <= y_max;
    return inside ? cost : kFreeSpace;
  };
}

// The local costmap's geometry (reference §6: 0.05 m cells, edges on multiples of 0.05 m here)
// over 5 m × 5 m around the origin, LETHAL in the cells that contain `obstacles`, inflated as the
// local costmap is (inscribed radius 0.135 m, inflation radius 0.3 m, scale 5.0).
CostQuery InflatedCostmap(const std::vector<Vec2>& obstacles) {
  auto grid = std::make_shared<Costmap2D>(100, 100, 0.05, Vec2(-2.5, -2.5));
  for (const Vec2& p : obstacles) {
    const std::optional<CellIndex> cell = grid->WorldToMap(p);
    grid->SetCost(cell->mx, cell->my, kLethalObstacle);
  }
  Inflation(InflationParams{.inflation_radius_m = 0.3, .cost_scaling_factor = 5.0}, 0.135, 0.05)
      .Apply(grid.get());
  return [grid](const Vec2& p) { return grid->CostAt(p); };
}

CollisionCheckParams WithModel(CollisionModel model) {
  CollisionCheckParams params;
  params.model = model;
  return params;
}

PathFollowerParams FollowerWithModel(CollisionModel model) {
  PathFollowerParams params;
  params.collision.model = model;
  return params;
}

PathFollowerOutput Follow(const std::vector<Vec2>& path, const Pose2& X, CostQuery cost = {},
                          PathFollowerParams params = {}) {
  PathFollowerState state;
  PathFollowerInput input;
  input.path = path;
  input.X_F_base = X;
  input.speed_mps = 0.25;
  input.cell_cost = std::move(cost);
  return StepPathFollower(params, input, &state);
}

TEST(PathFollowerParamsTest, DefaultsKeysAndValidation) {
  PathFollowerParams params;
  EXPECT_EQ(params.pursuit.desired_speed_mps, 0.25);
  EXPECT_EQ(params.pursuit.lookahead_dist_m, 0.6);
  EXPECT_EQ(params.pursuit.regulated_min_radius_m, 0.9);
  EXPECT_EQ(params.goal_tolerance_m, 0.25);
  EXPECT_EQ(params.collision.model, CollisionModel::kCentre);  // the lab's
  EXPECT_EQ(params.collision.horizon_s, 1.0);
  EXPECT_EQ(params.collision.footprint_half_length_m, 0.265);
  EXPECT_EQ(params.collision.footprint_half_width_m, 0.135);
  EXPECT_NO_THROW(params.Validate());
  std::vector<std::string> keys;
  auto visit = [&](const std::string& key, auto&, auto&&...) { keys.push_back(key); };
  params.Describe(visit);
  EXPECT_THAT(keys,
              ElementsAre("pursuit", "collision", "goal_tolerance_m", "yaw_goal_tolerance_rad",
                          "max_robot_pose_search_dist_m", "max_costmap_extent_m"));
  std::vector<std::string> pursuit_keys;
  auto visit_pursuit = [&](const std::string& key, auto&, auto&&...) {
    pursuit_keys.push_back(key);
  };
  params.pursuit.Describe(visit_pursuit);
  EXPECT_EQ(pursuit_keys.size(), 12u);
  std::vector<std::string> collision_keys;
  auto visit_collision = [&](const std::string& key, auto&, auto&&...) {
    collision_keys.push_back(key);
  };
  params.collision.Describe(visit_collision);
  EXPECT_THAT(collision_keys, ElementsAre("model", "horizon_s", "step_m", "footprint_half_length_m",
                                          "footprint_half_width_m", "footprint_sample_spacing_m"));
  EXPECT_EQ(FromName<CollisionModel>("centre"), CollisionModel::kCentre);
  EXPECT_EQ(FromName<CollisionModel>("footprint"), CollisionModel::kFootprint);
  EXPECT_EQ(NameList<CollisionModel>(), "'centre' or 'footprint'");

  params.pursuit.min_lookahead_dist_m = 1.0;
  try {
    params.Validate();
    FAIL() << "accepted min_lookahead_dist_m > max_lookahead_dist_m";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("min_lookahead_dist_m"));
  }
  params = {};
  params.collision.step_m = 0.0;
  EXPECT_THROW(params.Validate(), std::invalid_argument);
  params = {};
  params.goal_tolerance_m = -0.25;
  EXPECT_THROW(params.Validate(), std::invalid_argument);
}

TEST(PurePursuitTest, CurvatureAndLookaheadByHand) {
  EXPECT_NEAR(PurePursuitCurvature({0.6, 0.0}), 0.0, 1e-15);
  EXPECT_NEAR(PurePursuitCurvature({0.6, 0.1}), 2.0 * 0.1 / 0.37, 1e-12);
  EXPECT_NEAR(PurePursuitCurvature({0.6, -0.1}), -2.0 * 0.1 / 0.37, 1e-12);
  EXPECT_EQ(PurePursuitCurvature({0.02, 0.02}), 0.0);  // L² = 0.0008 <= 0.001

  RegulatedPurePursuitParams params;
  EXPECT_EQ(LookaheadDistance(params, 0.25), 0.6);
  params.use_velocity_scaled_lookahead = true;
  EXPECT_NEAR(LookaheadDistance(params, 0.4), 0.6, 1e-12);  // 0.4 · 1.5
  EXPECT_EQ(LookaheadDistance(params, 0.1), 0.3);           // clamped to min
  EXPECT_EQ(LookaheadDistance(params, -1.0), 0.9);          // |v|, clamped to max
}

TEST(PurePursuitTest, RegulatedSpeedByHand) {
  RegulatedPurePursuitParams params;
  // Straight and gentle: the desired speed.
  EXPECT_EQ(RegulatedSpeed(params, 0.0, 0.6, 0.6), 0.25);
  EXPECT_EQ(RegulatedSpeed(params, 1.0, 0.6, 0.6), 0.25);
  // r = 0.5 < 0.9: the slow-down gives 0.25 · 0.5 / 0.9, but the car's floor of 0.25 wins.
  EXPECT_EQ(RegulatedSpeed(params, 2.0, 0.6, 0.6), 0.25);
  params.regulated_min_speed_mps = 0.05;
  EXPECT_NEAR(RegulatedSpeed(params, 2.0, 0.6, 0.6), 0.25 * 0.5 / 0.9, 1e-15);
  EXPECT_NEAR(RegulatedSpeed(params, -2.0, 0.6, 0.6), 0.25 * 0.5 / 0.9, 1e-15);
  // Tighter than the floor allows: r = 0.1 → 0.0278, floored at 0.05.
  EXPECT_EQ(RegulatedSpeed(params, 10.0, 0.6, 0.6), 0.05);
  // Approach scaling: the carrot 0.2 m beyond L = 0.6 scales by 1 − 0.2/0.6.
  params = {};
  EXPECT_NEAR(RegulatedSpeed(params, 0.0, 0.6, 0.8), 0.25 * (1.0 - 0.2 / 0.6), 1e-12);
  // ... but not within 0.1 m (2 cells) of L.
  EXPECT_EQ(RegulatedSpeed(params, 0.0, 0.6, 0.69), 0.25);
  // ... and not below min_approach_speed_mps: 0.25 · (1 − 0.55/0.6) = 0.0208 → 0.05.
  EXPECT_EQ(RegulatedSpeed(params, 0.0, 0.6, 0.05), 0.05);
  params.use_approach_speed_scaling = false;
  EXPECT_EQ(RegulatedSpeed(params, 0.0, 0.6, 0.05), 0.25);
}

TEST(PathFollowerTest, StraightPathDrivesStraight) {
  const std::vector<Vec2> path = StraightPath(0.0, 3.0);
  const PathFollowerOutput out = Follow(path, Pose2{0.0, 0.0, 0.0});
  ASSERT_TRUE(out.carrot.has_value());
  EXPECT_NEAR(out.carrot->x(), 0.6, 0.05 + 1e-9);
  EXPECT_NEAR(out.curvature_per_m, 0.0, 1e-12);
  EXPECT_EQ(out.speed_mps, 0.25);
  EXPECT_NEAR(out.yaw_rate_rad_per_s, 0.0, 1e-12);
  EXPECT_FALSE(out.goal_reached);
  EXPECT_FALSE(out.collision_ahead);
  EXPECT_FALSE(out.no_path);
}

TEST(PathFollowerTest, OffsetFromTheStraightPathSteersBack) {
  // 0.1 m left of a path along +x: turns right.
  const PathFollowerOutput out = Follow(StraightPath(0.0, 3.0), Pose2{0.0, 0.1, 0.0});
  EXPECT_LT(out.curvature_per_m, 0.0);
  EXPECT_NEAR(out.yaw_rate_rad_per_s, out.speed_mps * out.curvature_per_m, 1e-15);
}

TEST(PathFollowerTest, ArcPathGivesOneOverR) {
  for (const double r_m : {1.0, 1.5, 3.0}) {
    const PathFollowerOutput out = Follow(ArcPath(r_m, 2.0), Pose2{0.0, 0.0, 0.0});
    // A carrot on the circle through the car, tangent to its heading, gives κ = 1/R exactly.
    EXPECT_NEAR(out.curvature_per_m, 1.0 / r_m, 1e-9) << "R = " << r_m;
    EXPECT_EQ(out.speed_mps, 0.25);
    EXPECT_NEAR(out.yaw_rate_rad_per_s, 0.25 / r_m, 1e-9);
  }
  // A right-hand arc: mirror the points.
  std::vector<Vec2> right = ArcPath(1.5, 2.0);
  for (Vec2& p : right) p.y() = -p.y();
  EXPECT_NEAR(Follow(right, Pose2{0.0, 0.0, 0.0}).curvature_per_m, -1.0 / 1.5, 1e-9);
  // Below 0.9 m with a lower floor, the curvature slow-down acts: v = 0.25 · 0.5 / 0.9.
  PathFollowerParams params;
  params.pursuit.regulated_min_speed_mps = 0.05;
  const PathFollowerOutput tight = Follow(ArcPath(0.5, 1.5), Pose2{0.0, 0.0, 0.0}, {}, params);
  EXPECT_NEAR(tight.curvature_per_m, 2.0, 1e-9);
  EXPECT_NEAR(tight.speed_mps, 0.25 * 0.5 / 0.9, 1e-9);
}

TEST(PathFollowerTest, GoalReachedWithinTolerance) {
  const std::vector<Vec2> path = StraightPath(0.0, 2.0);
  PathFollowerOutput out = Follow(path, Pose2{1.8, 0.0, 0.0});  // 0.2 m short
  EXPECT_TRUE(out.goal_reached);
  EXPECT_EQ(out.speed_mps, 0.0);
  EXPECT_EQ(out.yaw_rate_rad_per_s, 0.0);
  EXPECT_TRUE(Follow(path, Pose2{2.0, 0.25, 0.0}).goal_reached);  // exactly at tolerance
  out = Follow(path, Pose2{1.7, 0.0, 0.0});                       // 0.3 m short
  EXPECT_FALSE(out.goal_reached);
  EXPECT_GT(out.speed_mps, 0.0);  // approaching: the carrot is the goal, 0.3 m < L

  // With a goal yaw, the heading must be within 0.25 rad too.
  PathFollowerState state;
  PathFollowerInput input;
  input.path = path;
  input.X_F_base = Pose2{1.9, 0.0, 0.3};
  input.goal_yaw_rad = 0.0;
  EXPECT_FALSE(StepPathFollower(PathFollowerParams{}, input, &state).goal_reached);
  input.X_F_base.yaw_rad = 0.2;
  EXPECT_TRUE(StepPathFollower(PathFollowerParams{}, input, &state).goal_reached);
  input.X_F_base.yaw_rad = 2.0 * std::numbers::pi + 0.2;  // wrapped
  EXPECT_TRUE(StepPathFollower(PathFollowerParams{}, input, &state).goal_reached);
}

TEST(PathFollowerTest, FootprintModelStopsForLethalCellsUnderTheSweptFootprint) {
  const std::vector<Vec2> path = StraightPath(0.0, 3.0);
  const Pose2 X{0.0, 0.0, 0.0};
  const PathFollowerParams params = FollowerWithModel(CollisionModel::kFootprint);
  // In 1 s at 0.25 m/s the front (0.265 m) sweeps to 0.515 m.
  PathFollowerOutput out = Follow(path, X, Obstacle(0.45, 0.5, -0.02, 0.02), params);
  EXPECT_TRUE(out.collision_ahead);
  EXPECT_EQ(out.speed_mps, 0.0);
  EXPECT_EQ(out.yaw_rate_rad_per_s, 0.0);
  out = Follow(path, X, Obstacle(0.55, 0.6, -0.02, 0.02), params);  // beyond the 1 s arc
  EXPECT_FALSE(out.collision_ahead);
  EXPECT_EQ(out.speed_mps, 0.25);
  // Beside the path: the footprint is ±0.135 m wide.
  EXPECT_FALSE(Follow(path, X, Obstacle(0.3, 0.35, 0.15, 0.2), params).collision_ahead);
  EXPECT_TRUE(Follow(path, X, Obstacle(0.3, 0.35, 0.12, 0.2), params).collision_ahead);
  // A 5 cm cell under the car now: the footprint's sample grid is at most 5 cm apart.
  EXPECT_TRUE(Follow(path, X, Obstacle(-0.1, -0.05, 0.0, 0.05), params).collision_ahead);
  // Only LETHAL counts: INSCRIBED and NO_INFORMATION under the footprint do not stop it.
  for (const std::uint8_t cost : {kInscribedInflatedObstacle, kNoInformation}) {
    EXPECT_FALSE(Follow(path, X, Obstacle(0.3, 0.35, -0.02, 0.02, cost), params).collision_ahead);
  }
}

// lane_controller.cpp:364-443 (and Galactic's regulated_pure_pursuit_controller.cpp:372-452):
// inCollision(x, y) of the centre point at the pose and every 0.05 m along the 1 s arc, cost >=
// INSCRIBED with track_unknown_space false.
TEST(PathFollowerTest, CentreModelStopsForAnInscribedCellOnTheArcOnly) {
  const std::vector<Vec2> path = StraightPath(0.0, 3.0);
  const Pose2 X{0.0, 0.0, 0.0};
  // The arc's points: x = 0, 0.05, ..., 0.25 m on y = 0.
  for (const std::uint8_t cost : {kInscribedInflatedObstacle, kLethalObstacle, kNoInformation}) {
    const PathFollowerOutput out = Follow(path, X, Obstacle(0.18, 0.22, -0.02, 0.02, cost));
    EXPECT_TRUE(out.collision_ahead) << int{cost};
    EXPECT_EQ(out.speed_mps, 0.0);
  }
  EXPECT_FALSE(
      Follow(path, X, Obstacle(0.18, 0.22, -0.02, 0.02, kMaxNonInscribedCost)).collision_ahead);
  // LETHAL beyond the arc's last point (0.25 m): the footprint's front would reach it.
  EXPECT_FALSE(Follow(path, X, Obstacle(0.3, 0.5, -0.02, 0.02)).collision_ahead);
  EXPECT_TRUE(Follow(path, X, Obstacle(0.3, 0.5, -0.02, 0.02),
                     FollowerWithModel(CollisionModel::kFootprint))
                  .collision_ahead);
  // A LETHAL cell under the footprint's front corner, off the centre line, uninflated: only the
  // footprint model sees it.
  EXPECT_FALSE(Follow(path, X, Obstacle(0.2, 0.25, 0.1, 0.15)).collision_ahead);
  EXPECT_TRUE(
      Follow(path, X, Obstacle(0.2, 0.25, 0.1, 0.15), FollowerWithModel(CollisionModel::kFootprint))
          .collision_ahead);
  // Outside the costmap: no collision (Nav2: worldToMap fails).
  const CostQuery outside = [](const Vec2&) { return std::optional<std::uint8_t>(); };
  EXPECT_FALSE(Follow(path, X, outside).collision_ahead);
}

// The reach of each model on an inflated local costmap (0.05 m cells), the car at (0.01, 0.01)
// heading +x at 0.25 m/s, so that no arc point lies on a cell edge. Centre: the arc ends at
// x = 0.26 m, in the cell [0.25, 0.30); the INSCRIBED cells reach two cells (0.10 m <= 0.135 m)
// from a LETHAL one, so a LETHAL cell [0.35, 0.40) stops the car, 0.34 m ahead of base_link, and
// [0.40, 0.45), 0.39 m ahead, does not. Footprint: the front sweeps to 0.01 + 0.265 + 0.25 =
// 0.525 m, LETHAL only: [0.50, 0.55) stops it, [0.55, 0.60) does not.
TEST(CollisionCheckTest, ReachOnAnInflatedCostmapByModel) {
  const Pose2 X{0.01, 0.01, 0.0};
  const CollisionCheckParams centre = WithModel(CollisionModel::kCentre);
  const CollisionCheckParams footprint = WithModel(CollisionModel::kFootprint);
  auto imminent = [&](const CollisionCheckParams& params, const Vec2& obstacle) {
    return IsCollisionImminent(params, X, 0.25, 0.0, InflatedCostmap({obstacle}));
  };
  EXPECT_TRUE(imminent(centre, Vec2(0.37, 0.01)));
  EXPECT_FALSE(imminent(centre, Vec2(0.42, 0.01)));
  EXPECT_TRUE(imminent(footprint, Vec2(0.52, 0.01)));
  EXPECT_FALSE(imminent(footprint, Vec2(0.57, 0.01)));
  // Sideways, the centre sees the inscribed circle: two cells off the centre line ([0.10, 0.15),
  // the footprint's edge at 0.145 m) it stops, three ([0.15, 0.20)) it does not.
  EXPECT_TRUE(imminent(centre, Vec2(0.12, 0.12)));
  EXPECT_FALSE(imminent(centre, Vec2(0.12, 0.17)));
  // The footprint's front corner at the arc's end (0.525, 0.145): a LETHAL cell there stops the
  // footprint model; the centre's cells are four cells away from it.
  EXPECT_TRUE(imminent(footprint, Vec2(0.47, 0.12)));
  EXPECT_FALSE(imminent(centre, Vec2(0.47, 0.12)));
}

TEST(CollisionCheckTest, ArcIsSteppedForOneSecond) {
  const CollisionCheckParams params = WithModel(CollisionModel::kFootprint);
  // Exactly at the 1 s horizon: the front reaches 0.265 + 0.25 = 0.515 m.
  EXPECT_TRUE(IsCollisionImminent(params, Pose2{}, 0.25, 0.0, Obstacle(0.514, 0.6, -0.1, 0.1)));
  EXPECT_FALSE(IsCollisionImminent(params, Pose2{}, 0.25, 0.0, Obstacle(0.52, 0.6, -0.1, 0.1)));
  // The centre point: 0.25 m (5 steps of 0.2 s, the last at exactly 1 s).
  const CollisionCheckParams centre = WithModel(CollisionModel::kCentre);
  EXPECT_TRUE(IsCollisionImminent(centre, Pose2{}, 0.25, 0.0, Obstacle(0.249, 0.6, -0.1, 0.1)));
  EXPECT_FALSE(IsCollisionImminent(centre, Pose2{}, 0.25, 0.0, Obstacle(0.26, 0.6, -0.1, 0.1)));
  // Standing still: only the current footprint.
  EXPECT_FALSE(IsCollisionImminent(params, Pose2{}, 0.0, 0.5, Obstacle(0.3, 0.6, -0.1, 0.1)));
  // Reversing sweeps the rear.
  EXPECT_TRUE(IsCollisionImminent(params, Pose2{}, -0.25, 0.0, Obstacle(-0.5, -0.45, -0.1, 0.1)));
  EXPECT_TRUE(IsCollisionImminent(centre, Pose2{}, -0.25, 0.0, Obstacle(-0.3, -0.2, -0.1, 0.1)));
  // Turning left at ω = 1 rad/s (R = 0.25 m) sweeps to the left, not straight ahead.
  EXPECT_FALSE(IsCollisionImminent(params, Pose2{}, 0.25, 1.0, Obstacle(0.5, 0.6, -0.1, 0.1)));
  EXPECT_TRUE(IsCollisionImminent(params, Pose2{}, 0.25, 1.0, Obstacle(0.0, 0.6, 0.3, 0.4)));
  // The pose's frame: the same obstacle relative to a rotated, shifted car.
  const Pose2 X{1.0, 2.0, std::numbers::pi / 2.0};
  EXPECT_TRUE(IsCollisionImminent(params, X, 0.25, 0.0, Obstacle(0.9, 1.1, 2.45, 2.5)));
  EXPECT_FALSE(IsCollisionImminent(params, X, 0.25, 0.0, Obstacle(1.45, 1.5, 1.9, 2.1)));
  EXPECT_TRUE(IsCollisionImminent(centre, X, 0.25, 0.0, Obstacle(0.95, 1.05, 2.2, 2.3)));
}

TEST(PathFollowerTest, PruningNeverGoesBackOnTheSamePath) {
  const std::vector<Vec2> path = StraightPath(0.0, 3.0);
  PathFollowerState state;
  PathFollowerInput input;
  input.path = path;
  input.path_id = 7;
  input.X_F_base = Pose2{1.0, 0.0, 0.0};
  StepPathFollower(PathFollowerParams{}, input, &state);
  EXPECT_EQ(state.begin, 20u);
  // Estimated back at the start: the passed part stays pruned, the carrot is the closest
  // remaining point at range >= L.
  input.X_F_base = Pose2{0.0, 0.0, 0.0};
  PathFollowerOutput out = StepPathFollower(PathFollowerParams{}, input, &state);
  EXPECT_EQ(state.begin, 20u);
  ASSERT_TRUE(out.carrot.has_value());
  EXPECT_NEAR(out.carrot->x(), 1.0, 1e-12);
  // A new path starts over.
  input.path_id = 8;
  out = StepPathFollower(PathFollowerParams{}, input, &state);
  EXPECT_EQ(state.begin, 0u);
  EXPECT_NEAR(out.carrot->x(), 0.6, 0.05 + 1e-9);
}

// The pruning compares squared distances where they decide and hypots only where they are close
// (path_follower.cc kSquaresApart): the same closest point (the first of equals) and the same
// last point within max_costmap_extent_m as hypot over every point, here on jittered paths with
// ties and points at exactly the extent. A look-ahead beyond every point makes the carrot that
// last point.
TEST(PathFollowerTest, PruningAgreesWithTheHypotOfEveryPoint) {
  PathFollowerParams params;
  params.pursuit.lookahead_dist_m = 100.0;
  params.max_costmap_extent_m = 5.0;
  const auto reference = [&](const std::vector<Vec2>& path, const Pose2& X) {
    const auto distance = [&](const Vec2& p) { return std::hypot(p.x() - X.x_m, p.y() - X.y_m); };
    std::size_t closest = 0;
    for (std::size_t i = 1; i < path.size(); ++i) {
      if (distance(path[i]) < distance(path[closest])) closest = i;
    }
    std::size_t end = closest;
    while (end < path.size() && distance(path[end]) <= params.max_costmap_extent_m) ++end;
    return std::pair{closest, end};
  };
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> jitter(-1e-15, 1e-15);
  for (int trial = 0; trial < 200; ++trial) {
    const Pose2 X{0.0, 0.0, 0.0};
    std::vector<Vec2> path;
    // towards X and away, with mirrored (equal-distance) pairs, then out past the extent through
    // (3, 4) and (-3, -4) at exactly 5 m, each point perhaps nudged by up to 1e-15 m
    // (the nearest two, at ±0.01 m, tie exactly in every other trial)
    for (int i = -20; i <= 20; ++i) {
      if (i != 0) path.emplace_back(0.01 * std::abs(i) + (trial % 4 < 2 ? jitter(rng) : 0.0), 0.3);
    }
    for (int i = 0; i <= 10; ++i) {
      const double k = 0.9 + 0.02 * i;
      const Vec2 p = (trial % 2 == 0 ? Vec2(3.0, 4.0) : Vec2(-3.0, -4.0)) * k;
      path.push_back(i == 5 ? p : p + Vec2(jitter(rng), jitter(rng)));
    }
    PathFollowerState state;
    PathFollowerInput input;
    input.path = path;
    input.X_F_base = X;
    const PathFollowerOutput out = StepPathFollower(params, input, &state);
    const auto [closest, end] = reference(path, X);
    ASSERT_EQ(state.begin, closest) << trial;
    ASSERT_TRUE(out.carrot.has_value());
    ASSERT_EQ(*out.carrot, path[end - 1]) << trial;
  }
  // Squares that underflow (coordinates near 1e-162 m) do not decide: there the hypots do.
  // Nearest by hypot is the second point, though its square rounds above the first's. (A goal
  // tolerance below these distances, so that the goal is not reached at once.)
  params.goal_tolerance_m = 1e-200;
  {
    const std::vector<Vec2> tiny{{2.7132228295948296e-162, 0.0},
                                 {1.5873672523365087e-162, 1.5873672523365087e-162}};
    PathFollowerState state;
    PathFollowerInput input;
    input.path = tiny;
    input.X_F_base = Pose2{0.0, 0.0, 0.0};
    StepPathFollower(params, input, &state);
    EXPECT_EQ(state.begin, reference(tiny, input.X_F_base).first);
    EXPECT_EQ(state.begin, 1u);
  }
  {  // an extent so small that the point's square underflows to 0, though its hypot is beyond
    PathFollowerParams tiny_extent = params;
    tiny_extent.max_costmap_extent_m = 1.7217e-162;
    const std::vector<Vec2> tiny{{1.5559e-162, 1.5559e-162}};
    PathFollowerState state;
    PathFollowerInput input;
    input.path = tiny;
    input.X_F_base = Pose2{0.0, 0.0, 0.0};
    EXPECT_TRUE(StepPathFollower(tiny_extent, input, &state).no_path);
  }
}

TEST(PathFollowerTest, NoPathStopsAndBadInputThrows) {
  const std::vector<Vec2> empty;
  PathFollowerOutput out = Follow(empty, Pose2{});
  EXPECT_TRUE(out.no_path);
  EXPECT_EQ(out.speed_mps, 0.0);
  // The whole path beyond the local costmap (2.5 m): no path either.
  out = Follow(StraightPath(4.0, 6.0), Pose2{});
  EXPECT_TRUE(out.no_path);

  std::vector<Vec2> path = StraightPath(0.0, 1.0);
  path[3].x() = std::numeric_limits<double>::quiet_NaN();
  try {
    Follow(path, Pose2{});
    FAIL() << "accepted a NaN path point";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("path point 3"));
  }
  EXPECT_THROW(Follow(StraightPath(0.0, 1.0), Pose2{0.0, std::nan(""), 0.0}),
               std::invalid_argument);
}

// stack.*.collision.horizon_s: the lab's 1.0 s (lane_controller.cpp:85-86; Galactic
// regulated_pure_pursuit_controller.cpp:81-82) checks 0.25 m of arc at 0.25 m/s, safe's 2.0 s
// 0.5 m: an INSCRIBED band 0.40-0.45 m ahead of the centre stops only the latter.
TEST(CollisionCheckTest, TheHorizonSetsHowFarAheadTheArcIsChecked) {
  const CostQuery band = Obstacle(0.40, 0.45, -1.0, 1.0, kInscribedInflatedObstacle);
  CollisionCheckParams lab = WithModel(CollisionModel::kCentre);
  CollisionCheckParams safe = lab;
  safe.horizon_s = 2.0;
  EXPECT_FALSE(IsCollisionImminent(lab, Pose2{0.0, 0.0, 0.0}, 0.25, 0.0, band));
  EXPECT_TRUE(IsCollisionImminent(safe, Pose2{0.0, 0.0, 0.0}, 0.25, 0.0, band));
}

// The lab's lookahead 0.6 m (nav2_car_params.yaml:103) against safe's 0.4 m on the intersection
// turn (a 0.9 m arc between straights): driven kinematically at the follower's command, the car
// cuts the corner towards the arc's centre by more with the longer lookahead.
TEST(PathFollowerTest, TheLabsLookaheadCutsTheIntersectionTurnMore) {
  std::vector<Vec2> path = StraightPath(-1.0, 0.0);
  for (const Vec2& p : ArcPath(0.9, 0.9 * 1.5707963267948966)) path.push_back(p);
  for (int i = 1; i <= 20; ++i) path.emplace_back(0.9, 0.9 + 0.05 * i);
  auto cut = [&](double lookahead_m) {
    PathFollowerParams params;
    params.pursuit.lookahead_dist_m = lookahead_m;
    PathFollowerState state;
    Pose2 pose{-0.8, 0.0, 0.0};
    double worst = 0.0;  // how far inside the arc (towards its centre (0, 0.9)) the car gets
    for (int step = 0; step < 400 && pose.y_m < 1.5; ++step) {
      const PathFollowerOutput out =
          StepPathFollower(params, {.path = path, .path_id = 1, .X_F_base = pose}, &state);
      pose.x_m += 0.05 * out.speed_mps * std::cos(pose.yaw_rad);
      pose.y_m += 0.05 * out.speed_mps * std::sin(pose.yaw_rad);
      pose.yaw_rad += 0.05 * out.yaw_rate_rad_per_s;
      if (pose.x_m > 0.0 && pose.y_m < 0.9) {
        worst = std::max(worst, 0.9 - std::hypot(pose.x_m, pose.y_m - 0.9));
      }
    }
    return worst;
  };
  const double lab = cut(0.6);
  const double safe = cut(0.4);
  // kinematically 0.041 m against 0.017 m; in the closed loop, with the car's steering, up to
  // 0.27 m (docs/lab-stack.md)
  EXPECT_GT(lab, 0.03);
  EXPECT_GT(lab, 1.5 * safe) << "lab " << lab << " m, safe " << safe << " m";
}

}  // namespace
}  // namespace autonomsim::stack
