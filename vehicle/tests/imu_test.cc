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
  ImuParams params;  // the defaults, with the gyro-integrated heading
  params.heading_source = ImuHeadingSource::kGyro;
  ImuState state = InitialImuState(params, ImuBiasDraws{.gyro = 1.0, .accel_x = -2.0});
  EXPECT_DOUBLE_EQ(state.gyro_bias_rad_per_s, params.gyro_bias_stddev_rad_per_s);
  EXPECT_DOUBLE_EQ(state.accel_bias_x_mps2, -2.0 * params.accel_bias_stddev_mps2);
  const ImuReading r = StepImu(params, ImuTruth{.t = std::chrono::seconds(100)},
                               ImuNoiseDraws{.gyro = 1.0, .accel_z = -1.0, .yaw = 0.5}, &state);
  EXPECT_DOUBLE_EQ(r.yaw_rate_rad_per_s,
                   params.gyro_bias_stddev_rad_per_s + params.gyro_noise_stddev_rad_per_s);
  EXPECT_DOUBLE_EQ(r.accel_x_mps2, -2.0 * params.accel_bias_stddev_mps2);
  EXPECT_DOUBLE_EQ(r.accel_z_mps2, params.gravity_mps2 - params.accel_noise_stddev_mps2);
  // the integrated heading drifts with the gyro bias over the run
  EXPECT_NEAR(r.yaw_rad,
              100.0 * params.gyro_bias_stddev_rad_per_s + 0.5 * params.yaw_noise_stddev_rad, 1e-12);
}

// The lab's BNO055 runs NDOF_FMC_OFF (code/ros_ws/src/nav2_local/params/nav2_car_params.yaml:376,
// operation_mode 0x0B = OPERATION_MODE_NDOF_FMC_OFF in flynneva/bno055 bno055/registers.py:229): a
// heading fused with the magnetometer, so the gyro's bias shows in the yaw rate and not in the
// heading, however long the run.
TEST(ImuTest, TheLabsMagnetometerHeadingDoesNotDriftWithTheGyroBias) {
  ImuParams params = Noiseless();
  params.magnetic_distortion_rad = 0.0;
  ASSERT_EQ(ImuParams{}.heading_source, ImuHeadingSource::kMagnetometer);  // the default
  ImuState state = InitialImuState(params, {});
  state.gyro_bias_rad_per_s = 0.002;
  StepGyroBias(std::chrono::seconds(10), 0.05, &state);  // and a fault's step on top
  const ImuReading r = StepImu(
      params, ImuTruth{.t = std::chrono::seconds(240), .X_map_car = {0.0, 0.0, 0.3}}, {}, &state);
  EXPECT_DOUBLE_EQ(r.yaw_rad, 0.3);
  EXPECT_DOUBLE_EQ(r.yaw_rate_rad_per_s, 0.052);
  // the same sensor integrating its gyro is 0.002 · 240 + 0.05 · 230 rad off
  params.heading_source = ImuHeadingSource::kGyro;
  const ImuReading g = StepImu(
      params, ImuTruth{.t = std::chrono::seconds(240), .X_map_car = {0.0, 0.0, 0.3}}, {}, &state);
  EXPECT_NEAR(g.yaw_rad, world::WrapAngle(0.3 + 0.48 + 11.5), 1e-9);
}

TEST(ImuTest, TheMagneticFieldBendsTheHeadingByWhereTheCarIs) {
  ImuParams params = Noiseless();  // A 0.035 rad, λ 2 m
  const MagneticFieldDraws field{.phase_x_rad = 0.0, .phase_y_rad = std::numbers::pi / 2.0};
  ImuState state = InitialImuState(params, {}, field);
  auto heading_at = [&](double x, double y) {
    return StepImu(params, ImuTruth{.t = Milliseconds(10), .X_map_car = {x, y, 1.0}}, {}, &state)
        .yaw_rad;
  };
  // sin(πx) · cos(πy): the full error a quarter wavelength along x, none on x = 0 or 1 m
  EXPECT_NEAR(heading_at(0.5, 0.0), 1.0 + 0.035, 1e-12);
  EXPECT_NEAR(heading_at(0.5, 1.0), 1.0 - 0.035, 1e-12);
  EXPECT_NEAR(heading_at(0.0, 0.0), 1.0, 1e-12);
  EXPECT_NEAR(heading_at(1.0, 0.3), 1.0, 1e-12);
  // the same place reads the same error at any time, and it never exceeds A
  for (double x = -2.5; x <= 2.5; x += 0.1) {
    for (double y = -2.5; y <= 2.5; y += 0.1) {
      EXPECT_LE(std::abs(MagneticHeadingError(params, field, {x, y})), 0.035 + 1e-15);
    }
  }
  params.magnetic_distortion_wavelength_m = 0.0;
  EXPECT_THROW(params.Validate(), std::invalid_argument);
}

}  // namespace
}  // namespace autonomsim::vehicle
