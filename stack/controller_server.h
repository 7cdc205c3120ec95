// The controller server (reference §6: Nav2's controller_server on the car with the lab's
// /controller_selector) as one pure cycle, run at 20 Hz on the latest messages its node holds:
//   hold      while the behaviour holds the car (stack/behavior.h: intersection wait, recovery,
//             failed, done; and before its first goals) the controller is cancelled: one zero
//             velocity goes out (Nav2's publishZeroVelocity), then nothing on cmd_vel until the
//             car may drive again;
//   select    FollowPath inside an intersection's area or stop zones (UseFollowPath), the
//             LaneController elsewhere; with follow_path_without_line (beyond the lab's) also
//             FollowPath on a cycle where the LaneController finds no carrot;
//   drive     FollowPath (stack/path_follower.h) on the newest successful plan, the
//             LaneController (stack/lane_controller.h) on the newest lane points; a controller
//             with nothing to follow yet commands (0, 0);
//   stamp     the twist carries the lane points' stamp when the LaneController ran on them (so the
//             latency chain from the camera reaches the actuator command), else the odometry's;
//   progress  Nav2's SimpleProgressChecker (reference §6; nav2_car_params.yaml:67-70; Galactic
//             simple_progress_checker.cpp:63-92): reset when a FollowPath action starts (a new
//             `attempt` from the behaviour, nav2_controller.cpp:356-357); the car must move more
//             than required_movement_radius_m from its baseline within
//             movement_time_allowance_s, else the action fails ("Failed to make progress") —
//             also a car that stands because its LaneController sees no line;
//   fail      a controller that sees a collision ahead throws, and so does the progress check:
//             the action aborts (nav2_controller.cpp:395-398): one zero velocity, then nothing
//             until the behaviour starts a new attempt; the status reports the failed attempt;
//   status    every cycle, stamped with the odometry: the attempt, whether it failed (and by a
//             collision), FollowPath selected (all false while held).
// Differences from the real node: the real node reads its costmap in-process; here the caller
// passes the cost query (LocalCostmapCost on the latest local costmap).
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <span>

#include "stack/costmap.h"
#include "stack/lane_controller.h"
#include "stack/path_follower.h"
#include "world/geometry.h"
#include "world/time.h"
#include "world/track_spec.h"

namespace autonomsim::stack {

// Nav2's SimpleProgressChecker with the car's parameters (reference §6).
struct ProgressCheckerParams {
  double required_movement_radius_m{0.5};                      // nav2_car_params.yaml:69
  Duration movement_time_allowance{std::chrono::seconds(10)};  // nav2_car_params.yaml:70

  template <class V>
  void Describe(V& v) {
    v("required_movement_radius_m", required_movement_radius_m,
      "the car must move this far within `movement_time_allowance_s`");
    v("movement_time_allowance_s", movement_time_allowance, "or the controller gives up");
  }
  void Validate() const;
};

// Assembled by the node from the stack's lane_controller and follow_path entries.
struct ControllerServerParams {
  LaneControllerParams lane_controller;
  PathFollowerParams follow_path;
  // Beyond the lab's /controller_selector (0: its strict boxes): FollowPath also within this
  // distance of an intersection's area and stop zones (stack.controller_selector.zone_margin_m).
  double zone_margin_m{0.0};
  // Beyond the lab's (false: without a lane point beyond the lookahead its LaneController has the
  // origin for a carrot and stops, lane_controller.cpp:343-362): on a cycle where the
  // LaneController finds no carrot, FollowPath drives on the plan instead
  // (stack.controller_selector.follow_path_without_line).
  bool follow_path_without_line{false};
  ProgressCheckerParams progress_checker;

  void Validate() const;
};

// The newest lane points (LanePoints, reference §5), decoded to base_link.
struct ControllerLanes {
  std::span<const world::Vec2> points_base;  // read only when valid
  bool valid{false};
  Time stamp{kZeroTime};  // the camera frame's
};

// The newest successful plan (/plan).
struct ControllerPath {
  std::span<const world::Vec2> points_map;  // start to goal
  std::uint64_t id{0};                      // the planner's counter: a new id restarts pruning
};

struct ControllerServerInput {
  Time now{kZeroTime};       // the cycle's time (the progress checker's clock)
  bool hold{true};           // the behaviour's newest hold; true before its first output
  std::uint64_t attempt{0};  // the behaviour's FollowPath action: a new one resets the checks
  // The newest odometry (the node runs no cycle before the first).
  Time odometry_stamp{kZeroTime};
  world::Pose2 X_map_base;
  double speed_mps{0.0};
  std::optional<ControllerLanes> lanes;  // none: no lane points received yet
  std::optional<ControllerPath> path;    // none: no successful plan received yet
  // map frame; empty: no costmap yet (or none a pose can collide on, CanCollide), no check
  CostQuery cell_cost;
};

// geometry_msgs/Twist on cmd_vel.
struct Twist {
  double speed_mps{0.0};           // linear.x
  double yaw_rate_rad_per_s{0.0};  // angular.z
};

// /controller/status, read by the behaviour.
struct ControllerStatus {
  std::uint64_t attempt{0};     // the FollowPath action it reports on
  bool failed{false};           // that action failed (and stays failed)
  bool collision_ahead{false};  // it failed by a collision ahead (else: no progress)
  bool follow_path{false};      // FollowPath selected (else the LaneController)
};

enum class ActiveController { kNone, kLaneController, kFollowPath };

struct ControllerServerOutput {
  std::optional<Twist> cmd_vel;  // to publish; none: silent (held, its zero already sent)
  Time cmd_vel_stamp{kZeroTime};
  ControllerStatus status;  // published every cycle
  Time status_stamp{kZeroTime};
  ActiveController controller{ActiveController::kNone};  // the one selected; kNone while held
};

struct ControllerServerState {
  bool stopped{false};  // the zero velocity of the current hold went out
  PathFollowerState follower;
  std::uint64_t attempt{0};  // the action the checks below belong to
  bool failed{false};        // it failed: silent until the next attempt
  bool failed_by_collision{false};
  std::optional<world::Vec2> baseline;  // the progress checker's baseline position (map)
  Time baseline_time{kZeroTime};
};

// `intersections` are the zone boxes of the map the car is given. Throws std::invalid_argument
// where the controllers do (non-finite pose, speed, path or valid lane points).
ControllerServerOutput StepControllerServer(const ControllerServerParams& params,
                                            std::span<const world::IntersectionSpec> intersections,
                                            const ControllerServerInput& input,
                                            ControllerServerState* state);

// The local costmap's (odom frame) cost at a map-frame point, through the static map→odom
// transform; nullopt outside the costmap. Keeps the costmap alive.
CostQuery LocalCostmapCost(std::shared_ptr<const Costmap2D> costmap,
                           const world::Pose2& X_map_odom);

// Whether the collision check can find a collision on `costmap`: some cell's cost is at least
// INSCRIBED (the centre model's threshold; the footprint model's LETHAL is above it). Where none
// is, the check answers "no collision" for every pose, and a caller may leave it out (no query).
bool CanCollide(const Costmap2D& costmap);

}  // namespace autonomsim::stack
