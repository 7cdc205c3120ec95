// The car's behaviour (reference §6: Nav2's behaviour tree on the car) as a pure step, ticked at
// 3 Hz. It decides three things:
//   goals      the poses the global planner plans through (Nav2 NavigateThroughPoses): points on
//              the car's route, every waypoint_spacing_m from the car's estimated position out to
//              waypoint_horizon_m ahead. A plan through poses on the lane keeps A* on the car's own
//              lane (one goal far ahead lets it take the shorter, wrong lane of the middle road);
//   gate       the IntersectionFree condition: while the intersection client says "wait", a long
//              Wait pre-empts the controller (hold);
//   recovery   when the controller reports a collision ahead (or the planner finds no path):
//              clear the costmaps, wait recovery_wait, retry; after max_retries failed retries
//              the navigation fails and the car holds for good. Progress of recovery_reset_m along
//              the route since the last recovery counts as a success and resets the count.
//              A failed plan counts until the next plan reply or until a recovery starts: the
//              planner replies at 1 Hz and the tree ticks at 3 Hz, and Nav2 plans again after a
//              recovery, so the old failure must not start a second one.
// The route is map knowledge (the road graph a car is given); the position is the estimate.
#pragma once

#include <optional>
#include <span>
#include <vector>

#include "world/geometry.h"
#include "world/polyline.h"
#include "world/time.h"
#include "world/track_spec.h"

namespace autonomsim::stack {

struct BehaviorParams {
  Duration tick_period{Milliseconds(333)};  // reference §6: the BT ticks IntersectionFree at 3 Hz
  // assumed: NavigateThroughPoses goals along the lane, one every quarter metre. Between goals
  // the cost term of A* pulls the path towards the middle of free space (at 0.5 m spacing up to
  // 0.16 m off the lane on the lab; at 0.25 m 0.11 m: GlobalPlannerLabTest)
  double waypoint_spacing_m{0.25};
  // assumed: the goals reach as far ahead as the local costmap's half width (reference §6: 5 m
  // rolling window), so the path always covers the controller's 0.6 m lookahead
  double waypoint_horizon_m{2.5};
  Duration recovery_wait{std::chrono::seconds(5)};  // reference §6: recovery waits 5 s
  int max_retries{6};                               // reference §6: up to 6 retries
  // assumed: driving this far along the route after a recovery counts as the navigation
  // succeeding again (Nav2 resets a RecoveryNode's count when its child succeeds)
  double recovery_reset_m{0.5};
  // assumed: how far the car's position may move along the route between two ticks (3 Hz at
  // 0.25 m/s: 0.08 m), for tracking it on the route
  double tracking_window_m{1.0};
  // Beyond the lab's BT (false: every recovery counts): a collision ahead within
  // queue_margin_m of an intersection's boxes starts a recovery that does not count toward
  // max_retries. A car queued behind cars waiting at a red light otherwise used up its six
  // retries in about 35 s and failed for good while it waited in line.
  bool patient_in_queue{false};
  double queue_margin_m{1.5};  // assumed: three cars' lengths back from a stop box
  // Beyond the lab's BT (0: off, the lab's IntersectionFree keeps the last message for ever): in a
  // stop zone, a permission older than this counts as "not free", so a car whose intersection
  // client died (a crashed or hung vehicle_communication node) waits at the next stop line
  // instead of driving on a stale "free" through every intersection; it still clears the one it
  // is in. Assumed 1 s: ten of the client's 100 ms ticks.
  Duration intersection_free_timeout{kZeroTime};

  template <class V>
  void Describe(V& v) {
    v("tick_period_s", tick_period);
    v("waypoint_spacing_m", waypoint_spacing_m);
    v("waypoint_horizon_m", waypoint_horizon_m);
    v("recovery_wait_s", recovery_wait);
    v("max_retries", max_retries);
    v("recovery_reset_m", recovery_reset_m);
    v("tracking_window_m", tracking_window_m);
    v("patient_in_queue", patient_in_queue);
    v("queue_margin_m", queue_margin_m);
    v("intersection_free_timeout_s", intersection_free_timeout);
  }
  void Validate() const;
};

enum class BehaviorMode {
  kDrive,             // following the goals
  kIntersectionWait,  // held until the intersection is granted
  kRecovery,          // costmaps cleared, waiting before the retry
  kFailed,            // retries exhausted: holds for good
  kDone,              // the end of an open route, or the mission was ended
};
const char* ToString(BehaviorMode mode);

struct BehaviorInput {
  Time now{kZeroTime};
  world::Vec2 p_map{world::Vec2::Zero()};  // the estimated position
  bool intersection_free{true};            // the intersection client's permission
  // The sensor time of the newest permission (intersection_free_timeout); none before the first.
  std::optional<Time> intersection_free_stamp;
  bool collision_ahead{false};  // the controller's latest report
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
  bool hold{false};                // the controller must not drive
  std::vector<world::Vec2> goals;  // map frame, nearest first; empty while holding
  bool clear_costmaps{false};      // the recovery's first action, once per recovery
  int retries{0};                  // recoveries since the last success
};

struct BehaviorState {
  bool started{false};
  double route_s_m{0.0};  // the estimated position's projection on the route
  BehaviorMode mode{BehaviorMode::kDrive};
  Time recovery_until{kZeroTime};
  int retries{0};
  double progress_since_recovery_m{0.0};
  bool plan_failed{false};  // the latest plan reply failed, and no recovery has run since
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
