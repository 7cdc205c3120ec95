// The IMU model: what it reads at rest, in a turn (lever arm), its bias and noise scaling.
#include "vehicle/imu.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace autonomsim::vehicle {
namespace {

ImuParams Noiseless() {
  ImuParams p;
  p.gyro_noise_stddev_rad_per_s = 0.0;
  p.gyro_bias_stddev_rad_per_s = 0.0;
  p.accel_noise_stddev_mps2 = 0.0;
  p.accel_bias_stddev_mps2 = 0.0;
  p.yaw_noise_stddev_rad = 0.0;
  return p;
}

TEST(ImuTest, DefaultsValidateAndBadValuesThrow) {
  EXPECT_NO_THROW(ImuParams{}.Validate());
  ImuParams p;
  p.gyro_noise_stddev_rad_per_s = -1.0;
  EXPECT_THROW(p.Validate(), std::invalid_argument);
  p = ImuParams{};
  p.gravity_mps2 = 0.0;
  EXPECT_THROW(p.Validate(), std::invalid_argument);
}

TEST(ImuTest, AtRestItReadsGravityAndTheHeading) {
  const ImuParams params = Noiseless();
  ImuState state = InitialImuState(params, {});
  const ImuReading r =
      StepImu(params, ImuTruth{.t = Milliseconds(10), .X_map_car = {1.0, 2.0, 0.5}}, {}, &state);
  EXPECT_EQ(r.stamp, Milliseconds(10));
  EXPECT_DOUBLE_EQ(r.yaw_rad, 0.5);
  EXPECT_DOUBLE_EQ(r.yaw_rate_rad_per_s, 0.0);
  EXPECT_DOUBLE_EQ(r.accel_x_mps2, 0.0);
  EXPECT_DOUBLE_EQ(r.accel_y_mps2, 0.0);
  EXPECT_DOUBLE_EQ(r.accel_z_mps2, 9.80665);
}

TEST(ImuTest, InASteadyTurnTheMountFeelsTheCentripetalAcceleration) {
  // the chassis centre circles at v = 0.4 m/s, ω = 0.5 rad/s: a_c = (0, v ω) in the body frame;
  // the IMU 9 cm behind and 1 cm right of it adds -ω² r
  const ImuParams params = Noiseless();
  ImuState state = InitialImuState(params, {});
  const double w = 0.5;
  ImuTruth truth{.t = Milliseconds(0), .yaw_rate_rad_per_s = w, .accel_body_mps2 = {0.0, 0.2}};
  StepImu(params, truth, {}, &state);
  truth.t = Milliseconds(10);
  const ImuReading r = StepImu(params, truth, {}, &state);
  EXPECT_NEAR(r.accel_x_mps2, -w * w * -0.09, 1e-12);
  EXPECT_NEAR(r.accel_y_mps2, 0.2 - w * w * -0.01, 1e-12);
  EXPECT_DOUBLE_EQ(r.yaw_rate_rad_per_s, w);
}

TEST(ImuTest, AYawAccelerationAddsTheTangentialTerm) {
  const ImuParams params = Noiseless();
  ImuState state = InitialImuState(params, {});
  StepImu(params, ImuTruth{.t = Milliseconds(0)}, {}, &state);
  // α = 0.1 rad/s / 10 ms = 10 rad/s²; ω² r is 1e-4 of that
  const ImuReading r =
      StepImu(params, ImuTruth{.t = Milliseconds(10), .yaw_rate_rad_per_s = 0.1}, {}, &state);
  EXPECT_NEAR(r.accel_x_mps2, -10.0 * -0.01 - 0.01 * -0.09, 1e-12);
  EXPECT_NEAR(r.accel_y_mps2, 10.0 * -0.09 - 0.01 * -0.01, 1e-12);
}

TEST(ImuTest, BiasAndNoiseScaleTheDraws) {
  const ImuParams params;  // the defaults
  ImuState state = InitialImuState(params, ImuBiasDraws{.gyro = 1.0, .accel_x = -2.0});
  EXPECT_DOUBLE_EQ(state.gyro_bias_rad_per_s, params.gyro_bias_stddev_rad_per_s);
  EXPECT_DOUBLE_EQ(state.accel_bias_x_mps2, -2.0 * params.accel_bias_stddev_mps2);
  const ImuReading r = StepImu(params, ImuTruth{.t = std::chrono::seconds(100)},
                               ImuNoiseDraws{.gyro = 1.0, .accel_z = -1.0, .yaw = 0.5}, &state);
  EXPECT_DOUBLE_EQ(r.yaw_rate_rad_per_s,
                   params.gyro_bias_stddev_rad_per_s + params.gyro_noise_stddev_rad_per_s);
  EXPECT_DOUBLE_EQ(r.accel_x_mps2, -2.0 * params.accel_bias_stddev_mps2);
  EXPECT_DOUBLE_EQ(r.accel_z_mps2, params.gravity_mps2 - params.accel_noise_stddev_mps2);
  // the heading drifts with the gyro bias over the run
  EXPECT_NEAR(r.yaw_rad,
              100.0 * params.gyro_bias_stddev_rad_per_s + 0.5 * params.yaw_noise_stddev_rad, 1e-12);
}

}  // namespace
}  // namespace autonomsim::vehicle
