// The car's behaviour: the lab's behaviour tree (reference §6,
// code/ros_ws/src/nav2_local/behavior_tree/drive_to_pose_test.xml, on Nav2 Galactic's BT nodes)
// as a pure step, ticked every bt_loop_duration (10 ms). It decides four things:
//   goals      the poses the global planner plans through: the route's stations (every
//              waypoint_spacing_m of arc length, fixed along the route like a waypoint mission's
//              poses) ahead of the car's estimated position out to waypoint_horizon_m (assumed:
//              how the lab sent its goals is not recorded; a plan through poses on the lane keeps
//              A* on the car's own lane);
//   gate       IntersectionFree inside RateController(3 Hz) inside the FollowPath fallback
//              (xml:19-26). Galactic's RateController (rate_controller.cpp:34-77) ticks its child
//              the first time, while the child runs, and once gate_period has passed since it
//              went from idle; otherwise it returns RUNNING, and the ReactiveFallback halts
//              FollowPath. Its timer restarts only on SUCCESS, which the Inverter never returns,
//              so after gate_period the gate is checked every tick. So each time FollowPath's
//              fallback is (re)started (the first tick, after every recovery) FollowPath runs for
//              one tick and is then halted for the rest of gate_period: `hold` with mode drive.
//              Not free: Wait(600) runs, FollowPath is halted (mode intersection_wait);
//   attempt    each time FollowPath starts again after a halt it is a new FollowPath action
//              (its id in `attempt`): the controller server resets its progress checker;
//   recovery   (xml:5-45, Galactic recovery_node.cpp:18-100, round_robin_node.cpp:20-65) a failed
//              FollowPath (the controller reports a collision ahead or no progress for its
//              attempt) first clears the local costmap and retries at once (inner RecoveryNode,
//              follow_path_retries); when that fails too, the outer RecoveryNode runs its
//              RoundRobin, which alternates "clear both costmaps" (instant) and Wait
//              recovery_wait, then retries; after max_retries outer retries the next failure
//              fails the navigation for good. A failed plan first clears the global costmap and
//              waits for the next plan (inner RecoveryNode of ComputePathToPose, xml:9-15); a
//              second failed plan goes to the outer recovery. The outer count resets only when
//              the goal succeeds or the tree is halted (recovery_node.cpp:102-107), which a car
//              looping its route never does: recovery_reset_m (safe) resets it after progress.
// The route is map knowledge (the road graph a car is given); the position is the estimate.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "world/enum_names.h"
#include "world/geometry.h"
#include "world/polyline.h"
#include "world/time.h"
#include "world/track_spec.h"

namespace autonomsim::stack {

struct BehaviorParams {
  // reference §6: bt_loop_duration 10 ms (nav2_car_params.yaml:7)
  Duration tick_period{Milliseconds(10)};
  // reference §6: RateController hz=3 around IntersectionFree (drive_to_pose_test.xml:19)
  Duration gate_period{333'333'333};  // 1/3 s
  // assumed: the goals go to the planner (which plans at 1 Hz) at least this often; the tree's
  // other outputs (hold, attempt, recovery) go out on the tick they change
  Duration goals_period{333'333'333};  // 1/3 s
  // assumed: NavigateThroughPoses goals along the lane, one every quarter metre. Between goals
  // the cost term of A* pulls the path towards the middle of free space (at 0.25 m spacing up to
  // 0.08 m off the lane on the lab's map: GlobalPlannerLabTest)
  double waypoint_spacing_m{0.25};
  // assumed: the goals reach as far ahead as the local costmap's half width (reference §6: 5 m
  // rolling window), so the path always covers the controller's 0.6 m lookahead
  double waypoint_horizon_m{2.5};
  Duration recovery_wait{std::chrono::seconds(5)};  // reference §6: Wait 5 s (xml:42)
  int max_retries{6};                               // reference §6: outer RecoveryNode (xml:5)
  int follow_path_retries{1};                       // reference §6: inner RecoveryNode (xml:17)
  int plan_retries{1};                              // reference §6: ComputePathToPose's (xml:9)
  // Beyond the lab's tree (0: never, as the lab's: the count resets only when the goal
  // succeeds). Driving this far along the route after a recovery resets the outer count, so a
  // car that lapped for minutes is not one blocked moment away from failing for good.
  double recovery_reset_m{0.0};
  // assumed: how far the car's position may move along the route between two ticks, for
  // tracking it on the route
  double tracking_window_m{1.0};
  // Beyond the lab's BT (false: every recovery counts): a collision ahead within
  // queue_margin_m of an intersection's boxes starts a recovery (clear, wait recovery_wait,
  // retry) that does not count toward max_retries. A car queued behind cars waiting at a red
  // light otherwise uses up its retries while it waits in line.
  bool patient_in_queue{false};
  double queue_margin_m{1.5};  // assumed: three cars' lengths back from a stop box
  // Beyond the lab's BT (patient_in_queue only): how long a car waiting in line waits before it
  // tries again. The line moves when the light ahead changes, not on the recovery's 5 s clock;
  // with 5 s the outer-loop car of a six-car fleet lost up to 20 s a lap in line (2 of 20 seeds
  // short of two laps in 200 s). Default: the lab tree's only wait, Wait 5 s (xml:42); safe sets
  // 2 s (assumed).
  Duration queue_wait{std::chrono::seconds(5)};
  // Beyond the lab's BT (0: off, the lab's IntersectionFree keeps the last message for ever): in a
  // stop zone, a permission older than this counts as "not free", so a car whose intersection
  // client died (a crashed or hung vehicle_communication node) waits at the next stop line
  // instead of driving on a stale "free" through every intersection; it still clears the one it
  // is in. Assumed 1 s: ten of the client's 100 ms ticks.
  Duration intersection_free_timeout{kZeroTime};

