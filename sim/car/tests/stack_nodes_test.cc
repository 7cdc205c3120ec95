// The stack nodes' own pieces that are not wiring: the pose fix's noise draw.
#include "sim/car/stack_nodes.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace autonomsim::sim {
namespace {

TEST(PoseFixTest, WithoutNoiseTheFixIsTheTruthWithTheVarianceFloor) {
  const PoseFixConfig config{.position_stddev_m = 0.0, .yaw_stddev_rad = 0.0};
  Rng noise(7);
  const stack::PoseFix fix =
      DrawPoseFix(config, world::Pose2{1.0, -2.0, 0.5}, FromSeconds(3.0), &noise);
  EXPECT_EQ(fix.stamp, FromSeconds(3.0));
  EXPECT_EQ(fix.X_map_base.x_m, 1.0);
  EXPECT_EQ(fix.X_map_base.y_m, -2.0);
  EXPECT_EQ(fix.X_map_base.yaw_rad, 0.5);
  // (1 mm)² and (1 mrad)² at least: the EKF inverts the covariance.
  EXPECT_EQ(fix.covariance(0, 0), 1e-6);
  EXPECT_EQ(fix.covariance(1, 1), 1e-6);
  EXPECT_EQ(fix.covariance(2, 2), 1e-6);
  EXPECT_EQ(fix.covariance(0, 1), 0.0);
}

TEST(PoseFixTest, DrawsXThenYThenYawAndWrapsTheYaw) {
  const PoseFixConfig config{.position_stddev_m = 0.02, .yaw_stddev_rad = 0.5};
  Rng noise(11);
  Rng same(11);
  const double yaw_true = std::numbers::pi - 0.01;
  const stack::PoseFix fix = DrawPoseFix(config, world::Pose2{1.0, 2.0, yaw_true}, {}, &noise);
  EXPECT_EQ(fix.X_map_base.x_m, 1.0 + same.Normal(0.0, 0.02));
  EXPECT_EQ(fix.X_map_base.y_m, 2.0 + same.Normal(0.0, 0.02));
  EXPECT_EQ(fix.X_map_base.yaw_rad, world::WrapAngle(yaw_true + same.Normal(0.0, 0.5)));
  EXPECT_LE(std::abs(fix.X_map_base.yaw_rad), std::numbers::pi);
  EXPECT_NEAR(fix.covariance(0, 0), 4e-4, 1e-18);
  EXPECT_NEAR(fix.covariance(2, 2), 0.25, 1e-18);
  // The stream moved on by exactly those three draws.
  EXPECT_EQ(noise.NextU64(), same.NextU64());
}

}  // namespace
}  // namespace autonomsim::sim
