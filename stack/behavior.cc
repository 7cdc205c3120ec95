#include "stack/behavior.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>

namespace autonomsim::stack {

void BehaviorParams::Validate() const {
  if (tick_period <= kZeroTime) throw std::invalid_argument("tick_period_s must be > 0");
  if (gate_period < kZeroTime) throw std::invalid_argument("gate_period_s must be >= 0");
  if (goals_period <= kZeroTime) throw std::invalid_argument("goals_period_s must be > 0");
  if (!(waypoint_spacing_m > 0.0)) throw std::invalid_argument("waypoint_spacing_m must be > 0");
  if (!(waypoint_horizon_m >= waypoint_spacing_m)) {
    throw std::invalid_argument("waypoint_horizon_m must be >= waypoint_spacing_m");
  }
  if (recovery_wait < kZeroTime) throw std::invalid_argument("recovery_wait_s must be >= 0");
  if (max_retries < 0) throw std::invalid_argument("max_retries must be >= 0");
  if (follow_path_retries < 0) throw std::invalid_argument("follow_path_retries must be >= 0");
  if (plan_retries < 0) throw std::invalid_argument("plan_retries must be >= 0");
  if (!(recovery_reset_m >= 0.0)) {
    throw std::invalid_argument("recovery_reset_m must be >= 0 (0: never, as the lab's tree)");
  }
  if (!(tracking_window_m > 0.0)) throw std::invalid_argument("tracking_window_m must be > 0");
  if (intersection_free_timeout < kZeroTime) {
    throw std::invalid_argument("intersection_free_timeout_s must be >= 0 (0: off)");
  }
  if (queue_wait < kZeroTime) throw std::invalid_argument("queue_wait_s must be >= 0");
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

// Goals at the route's stations (arc lengths that are whole multiples of the spacing) after the
// position's projection (exclusive) out to the horizon; an open route's goals stop at its end,
// which is always the last goal once within the horizon. A station is n · spacing, computed the
// same way every time, so the goals two ticks share are the same points bit for bit (the planner
// node plans each leg between two goals once: PlanLegMemo).
std::vector<world::Vec2> GoalsAhead(const BehaviorParams& params, const world::Polyline& route,
                                    double s_m) {
  std::vector<world::Vec2> goals;
  const double end_m = route.cyclic() ? s_m + params.waypoint_horizon_m
                                      : std::min(s_m + params.waypoint_horizon_m, route.length_m());
  const double spacing = params.waypoint_spacing_m;
  // (one allocation, not one per doubling: the count is known to within the end's rounding; a
  // horizon too long to hold is left to grow, as before)
  const double count = (end_m - s_m) / spacing;
  if (count >= 0.0 && count < 1e6) goals.reserve(static_cast<std::size_t>(count) + 2);
  for (auto n = static_cast<std::int64_t>(std::floor(s_m / spacing)) + 1;
       static_cast<double>(n) * spacing < end_m + 1e-9; ++n) {
    const double s = static_cast<double>(n) * spacing;
    if (s <= s_m) continue;  // floor's rounding at a station
    goals.push_back(route.PointAt(s));
  }
  if (!route.cyclic() && end_m >= route.length_m() - 1e-9 &&
      (goals.empty() || (goals.back() - route.PointAt(route.length_m())).norm() > 1e-9)) {
    goals.push_back(route.PointAt(route.length_m()));
  }
  return goals;
}

// One tick of the tree below the navigation's end, as the lab's XML composes Galactic's nodes.
class Tick {
 public:
  Tick(const BehaviorParams& params, const BehaviorInput& input, BehaviorState* state,
       BehaviorOutput* out)
      : p_(params), in_(input), s_(*state), out_(*out) {}

  void Run() {
    if (s_.retries > 0 && p_.recovery_reset_m > 0.0 && s_.mode == BehaviorMode::kDrive &&
        s_.progress_since_recovery_m >= p_.recovery_reset_m) {
      s_.retries = 0;  // safe: the navigation succeeded again
    }
    if (s_.mode == BehaviorMode::kRecovery) {
      if (in_.now < s_.recovery_until) return;
      if (s_.recovery_counts) ++s_.retries;  // the Wait succeeded: the outer node counts it
      s_.plan_failed = false;                // the planner was not asked during the wait
      Restart();
    }
    if (HandlePlanFailure()) return;
    // FollowPath sees its action's result only when it is ticked again: the gate is checked
    // first, and a throttled or waiting gate halts it instead (the ReactiveFallback, xml:18-28)
    const bool was_following = s_.following;
    const std::uint64_t attempt = s_.attempt;
    Gate();
    if (s_.following && was_following && s_.attempt == attempt) HandleFollowPathFailure();
  }

 private:
  // The pipeline (FollowPath's fallback and its gate) starts again: the gate's RateController
  // is idle, FollowPath halted.
  void Restart() {
    s_.mode = BehaviorMode::kDrive;
    s_.gate_idle = true;
    s_.gate_waiting = false;
    s_.following = false;
    s_.follow_path_retries = 0;
  }

  // The outer RecoveryNode: the RoundRobin's next action, or the navigation fails.
  void OuterRecovery() {
    s_.follow_path_retries = 0;
    s_.plan_retries = 0;
    s_.plan_failed = false;
    if (s_.retries >= p_.max_retries) {
      s_.mode = BehaviorMode::kFailed;
      s_.following = false;
      return;
    }
    if (s_.round_robin == 0) {
      out_.recovery = RecoveryAction::kClearBoth;
      ++s_.retries;  // instant success
      Restart();
    } else {
      out_.recovery = RecoveryAction::kWait;
      StartWait(/*counts=*/true);
    }
    s_.round_robin = 1 - s_.round_robin;
    s_.progress_since_recovery_m = 0.0;
  }

  void StartWait(bool counts) {
    Restart();
    s_.mode = BehaviorMode::kRecovery;
    s_.recovery_until = in_.now + (counts ? p_.recovery_wait : p_.queue_wait);
    s_.recovery_counts = counts;
  }

  // ComputePathToPose failed: clear the global costmap and plan again, then the outer recovery.
  bool HandlePlanFailure() {
    if (!s_.plan_failed) return false;
    s_.plan_failed = false;
    if (s_.plan_retries < p_.plan_retries) {
      ++s_.plan_retries;
      out_.recovery = RecoveryAction::kClearGlobal;
      return false;  // FollowPath keeps running on the previous plan meanwhile
    }
    OuterRecovery();
    return true;
  }

  // FollowPath failed (the controller's report for the running attempt).
  bool HandleFollowPathFailure() {
    if (!in_.follow_path_failure || in_.follow_path_failure->attempt != s_.attempt ||
        s_.failed_attempt == s_.attempt) {
      return false;
    }
    s_.failed_attempt = s_.attempt;
    if (p_.patient_in_queue && in_.follow_path_failure->collision && in_.near_intersection) {
      out_.recovery = RecoveryAction::kWaitInLine;  // waiting in line: not a failure
      StartWait(/*counts=*/false);
      s_.progress_since_recovery_m = 0.0;
      return true;
    }
    if (s_.follow_path_retries < p_.follow_path_retries) {
      const int inner = s_.follow_path_retries + 1;
      Restart();
      s_.follow_path_retries = inner;
      out_.recovery = RecoveryAction::kClearLocal;
      return true;
    }
    OuterRecovery();
    return true;
  }

  // RateController(gate_period) around Inverter(ReactiveFallback(IntersectionFree, Wait)), then
  // FollowPath (rate_controller.cpp:34-77).
  void Gate() {
    if (s_.gate_idle) {
      s_.gate_idle = false;
      s_.gate_start = in_.now;
      s_.gate_ticked = false;
    }
    const bool tick_child =
        !s_.gate_ticked || s_.gate_waiting || in_.now - s_.gate_start >= p_.gate_period;
    if (!tick_child) {  // throttled: RUNNING, FollowPath halted
      s_.following = false;
      return;
    }
    s_.gate_ticked = true;
    const bool stale = p_.intersection_free_timeout > kZeroTime && in_.in_stop_zone &&
                       (!in_.intersection_free_stamp ||
                        in_.now - *in_.intersection_free_stamp > p_.intersection_free_timeout);
    s_.gate_waiting = !in_.intersection_free || stale;
    if (s_.gate_waiting) {
      s_.mode = BehaviorMode::kIntersectionWait;
      s_.following = false;
      return;
    }
    s_.mode = BehaviorMode::kDrive;
    if (!s_.following) {
      s_.following = true;
      ++s_.attempt;  // a new FollowPath action
    }
  }

  const BehaviorParams& p_;
  const BehaviorInput& in_;
  BehaviorState& s_;
  BehaviorOutput& out_;
};

}  // namespace

BehaviorOutput StepBehavior(const BehaviorParams& params, const world::Polyline& route,
                            const BehaviorInput& input, BehaviorState* state) {
  if (!std::isfinite(input.p_map.x()) || !std::isfinite(input.p_map.y())) {
    throw std::invalid_argument("StepBehavior: non-finite position");
  }
  if (input.plan_failed) {
    state->plan_failed = *input.plan_failed;
    if (!*input.plan_failed) state->plan_retries = 0;  // its RecoveryNode succeeded: reset
  }
  // where the estimate is along the route
  const double previous_s = state->route_s_m;
  state->route_s_m =
      state->started
          ? route.ProjectNear(input.p_map, state->route_s_m, params.tracking_window_m).s_m
          : route.Project(input.p_map).s_m;
  if (state->started) {
    double ds = state->route_s_m - previous_s;
    if (route.cyclic()) ds = world::Remainder(ds, route.length_m());
    state->progress_since_recovery_m += ds;
  }
  state->started = true;

  BehaviorOutput out;
  const bool at_end =
      !route.cyclic() && state->route_s_m >= route.length_m() - params.waypoint_spacing_m;
  if (input.mission_done || at_end) state->mode = BehaviorMode::kDone;
  if (state->mode != BehaviorMode::kDone && state->mode != BehaviorMode::kFailed) {
    Tick(params, input, state, &out).Run();
  }
  if (state->mode == BehaviorMode::kDone || state->mode == BehaviorMode::kFailed) {
    state->following = false;
  }
  out.mode = state->mode;
  out.retries = state->retries;
  out.attempt = state->attempt;
  out.hold = !state->following;
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
