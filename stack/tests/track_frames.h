// Test fixture for the perception components: the lab track's colour and depth camera frames
// rendered at chosen poses, and the poses themselves taken from the track's lane centre paths.
// Shared by the perception tests and bench/bench_perception; it reads scenarios/tracks/lab.yaml
// (tests run from the repository root).
#pragma once

#include <memory>
#include <span>
#include <string>

#include "vehicle/ray_caster.h"
#include "world/geometry.h"
#include "world/track.h"

namespace autonomsim::stack::testing {

struct RgbdFrame {
  vehicle::ColorImage color;  // the colour camera's raw (distorted) bgr8 image
  vehicle::DepthImage depth;  // the depth camera's mono16 image (mm)
};

class TrackFrames {
 public:
  // `track_file` relative to the working directory (the repository root for ctest).
  explicit TrackFrames(const std::string& track_file = "scenarios/tracks/lab.yaml");

  const world::Track& track() const { return *track_; }
  const vehicle::CameraModel& color_camera() const { return color_->camera(); }
  const vehicle::CameraModel& depth_camera() const { return depth_->camera(); }

  // The car (chassis centre) on route `route` at arc length s_m, `lateral_m` to the left of the
  // lane centre, heading along the lane plus `yaw_offset_rad`.
  world::Pose2 PoseOnRoute(const std::string& route, double s_m, double lateral_m = 0.0,
                           double yaw_offset_rad = 0.0) const;

  // Both cameras at X_map_car among `prisms` (obstacles, other cars; map frame).
  RgbdFrame Render(const world::Pose2& X_map_car,
                   std::span<const vehicle::Prism> prisms = {}) const;

 private:
  std::unique_ptr<world::Track> track_;
  std::unique_ptr<vehicle::CameraRenderer> color_;
  std::unique_ptr<vehicle::CameraRenderer> depth_;
};

}  // namespace autonomsim::stack::testing
