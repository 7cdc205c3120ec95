// The car's side of the /vtl/ protocol (reference §7: vehicle communication + intersection_checker)
// as a pure step, run every tick_period on the car's estimated position. Where it departs from the
// lab's client, a parameter says so and its other value is the lab's behaviour (stack.preset: lab
// selects all of them, docs/lab-stack.md#the-options):
//   re_request          the original requests once and then waits forever; ours asks again after
//                       a denial or a lost message and keeps a held intersection alive against
//                       the server's lease;
//   release_margin_m,   the original frees on the first tick outside the boxes (margins 0);
//   exit_margin_m
//   latch_wait          the original lets the car go whenever its estimate is outside the stop
//                       zone, so a waiting car whose estimate jitters across the zone's edge
//                       creeps forward tick by tick; latched, a car held in a stop zone stays
//                       held until it is granted;
//   release_on_failure  the original client runs on when the car's navigation has failed; with
//                       it, a car that can no longer drive frees what it holds and asks no more
//                       (unless it stands inside the intersection's area, which it blocks: then
//                       it keeps its grant alive).
//
// State machine (one intersection at a time: a response names no intersection, so it answers the
// one pending request; a free names none either, so it releases everything the car holds):
//   kIdle        --p in a stop zone of i-------------------------> kWaiting(i)  send Request{i}
//   kWaiting(i)  --"<car>1"------------------------------------> kHolding(i)
//   kWaiting(i)  --"<car>0"------------------------------------> kWaiting(i)  (FIFO grants later)
//   kWaiting(i)  --retry_period since the last Request----------> kWaiting(i)  send Request{i}
//   kWaiting(i)  --p outside i's stop zones and area (gave up)----> kIdle       send Free
//   kHolding(i)  --keepalive_period since last Request-----------> kHolding(i)  send Request{i}
//   kHolding(i)  --p outside i's stop zones and area--------------> kIdle       send Free
//                  (outside them by release_margin_m before the car has been in the area,
//                  by exit_margin_m after)
//   kHolding(i)  --"<car>0" (grant lost: lease expired)----------> kWaiting(i)
//   kIdle        --"<car>1" (late or stale grant)-----------------> kIdle       send Free
//   any          --navigation failed (release_on_failure)---------> retired     send Free if
//                                                    not kIdle (in the area: keeps its grant)
// Without re_request, the two re-request transitions never fire.
// Responses are applied first, in arrival order, then the position. Entering a stop zone uses the
// real cars' strict Box::Contains; being still in i (stop zone or area) uses the closed boxes, so
// a car sampled exactly on the edge a stop zone shares with its area (lab: y = -0.6) neither frees
// mid-crossing nor rolls on while waiting. Leaving i straight into a stop zone of another
// intersection j frees i and requests j in the same step. may_proceed is false only while in a
// stop zone of i in kWaiting(i); a car that overshot into the area keeps going (stopping inside
// the intersection helps nobody) and keeps asking until it leaves.
#pragma once

#include <optional>
#include <vector>

#include "world/geometry.h"
#include "world/time.h"
#include "world/track_spec.h"
#include "world/v2i_protocol.h"

namespace autonomsim::stack {

struct IntersectionClientParams {
  // Reference §7: the car client checks its zone every 100 ms (used by the node that runs it).
  Duration tick_period{Milliseconds(100)};
  // Assumed: re-request when no grant arrived within this (the original never re-asks, §7).
  // Must be < the server's lease, or a waiting car is dropped from the queue between retries.
  Duration retry_period{std::chrono::seconds(1)};
  // Assumed: a holder re-requests this often to renew the server's lease (5 s); 1 s leaves room
  // for four lost keepalives. Must be < the server's lease.
  Duration keepalive_period{std::chrono::seconds(1)};
  // Assumed: the lab's left intersection leaves 0.1 m between two of its stop zones and its area
  // (reference §1), so a car that leaves a stop zone has not necessarily left the intersection.
  // Until the car has been inside the area, it keeps its claim while within this distance of the
  // intersection's boxes. The original client frees in that gap and then enters unclaimed.
  double release_margin_m{0.3};
  // Assumed: once the car has been in the area, it frees when its estimate is this far outside
  // the intersection's boxes. The estimate is noisy (up to 0.09 m off with the pose fix in the
  // default scenario); with no margin, a car stopped on the area's edge whose estimate steps back
  // into the 0.1 m gap above freed while still inside, and the next car was granted (4 of 20
  // seeds of the default scenario broke intersection_mutex that way). Costs ≈ 0.6 s of lease
  // at 0.25 m/s.
  double exit_margin_m{0.15};
  // Assumed, beyond the lab's client (which never re-asks, reference §7): retry and keepalive.
  bool re_request{true};
  // Beyond the lab's client: once held in a stop zone, stay held until granted (see above).
  bool latch_wait{false};
  // Beyond the lab's client: a car whose navigation failed frees its intersection and retires.
  bool release_on_failure{false};

  template <class V>
  void Describe(V& v) {
    v("tick_period_s", tick_period);
    v("retry_period_s", retry_period);
    v("keepalive_period_s", keepalive_period);
    v("release_margin_m", release_margin_m);
    v("exit_margin_m", exit_margin_m);
    v("re_request", re_request);
    v("latch_wait", latch_wait);
    v("release_on_failure", release_on_failure);
  }
  void Validate() const;
};

// Cross-struct check for whoever assembles cars and server: retry_period_s and keepalive_period_s
// must be shorter than the server's lease_s. Throws std::invalid_argument naming the key.
void ValidateAgainstLease(const IntersectionClientParams& params, Duration server_lease);

struct IntersectionClientInput {
  Time now{kZeroTime};
  world::Vec2 p_map{world::Vec2::Zero()};  // the car's estimated position, map frame
  // Every /vtl/response broadcast received since the last step, in arrival order; other cars'
  // responses are ignored.
  std::vector<world::Response> responses;
  bool navigation_failed{false};  // the car's navigation gave up (behaviour mode `failed`)
};

struct IntersectionClientOutput {
  // Send frees before requests: whenever a step emits both, the free releases the intersection
  // being left and the request asks for the next one.
  std::vector<world::Request> requests;
  std::vector<world::Free> frees;
  bool may_proceed{true};
  std::optional<int> waiting_for;  // the intersection id while kWaiting
};

struct IntersectionClientState {
  enum class Phase { kIdle, kWaiting, kHolding };
  Phase phase{Phase::kIdle};
  int intersection{-1};               // the one waited for or held; -1 in kIdle
  Time last_request_sent{kZeroTime};  // when the last Request for `intersection` went out
  bool crossed{false};                // has been inside `intersection`'s area
  bool held{false};     // latch_wait: was held in a stop zone while waiting for `intersection`
  bool retired{false};  // release_on_failure: the navigation failed; nothing more is sent
};

// car_id must be 0..9 (std::invalid_argument otherwise). `intersections` are the track's, in
// track order; where stop zones of two intersections overlap, the first listed wins.
IntersectionClientOutput StepIntersectionClient(
    const IntersectionClientParams& params, int car_id,
    const std::vector<world::IntersectionSpec>& intersections, const IntersectionClientInput& input,
    IntersectionClientState* state);

}  // namespace autonomsim::stack
