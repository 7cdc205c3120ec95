// FollowPath (reference §6): Nav2's regulated pure pursuit (RPP, ROS 2 Galactic) on the planned
// path, with the parameters of code/ros_ws/src/nav2_local/params/nav2_car_params.yaml, and the
// arc collision check both of the car's controllers run. The RPP core here (lookahead, curvature,
// speed regulation, collision check) is shared with the lane controller (stack/lane_controller.h),
// which is the same plugin with lane points instead of a path.
//
// One step (the controller server runs it at 20 Hz):
//   goal       within goal_tolerance_m of the path's last point (and the goal yaw, if given)
//              → goal_reached, (0, 0);
//   prune      the path up to the point closest to the car (searched within
//              max_robot_pose_search_dist_m of path length from the last pruned point; never
//              backwards while path_id is unchanged), keep it out to max_costmap_extent_m;
//   carrot     the first remaining point at range >= the lookahead distance, else the last kept;
//   curvature  κ = 2·y / L² in base_link (0 when L² <= 0.001 m², as Nav2);
//   speed      RegulatedSpeed below; ω = v·κ;
//   collision  IsCollisionImminent on the (v, ω) arc for horizon_s, by the CollisionModel below,
//              against the local costmap's `cell_cost` → (0, 0) and collision_ahead (the real
//              controller throws, the controller server then publishes zero velocity and the
//              behaviour tree recovers).
// Nav2 options the car switches off (rotate to heading, reversing, cost-regulated scaling) are
// not modelled. Frames: the path, the pose and `cell_cost` share one frame F (the planner's map
// frame; the node wraps the odom-frame local costmap through the static map→odom transform).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <string_view>
#include <utility>
#include <vector>

#include "world/enum_names.h"
#include "world/geometry.h"

namespace autonomsim::stack {

// The local costmap's cost (Nav2's cost values, stack/costmap.h) of the cell containing p, in the
// frame the caller gave the pose in; nullopt outside the costmap.
using CostQuery = std::function<std::optional<std::uint8_t>(const world::Vec2& p)>;

// What the arc collision check tests at each pose (stack.*.collision.model):
//   centre     the lab's: the robot's centre point against cells of cost >= INSCRIBED (253), so
//              also LETHAL (254) and NO_INFORMATION (255, the local costmap has
//              track_unknown_space false); a point outside the costmap does not collide
//              (lane_controller.cpp:364-443 isCollisionImminent/inCollision, a copy of Galactic's
//              regulated_pure_pursuit_controller.cpp:372-452). The inflation layer marks every
//              cell within the inscribed radius (0.135 m) of a LETHAL cell INSCRIBED (two 0.05 m
//              cells straight ahead), so this tests the footprint's inscribed circle, not its
//              corners: a LETHAL cell stops the car when it is at most two cells beyond the cell
//              of the arc's last point (0.25 m ahead at 0.25 m/s), so its near edge is 0.30-0.35 m
//              ahead of base_link (reference §6 estimates 0.25 + 0.135 ≈ 0.385 m), inside the
//              depth camera's ≈ 0.445 m near limit (0.6 m range, camera 0.155 m behind base_link);
//   footprint  ours, the safe choice: every sample of the footprint rectangle against LETHAL
//              cells, so the corners are checked too and the car stops further away: reach
//              0.265 + 0.25 = 0.515 m ahead of base_link, beyond the camera's near limit.
enum class CollisionModel { kCentre, kFootprint };

}  // namespace autonomsim::stack

namespace autonomsim {
template <>
struct NameTable<stack::CollisionModel> {
  static constexpr std::array<std::pair<stack::CollisionModel, std::string_view>, 2> kEntries{
      {{stack::CollisionModel::kCentre, "centre"},
       {stack::CollisionModel::kFootprint, "footprint"}}};
};
}  // namespace autonomsim

