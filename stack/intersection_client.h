// The car's side of the /vtl/ protocol (reference §7: vehicle communication + intersection_checker)
// as a pure step, run every tick_period on the car's estimated position. Two clients:
//   blocking: false  ours (below), the default;
//   blocking: true   the lab's intersection_checker.cpp as it runs (see "The blocking client").
// Where ours departs from the lab's client, a parameter says so (stack.preset: lab selects the
// lab's values, docs/lab-stack.md#the-options):
//   re_request          the original requests once and then waits forever; ours asks again after
//                       a denial or a lost message and keeps a held intersection alive against
//                       the server's lease;
//   release_margin_m,   the original frees on the first tick outside the boxes (margins 0);
//   exit_margin_m
//   latch_wait          ours, unlatched, lets the car go whenever its estimate is outside the stop
//                       zone, so a waiting car whose estimate jitters across the zone's edge creeps
//                       forward tick by tick; latched, a car held in a stop zone stays held until
//                       it is granted. (The lab's client holds the car until granted wherever its
//                       estimate goes, because it blocks: `blocking`, not this option.);
//   release_on_failure  the original client runs on when the car's navigation has failed; with
//                       it, a car that can no longer drive frees what it holds and asks no more
//                       (unless it stands inside the intersection's area, which it blocks: then
//                       it keeps its grant alive);
//   enter_only_if_clear the original enters on its grant whatever is in the area; with it, a
//                       granted car that has not yet been inside waits in the stop zone while its
//                       sensors see another car in the area (input.occupied_areas). A grant can
//                       reach a second car while the first stands inside: the holder's renewals
//                       cut off (a partitioned uplink) or a restarted server, which knows no
//                       holder, so its lease runs out (issue 33). Nothing on the server's side
//                       can tell a dead holder from a silent one; the car in front of the area can.
// Under blocking: true none of these six applies (the lab's client has none of them), nor do
// retry_period_s and keepalive_period_s: blocking overrides them, whatever they are set to.
//
// The blocking client (intersection_checker.cpp, lab commit 02c5ab4; lines below):
//   - Entering a stop zone (strict, as the lab's `>`/`<` tests, :143-205) while new_intersection
//     is set (kIdle): "not free" to the behaviour (:73), Request{i} once (:76-81), then the
//     timer callback blocks in `while (true) consume_message()` (:84-104) until "<car>1": denials
//     are logged and ignored (:96-99), other cars' messages dropped (:101-103), nothing is asked
//     again, no zone is checked, nothing is freed and nothing published. The grant publishes
//     "free" (:92) and sets switch_controller (:93). new_intersection stays false (:148) until
//     the car frees: the client asks for no other intersection in between.
//   - Responses received while not blocked stay in the MQTT client's queue and the next wait
//     consumes them first, in arrival order (paho's consume_message): a stale "<car>1" lets the
//     car go at its next stop line at once. Only this car's grants can end a wait, so the state
//     keeps their number (queued_grants) instead of the queue.
//   - Inside an intersection's area nothing happens (:138-140, :173-176); inside a stop zone with
//     new_intersection unset, nothing either. On the first tick outside every area and stop zone
//     of every intersection (the else branch, :207-215) after a grant (switch_controller) it sends
//     Free (:107-117, which also sets new_intersection again).
//   - The boxes are tested in the lab's order: per intersection in track order, the area, then
//     its stop zones (the if/else chain of :138-205). Strict tests throughout: a point on a
//     box's edge is outside it.
//   How "blocked" is modelled: the step that sends the request enters kWaiting. Every later step
//   in kWaiting is the same blocked callback: it takes the responses received since the last step
//   and, without a grant, returns `stuck` (the node publishes nothing, may_proceed stays false).
//   With a grant it returns as the lab's wait does, then runs the tick rclcpp owes the timer at
//   once (a wall timer that missed periods fires once on return, not once per missed period) on
//   the position now: a car whose estimate is outside every box by then frees at once. The
//   simulated timer keeps its 100 ms grid meanwhile, so a grant is taken at the first tick after
//   it arrives: up to one tick_period later than the lab's client, which wakes on the message.
//   A blocked job still costs its node's CPU time on the platform model (the lab's thread sleeps).
//   Publishing: ours publishes may_proceed every tick; the lab's client publishes only on a change
//   (:48, :73, :92). The behaviour keeps the last message, so every unstuck tick republishing the
//   current value is the same permission, and it keeps intersection_free_timeout_s fed.
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
  // Beyond the lab's client: a granted car waits while another car is seen in the area (above).
  bool enter_only_if_clear{false};
  // The lab's client as it runs (above): the node blocks from its request until its grant.
  // Default false, ours, as the other options whose defaults are ours.
  bool blocking{false};

  template <class V>
  void Describe(V& v) {
    v("tick_period_s", tick_period, "how often the client checks the car's zone");
    v("retry_period_s", retry_period, "ask again when no grant came within this (`re_request`)");
    v("keepalive_period_s", keepalive_period,
      "a holder renews its grant this often (`re_request`)");
    v("release_margin_m", release_margin_m,
      "until the car has been inside, it keeps its claim within this of the intersection's boxes "
      "(lab: 0)");
    v("exit_margin_m", exit_margin_m,
      "after it has been inside, it frees when this far outside the boxes (lab: 0)");
    v("re_request", re_request,
      "ask again after a denial or a lost message, and keep the grant alive (lab: false, asks "
      "once)");
    v("latch_wait", latch_wait, "a car held in a stop zone stays held until granted (lab: false)");
    v("release_on_failure", release_on_failure,
      "a car whose navigation failed frees what it holds and asks no more (lab: false)");
    v("enter_only_if_clear", enter_only_if_clear,
      "a granted car waits while it sees another car in the area (lab: false)");
    v("blocking", blocking,
      "the lab's client as it runs: blocks from its request until its grant (lab: true)");
  }
  void Validate() const;
};

