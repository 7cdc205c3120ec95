#include "stack/localization_ekf.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <string>

#include "world/validation.h"

namespace autonomsim::stack {
namespace {

// Below this |h| the series of sin(h)/h is used (its error there is < 1e-17).
constexpr double kSmallHalfAngle_rad = 1e-4;

std::string Seconds(Time t) { return Num(ToSeconds(t)) + " s"; }

void RequireFinite(double x, const std::string& what) {
  Require(std::isfinite(x),
          [&] { return "localization: " + what + " must be finite, got " + Num(x); });
}

// sin(h)/h and its derivative.
double Sinc(double h) {
  return std::abs(h) < kSmallHalfAngle_rad ? 1.0 - h * h / 6.0 : std::sin(h) / h;
}
double SincDerivative(double h) {
  return std::abs(h) < kSmallHalfAngle_rad ? -h / 3.0 : (h * std::cos(h) - std::sin(h)) / (h * h);
}

void Symmetrize(EkfMatrix* P) { *P = 0.5 * (*P + P->transpose()).eval(); }

// Moves the state along the constant-(v, ω) arc for dt_s and propagates the covariance.
void Predict(const LocalizationEkfParams& params, double dt_s, LocalizationEkfState* s) {
  EkfVector& m = s->mean;
  const double v = m(kEkfSpeed);
  const double w = m(kEkfYawRate);
  const double h = 0.5 * w * dt_s;
  const double sinc = Sinc(h);
  const double chord = v * dt_s * sinc;  // the straight distance along the arc
  const double phi = m(kEkfYaw) + h;     // the chord's direction
  const double c = std::cos(phi);
  const double sn = std::sin(phi);

  EkfMatrix F = EkfMatrix::Identity();
  F(kEkfX, kEkfYaw) = -chord * sn;
  F(kEkfY, kEkfYaw) = chord * c;
  F(kEkfX, kEkfSpeed) = dt_s * sinc * c;
  F(kEkfY, kEkfSpeed) = dt_s * sinc * sn;
  const double dchord_dw = v * dt_s * SincDerivative(h) * 0.5 * dt_s;
  F(kEkfX, kEkfYawRate) = dchord_dw * c - chord * sn * 0.5 * dt_s;
  F(kEkfY, kEkfYawRate) = dchord_dw * sn + chord * c * 0.5 * dt_s;
  F(kEkfYaw, kEkfYawRate) = dt_s;

  m(kEkfX) += chord * c;
  m(kEkfY) += chord * sn;
  m(kEkfYaw) = world::WrapAngle(m(kEkfYaw) + w * dt_s);

  EkfVector q;
  q << params.q_position_m2_per_s, params.q_position_m2_per_s, params.q_yaw_rad2_per_s,
      params.q_speed_m2_per_s3, params.q_yaw_rate_rad2_per_s3;
  s->covariance = (F * s->covariance * F.transpose()).eval();
  s->covariance.diagonal() += q * dt_s;
  Symmetrize(&s->covariance);
}

// Kalman correction with residual r = z − H·x (angles already wrapped) and noise R, in Joseph
// form so that the covariance stays symmetric positive definite.
template <int M>
void Correct(const Eigen::Matrix<double, M, kEkfSize>& H, const Eigen::Matrix<double, M, 1>& r,
             const Eigen::Matrix<double, M, M>& R, LocalizationEkfState* s) {
  const EkfMatrix& P = s->covariance;
  const Eigen::Matrix<double, M, M> S = H * P * H.transpose() + R;
  const Eigen::Matrix<double, kEkfSize, M> K =
      S.llt().solve((P * H.transpose()).transpose()).transpose();
  s->mean += K * r;
  s->mean(kEkfYaw) = world::WrapAngle(s->mean(kEkfYaw));
  const EkfMatrix I_KH = EkfMatrix::Identity() - K * H;
  s->covariance = (I_KH * P * I_KH.transpose() + K * R * K.transpose()).eval();
  Symmetrize(&s->covariance);
}

void CorrectScalar(int index, double residual, double variance, LocalizationEkfState* s) {
  Eigen::Matrix<double, 1, kEkfSize> H = Eigen::Matrix<double, 1, kEkfSize>::Zero();
  H(0, index) = 1.0;
  Correct<1>(H, Eigen::Matrix<double, 1, 1>(residual), Eigen::Matrix<double, 1, 1>(variance), s);
}

// One measurement of any kind, for the merge by stamp.
struct Pending {
  Time stamp;
  int kind;  // 0 IMU, 1 wheel speed, 2 pose fix: the tie order
  std::size_t index;
};

// A sensor's stamps must not go backwards, nor lie after now.
template <class Measurement>
void CheckStamps(const std::vector<Measurement>& list, const std::optional<Time>& last, Time now,
                 const char* sensor) {
  std::optional<Time> previous = last;
  for (const Measurement& m : list) {
    if (previous && m.stamp < *previous) {
      Require(false, [&] {
        return std::string("localization: ") + sensor + " reading stamped " + Seconds(m.stamp) +
               " is out of order: older than the previous " + sensor + " reading at " +
               Seconds(*previous);
      });
    }
    Require(m.stamp <= now, [&] {
      return std::string("localization: ") + sensor + " reading stamped " + Seconds(m.stamp) +
             " is after now (" + Seconds(now) + ")";
    });
    previous = m.stamp;
  }
}

}  // namespace

void LocalizationEkfParams::Validate() const {
  Require(period > Duration::zero(),
          [&] { return "period_s must be > 0, got " + Num(ToSeconds(period)); });
  Require(sensor_timeout > Duration::zero(),
          [&] { return "sensor_timeout_s must be > 0, got " + Num(ToSeconds(sensor_timeout)); });
  RequirePositive(q_position_m2_per_s, "q_position_m2_per_s");
  RequirePositive(q_yaw_rad2_per_s, "q_yaw_rad2_per_s");
  RequirePositive(q_speed_m2_per_s3, "q_speed_m2_per_s3");
  RequirePositive(q_yaw_rate_rad2_per_s3, "q_yaw_rate_rad2_per_s3");
  RequirePositive(initial_variance, "initial_variance");
  RequirePositive(imu_yaw_variance_rad2, "imu_yaw_variance_rad2");
  RequirePositive(imu_yaw_rate_variance_rad2_per_s2, "imu_yaw_rate_variance_rad2_per_s2");
  RequirePositive(wheel_speed_variance_m2_per_s2, "wheel_speed_variance_m2_per_s2");
}

world::Pose2 MapFromOdom(const world::Pose2& X_map_odom, const world::Pose2& X_odom_base) {
  const double c = std::cos(X_map_odom.yaw_rad);
  const double s = std::sin(X_map_odom.yaw_rad);
  return {X_map_odom.x_m + c * X_odom_base.x_m - s * X_odom_base.y_m,
          X_map_odom.y_m + s * X_odom_base.x_m + c * X_odom_base.y_m,
          world::WrapAngle(X_map_odom.yaw_rad + X_odom_base.yaw_rad)};
}

world::Pose2 OdomFromMap(const world::Pose2& X_map_odom, const world::Pose2& X_map_base) {
  const world::Vec2 p_odom = OdomPointFromMap(X_map_odom)(X_map_base.position());
  return {p_odom.x(), p_odom.y(), world::WrapAngle(X_map_base.yaw_rad - X_map_odom.yaw_rad)};
}

LocalizationEkfState InitialLocalizationEkfState(const LocalizationEkfParams& params, Time start,
                                                 const world::Pose2& X_map_odom) {
  params.Validate();
  Require(std::isfinite(X_map_odom.x_m) && std::isfinite(X_map_odom.y_m) &&
              std::isfinite(X_map_odom.yaw_rad),
          "localization: the start pose (map→odom) must be finite");
  LocalizationEkfState state;
  state.time = start;
  state.last_measurement = start;
  state.covariance = EkfMatrix::Identity() * params.initial_variance;
  state.X_map_odom = X_map_odom;
  return state;
}

namespace {

// The input's own checks: finite readings, stamps in order and not after now, the filter's time
// not ahead of now.
void CheckInput(const LocalizationEkfParams& params, const LocalizationEkfInput& input,
                const LocalizationEkfState& s) {
  Require(input.now >= s.time, [&] {
    return "localization: now (" + Seconds(input.now) + ") is before the filter's time (" +
           Seconds(s.time) + ")";
  });
  Require(params.use_pose_fix || input.pose_fixes.empty(),
          "localization: a pose fix was given but use_pose_fix is off");
  for (const ImuMeasurement& m : input.imu) {
    RequireFinite(m.yaw_rad, "IMU yaw_rad");
    RequireFinite(m.yaw_rate_rad_per_s, "IMU yaw_rate_rad_per_s");
  }
  for (const WheelSpeedMeasurement& m : input.wheel_speed) {
    RequireFinite(m.speed_mps, "wheel speed_mps");
  }
  for (const PoseFix& f : input.pose_fixes) {
    RequireFinite(f.X_map_base.x_m, "pose fix x_m");
    RequireFinite(f.X_map_base.y_m, "pose fix y_m");
    RequireFinite(f.X_map_base.yaw_rad, "pose fix yaw_rad");
    Require(f.covariance.allFinite() && f.covariance.isApprox(f.covariance.transpose()) &&
                f.covariance.llt().info() == Eigen::Success,
            "localization: a pose fix covariance must be symmetric positive definite");
  }
  CheckStamps(input.imu, s.last_imu, input.now, "IMU");
  CheckStamps(input.wheel_speed, s.last_wheel_speed, input.now, "wheel speed");
  CheckStamps(input.pose_fixes, s.last_pose_fix, input.now, "pose fix");
}

std::vector<Pending> MeasurementsInStampOrder(const LocalizationEkfInput& input) {
  std::vector<Pending> pending;
  for (std::size_t i = 0; i < input.imu.size(); ++i) pending.push_back({input.imu[i].stamp, 0, i});
  for (std::size_t i = 0; i < input.wheel_speed.size(); ++i) {
    pending.push_back({input.wheel_speed[i].stamp, 1, i});
  }
  for (std::size_t i = 0; i < input.pose_fixes.size(); ++i) {
    pending.push_back({input.pose_fixes[i].stamp, 2, i});
  }
  std::stable_sort(pending.begin(), pending.end(), [](const Pending& a, const Pending& b) {
    return a.stamp != b.stamp ? a.stamp < b.stamp : a.kind < b.kind;
  });
  return pending;
}

void FuseImu(const LocalizationEkfParams& params, const ImuMeasurement& m,
             LocalizationEkfState* state) {
  LocalizationEkfState& s = *state;
  if (params.imu_yaw_relative && !s.imu_yaw_origin_rad) s.imu_yaw_origin_rad = m.yaw_rad;
  const double yaw_odom = params.imu_yaw_relative ? m.yaw_rad - *s.imu_yaw_origin_rad : m.yaw_rad;
  if (params.fuse_imu_yaw) {
    CorrectScalar(kEkfYaw, world::WrapAngle(yaw_odom - s.mean(kEkfYaw)),
                  params.imu_yaw_variance_rad2, &s);
  }
  CorrectScalar(kEkfYawRate, m.yaw_rate_rad_per_s - s.mean(kEkfYawRate),
                params.imu_yaw_rate_variance_rad2_per_s2, &s);
  s.last_imu = m.stamp;
}

void FuseWheelSpeed(const LocalizationEkfParams& params, const WheelSpeedMeasurement& m,
                    LocalizationEkfState* s) {
  CorrectScalar(kEkfSpeed, m.speed_mps - s->mean(kEkfSpeed), params.wheel_speed_variance_m2_per_s2,
                s);
  s->last_wheel_speed = m.stamp;
}

void FusePoseFix(const PoseFix& f, LocalizationEkfState* state) {
  LocalizationEkfState& s = *state;
  // Into the odom frame: rotate the position block of the covariance by map→odom's yaw.
  const world::Pose2 X_odom_fix = OdomFromMap(s.X_map_odom, f.X_map_base);
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  const double c = std::cos(s.X_map_odom.yaw_rad);
  const double sn = std::sin(s.X_map_odom.yaw_rad);
  rotation.topLeftCorner<2, 2>() << c, sn, -sn, c;
  const Eigen::Matrix3d R = rotation * f.covariance * rotation.transpose();
  Eigen::Matrix<double, 3, kEkfSize> H = Eigen::Matrix<double, 3, kEkfSize>::Zero();
  H(0, kEkfX) = 1.0;
  H(1, kEkfY) = 1.0;
  H(2, kEkfYaw) = 1.0;
  const Eigen::Vector3d r{X_odom_fix.x_m - s.mean(kEkfX), X_odom_fix.y_m - s.mean(kEkfY),
                          world::WrapAngle(X_odom_fix.yaw_rad - s.mean(kEkfYaw))};
  Correct<3>(H, r, R, &s);
  s.last_pose_fix = f.stamp;
}

}  // namespace

LocalizationEkfOutput StepLocalizationEkf(const LocalizationEkfParams& params,
                                          const LocalizationEkfInput& input,
                                          LocalizationEkfState* state) {
  LocalizationEkfState& s = *state;
  CheckInput(params, input, s);

  LocalizationEkfOutput out;
  for (const Pending& p : MeasurementsInStampOrder(input)) {
    if (p.stamp > s.time) {
      Predict(params, ToSeconds(p.stamp - s.time), &s);
      s.time = p.stamp;
    } else if (p.stamp < s.time) {
      ++out.late;
    }
    if (p.kind == 0) {
      FuseImu(params, input.imu[p.index], &s);
    } else if (p.kind == 1) {
      FuseWheelSpeed(params, input.wheel_speed[p.index], &s);
    } else {
      FusePoseFix(input.pose_fixes[p.index], &s);
    }
    s.last_measurement = std::max(s.last_measurement, p.stamp);
    ++out.fused;
  }

  // sensor timeout: predict to now
  if (input.now - s.last_measurement >= params.sensor_timeout && input.now > s.time) {
    Predict(params, ToSeconds(input.now - s.time), &s);
    s.time = input.now;
    s.last_measurement = input.now;
  }

  out.stamp = s.time;
  out.X_odom_base = {s.mean(kEkfX), s.mean(kEkfY), s.mean(kEkfYaw)};
  out.X_map_base = MapFromOdom(s.X_map_odom, out.X_odom_base);
  out.speed_mps = s.mean(kEkfSpeed);
  out.yaw_rate_rad_per_s = s.mean(kEkfYawRate);
  out.covariance = s.covariance;
  return out;
}

void JumpLocalizationEstimate(double dx_m, double dy_m, double dyaw_rad,
                              LocalizationEkfState* state) {
  // the mean is in the odom frame: turn the map-frame step into it
  const double c = std::cos(state->X_map_odom.yaw_rad);
  const double s = std::sin(state->X_map_odom.yaw_rad);
  state->mean(kEkfX) += c * dx_m + s * dy_m;
  state->mean(kEkfY) += -s * dx_m + c * dy_m;
  state->mean(kEkfYaw) = world::WrapAngle(state->mean(kEkfYaw) + dyaw_rad);
}

}  // namespace autonomsim::stack