namespace autonomsim::stack {

// The pure pursuit and speed regulation both controllers share. Defaults: nav2_car_params.yaml,
// identical for LaneController and FollowPath.
struct RegulatedPurePursuitParams {
  double desired_speed_mps{0.25};             // reference §2/§6: desired_linear_vel on the car
  double lookahead_dist_m{0.6};               // reference §5/§6 (lookahead_dist)
  double min_lookahead_dist_m{0.3};           // nav2_car_params (velocity-scaled lookahead only)
  double max_lookahead_dist_m{0.9};           // nav2_car_params
  double lookahead_time_s{1.5};               // nav2_car_params
  bool use_velocity_scaled_lookahead{false};  // nav2_car_params: off, L is lookahead_dist_m
  // Curvature slow-down (Nav2 RPP): below radius r_min, v_curv = v·r/r_min (Nav2 writes it
  // v·(1 − |r − r_min| / r_min)); then v = max(v_curv, regulated_min_speed_mps).
  bool use_regulated_speed_scaling{true};  // nav2_car_params
  double regulated_min_radius_m{0.9};      // reference §5: slow down below radius 0.9 m
  // nav2_car_params: 0.25 m/s, equal to the desired speed, so on the real car the curvature
  // slow-down never lowers the speed. Set it lower to let the slow-down act.
  double regulated_min_speed_mps{0.25};
  // Approach scaling (Nav2 RPP, on by default and not overridden on the car): when the carrot is
  // nearer or farther than L by more than approach_min_dist_error_m, v is scaled by
  // 1 − |L − d|/L, but not below min_approach_speed_mps.
  bool use_approach_speed_scaling{true};
  double min_approach_speed_mps{0.05};    // nav2_car_params (min_approach_linear_velocity)
  double approach_min_dist_error_m{0.1};  // Nav2: 2 × costmap resolution, 0.05 m (reference §6)

  template <class V>
  void Describe(V& v) {
    v("desired_speed_mps", desired_speed_mps, "the speed it aims for");
    v("lookahead_dist_m", lookahead_dist_m, "the carrot's distance ahead on the path");
    v("min_lookahead_dist_m", min_lookahead_dist_m,
      "`use_velocity_scaled_lookahead`: the shortest look-ahead");
    v("max_lookahead_dist_m", max_lookahead_dist_m,
      "`use_velocity_scaled_lookahead`: the longest look-ahead");
    v("lookahead_time_s", lookahead_time_s,
      "`use_velocity_scaled_lookahead`: look-ahead = speed × this");
    v("use_velocity_scaled_lookahead", use_velocity_scaled_lookahead,
      "scale the look-ahead with the speed (false: `lookahead_dist_m`)");
    v("use_regulated_speed_scaling", use_regulated_speed_scaling,
      "slow down in curves tighter than `regulated_min_radius_m`");
    v("regulated_min_radius_m", regulated_min_radius_m, "curves tighter than this slow the car");
    v("regulated_min_speed_mps", regulated_min_speed_mps,
      "the curve slow-down never goes below this");
    v("use_approach_speed_scaling", use_approach_speed_scaling,
      "slow down as the carrot comes nearer than the look-ahead");
    v("min_approach_speed_mps", min_approach_speed_mps,
      "the approach slow-down never goes below this");
    v("approach_min_dist_error_m", approach_min_dist_error_m,
      "the approach slow-down starts when the carrot is this much nearer or farther than the "
      "look-ahead");
  }
  void Validate() const;
};

// Nav2 RPP's isCollisionImminent (Galactic), with the point test chosen by `model`.
struct CollisionCheckParams {
  // reference §6: the lab's centre point against INSCRIBED (lane_controller.cpp:364-443);
  // footprint: ours (see CollisionModel).
  CollisionModel model{CollisionModel::kCentre};
  double horizon_s{1.0};  // reference §6: the arc 1.0 s ahead (max_allowed_time_to_collision)
  // Nav2 steps the arc by one costmap cell: 0.05 m (reference §6, local costmap).
  double step_m{0.05};
  // The footprint model only. reference §2: planner footprint ±0.265 × ±0.135 m.
  double footprint_half_length_m{0.265};
  double footprint_half_width_m{0.135};
  // The footprint model only. Assumed: one costmap cell; the footprint is tested as a grid of
  // points this far apart (edges included), so no 0.05 m lethal cell fits between them.
  double footprint_sample_spacing_m{0.05};