// Cross-struct check for whoever assembles cars and server: retry_period_s and keepalive_period_s
// must be shorter than the server's lease_s (unless blocking, which uses neither). Throws
// std::invalid_argument naming the key.
void ValidateAgainstLease(const IntersectionClientParams& params, Duration server_lease);

struct IntersectionClientInput {
  Time now{kZeroTime};
  world::Vec2 p_map{world::Vec2::Zero()};  // the car's estimated position, map frame
  // Every /vtl/response broadcast received since the last step, in arrival order; other cars'
  // responses are ignored.
  std::vector<world::Response> responses;
  bool navigation_failed{false};  // the car's navigation gave up (behaviour mode `failed`)
  // The intersections whose area the car's sensors see another car in (enter_only_if_clear).
  std::vector<int> occupied_areas;
};

struct IntersectionClientOutput {
  // Send frees before requests: whenever a step emits both, the free releases the intersection
  // being left and the request asks for the next one.
  std::vector<world::Request> requests;
  std::vector<world::Free> frees;
  bool may_proceed{true};
  std::optional<int> waiting_for;  // the intersection id while kWaiting
  // blocking: the node spent this tick stuck in its wait for a grant and publishes nothing (its
  // "not free" went out when the wait began). Always false for our client.
  bool stuck{false};
};

struct IntersectionClientState {
  enum class Phase { kIdle, kWaiting, kHolding };
  Phase phase{Phase::kIdle};
  int intersection{-1};               // the one waited for or held; -1 in kIdle
  Time last_request_sent{kZeroTime};  // when the last Request for `intersection` went out
  bool crossed{false};                // has been inside `intersection`'s area
  bool held{false};     // latch_wait: was held in a stop zone while waiting for `intersection`
  bool retired{false};  // release_on_failure: the navigation failed; nothing more is sent
  // blocking: this car's grants waiting in the MQTT client's queue (received while not blocked;
  // the next wait takes one at once). kIdle is new_intersection set, kWaiting the blocked wait,
  // kHolding switch_controller set.
  int queued_grants{0};
};

// car_id must be 0..9 (std::invalid_argument otherwise). `intersections` are the track's, in
// track order; where stop zones of two intersections overlap, the first listed wins.
IntersectionClientOutput StepIntersectionClient(
    const IntersectionClientParams& params, int car_id,
    const std::vector<world::IntersectionSpec>& intersections, const IntersectionClientInput& input,
    IntersectionClientState* state);

}  // namespace autonomsim::stack
