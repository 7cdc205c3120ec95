// The car's IMU (BNO055, reference §2) as the localization reads it (reference §6: the EKF takes
// the IMU's yaw, yaw rate and planar accelerations): a pure step from the car's true motion to one
// reading, with a per-run bias and white noise. The noise enters as standard normal draws, so the
// caller owns the random streams (sim/car/sensors.h draws them from seeded named streams).
#pragma once

#include <chrono>

#include "world/geometry.h"
#include "world/time.h"

namespace autonomsim::vehicle {

struct ImuParams {
  // reference §2: mounted at (-0.09, -0.01, 0.135) m in base_link (x forward, y left, z up).
  double mount_x_m{-0.09};
  double mount_y_m{-0.01};
  double mount_z_m{0.135};
  // assumed: the BNO055 datasheet's gyro noise density, 0.014 °/s/√Hz, over a 50 Hz bandwidth.
  double gyro_noise_stddev_rad_per_s{0.0017};
  // assumed: the residual zero-rate offset after the BNO055's own calibration, ~0.1 °/s.
  double gyro_bias_stddev_rad_per_s{0.0017};
  // assumed: the BNO055 datasheet's accelerometer noise density, 150 µg/√Hz, over 50 Hz.
  double accel_noise_stddev_mps2{0.01};
  // assumed: residual accelerometer offset after calibration, ~5 mg.
  double accel_bias_stddev_mps2{0.05};
  // assumed: jitter of the fused heading. The heading also drifts with the gyro bias (the sensor
  // integrates its gyro; a magnetometer is of no use next to a motor).
  double yaw_noise_stddev_rad{0.002};
  double gravity_mps2{9.80665};  // standard gravity: a resting IMU reads +g on z (sensor_msgs/Imu)

  template <class V>
  void Describe(V& v) {
    v("mount_x_m", mount_x_m);
    v("mount_y_m", mount_y_m);
    v("mount_z_m", mount_z_m);
    v("gyro_noise_stddev_rad_per_s", gyro_noise_stddev_rad_per_s);
    v("gyro_bias_stddev_rad_per_s", gyro_bias_stddev_rad_per_s);
    v("accel_noise_stddev_mps2", accel_noise_stddev_mps2);
    v("accel_bias_stddev_mps2", accel_bias_stddev_mps2);
    v("yaw_noise_stddev_rad", yaw_noise_stddev_rad);
    v("gravity_mps2", gravity_mps2);
  }
  void Validate() const;  // finite mount, standard deviations >= 0, gravity > 0
};

// The car's true motion at the sample time (vehicle::Car's accessors).
struct ImuTruth {
  Time t{};
  world::Pose2 X_map_car;
  double yaw_rate_rad_per_s{0.0};
  world::Vec2 accel_body_mps2{0.0, 0.0};  // of the chassis centre, body frame, without gravity
};

// One sensor_msgs/Imu, reduced to the fields the car's EKF uses (reference §6) plus a_z.
struct ImuReading {
  Time stamp{};
  double yaw_rad{0.0};             // orientation about z, map frame, wrapped to (-pi, pi]
  double yaw_rate_rad_per_s{0.0};  // angular_velocity.z
  double accel_x_mps2{0.0};        // linear_acceleration in the IMU (= body) frame, gravity in z
  double accel_y_mps2{0.0};
  double accel_z_mps2{0.0};
};

// Standard normal draws; the bias ones once per run, the sample ones per reading.
struct ImuBiasDraws {
  double gyro{0.0};
  double accel_x{0.0};
  double accel_y{0.0};
};
struct ImuNoiseDraws {
  double gyro{0.0};
  double accel_x{0.0};
  double accel_y{0.0};
  double accel_z{0.0};
  double yaw{0.0};
};

struct ImuState {
  double gyro_bias_rad_per_s{0.0};
  double accel_bias_x_mps2{0.0};
  double accel_bias_y_mps2{0.0};
  bool has_previous{false};
  Time previous_t{};
  double previous_yaw_rate_rad_per_s{0.0};
  // Bias steps (a fault: StepGyroBias): their sum, and Σ step · t_step, so that the heading drifts
  // by Σ step · (t − t_step) from each step on.
  double bias_step_rad_per_s{0.0};
  double bias_step_time_rad{0.0};
};

// From `t` on, the gyro's bias is `step_rad_per_s` more, and the heading drifts by it from then.
void StepGyroBias(Time t, double step_rad_per_s, ImuState* state);

ImuState InitialImuState(const ImuParams& params, const ImuBiasDraws& bias);

// The reading at truth.t. The accelerations are those of the mounting point: the chassis centre's
// plus the lever-arm terms α × r + ω × (ω × r), with the yaw acceleration α taken from the
// previous reading (zero for the first). The heading drifts by bias · t (t from the run's start).
ImuReading StepImu(const ImuParams& params, const ImuTruth& truth, const ImuNoiseDraws& noise,
                   ImuState* state);

}  // namespace autonomsim::vehicle
