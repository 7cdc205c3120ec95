#include "sim/loop/lane_judge.h"

#include <cmath>

namespace autonomsim::sim {

std::optional<double> LaneDetectionError(const LaneJudgeParams& params, const world::Track& track,
                                         const world::Polyline& path, const world::Pose2& X_map_car,
                                         const stack::LanePoints& lanes) {
  if (lanes.valid == 0) return std::nullopt;
  if (track.IntersectionAt(X_map_car.position()) != nullptr ||
      track.StopZoneAt(X_map_car.position())) {
    return std::nullopt;
  }
  const double s_car = path.Project(X_map_car.position()).s_m;
  for (double ds = -params.settled_m; ds <= params.straight_m; ds += params.step_m) {
    if (std::abs(path.CurvatureAt(path.NormalizeS(s_car + ds))) > params.straight_curvature_per_m) {
      return std::nullopt;
    }
  }
  // the detected lane centre where it is ahead_m ahead (the points run far to near)
  for (std::size_t i = 0; i + 1 < lanes.points.size(); ++i) {
    const stack::LanePoint& far = lanes.points[i];
    const stack::LanePoint& near = lanes.points[i + 1];
    if (!(far.x_m >= params.ahead_m && near.x_m <= params.ahead_m) || far.x_m == near.x_m) {
      continue;
    }
    const double w = (params.ahead_m - near.x_m) / (far.x_m - near.x_m);
    const double y_car = near.y_m + w * (far.y_m - near.y_m);
    const world::Vec2 left(-std::sin(X_map_car.yaw_rad), std::cos(X_map_car.yaw_rad));
    const world::Vec2 p_map =
        X_map_car.position() + params.ahead_m * X_map_car.heading() + y_car * left;
    return std::abs(path.Project(p_map).lateral_m);
  }
  return std::nullopt;
}

}  // namespace autonomsim::sim
