#include "stack/controller_server.h"

#include <algorithm>
#include <stdexcept>
#include <utility>

#include "stack/behavior.h"
#include "stack/localization_ekf.h"

namespace autonomsim::stack {

void ProgressCheckerParams::Validate() const {
  if (!(required_movement_radius_m >= 0.0)) {
    throw std::invalid_argument("required_movement_radius_m must be >= 0");
  }
  if (movement_time_allowance <= kZeroTime) {
    throw std::invalid_argument("movement_time_allowance_s must be > 0");
  }
}

void ControllerServerParams::Validate() const {
  lane_controller.Validate();
  follow_path.Validate();
  progress_checker.Validate();
}

namespace {

// SimpleProgressChecker::check: true while the car makes progress.
bool CheckProgress(const ProgressCheckerParams& params, const world::Vec2& p, Time now,
                   ControllerServerState* state) {
  if (!state->baseline || (p - *state->baseline).norm() > params.required_movement_radius_m) {
    state->baseline = p;
    state->baseline_time = now;
    return true;
  }
  return !(now - state->baseline_time > params.movement_time_allowance);
}

// The controller selected for this cycle, and what it commands.
struct Drive {
  Twist twist;
  bool collision{false};
  bool follow{false};  // FollowPath ran (else the LaneController)
};

// Selects the controller (UseFollowPath; with follow_path_without_line also FollowPath where the
// LaneController finds no carrot) and runs it; sets out->controller and, for the LaneController,
// out->cmd_vel_stamp.
Drive SelectAndDrive(const ControllerServerParams& params,
                     std::span<const world::IntersectionSpec> intersections,
                     const ControllerServerInput& input, ControllerServerState* state,
                     ControllerServerOutput* out) {
  Drive drive;
  drive.follow = UseFollowPath(intersections, input.X_map_base.position(), params.zone_margin_m);
  out->controller =
      drive.follow ? ActiveController::kFollowPath : ActiveController::kLaneController;
  const auto follow_plan = [&] {
    if (!input.path) return;
    const PathFollowerOutput r = StepPathFollower(params.follow_path,
                                                  {.path = input.path->points_map,
                                                   .path_id = input.path->id,
                                                   .X_F_base = input.X_map_base,
                                                   .speed_mps = input.speed_mps,
                                                   .cell_cost = input.cell_cost},
                                                  &state->follower);
    drive.twist = {r.speed_mps, r.yaw_rate_rad_per_s};
    drive.collision = r.collision_ahead;
  };
  if (drive.follow) {
    follow_plan();
    return drive;
  }
  std::optional<LaneControllerOutput> lane;
  if (input.lanes) {
    lane = StepLaneController(params.lane_controller, {.lane_points_base = input.lanes->points_base,
                                                       .lanes_valid = input.lanes->valid,
                                                       .speed_mps = input.speed_mps,
                                                       .X_F_base = input.X_map_base,
                                                       .cell_cost = input.cell_cost});
  }
  if (params.follow_path_without_line && (!lane || !lane->carrot_base) && input.path) {
    drive.follow = true;  // beyond the lab's: no line to follow, the plan instead
    out->controller = ActiveController::kFollowPath;
    follow_plan();
  } else if (lane) {
    drive.twist = {lane->speed_mps, lane->yaw_rate_rad_per_s};
    drive.collision = lane->collision_ahead;
    out->cmd_vel_stamp = input.lanes->stamp;
  }
  return drive;
}

}  // namespace

ControllerServerOutput StepControllerServer(const ControllerServerParams& params,
                                            std::span<const world::IntersectionSpec> intersections,
                                            const ControllerServerInput& input,
                                            ControllerServerState* state) {
  ControllerServerOutput out;
  out.status_stamp = input.odometry_stamp;
  out.cmd_vel_stamp = input.odometry_stamp;

  // hold: cancelled, one zero velocity then silence
  if (input.hold) {
    if (!state->stopped) out.cmd_vel = Twist{};
    state->stopped = true;
    return out;
  }
  state->stopped = false;
  if (input.attempt != state->attempt) {  // a new action: the checks start again
    state->attempt = input.attempt;
    state->failed = false;
    state->baseline.reset();
  }
  const auto failed_status = [&] {
    return ControllerStatus{
        .attempt = state->attempt, .failed = true, .collision_ahead = state->failed_by_collision};
  };
  if (state->failed) {  // aborted: silent until the behaviour tries again
    out.status = failed_status();
    return out;
  }
  if (!CheckProgress(params.progress_checker, input.X_map_base.position(), input.now, state)) {
    state->failed = true;
    state->failed_by_collision = false;
    out.cmd_vel = Twist{};
    out.status = failed_status();
    return out;
  }

  // select and drive
  const Drive drive = SelectAndDrive(params, intersections, input, state, &out);
  if (drive.collision) {  // the controller threw: the action aborts with one zero velocity
    state->failed = true;
    state->failed_by_collision = true;
    out.cmd_vel = Twist{};
    out.status = failed_status();
    out.status.follow_path = drive.follow;
    return out;
  }
  out.cmd_vel = drive.twist;
  out.status = {.attempt = state->attempt, .follow_path = drive.follow};
  return out;
}

bool CanCollide(const Costmap2D& costmap) {
  std::uint8_t highest = 0;  // (a reduction without an early exit, which the compiler vectorizes)
  for (const std::uint8_t cost : costmap.costs()) highest = std::max(highest, cost);
  return highest >= kInscribedInflatedObstacle;
}

CostQuery LocalCostmapCost(std::shared_ptr<const Costmap2D> costmap,
                           const world::Pose2& X_map_odom) {
  return [costmap = std::move(costmap), to_odom = OdomPointFromMap(X_map_odom)](
             const world::Vec2& p_map) { return costmap->CostAt(to_odom(p_map)); };
}

}  // namespace autonomsim::stack
