#include "stack/lane_controller.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "stack/costmap.h"

namespace autonomsim::stack {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;
using world::Vec2;

// 30 points like LanePoints (reference §5): far to near, 0.89 m → 0.28 m ahead, on a left-hand
// circle of radius r_m tangent to the car's heading (r_m = 0: straight ahead).
std::vector<Vec2> LanePoints(double r_m) {
  std::vector<Vec2> points;
  for (int i = 0; i < 30; ++i) {
    const double s_m = 0.89 - (0.89 - 0.28) * i / 29.0;  // arc length
    if (r_m == 0.0) {
      points.emplace_back(s_m, 0.0);
    } else {
      const double a = s_m / r_m;
      points.emplace_back(r_m * std::sin(a), r_m * (1.0 - std::cos(a)));
    }
  }
  return points;
}

LaneControllerOutput Control(const std::vector<Vec2>& points, bool valid = true,
                             LaneControllerParams params = {}, CostQuery cost = {}) {
  LaneControllerInput input;
  input.lane_points_base = points;
  input.lanes_valid = valid;
  input.speed_mps = 0.25;
  input.cell_cost = std::move(cost);
  return StepLaneController(params, input);
}

TEST(LaneControllerParamsTest, DefaultsKeysAndValidation) {
  LaneControllerParams params;
  EXPECT_EQ(params.pursuit.desired_speed_mps, 0.25);
  EXPECT_EQ(params.pursuit.lookahead_dist_m, 0.6);
  EXPECT_EQ(params.pursuit.regulated_min_radius_m, 0.9);
  EXPECT_NO_THROW(params.Validate());
  std::vector<std::string> keys;
  auto visit = [&](const std::string& key, auto&, auto&&...) { keys.push_back(key); };
  params.Describe(visit);
  EXPECT_THAT(keys, ElementsAre("pursuit", "collision"));
  params.pursuit.desired_speed_mps = 0.0;
  try {
    params.Validate();
    FAIL() << "accepted desired_speed_mps = 0";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("desired_speed_mps"));
  }
}

TEST(LaneControllerTest, StraightLaneDrivesStraightAtTheDesiredSpeed) {
  const LaneControllerOutput out = Control(LanePoints(0.0));
  ASSERT_TRUE(out.carrot_base.has_value());
  EXPECT_GE(out.carrot_base->norm(), 0.6);
  EXPECT_LT(out.carrot_base->norm(), 0.6 + 0.61 / 29.0);  // the nearest such point
  EXPECT_EQ(out.curvature_per_m, 0.0);
  EXPECT_EQ(out.speed_mps, 0.25);
  EXPECT_EQ(out.yaw_rate_rad_per_s, 0.0);
}

TEST(LaneControllerTest, CarrotCurvatureAndSpeedByHand) {
  // Ranges 0.51, 0.628, 0.728 m: the carrot is (0.62, 0.1), κ = 2 · 0.1 / 0.3944.
  std::vector<Vec2> points = {{0.7, 0.2}, {0.62, 0.1}, {0.5, 0.1}};
  LaneControllerOutput out = Control(points);
  ASSERT_TRUE(out.carrot_base.has_value());
  EXPECT_EQ(*out.carrot_base, Vec2(0.62, 0.1));
  const double kappa = 0.2 / (0.62 * 0.62 + 0.1 * 0.1);
  EXPECT_NEAR(out.curvature_per_m, kappa, 1e-12);
  EXPECT_EQ(out.speed_mps, 0.25);  // r = 1.97 m > 0.9 m, carrot 0.028 m beyond L
  EXPECT_NEAR(out.yaw_rate_rad_per_s, 0.25 * kappa, 1e-12);
  // The order of the points does not matter.
  std::reverse(points.begin(), points.end());
  EXPECT_EQ(*Control(points).carrot_base, Vec2(0.62, 0.1));
  // To the right: negative curvature and yaw rate.
  out = Control({{0.62, -0.1}});
  EXPECT_NEAR(out.curvature_per_m, -kappa, 1e-12);
  EXPECT_LT(out.yaw_rate_rad_per_s, 0.0);
}

TEST(LaneControllerTest, CurvedLaneGivesOneOverR) {
  for (const double r_m : {1.0, 2.0, 5.0}) {
    const LaneControllerOutput out = Control(LanePoints(r_m));
    EXPECT_NEAR(out.curvature_per_m, 1.0 / r_m, 1e-9) << "R = " << r_m;
    EXPECT_EQ(out.speed_mps, 0.25);
  }
}