  template <class V>
  void Describe(V& v) {
    v("tick_period_s", tick_period, "how often the behaviour tree ticks");
    v("gate_period_s", gate_period, "how often it asks whether the intersection ahead is free");
    v("goals_period_s", goals_period, "how often it sends the goals ahead to the planner");
    v("waypoint_spacing_m", waypoint_spacing_m, "the goals' spacing along the lane");
    v("waypoint_horizon_m", waypoint_horizon_m, "how far ahead along the route the goals reach");
    v("recovery_wait_s", recovery_wait, "a recovery's wait before the car tries again");
    v("max_retries", max_retries, "recoveries before the navigation fails for good");
    v("follow_path_retries", follow_path_retries, "FollowPath's retries before a recovery");
    v("plan_retries", plan_retries, "the planner's retries before a recovery");
    v("recovery_reset_m", recovery_reset_m,
      "driving this far after a recovery resets the count of retries (lab: 0, never)");
    v("tracking_window_m", tracking_window_m,
      "how far the car's position may move along the route between two ticks, to track it on the "
      "route");
    v("patient_in_queue", patient_in_queue,
      "a car stopped behind a queue near an intersection waits without using up its retries (lab: "
      "false)");
    v("queue_margin_m", queue_margin_m,
      "`patient_in_queue`: how far back from an intersection's boxes a stop counts as queueing");
    v("queue_wait_s", queue_wait,
      "`patient_in_queue`: how long a queued car waits before it tries again");
    v("intersection_free_timeout_s", intersection_free_timeout,
      "in a stop zone, a permission older than this counts as not free (lab: 0, off)");
  }
  void Validate() const;
};

enum class BehaviorMode {
  kDrive,             // following the goals (held while the gate's RateController throttles)
  kIntersectionWait,  // held until the intersection is granted
  kRecovery,          // the RoundRobin's Wait (or a patient car's): held, then retry
  kFailed,            // retries exhausted: holds for good
  kDone,              // the end of an open route, or the mission was ended
};
const char* ToString(BehaviorMode mode);

// What a recovery did on this tick (none on most ticks).
enum class RecoveryAction {
  kNone,
  kClearLocal,   // FollowPath's inner recovery: clear the local costmap, retry at once
  kClearGlobal,  // ComputePathToPose's inner recovery: clear the global costmap, plan again
  kClearBoth,    // the outer RoundRobin's first action: clear both costmaps, retry
  kWait,         // the outer RoundRobin's second action: wait recovery_wait, then retry
  kWaitInLine,   // patient_in_queue: clear the local costmap, wait queue_wait, retry (not counted)
};

}  // namespace autonomsim::stack

