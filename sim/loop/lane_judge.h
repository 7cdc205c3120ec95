// Judging a car's lane detection against ground truth: where the detected lane centre lies, a
// fixed distance ahead of the car, relative to the route's lane centre. A monitor of the loop, not
// part of the stack: the real car has no ground truth to compare with.
#pragma once

#include <optional>

#include "stack/lane_detection.h"
#include "world/geometry.h"
#include "world/polyline.h"
#include "world/track.h"

namespace autonomsim::sim {

struct LaneJudgeParams {
  // Judged where the lane centre is this far ahead of the chassis centre (the lane tests'
  // distance, issue 5).
  double ahead_m{0.5};
  // ... and only where the route is straight (|κ| below straight_curvature_per_m, checked every
  // step_m) from settled_m behind the car to straight_m ahead: in corners the route's 0.9 m arcs
  // are not the painted centre (the car cannot turn tighter).
  double settled_m{0.5};
  double straight_m{0.9};  // the bird's-eye view ends ≈ 0.9 m ahead (reference §5)
  double step_m{0.05};
  double straight_curvature_per_m{1e-3};
};

// The distance (m) of the detected lane centre `ahead_m` ahead of a car at `X_map_car` from the
// route's lane centre `path`, or nullopt where the result is not judged: an invalid detection,
// points that do not reach `ahead_m`, a car inside an intersection area or stop box (FollowPath
// steers there, reference §6), or a route not straight around the car.
std::optional<double> LaneDetectionError(const LaneJudgeParams& params, const world::Track& track,
                                         const world::Polyline& path, const world::Pose2& X_map_car,
                                         const stack::LanePoints& lanes);

}  // namespace autonomsim::sim