  template <class V>
  void Describe(V& v) {
    v("model", model,
      "what is tested along the arc ahead: `centre`, the lab's centre point, or `footprint`, the "
      "car's outline");
    v("horizon_s", horizon_s, "how far ahead in time the arc is tested");
    v("step_m", step_m, "the arc's step");
    v("footprint_half_length_m", footprint_half_length_m, "`footprint`: half the car's length");
    v("footprint_half_width_m", footprint_half_width_m, "`footprint`: half the car's width");
    v("footprint_sample_spacing_m", footprint_sample_spacing_m,
      "`footprint`: the tested points' spacing");
  }
  void Validate() const;
};

// The lookahead distance L at the measured speed.
double LookaheadDistance(const RegulatedPurePursuitParams& params, double speed_mps);

// κ = 2·y / (x² + y²) for a carrot in base_link; 0 when x² + y² <= 0.001 m² (Nav2).
double PurePursuitCurvature(const world::Vec2& p_base_carrot);

// The regulated speed (>= 0) for a carrot at carrot_dist_m with curvature κ and lookahead L:
// curvature slow-down, the minimum regulated speed, approach scaling, then clamp to
// [0, desired_speed_mps] (Nav2 RPP's applyConstraints without the cost term).
double RegulatedSpeed(const RegulatedPurePursuitParams& params, double curvature_per_m,
                      double lookahead_dist_m, double carrot_dist_m);

// Whether the car collides (by params.model) at X_F_base or along the (v, ω) arc from it: poses
// every step_m / |v| seconds (Euler, as Nav2) while the elapsed time is <= horizon_s. At v = 0
// only the current pose is tested. Allocates nothing; calls `cell_cost` once per point tested
// (centre: 1 + ⌊horizon·|v| / step_m⌋ points; footprint: 12 × 7 samples per pose with the
// defaults).
bool IsCollisionImminent(const CollisionCheckParams& params, const world::Pose2& X_F_base,
                         double speed_mps, double yaw_rate_rad_per_s, const CostQuery& cell_cost);

// What both controllers command for a carrot: the regulated speed along κ and ω = v·κ, or (0, 0)
// with collision_ahead when that arc collides within the horizon (no check when cell_cost is
// empty).
struct PursuitCommand {
  double speed_mps{0.0};
  double yaw_rate_rad_per_s{0.0};
  bool collision_ahead{false};
};
PursuitCommand RegulatedPursuitCommand(const RegulatedPurePursuitParams& pursuit,
                                       const CollisionCheckParams& collision,
                                       double curvature_per_m, double lookahead_dist_m,
                                       double carrot_dist_m, const world::Pose2& X_F_base,
                                       const CostQuery& cell_cost);

struct PathFollowerParams {
  RegulatedPurePursuitParams pursuit;
  CollisionCheckParams collision;
  double goal_tolerance_m{0.25};  // reference §6 (goal checker xy_goal_tolerance)
  // nav2_car_params goal_checker yaw_goal_tolerance; used when the input names a goal yaw.
  double yaw_goal_tolerance_rad{0.25};
  double max_robot_pose_search_dist_m{10.0};  // nav2_car_params
  // Nav2 keeps path points within the local costmap's half extent: 5 × 5 m (reference §6).
  double max_costmap_extent_m{2.5};

  template <class V>
  void Describe(V& v) {
    v("pursuit", pursuit, "its pure pursuit and speed regulation");
    v("collision", collision, "its check for a collision ahead");
    v("goal_tolerance_m", goal_tolerance_m, "the goal is reached this close");
    v("yaw_goal_tolerance_rad", yaw_goal_tolerance_rad,
      "and, where a goal has a heading, this close to it");
    v("max_robot_pose_search_dist_m", max_robot_pose_search_dist_m,
      "how far along the path the car's nearest point is searched");
    v("max_costmap_extent_m", max_costmap_extent_m,
      "path points beyond this distance are not followed");
  }
  void Validate() const;
};

struct PathFollowerInput {
  std::span<const world::Vec2> path;   // the planned path in frame F, start to goal
  std::uint64_t path_id{0};            // the planner's path counter: a new value restarts pruning
  world::Pose2 X_F_base;               // the pose estimate in F
  double speed_mps{0.0};               // measured forward speed (velocity-scaled lookahead only)
  std::optional<double> goal_yaw_rad;  // the goal's yaw in F, if the goal checker should test it
  CostQuery cell_cost;                 // in F; empty: no collision check
};

struct PathFollowerOutput {
  double speed_mps{0.0};  // cmd_vel linear.x
  double yaw_rate_rad_per_s{0.0};
  double curvature_per_m{0.0};  // the pure pursuit curvature (also when stopped)
  bool goal_reached{false};
  bool collision_ahead{false};
  bool no_path{false};                // empty path: the real controller throws; here (0, 0)
  std::optional<world::Vec2> carrot;  // in F
};

struct PathFollowerState {
  std::optional<std::uint64_t> path_id;  // the path the pruning index belongs to
  std::size_t begin{0};                  // the first path point not yet passed
};

// Throws std::invalid_argument on a non-finite pose, speed or path point.
PathFollowerOutput StepPathFollower(const PathFollowerParams& params,
                                    const PathFollowerInput& input, PathFollowerState* state);

}  // namespace autonomsim::stack
