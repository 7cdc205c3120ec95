#include "vehicle/imu.h"

#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

#include "world/validation.h"

namespace autonomsim::vehicle {
namespace {

void RequireStddev(double value, const char* key) {
  Require(std::isfinite(value) && value >= 0.0,
          [&] { return std::string(key) + " must be finite and >= 0, got " + Num(value); });
}

}  // namespace

void ImuParams::Validate() const {
  Require(std::isfinite(mount_x_m) && std::isfinite(mount_y_m) && std::isfinite(mount_z_m),
          "mount_x_m, mount_y_m and mount_z_m must be finite");
  RequireStddev(gyro_noise_stddev_rad_per_s, "gyro_noise_stddev_rad_per_s");
  RequireStddev(gyro_bias_stddev_rad_per_s, "gyro_bias_stddev_rad_per_s");
  RequireStddev(accel_noise_stddev_mps2, "accel_noise_stddev_mps2");
  RequireStddev(accel_bias_stddev_mps2, "accel_bias_stddev_mps2");
  RequireStddev(yaw_noise_stddev_rad, "yaw_noise_stddev_rad");
  RequireStddev(magnetic_distortion_rad, "magnetic_distortion_rad");
  Require(std::isfinite(magnetic_distortion_wavelength_m) && magnetic_distortion_wavelength_m > 0.0,
          [&] {
            return "magnetic_distortion_wavelength_m must be > 0, got " +
                   Num(magnetic_distortion_wavelength_m);
          });
  Require(std::isfinite(gravity_mps2) && gravity_mps2 > 0.0,
          [&] { return "gravity_mps2 must be > 0, got " + Num(gravity_mps2); });
}

ImuState InitialImuState(const ImuParams& params, const ImuBiasDraws& bias,
                         const MagneticFieldDraws& field) {
  ImuState state;
  state.field = field;
  state.gyro_bias_rad_per_s = params.gyro_bias_stddev_rad_per_s * bias.gyro;
  state.accel_bias_x_mps2 = params.accel_bias_stddev_mps2 * bias.accel_x;
  state.accel_bias_y_mps2 = params.accel_bias_stddev_mps2 * bias.accel_y;
  return state;
}

double MagneticHeadingError(const ImuParams& params, const MagneticFieldDraws& field,
                            const world::Vec2& p_map) {
  if (params.magnetic_distortion_rad == 0.0) return 0.0;
  const double k = 2.0 * std::numbers::pi / params.magnetic_distortion_wavelength_m;
  return params.magnetic_distortion_rad * std::sin(k * p_map.x() + field.phase_x_rad) *
         std::sin(k * p_map.y() + field.phase_y_rad);
}

namespace {

// The reported heading before its noise.
double HeadingWithoutNoise(const ImuParams& params, const ImuTruth& truth, const ImuState& state) {
  const double yaw = truth.X_map_car.yaw_rad;
  if (params.heading_source == ImuHeadingSource::kMagnetometer) {
    return yaw + MagneticHeadingError(params, state.field, truth.X_map_car.position());
  }
  const double t_s = ToSeconds(truth.t);
  return yaw + state.gyro_bias_rad_per_s * t_s + state.bias_step_rad_per_s * t_s -
         state.bias_step_time_rad;
}

}  // namespace

ImuReading StepImu(const ImuParams& params, const ImuTruth& truth, const ImuNoiseDraws& noise,
                   ImuState* state) {
  const double w = truth.yaw_rate_rad_per_s;
  double alpha = 0.0;  // yaw acceleration, rad/s²
  if (state->has_previous && truth.t > state->previous_t) {
    alpha = (w - state->previous_yaw_rate_rad_per_s) / ToSeconds(truth.t - state->previous_t);
  }
  state->has_previous = true;
  state->previous_t = truth.t;
  state->previous_yaw_rate_rad_per_s = w;

  // a_imu = a_c + α × r + ω × (ω × r), in the plane
  const double rx = params.mount_x_m;
  const double ry = params.mount_y_m;
  const double ax = truth.accel_body_mps2.x() - alpha * ry - w * w * rx;
  const double ay = truth.accel_body_mps2.y() + alpha * rx - w * w * ry;

  ImuReading reading;
  reading.stamp = truth.t;
  reading.yaw_rate_rad_per_s =
      w + state->gyro_bias_rad_per_s + params.gyro_noise_stddev_rad_per_s * noise.gyro;
  reading.accel_x_mps2 =
      ax + state->accel_bias_x_mps2 + params.accel_noise_stddev_mps2 * noise.accel_x;
  reading.accel_y_mps2 =
      ay + state->accel_bias_y_mps2 + params.accel_noise_stddev_mps2 * noise.accel_y;
  reading.accel_z_mps2 = params.gravity_mps2 + params.accel_noise_stddev_mps2 * noise.accel_z;
  reading.yaw_rate_rad_per_s += state->bias_step_rad_per_s;
  reading.yaw_rad = world::WrapAngle(HeadingWithoutNoise(params, truth, *state) +
                                     params.yaw_noise_stddev_rad * noise.yaw);
  return reading;
}

void StepGyroBias(Time t, double step_rad_per_s, ImuState* state) {
  state->bias_step_rad_per_s += step_rad_per_s;
  state->bias_step_time_rad += step_rad_per_s * ToSeconds(t);
}

}  // namespace autonomsim::vehicle