TEST(LaneControllerTest, CurvatureSlowDownBelowPointNineMetres) {
  // Carrot (0.64, 0.48): range 0.8, κ = 2 · 0.48 / 0.64 = 1.5, r = 2/3 m.
  const std::vector<Vec2> points = {{0.64, 0.48}};
  LaneControllerParams params;
  params.pursuit.use_approach_speed_scaling = false;
  // The car's floor (regulated_min_speed 0.25) keeps 0.25 m/s.
  EXPECT_EQ(Control(points, true, params).speed_mps, 0.25);
  // With a lower floor, Nav2's rule: v · r / r_min = 0.25 · (2/3) / 0.9.
  params.pursuit.regulated_min_speed_mps = 0.05;
  LaneControllerOutput out = Control(points, true, params);
  EXPECT_NEAR(out.curvature_per_m, 1.5, 1e-12);
  EXPECT_NEAR(out.speed_mps, 0.25 * (2.0 / 3.0) / 0.9, 1e-12);
  EXPECT_NEAR(out.yaw_rate_rad_per_s, out.speed_mps * 1.5, 1e-15);
  // With approach scaling too (the carrot is 0.2 m beyond L): min(0.185, 0.25 · 2/3).
  params.pursuit.use_approach_speed_scaling = true;
  out = Control(points, true, params);
  EXPECT_NEAR(out.speed_mps, 0.25 * (1.0 - 0.2 / 0.6), 1e-12);
}

TEST(LaneControllerTest, NoCarrotOrInvalidLanesStop) {
  // All points nearer than 0.6 m.
  LaneControllerOutput out = Control({{0.3, 0.0}, {0.5, 0.1}, {0.59, 0.0}});
  EXPECT_FALSE(out.carrot_base.has_value());
  EXPECT_EQ(out.speed_mps, 0.0);
  EXPECT_EQ(out.yaw_rate_rad_per_s, 0.0);
  // Good points, but the message says invalid.
  out = Control(LanePoints(0.0), false);
  EXPECT_FALSE(out.carrot_base.has_value());
  EXPECT_EQ(out.speed_mps, 0.0);
  // No points at all.
  EXPECT_EQ(Control({}).speed_mps, 0.0);
}

// LETHAL where x_min_m <= x <= x_max_m, FREE elsewhere.
CostQuery Wall(double x_min_m, double x_max_m) {
  return [=](const Vec2& p) {
    return p.x() >= x_min_m && p.x() <= x_max_m ? kLethalObstacle : kFreeSpace;
  };
}

TEST(LaneControllerTest, CollisionAheadStops) {
  // lane_controller.cpp:364-443: the centre point along the 1 s arc, 0.25 m at 0.25 m/s.
  LaneControllerOutput out = Control(LanePoints(0.0), true, {}, Wall(0.18, 0.3));
  EXPECT_TRUE(out.collision_ahead);
  EXPECT_EQ(out.speed_mps, 0.0);
  EXPECT_EQ(out.yaw_rate_rad_per_s, 0.0);
  out = Control(LanePoints(0.0), true, {}, Wall(0.45, 0.5));  // beyond the centre's arc
  EXPECT_FALSE(out.collision_ahead);
  EXPECT_EQ(out.speed_mps, 0.25);
  // The footprint model: the front (0.265 m) sweeps to 0.515 m.
  LaneControllerParams footprint;
  footprint.collision.model = CollisionModel::kFootprint;
  EXPECT_TRUE(Control(LanePoints(0.0), true, footprint, Wall(0.45, 0.5)).collision_ahead);
  out = Control(LanePoints(0.0), true, footprint, Wall(0.6, 1.0));
  EXPECT_FALSE(out.collision_ahead);
  EXPECT_EQ(out.speed_mps, 0.25);
}

// A point that is not a number is never the carrot, as in the lab's scan: `hypot(x, y) >=
// lookahead` is false for it (lane_controller.cpp:349-351). The hardware fit's overwritten message
// carries such points when its fit had no pixels (rt_polyfit.cpp:101, 249, 258).
TEST(LaneControllerTest, APointThatIsNotANumberIsNeverTheCarrot) {
  constexpr double kNan = std::numeric_limits<double>::quiet_NaN();
  std::vector<Vec2> points = LanePoints(0.0);
  const LaneControllerOutput clean = Control(points);
  ASSERT_TRUE(clean.carrot_base);
  const Vec2 carrot = *clean.carrot_base;
  for (Vec2& p : points) {
    if (p == carrot) p.y() = kNan;
  }
  const LaneControllerOutput skipped = Control(points);
  ASSERT_TRUE(skipped.carrot_base);
  EXPECT_GT(skipped.carrot_base->norm(), carrot.norm());  // the next one out
  // all of them: no carrot, the car stops
  std::vector<Vec2> all(30, Vec2(kNan, kNan));
  EXPECT_FALSE(Control(all).carrot_base);
  EXPECT_EQ(Control(all).speed_mps, 0.0);
  EXPECT_EQ(Control(points, false).speed_mps, 0.0);
}

}  // namespace
}  // namespace autonomsim::stack
