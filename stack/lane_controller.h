// LaneController (reference §5; code/ros_ws/src/autonomros_lane_detection/src/lane_controller.cpp):
// Nav2's regulated pure pursuit with the lane detector's points as the path. One step (the
// controller server runs it at 20 Hz):
//   carrot     the nearest lane point at range >= the lookahead distance (0.6 m). The real code
//              scans the 30 points from the last to the first and takes the first at range >= L;
//              the detector orders them far to near (row i·16), so that is the nearest one;
//   curvature  κ = 2·y / L² (PurePursuitCurvature);
//   speed      RegulatedSpeed (0.25 m/s; Nav2's curvature slow-down below radius 0.9 m, v scaled
//              by r / r_min, floored at regulated_min_speed_mps; approach scaling); ω = v·κ;
//   no carrot  (lanes invalid, or no point far enough; a point that is not finite is never one):
//              v = 0, ω = 0;
//   collision  the real plugin runs the same arc check as FollowPath (lane_controller.cpp:364-443,
//              stack/path_follower.h IsCollisionImminent, by collision.model) and stops; here
//              when the caller passes `cell_cost`.
#pragma once

#include <optional>
#include <span>

#include "stack/path_follower.h"
#include "world/geometry.h"

namespace autonomsim::stack {

struct LaneControllerParams {
  RegulatedPurePursuitParams pursuit;  // nav2_car_params LaneController: the FollowPath values
  CollisionCheckParams collision;

  template <class V>
  void Describe(V& v) {
    v("pursuit", pursuit, "its pure pursuit and speed regulation");
    v("collision", collision, "its check for a collision ahead");
  }
  void Validate() const;
};

struct LaneControllerInput {
  // LanePoints (reference §5): the centre-line points in base_link (x forward, y left) and the
  // message's valid flag; points are only read when valid.
  std::span<const world::Vec2> lane_points_base;
  bool lanes_valid{false};
  double speed_mps{0.0};  // measured forward speed (velocity-scaled lookahead only)
  // For the collision check: the pose in the frame of `cell_cost` (empty: no check).
  world::Pose2 X_F_base;
  CostQuery cell_cost;
};

struct LaneControllerOutput {
  double speed_mps{0.0};  // cmd_vel linear.x
  double yaw_rate_rad_per_s{0.0};
  double curvature_per_m{0.0};
  std::optional<world::Vec2> carrot_base;  // the chosen lane point, base_link
  bool collision_ahead{false};
};

// Stateless. Throws std::invalid_argument on a non-finite lane point (when valid), speed or pose.
LaneControllerOutput StepLaneController(const LaneControllerParams& params,
                                        const LaneControllerInput& input);

}  // namespace autonomsim::stack
