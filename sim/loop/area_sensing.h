// What a car's sensors tell its intersection client about an intersection's area (the client's
// enter_only_if_clear, stack/intersection_client.h): whether another car stands in it, as the car's
// depth camera would see it. A geometric model of seeing, not the perception pipeline: a car is
// seen when a corner or the centre of its footprint lies within the camera's horizontal field of
// view (from its intrinsics) between its near and far clip. Occlusion by a third car is not
// modelled (assumed: the cars concerned stand in front of the area, which a car at the stop line
// faces; a car hidden behind another is missed, as the real camera would miss it).
#pragma once

#include <vector>

#include "vehicle/camera_model.h"
#include "world/geometry.h"
#include "world/track_spec.h"

namespace autonomsim::sim {

// The camera's horizontal field of view on the floor plane, in the map frame.
struct CameraWedge {
  world::Pose2 X_map_camera;  // the camera's position and the heading of its optical axis
  double half_fov_rad{0.0};
  double near_m{0.0};
  double far_m{0.0};
};

// `camera`'s wedge on a car at X_map_car (the chassis centre, as the renderer mounts cameras).
CameraWedge WedgeOf(const world::Pose2& X_map_car, const vehicle::CameraParams& camera);

// Whether any corner or the centre of `box` lies within the wedge.
bool Sees(const CameraWedge& wedge, const world::OrientedBox& box);

// The ids of the intersections (track order) whose area holds the centre of one of `others` that
// the wedge sees.
std::vector<int> OccupiedAreasSeen(const CameraWedge& wedge,
                                   const std::vector<world::IntersectionSpec>& intersections,
                                   const std::vector<world::OrientedBox>& others);

}  // namespace autonomsim::sim
