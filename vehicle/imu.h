// The car's IMU (BNO055, reference §2) as the localization reads it (reference §6: the EKF takes
// the IMU's yaw, yaw rate and planar accelerations): a pure step from the car's true motion to one
// reading, with a per-run bias and white noise. The noise enters as standard normal draws, so the
// caller owns the random streams (sim/car/sensors.h draws them from seeded named streams).
//
// The heading. The lab runs the BNO055 in operation mode 0x0B, NDOF_FMC_OFF
// (code/ros_ws/src/nav2_local/params/nav2_car_params.yaml:376; flynneva/bno055
// bno055/registers.py:229): the sensor fuses accelerometer, gyroscope and magnetometer, so its
// heading is referenced to the magnetic field and does not accumulate the gyro's bias. What it
// has instead is the local field's distortion (steel in the floor and furniture, the car's own
// motor and wiring): a heading error that depends on where the car is. Nothing records its size in
// the lab, so it is modelled (assumed) as a smooth field over the floor,
//   e(x, y) = A · sin(2π x / λ + φx) · sin(2π y / λ + φy),
// one field per run shared by every car (the phases come from the scenario's seed), with A 2°
// and λ 2 m (below). `heading_source: gyro` is the other choice: a heading integrated from the
// gyro (the BNO055's IMU mode, or any sensor without a magnetometer), which drifts by bias · t.
#pragma once

#include <array>
#include <chrono>
#include <string_view>
#include <utility>

#include "world/enum_names.h"
#include "world/geometry.h"
#include "world/time.h"

namespace autonomsim::vehicle {

// Where the reported heading comes from (see above).
enum class ImuHeadingSource {
  kMagnetometer,  // NDOF / NDOF_FMC_OFF: fused with the magnetometer, distorted by local fields
  kGyro,          // integrated gyro (IMU mode): drifts with the gyro's bias
};

}  // namespace autonomsim::vehicle

namespace autonomsim {
template <>
struct NameTable<vehicle::ImuHeadingSource> {
  static constexpr std::array<std::pair<vehicle::ImuHeadingSource, std::string_view>, 2> kEntries{
      {{vehicle::ImuHeadingSource::kMagnetometer, "magnetometer"},
       {vehicle::ImuHeadingSource::kGyro, "gyro"}}};
};
}  // namespace autonomsim

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
  // assumed: jitter of the fused heading (the BNO055's Euler output has 1/16° resolution).
  double yaw_noise_stddev_rad{0.002};
  // The lab's mode is NDOF_FMC_OFF (see the top of this file): magnetometer.
  ImuHeadingSource heading_source{ImuHeadingSource::kMagnetometer};
  // assumed: the local field's heading error, A and λ of e(x, y) (top of this file). The lab's
  // field was never measured; 2° is the order of heading error indoor magnetometer fusion shows
  // away from large steel (more near it), and λ 2 m puts one or two swings along each side of
  // the 5 m track. Only with heading_source magnetometer; 0 turns the distortion off.
  double magnetic_distortion_rad{0.035};
  double magnetic_distortion_wavelength_m{2.0};
  double gravity_mps2{9.80665};  // standard gravity: a resting IMU reads +g on z (sensor_msgs/Imu)

  template <class V>
  void Describe(V& v) {
    v("mount_x_m", mount_x_m, "forward of base_link");
    v("mount_y_m", mount_y_m, "left of base_link");
    v("mount_z_m", mount_z_m, "above the floor");
    v("gyro_noise_stddev_rad_per_s", gyro_noise_stddev_rad_per_s, "the gyro's white noise");
    v("gyro_bias_stddev_rad_per_s", gyro_bias_stddev_rad_per_s,
      "the spread of the gyro's constant bias, drawn per car");
    v("accel_noise_stddev_mps2", accel_noise_stddev_mps2, "the accelerometer's white noise");
    v("accel_bias_stddev_mps2", accel_bias_stddev_mps2, "the spread of the accelerometer's bias");
    v("yaw_noise_stddev_rad", yaw_noise_stddev_rad, "the reported heading's jitter");
    v("heading_source", heading_source,
      "`magnetometer` (the lab's BNO055 mode: no drift, local distortion) or `gyro` (integrated: "
      "drifts with the bias)");
    v("magnetic_distortion_rad", magnetic_distortion_rad,
      "`magnetometer`: the heading error's amplitude from the local field");
    v("magnetic_distortion_wavelength_m", magnetic_distortion_wavelength_m,
      "`magnetometer`: its wavelength over the floor");
    v("gravity_mps2", gravity_mps2, "what a resting IMU reads on z");
  }
  // finite mount, standard deviations and distortion >= 0, wavelength > 0, gravity > 0
  void Validate() const;
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
// The magnetic field's phases φx, φy (rad), once per run and shared by every car.
struct MagneticFieldDraws {
  double phase_x_rad{0.0};
  double phase_y_rad{0.0};
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
  MagneticFieldDraws field;
};

// From `t` on, the gyro's bias is `step_rad_per_s` more (its yaw rate reads that much more). With
// heading_source gyro the heading drifts by it from then; the magnetometer's heading does not.
void StepGyroBias(Time t, double step_rad_per_s, ImuState* state);

ImuState InitialImuState(const ImuParams& params, const ImuBiasDraws& bias,
                         const MagneticFieldDraws& field = {});

// The magnetometer heading's error at p_map (rad): e(x, y) at the top of this file.
double MagneticHeadingError(const ImuParams& params, const MagneticFieldDraws& field,
                            const world::Vec2& p_map);

// The reading at truth.t. The accelerations are those of the mounting point: the chassis centre's
// plus the lever-arm terms α × r + ω × (ω × r), with the yaw acceleration α taken from the
// previous reading (zero for the first). The heading: the true heading plus the field's error at
// the car (magnetometer), or plus bias · t (gyro; t from the run's start); and its noise.
ImuReading StepImu(const ImuParams& params, const ImuTruth& truth, const ImuNoiseDraws& noise,
                   ImuState* state);

}  // namespace autonomsim::vehicle
