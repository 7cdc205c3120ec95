#include "stack/behavior.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace autonomsim::stack {

void BehaviorParams::Validate() const {
  if (tick_period <= kZeroTime) throw std::invalid_argument("tick_period_s must be > 0");
  if (!(waypoint_spacing_m > 0.0)) throw std::invalid_argument("waypoint_spacing_m must be > 0");
  if (!(waypoint_horizon_m >= waypoint_spacing_m)) {
    throw std::invalid_argument("waypoint_horizon_m must be >= waypoint_spacing_m");
  }
  if (recovery_wait < kZeroTime) throw std::invalid_argument("recovery_wait_s must be >= 0");
  if (max_retries < 0) throw std::invalid_argument("max_retries must be >= 0");
  if (!(recovery_reset_m >= 0.0)) throw std::invalid_argument("recovery_reset_m must be >= 0");
  if (!(tracking_window_m > 0.0)) throw std::invalid_argument("tracking_window_m must be > 0");
  if (intersection_free_timeout < kZeroTime) {
    throw std::invalid_argument("intersection_free_timeout_s must be >= 0 (0: off)");
  }
  if (!(queue_margin_m >= 0.0 && queue_margin_m <= 5.0)) {
    throw std::invalid_argument("queue_margin_m must be in [0, 5] m");
  }
}

const char* ToString(BehaviorMode mode) {
  switch (mode) {
    case BehaviorMode::kDrive:
      return "drive";
    case BehaviorMode::kIntersectionWait:
      return "intersection_wait";
    case BehaviorMode::kRecovery:
      return "recovery";
    case BehaviorMode::kFailed:
      return "failed";
    case BehaviorMode::kDone:
      return "done";
  }
  return "?";
}

namespace {

// Goals every spacing from the position's projection (exclusive) out to the horizon; an open
// route's goals stop at its end, which is always the last goal once within the horizon.
std::vector<world::Vec2> GoalsAhead(const BehaviorParams& params, const world::Polyline& route,
                                    double s_m) {
  std::vector<world::Vec2> goals;
  const double end_m = route.cyclic() ? s_m + params.waypoint_horizon_m
                                      : std::min(s_m + params.waypoint_horizon_m, route.length_m());
  for (double s = s_m + params.waypoint_spacing_m; s < end_m + 1e-9;
       s += params.waypoint_spacing_m) {
    goals.push_back(route.PointAt(s));
  }
  if (!route.cyclic() && end_m >= route.length_m() - 1e-9 &&
      (goals.empty() || (goals.back() - route.PointAt(route.length_m())).norm() > 1e-9)) {
    goals.push_back(route.PointAt(route.length_m()));
  }
  return goals;
}

}  // namespace

BehaviorOutput StepBehavior(const BehaviorParams& params, const world::Polyline& route,
                            const BehaviorInput& input, BehaviorState* state) {
  if (!std::isfinite(input.p_map.x()) || !std::isfinite(input.p_map.y())) {
    throw std::invalid_argument("StepBehavior: non-finite position");
  }
  if (input.plan_failed) state->plan_failed = *input.plan_failed;
  // where the estimate is along the route
  const double previous_s = state->route_s_m;
  state->route_s_m =
      state->started
          ? route.ProjectNear(input.p_map, state->route_s_m, params.tracking_window_m).s_m
          : route.Project(input.p_map).s_m;
  if (state->started) {
    double ds = state->route_s_m - previous_s;
    if (route.cyclic()) ds = std::remainder(ds, route.length_m());
    state->progress_since_recovery_m += ds;
  }
  state->started = true;

  BehaviorOutput out;
  const bool at_end =
      !route.cyclic() && state->route_s_m >= route.length_m() - params.waypoint_spacing_m;
  if (input.mission_done || at_end) state->mode = BehaviorMode::kDone;

  if (state->mode != BehaviorMode::kDone && state->mode != BehaviorMode::kFailed) {
    if (state->retries > 0 && state->mode == BehaviorMode::kDrive &&
        state->progress_since_recovery_m >= params.recovery_reset_m) {
      state->retries = 0;  // the navigation succeeded again
    }
    if (state->mode == BehaviorMode::kRecovery && input.now >= state->recovery_until) {
      state->mode = BehaviorMode::kDrive;  // retry
    }
    if (state->mode != BehaviorMode::kRecovery) {
      const bool stale =
          params.intersection_free_timeout > kZeroTime && input.in_stop_zone &&
          (!input.intersection_free_stamp ||
           input.now - *input.intersection_free_stamp > params.intersection_free_timeout);
      if (!input.intersection_free || stale) {
        state->mode = BehaviorMode::kIntersectionWait;
      } else if (input.collision_ahead && !state->plan_failed && params.patient_in_queue &&
                 input.near_intersection) {
        state->mode = BehaviorMode::kRecovery;  // waiting in line: not a failure
        state->recovery_until = input.now + params.recovery_wait;
        state->progress_since_recovery_m = 0.0;
        out.clear_costmaps = true;
      } else if (input.collision_ahead || state->plan_failed) {
        if (state->retries >= params.max_retries) {
          state->mode = BehaviorMode::kFailed;
        } else {
          ++state->retries;
          state->mode = BehaviorMode::kRecovery;
          state->recovery_until = input.now + params.recovery_wait;
          state->progress_since_recovery_m = 0.0;
          out.clear_costmaps = true;
        }
      } else {
        state->mode = BehaviorMode::kDrive;
      }
    }
  }

  if (out.clear_costmaps) state->plan_failed = false;  // the planner plans again after recovery
  out.mode = state->mode;
  out.retries = state->retries;
  out.hold = state->mode != BehaviorMode::kDrive;
  // the goals stay set while held (the planner keeps planning; the controller does not drive)
  if (state->mode != BehaviorMode::kDone && state->mode != BehaviorMode::kFailed) {
    out.goals = GoalsAhead(params, route, state->route_s_m);
  }
  return out;
}

bool UseFollowPath(std::span<const world::IntersectionSpec> intersections, const world::Vec2& p_map,
                   double margin_m) {
  auto within = [&](const world::Box& box) {
    if (margin_m <= 0.0) return box.Contains(p_map);
    return p_map.x() > box.x_min_m - margin_m && p_map.x() < box.x_max_m + margin_m &&
           p_map.y() > box.y_min_m - margin_m && p_map.y() < box.y_max_m + margin_m;
  };
  for (const world::IntersectionSpec& i : intersections) {
    if (within(i.area)) return true;
    for (const world::Box& zone : i.stop_zones) {
      if (within(zone)) return true;
    }
  }
  return false;
}

bool InStopZone(std::span<const world::IntersectionSpec> intersections, const world::Vec2& p_map) {
  for (const world::IntersectionSpec& i : intersections) {
    for (const world::Box& zone : i.stop_zones) {
      if (zone.Contains(p_map)) return true;
    }
  }
  return false;
}

}  // namespace autonomsim::stack