namespace autonomsim {
// The words of the `behavior` events' detail ("drive (clear local costmap, retry 1)").
template <>
struct NameTable<stack::RecoveryAction> {
  using A = stack::RecoveryAction;
  static constexpr std::array<std::pair<A, std::string_view>, 6> kEntries{
      {{A::kNone, "none"},
       {A::kClearLocal, "clear local costmap"},
       {A::kClearGlobal, "clear global costmap"},
       {A::kClearBoth, "clear both costmaps"},
       {A::kWait, "round-robin wait"},
       {A::kWaitInLine, "wait in line"}}};
};
}  // namespace autonomsim

namespace autonomsim::stack {

// Whether the action clears the local costmap (all but kClearGlobal and kWait; the global costmap
// holds only the static map here, which a clear restores at once).
constexpr bool ClearsLocalCostmap(RecoveryAction action) {
  return action == RecoveryAction::kClearLocal || action == RecoveryAction::kClearBoth ||
         action == RecoveryAction::kWaitInLine;
}

// The controller server's report that a FollowPath action failed (it throws, the action aborts).
struct FollowPathFailure {
  std::uint64_t attempt{0};  // the action that failed
  bool collision{false};     // a collision ahead (else: no progress)
};

struct BehaviorInput {
  Time now{kZeroTime};
  world::Vec2 p_map{world::Vec2::Zero()};  // the estimated position
  bool intersection_free{true};            // the intersection client's permission
  // The sensor time of the newest permission (intersection_free_timeout); none before the first.
  std::optional<Time> intersection_free_stamp;
  // The controller's newest failure report; one for an earlier attempt is ignored.
  std::optional<FollowPathFailure> follow_path_failure;
  // The newest plan reply since the previous tick: true when it failed; none when no reply came.
  std::optional<bool> plan_failed;
  bool mission_done{false};  // the operator ended the drive (laps done)
  // Whether the estimate is within queue_margin_m of an intersection's boxes (patient_in_queue).
  bool near_intersection{false};
  // Whether the estimate is in a stop zone (intersection_free_timeout; InStopZone).
  bool in_stop_zone{false};
};

struct BehaviorOutput {
  BehaviorMode mode{BehaviorMode::kDrive};
  bool hold{false};                // FollowPath halted: the controller must not drive
  std::uint64_t attempt{0};        // the current FollowPath action (new after every halt)
  std::vector<world::Vec2> goals;  // map frame, nearest first; empty once failed or done
  RecoveryAction recovery{RecoveryAction::kNone};
  int retries{0};  // outer retries so far
};

struct BehaviorState {
  bool started{false};
  double route_s_m{0.0};  // the estimated position's projection on the route
  BehaviorMode mode{BehaviorMode::kDrive};
  Time recovery_until{kZeroTime};
  bool recovery_counts{true};  // the running wait is the outer recovery's (else a patient car's)
  int retries{0};              // the outer RecoveryNode's count
  int follow_path_retries{0};  // the inner RecoveryNode's count for FollowPath
  int plan_retries{0};         // the inner RecoveryNode's count for ComputePathToPose
  int round_robin{0};          // the RoundRobin's next child: 0 clear both, 1 wait
  double progress_since_recovery_m{0.0};
  bool plan_failed{false};  // the latest plan reply failed, and no recovery has run since
  // the gate's RateController: idle (restarts its period on the next tick), its start, whether
  // its child has been ticked since, and whether the child (Wait) is running
  bool gate_idle{true};
  Time gate_start{kZeroTime};
  bool gate_ticked{false};
  bool gate_waiting{false};
  bool following{false};            // FollowPath is running (not halted)
  std::uint64_t attempt{0};         // the newest FollowPath action
  std::uint64_t failed_attempt{0};  // the newest attempt whose failure was handled (0: none)
};

// Throws std::invalid_argument on a non-finite position.
BehaviorOutput StepBehavior(const BehaviorParams& params, const world::Polyline& route,
                            const BehaviorInput& input, BehaviorState* state);

// Which controller the controller server runs (reference §6, /controller_selector): FollowPath
// inside an intersection's area or stop zones (strict boxes, as the real cars test them),
// LaneController elsewhere. With margin_m > 0 (beyond the lab's), also within margin_m of a box.
bool UseFollowPath(std::span<const world::IntersectionSpec> intersections, const world::Vec2& p_map,
                   double margin_m = 0.0);

// Whether p_map is in a stop zone of one of the intersections (strict boxes, as the client tests).
bool InStopZone(std::span<const world::IntersectionSpec> intersections, const world::Vec2& p_map);

}  // namespace autonomsim::stack
