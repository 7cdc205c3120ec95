// A pinhole camera with ROS CameraInfo semantics (sensor_msgs/CameraInfo, "plumb_bob"), mounted
// rigidly on the car.
//
// Frames:
//  - base: the car's base frame, x forward, y left, z up; origin the chassis centre on the floor
//    (vehicle::Car::pose(), lifted to 3D at z = 0).
//  - camera body: x forward, y left, z up (what the mount angles turn).
//  - optical: z forward, x right, y down (REP-103 "_optical" frames, OpenCV's camera frame). K, D
//    and P act in this frame; X_base_camera and X_map_camera name it.
// Pixels follow OpenCV: the integer coordinate (u, v) is the centre of column u, row v.
//
// The image a camera renders is its raw image: with lens_distortion on, pixel (u, v) sees the ray
// that K and D map there (image_raw of a real camera); P is then the projection of the rectified
// image, as a calibrated ROS camera publishes it. With lens_distortion off the image is the ideal
// pinhole image through K, and CameraInfo reports D = 0 and P = [K | 0].
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <optional>
#include <string>
#include <vector>

#include "world/geometry.h"

namespace autonomsim::vehicle {

// The pose of the camera body frame (x forward, y left, z up) in the car's base frame. The
// rotation is R = Rz(yaw) · Ry(pitch) · Rx(roll): yaw about z (positive turns left), then pitch
// about the new y (positive looks down, since y points left), then roll about the new x.
struct CameraMount {
  double x_m{0.0};
  double y_m{0.0};
  double z_m{0.0};
  double roll_deg{0.0};
  double pitch_deg{0.0};
  double yaw_deg{0.0};

  template <class V>
  void Describe(V& v) {
    v("x_m", x_m, "forward of base_link");
    v("y_m", y_m, "left of base_link");
    v("z_m", z_m, "above the floor");
    v("roll_deg", roll_deg, "roll about the camera's x");
    v("pitch_deg", pitch_deg, "pitch, positive looks down");
    v("yaw_deg", yaw_deg, "yaw, positive turns left");
  }
  void Validate() const;  // finite values, |angles| <= 180
  friend bool operator==(const CameraMount&, const CameraMount&) = default;
};

struct CameraParams {
  std::string name{"camera"};  // names the camera in outputs (render's sub-folder) and streams
  int width_px{640};
  int height_px{480};
  std::array<double, 9> K{1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0};  // row-major
  // plumb_bob: k1, k2, p1 (t1), p2 (t2), k3, as ROS and OpenCV order them.
  std::array<double, 5> D{0.0, 0.0, 0.0, 0.0, 0.0};
  // Row-major 3×4 [fx' 0 cx' Tx; 0 fy' cy' Ty; 0 0 1 0] of the rectified image; Tx = Ty = 0 for a
  // monocular camera (ROS: Tx = -fx' · baseline for the second camera of a stereo pair).
  std::array<double, 12> P{1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0};
  bool lens_distortion{false};  // render through D (image_raw); off: an ideal pinhole image
  CameraMount mount;
  // Surfaces nearer than clip_near_m (optical z) give no depth (0) but are still seen in colour;
  // surfaces beyond clip_far_m are not drawn at all (the surround colour, depth 0).
  double clip_near_m{0.01};
  double clip_far_m{10.0};

  template <class V>
  void Describe(V& v) {
    v("name", name, "names the camera in outputs");
    v("width_px", width_px, "image width");
    v("height_px", height_px, "image height");
    v("K", K, "intrinsics, row-major 3×3 (ROS CameraInfo K)");
    v("D", D, "plumb_bob distortion k1, k2, p1, p2, k3");
    v("P", P, "projection of the rectified image, row-major 3×4");
    v("lens_distortion", lens_distortion, "render through D (false: an ideal pinhole image)");
    v("mount", mount, "where the camera sits on the car");
    v("clip_near_m", clip_near_m, "nearer surfaces give no depth");
    v("clip_far_m", clip_far_m, "farther surfaces are not drawn");
  }
  // Positive sizes (<= 8192), fx, fy > 0, K's last row [0 0 1], P's last row [0 0 1 0], finite
  // D, 0 < clip_near_m < clip_far_m <= 65.535 (the largest depth a uint16 of millimetres holds).
  void Validate() const;
  friend bool operator==(const CameraParams&, const CameraParams&) = default;
};

// The colour camera of the real car (See3CAM CU30, reference §2), which the lane detection reads.
// Intrinsics: the real calibration (K, D) with its rectified P, and lens distortion on, so that the
// image is what the car's /image topic carries: the raw frame, which the real lane detection warps
// without undistorting it. Mount: derived from their PnP constants (reference §2).
CameraParams ColorCameraParams();
// The depth camera of the real car (Orbbec Astra Pro, reference §2): 640×480, clip 0.6–8 m, and
// intrinsics assumed from their Gazebo model's horizontal field of view, since the real ones are
// read from the device at run time and were not recorded. Mount: the obstacle code's
// camera→base transform (reference §2), interpreted in camera_model.cc.
CameraParams DepthCameraParams();

// sensor_msgs/CameraInfo, as a camera publishes it.
struct CameraInfo {
  int width{0};
  int height{0};
  std::string distortion_model{"plumb_bob"};
  std::array<double, 5> D{};
  std::array<double, 9> K{};
  std::array<double, 9> R{1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0};  // monocular: identity
  std::array<double, 12> P{};
};

// A rigid transform in 3D, lifted from a planar pose (z = 0, rotation about z).
Eigen::Isometry3d Lift(const world::Pose2& X_map_body);

class CameraModel {
 public:
  explicit CameraModel(const CameraParams& params);  // validates

  const CameraParams& params() const { return params_; }
  int width() const { return params_.width_px; }
  int height() const { return params_.height_px; }
  CameraInfo Info() const;

  // The optical frame in the car's base frame, and in the map frame for a car pose.
  const Eigen::Isometry3d& X_base_camera() const { return X_base_camera_; }
  Eigen::Isometry3d X_map_camera(const world::Pose2& X_map_car) const;

  // The ray through pixel (u, v), in the optical frame, scaled so that its z is 1: a point on it
  // at optical depth z is z · (x, y, 1). Undistorted through D when lens_distortion is on;
  // nullopt if the distortion model cannot be inverted there.
  std::optional<Eigen::Vector2d> NormalizedRay(double u, double v) const;
  // NormalizedRay(u, v) of every pixel u = 0 .. width() - 1 of row v, into `rays` (resized): the
  // same values, with the row's points undistorted together (world::UndistortAll, ~2x faster).
  void NormalizedRaysOfRow(int v, std::vector<std::optional<Eigen::Vector2d>>* rays) const;
  // A point in the optical frame to its pixel (through D when lens_distortion is on); nullopt
  // behind the camera (z <= 0) or where the distortion model folds back (beyond its monotone
  // range, where it no longer describes the lens).
  std::optional<Eigen::Vector2d> Project(const Eigen::Vector3d& p_camera) const;

 private:
  CameraParams params_;
  Eigen::Isometry3d X_base_camera_;
  bool distort_{false};
  double max_radius_sq_{0.0};  // of the monotone range of the radial model; +inf without D

  // Pixel (u, v) through K⁻¹: the distorted normalized coordinates it shows.
  Eigen::Vector2d DistortedRay(double u, double v) const;
  // An undistorted ray, or nullopt beyond the radial model's monotone range.
  std::optional<Eigen::Vector2d> WithinModel(const std::optional<Eigen::Vector2d>& ray) const;
};

}  // namespace autonomsim::vehicle
