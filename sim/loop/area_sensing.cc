#include "sim/loop/area_sensing.h"

#include <cmath>
#include <numbers>

namespace autonomsim::sim {

CameraWedge WedgeOf(const world::Pose2& X_map_car, const vehicle::CameraParams& camera) {
  const double c = std::cos(X_map_car.yaw_rad);
  const double s = std::sin(X_map_car.yaw_rad);
  const vehicle::CameraMount& m = camera.mount;
  const double fx_px = camera.K[0];
  return CameraWedge{
      .X_map_camera =
          world::Pose2{X_map_car.x_m + c * m.x_m - s * m.y_m, X_map_car.y_m + s * m.x_m + c * m.y_m,
                       X_map_car.yaw_rad + m.yaw_deg * std::numbers::pi / 180.0},
      .half_fov_rad = std::atan2(0.5 * camera.width_px, fx_px),
      .near_m = camera.clip_near_m,
      .far_m = camera.clip_far_m};
}

namespace {

bool InWedge(const CameraWedge& wedge, const world::Vec2& p) {
  const double dx = p.x() - wedge.X_map_camera.x_m;
  const double dy = p.y() - wedge.X_map_camera.y_m;
  const double c = std::cos(wedge.X_map_camera.yaw_rad);
  const double s = std::sin(wedge.X_map_camera.yaw_rad);
  const double ahead = c * dx + s * dy;  // along the optical axis
  const double left = -s * dx + c * dy;
  const double range = std::hypot(ahead, left);
  return ahead > 0.0 && range >= wedge.near_m && range <= wedge.far_m &&
         std::abs(std::atan2(left, ahead)) <= wedge.half_fov_rad;
}

}  // namespace

bool Sees(const CameraWedge& wedge, const world::OrientedBox& box) {
  if (InWedge(wedge, box.pose.position())) return true;
  for (const world::Vec2& corner : box.Corners()) {
    if (InWedge(wedge, corner)) return true;
  }
  return false;
}

std::vector<int> OccupiedAreasSeen(const CameraWedge& wedge,
                                   const std::vector<world::IntersectionSpec>& intersections,
                                   const std::vector<world::OrientedBox>& others) {
  std::vector<int> occupied;
  for (const world::IntersectionSpec& x : intersections) {
    for (const world::OrientedBox& other : others) {
      if (x.area.Contains(other.pose.position()) && Sees(wedge, other)) {
        occupied.push_back(x.id);
        break;
      }
    }
  }
  return occupied;
}

}  // namespace autonomsim::sim
