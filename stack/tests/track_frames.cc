#include "stack/tests/track_frames.h"

#include <cmath>

#include "sim/core/track_loader.h"
#include "vehicle/camera_model.h"
#include "world/floor_raster.h"

namespace autonomsim::stack::testing {

TrackFrames::TrackFrames(const std::string& track_file)
    : track_(std::make_unique<world::Track>(sim::LoadTrack(track_file))) {
  const auto floor = std::make_shared<const vehicle::FloorTexture>(world::RasterizeFloor(*track_));
  const vehicle::Bgr surround = vehicle::SceneAppearance{}.surround();
  color_ = std::make_unique<vehicle::CameraRenderer>(
      std::make_shared<const vehicle::CameraRays>(
          vehicle::CameraModel(vehicle::ColorCameraParams())),
      floor, surround);
  depth_ = std::make_unique<vehicle::CameraRenderer>(
      std::make_shared<const vehicle::CameraRays>(
          vehicle::CameraModel(vehicle::DepthCameraParams())),
      floor, surround);
}

world::Pose2 TrackFrames::PoseOnRoute(const std::string& route, double s_m, double lateral_m,
                                      double yaw_offset_rad) const {
  const world::Polyline& path = track_->RouteByName(route).path;
  const world::Vec2 p = path.PointAt(s_m);
  const double heading = path.HeadingAt(s_m);
  const world::Vec2 left(-std::sin(heading), std::cos(heading));
  const world::Vec2 q = p + lateral_m * left;
  return world::Pose2{q.x(), q.y(), world::WrapAngle(heading + yaw_offset_rad)};
}

RgbdFrame TrackFrames::Render(const world::Pose2& X_map_car,
                              std::span<const vehicle::Prism> prisms) const {
  RgbdFrame frame;
  color_->Render(X_map_car, prisms, &frame.color, nullptr);
  depth_->Render(X_map_car, prisms, nullptr, &frame.depth);
  return frame;
}

}  // namespace autonomsim::stack::testing
