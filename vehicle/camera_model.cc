#include "vehicle/camera_model.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>

#include "world/plumb_bob.h"
#include "world/validation.h"

namespace autonomsim::vehicle {
namespace {

constexpr double kRadPerDeg = std::numbers::pi / 180.0;
// Newton's method for the inverse of the distortion: iterations, and the residual (normalized
// image units, ≈1e-10 px) at which it stops.
// How far out (normalized radius) the radial model is searched for its monotone range, and in how
// many steps; a lens never sees beyond r = 10 (84°).
constexpr double kMaxSearchRadius = 10.0;
constexpr int kRadiusSearchSteps = 10000;

void RequireFinite(double value, const std::string& key) {
  Require(std::isfinite(value), [&] { return key + " must be finite, got " + Num(value); });
}

}  // namespace

void CameraMount::Validate() const {
  RequireFinite(x_m, "x_m");
  RequireFinite(y_m, "y_m");
  RequireFinite(z_m, "z_m");
  for (const auto& angle :
       {std::pair{"roll_deg", roll_deg}, {"pitch_deg", pitch_deg}, {"yaw_deg", yaw_deg}}) {
    Require(std::isfinite(angle.second) && std::abs(angle.second) <= 180.0, [&] {
      return std::string(angle.first) + " must be within [-180, 180], got " + Num(angle.second);
    });
  }
}

void CameraParams::Validate() const {
  Require(!name.empty(), "name must not be empty");
  Require(width_px > 0 && width_px <= 8192,
          [&] { return "width_px must be in [1, 8192], got " + std::to_string(width_px); });
  Require(height_px > 0 && height_px <= 8192,
          [&] { return "height_px must be in [1, 8192], got " + std::to_string(height_px); });
  for (std::size_t i = 0; i < K.size(); ++i) RequireFinite(K[i], "K[" + std::to_string(i) + "]");
  for (std::size_t i = 0; i < D.size(); ++i) RequireFinite(D[i], "D[" + std::to_string(i) + "]");
  for (std::size_t i = 0; i < P.size(); ++i) RequireFinite(P[i], "P[" + std::to_string(i) + "]");
  Require(K[0] > 0.0 && K[4] > 0.0, [&] {
    return "K: fx (K[0]) and fy (K[4]) must be > 0, got " + Num(K[0]) + ", " + Num(K[4]);
  });
  Require(K[3] == 0.0 && K[6] == 0.0 && K[7] == 0.0 && K[8] == 1.0,
          "K must be [fx s cx; 0 fy cy; 0 0 1] (K[3], K[6], K[7] = 0, K[8] = 1)");
  Require(P[0] > 0.0 && P[5] > 0.0, [&] {
    return "P: fx' (P[0]) and fy' (P[5]) must be > 0, got " + Num(P[0]) + ", " + Num(P[5]);
  });
  Require(P[4] == 0.0 && P[8] == 0.0 && P[9] == 0.0 && P[10] == 1.0 && P[11] == 0.0,
          "P must be [fx' s cx' Tx; 0 fy' cy' Ty; 0 0 1 0]");
  mount.Validate();
  Require(std::isfinite(clip_near_m) && clip_near_m > 0.0,
          [&] { return "clip_near_m must be > 0, got " + Num(clip_near_m); });
  Require(std::isfinite(clip_far_m) && clip_far_m > clip_near_m && clip_far_m <= 65.535, [&] {
    return "clip_far_m must be > clip_near_m and <= 65.535 (uint16 millimetres), got " +
           Num(clip_far_m);
  });
}

CameraParams ColorCameraParams() {
  CameraParams p;
  p.name = "color_camera";
  p.width_px = 640;  // reference §2: 640×480 bgr8 at 30 fps
  p.height_px = 480;
  // reference §2: the real calibration. (Their Gazebo camera, f = 288.128, c = (320.5, 240.5),
  // HFOV 1.67552 rad, no distortion, can be set instead; it goes with a different mount, see
  // the report of issue 3.)
  p.K = {426.393, 0.0, 262.009, 0.0, 428.576, 302.229, 0.0, 0.0, 1.0};
  p.D = {-0.210058, 0.043931, 0.004976, -0.004611, 0.0};
  p.P = {357.711, 0.0, 237.640, 0.0, 0.0, 386.370, 313.674, 0.0, 0.0, 0.0, 1.0, 0.0};
  p.lens_distortion = true;
  // reference §2, derived from their PnP constants: x ≈ 0.137, y ≈ -0.007, height 0.133 m,
  // pitched down ≈ 15.4°.
  p.mount = CameraMount{.x_m = 0.137, .y_m = -0.007, .z_m = 0.133, .pitch_deg = 15.4};
  // assumed: a colour camera has no depth range of its own; 1 cm keeps depth.png meaningful and
  // 10 m covers the 5 m track from anywhere on it (diagonal 7.1 m); beyond is the lab's wall.
  p.clip_near_m = 0.01;
  p.clip_far_m = 10.0;
  return p;
}

CameraParams DepthCameraParams() {
  CameraParams p;
  p.name = "depth_camera";
  p.width_px = 640;  // reference §2: 640×480 mono16 (millimetres) at 30 fps
  p.height_px = 480;
  // assumed: square pixels from their Gazebo model's HFOV of 1.0472 rad (reference §2):
  // fx = fy = (640 / 2) / tan(1.0472 / 2) = 554.255; the optical axis through the image centre,
  // which is (319.5, 239.5) with pixel centres at integers (Gazebo writes (W + 1) / 2 = 320.5).
  // The real Astra's intrinsics come from the device at run time and were not recorded.
  const double f = 0.5 * p.width_px / std::tan(0.5 * 1.0472);
  const double cx = 0.5 * (p.width_px - 1);
  const double cy = 0.5 * (p.height_px - 1);
  p.K = {f, 0.0, cx, 0.0, f, cy, 0.0, 0.0, 1.0};
  p.D = {0.0, 0.0, 0.0, 0.0, 0.0};
  p.P = {f, 0.0, cx, 0.0, 0.0, f, cy, 0.0, 0.0, 0.0, 1.0, 0.0};
  p.lens_distortion = false;
  // reference §2: the obstacle code maps a point from the camera's forward/left/up frame (the
  // frame its point cloud is in, reference §3) to base_link as p_base = R · p_cam + t (a 4×4
  // homogeneous matrix applied to the point), with R a rotation about y by 0.15 rad and
  // t = (-0.155, 0, 0.264). So t is the camera's position in base_link (15.5 cm behind the
  // chassis centre, on the mast at 26.4 cm) and R pitches its forward axis down
  // (R · x = (0.98875, 0, -0.14955)). The matrix's entries are those of 0.1501 rad to five digits;
  // we take its angle, atan2(0.14955, 0.98875), so that the stack's transform is exactly ours.
  // base_link is the chassis centre on the floor, as ours: the planner footprint is symmetric about
  // it (reference §2) and the obstacle box starts at z = 0.02 m, just above the floor. Consistency
  // check: the lowest image row then meets the floor 0.27 m ahead of the chassis centre, where that
  // box (x >= 0.3) begins.
  p.mount = CameraMount{.x_m = -0.155,
                        .y_m = 0.0,
                        .z_m = 0.264,
                        .pitch_deg = std::atan2(0.14955, 0.98875) / kRadPerDeg};
  p.clip_near_m = 0.6;  // reference §2: their Gazebo model's clip, 0.6–8 m
  p.clip_far_m = 8.0;
  return p;
}

Eigen::Isometry3d Lift(const world::Pose2& X_map_body) {
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.linear() = Eigen::AngleAxisd(X_map_body.yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  X.translation() = Eigen::Vector3d(X_map_body.x_m, X_map_body.y_m, 0.0);
  return X;
}

CameraModel::CameraModel(const CameraParams& params) : params_(params) {
  params_.Validate();
  const CameraMount& m = params_.mount;
  const Eigen::Matrix3d R_base_body =
      (Eigen::AngleAxisd(m.yaw_deg * kRadPerDeg, Eigen::Vector3d::UnitZ()) *
       Eigen::AngleAxisd(m.pitch_deg * kRadPerDeg, Eigen::Vector3d::UnitY()) *
       Eigen::AngleAxisd(m.roll_deg * kRadPerDeg, Eigen::Vector3d::UnitX()))
          .toRotationMatrix();
  // optical x (right) = body -y, optical y (down) = body -z, optical z (forward) = body x
  Eigen::Matrix3d R_body_optical;
  R_body_optical << 0.0, 0.0, 1.0,  //
      -1.0, 0.0, 0.0,               //
      0.0, -1.0, 0.0;
  X_base_camera_ = Eigen::Isometry3d::Identity();
  X_base_camera_.linear() = R_base_body * R_body_optical;
  X_base_camera_.translation() = Eigen::Vector3d(m.x_m, m.y_m, m.z_m);

  bool any = false;
  for (double d : params_.D) any = any || d != 0.0;
  distort_ = params_.lens_distortion && any;

  // The radial factor r · (1 + k1 r² + k2 r⁴ + k3 r⁶) must grow with r for the model to describe
  // a lens; find where it first stops growing.
  max_radius_sq_ = std::numeric_limits<double>::infinity();
  if (distort_) {
    const double k1 = params_.D[0];
    const double k2 = params_.D[1];
    const double k3 = params_.D[4];
    for (int i = 1; i <= kRadiusSearchSteps; ++i) {
      const double r = kMaxSearchRadius * i / kRadiusSearchSteps;
      const double r2 = r * r;
      const double slope = 1.0 + 3.0 * k1 * r2 + 5.0 * k2 * r2 * r2 + 7.0 * k3 * r2 * r2 * r2;
      if (slope <= 0.0) {
        max_radius_sq_ = r2;
        break;
      }
    }
  }
}

CameraInfo CameraModel::Info() const {
  CameraInfo info;
  info.width = params_.width_px;
  info.height = params_.height_px;
  info.K = params_.K;
  if (params_.lens_distortion) {
    info.D = params_.D;
    info.P = params_.P;
  } else {
    info.D = {0.0, 0.0, 0.0, 0.0, 0.0};
    const auto& K = params_.K;
    info.P = {K[0], K[1], K[2], 0.0, K[3], K[4], K[5], 0.0, K[6], K[7], K[8], 0.0};
  }
  return info;
}

Eigen::Isometry3d CameraModel::X_map_camera(const world::Pose2& X_map_car) const {
  return Lift(X_map_car) * X_base_camera_;
}

Eigen::Vector2d CameraModel::DistortedRay(double u, double v) const {
  const auto& K = params_.K;
  const double yd = (v - K[5]) / K[4];
  const double xd = (u - K[2] - K[1] * yd) / K[0];
  return {xd, yd};
}

std::optional<Eigen::Vector2d> CameraModel::WithinModel(
    const std::optional<Eigen::Vector2d>& ray) const {
  if (!ray || ray->squaredNorm() > max_radius_sq_) return std::nullopt;
  return ray;
}

std::optional<Eigen::Vector2d> CameraModel::NormalizedRay(double u, double v) const {
  const Eigen::Vector2d target = DistortedRay(u, v);
  if (!distort_) return target;
  return WithinModel(world::Undistort(params_.D, target));
}

void CameraModel::NormalizedRaysOfRow(int v,
                                      std::vector<std::optional<Eigen::Vector2d>>* rays) const {
  std::vector<Eigen::Vector2d> targets(static_cast<std::size_t>(width()));
  for (int u = 0; u < width(); ++u) targets[static_cast<std::size_t>(u)] = DistortedRay(u, v);
  rays->resize(targets.size());
  if (!distort_) {
    std::copy(targets.begin(), targets.end(), rays->begin());
    return;
  }
  world::UndistortAll(params_.D, targets, *rays);
  for (std::optional<Eigen::Vector2d>& ray : *rays) ray = WithinModel(ray);
}

std::optional<Eigen::Vector2d> CameraModel::Project(const Eigen::Vector3d& p_camera) const {
  if (!(p_camera.z() > 0.0)) return std::nullopt;
  Eigen::Vector2d x(p_camera.x() / p_camera.z(), p_camera.y() / p_camera.z());
  if (distort_) {
    if (x.squaredNorm() > max_radius_sq_) return std::nullopt;
    x = world::Distort(params_.D, x);
  }
  const auto& K = params_.K;
  return Eigen::Vector2d(K[0] * x.x() + K[1] * x.y() + K[2], K[4] * x.y() + K[5]);
}

}  // namespace autonomsim::vehicle
