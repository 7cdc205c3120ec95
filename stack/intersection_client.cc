#include "stack/intersection_client.h"

#include <algorithm>
#include <stdexcept>
#include <string>

#include "world/validation.h"

namespace autonomsim::stack {
namespace {

using Phase = IntersectionClientState::Phase;

const world::IntersectionSpec* Find(const std::vector<world::IntersectionSpec>& intersections,
                                    int id) {
  for (const auto& spec : intersections) {
    if (spec.id == id) return &spec;
  }
  return nullptr;
}

// Entering uses the real cars' strict test (reference §1). Staying uses the closed box: the lab's
// stop zones share an edge with their area (y = -0.6 at intersection 0), and a car sampled exactly
// on that edge must neither release its grant nor roll on while it waits.
bool ContainsClosed(const world::Box& box, const world::Vec2& p, double margin_m = 0.0) {
  return p.x() >= box.x_min_m - margin_m && p.x() <= box.x_max_m + margin_m &&
         p.y() >= box.y_min_m - margin_m && p.y() <= box.y_max_m + margin_m;
}

bool InStopZone(const world::IntersectionSpec& spec, const world::Vec2& p) {
  for (const world::Box& zone : spec.stop_zones) {
    if (zone.Contains(p)) return true;
  }
  return false;
}

bool InStopZoneClosed(const world::IntersectionSpec& spec, const world::Vec2& p,
                      double margin_m = 0.0) {
  for (const world::Box& zone : spec.stop_zones) {
    if (ContainsClosed(zone, p, margin_m)) return true;
  }
  return false;
}

// The first intersection (track order) with a stop zone containing p.
std::optional<int> StopZoneAt(const std::vector<world::IntersectionSpec>& intersections,
                              const world::Vec2& p) {
  for (const auto& spec : intersections) {
    if (InStopZone(spec, p)) return spec.id;
  }
  return std::nullopt;
}

}  // namespace

void IntersectionClientParams::Validate() const {
  RequirePositive(ToSeconds(tick_period), "tick_period_s");
  RequirePositive(ToSeconds(retry_period), "retry_period_s");
  RequirePositive(ToSeconds(keepalive_period), "keepalive_period_s");
  // (no structured bindings: clang 14, the fuzz build's compiler, cannot capture them)
  for (const auto& margin : {std::pair{release_margin_m, "release_margin_m"},
                             std::pair{exit_margin_m, "exit_margin_m"}}) {
    Require(margin.first >= 0.0 && margin.first <= 2.0, [&] {
      return std::string(margin.second) + " must be in [0, 2] m, got " + Num(margin.first);
    });
  }
}

void ValidateAgainstLease(const IntersectionClientParams& params, Duration server_lease) {
  if (params.blocking) return;  // the lab's client asks once: no retry, no keepalive
  auto require_shorter = [&](Duration d, const char* key) {
    if (d >= server_lease) {
      throw std::invalid_argument(std::string(key) + " (" + Num(ToSeconds(d)) +
                                  " s) must be shorter than the server's lease_s (" +
                                  Num(ToSeconds(server_lease)) + " s)");
    }
  };
  require_shorter(params.retry_period, "retry_period_s");
  require_shorter(params.keepalive_period, "keepalive_period_s");
}

namespace {

// One step of the client: what it sends, and its phase, as the input moves it.
class ClientStep {
 public:
  ClientStep(const IntersectionClientParams& params, int car_id,
             const std::vector<world::IntersectionSpec>& intersections,
             const IntersectionClientInput& input, IntersectionClientState* state,
             IntersectionClientOutput* out)
      : params_(params),
        car_id_(car_id),
        intersections_(intersections),
        input_(input),
        s_(*state),
        out_(*out) {}

  // A failed navigation retires the client (true), freeing what it holds, unless the car stopped
  // inside the area it holds: a car that died there blocks it, and keeps its grant alive rather
  // than let the next car drive into it.
  bool RetireOnFailure() {
    if (!input_.navigation_failed || !params_.release_on_failure) return false;
    const world::IntersectionSpec* held =
        s_.phase == Phase::kIdle ? nullptr : Find(intersections_, s_.intersection);
    if (held != nullptr && ContainsClosed(held->area, input_.p_map)) return false;
    if (s_.phase != Phase::kIdle) SendFree();
    GoIdle();
    s_.retired = true;
    return true;
  }

  // A response names no intersection, so it answers the pending one.
  void ReadResponses() {
    for (const world::Response& response : input_.responses) {
      if (response.car != car_id_) continue;
      if (response.granted) {
        if (s_.phase == Phase::kWaiting) {
          s_.phase = Phase::kHolding;
          s_.held = false;
        }
        if (s_.phase == Phase::kIdle) SendFree();  // a grant we no longer want
      } else if (s_.phase == Phase::kHolding) {
        s_.phase = Phase::kWaiting;  // the server let our lease lapse and queued our keepalive
      }
    }
  }

  // Leave what we are no longer in (or ask again, to retry or keep the lease alive).
  void LeaveOrRenew() {
    if (s_.phase == Phase::kIdle) return;
    const world::IntersectionSpec* spec = Find(intersections_, s_.intersection);
    if (spec != nullptr && ContainsClosed(spec->area, input_.p_map)) s_.crossed = true;
    // Until the car has been in the area, gaps between its boxes do not count as leaving; after,
    // the estimate's noise on the area's edge does not either.
    const double margin = s_.crossed ? params_.exit_margin_m : params_.release_margin_m;
    const bool inside = spec != nullptr && (InStopZoneClosed(*spec, input_.p_map, margin) ||
                                            ContainsClosed(spec->area, input_.p_map, margin));
    if (!inside) {
      SendFree();
      GoIdle();
    } else {
      const Duration period =
          s_.phase == Phase::kHolding ? params_.keepalive_period : params_.retry_period;
      if (params_.re_request && input_.now - s_.last_request_sent >= period) SendRequest();
    }
  }

  void EnterStopZone() {
    if (s_.phase != Phase::kIdle) return;
    if (std::optional<int> id = StopZoneAt(intersections_, input_.p_map)) {
      s_.phase = Phase::kWaiting;
      s_.intersection = *id;
      SendRequest();
    }
  }

  // enter_only_if_clear: granted, not yet inside, and another car seen in the area: wait in the
  // stop zone (or the release margin before the area) as a car without a grant does.
  void HoldWhileOccupied() {
    if (!params_.enter_only_if_clear || s_.phase != Phase::kHolding || s_.crossed) return;
    if (std::find(input_.occupied_areas.begin(), input_.occupied_areas.end(), s_.intersection) ==
        input_.occupied_areas.end()) {
      return;
    }
    const world::IntersectionSpec* spec = Find(intersections_, s_.intersection);
    if (spec == nullptr || !InStopZoneClosed(*spec, input_.p_map, params_.release_margin_m)) return;
    out_.may_proceed = false;
    out_.waiting_for = s_.intersection;
  }

  void SetWaitOutputs() {
    if (s_.phase != Phase::kWaiting) return;
    out_.waiting_for = s_.intersection;
    const world::IntersectionSpec* spec = Find(intersections_, s_.intersection);
    const bool in_zone = spec != nullptr && InStopZoneClosed(*spec, input_.p_map);
    if (params_.latch_wait && in_zone) s_.held = true;
    out_.may_proceed = !(in_zone || s_.held);
  }

 private:
  void SendFree() {
    if (out_.frees.empty()) out_.frees.push_back(world::Free{car_id_});
  }
  void SendRequest() {
    out_.requests.push_back(world::Request{car_id_, s_.intersection});
    s_.last_request_sent = input_.now;
  }
  void GoIdle() {
    s_.phase = Phase::kIdle;
    s_.intersection = -1;
    s_.crossed = false;
    s_.held = false;
  }

  const IntersectionClientParams& params_;
  int car_id_;
  const std::vector<world::IntersectionSpec>& intersections_;
  const IntersectionClientInput& input_;
  IntersectionClientState& s_;
  IntersectionClientOutput& out_;
};

// Where the lab's client finds the car (intersection_checker.cpp:138-215): the first box of its
// if/else chain that strictly contains p: per intersection in track order, the area, then the
// stop zones.
struct LabZone {
  enum class Kind { kOutside, kArea, kStopZone };
  Kind kind{Kind::kOutside};
  int intersection{-1};
};

LabZone LocateAsTheLab(const std::vector<world::IntersectionSpec>& intersections,
                       const world::Vec2& p) {
  for (const auto& spec : intersections) {
    if (spec.area.Contains(p)) return {LabZone::Kind::kArea, spec.id};
    if (InStopZone(spec, p)) return {LabZone::Kind::kStopZone, spec.id};
  }
  return {};
}

// The blocking wait's consume_message loop (intersection_checker.cpp:84-104) over what is queued:
// true when it took a grant for this car.
bool TakeQueuedGrant(IntersectionClientState* s) {
  if (s->queued_grants == 0) return false;
  --s->queued_grants;
  s->phase = Phase::kHolding;  // bt_call(1), switch_controller = true (:92-93)
  return true;
}

// The lab's client (blocking: true; see the header).
IntersectionClientOutput StepBlockingClient(
    int car_id, const std::vector<world::IntersectionSpec>& intersections,
    const IntersectionClientInput& input, IntersectionClientState* s) {
  IntersectionClientOutput out;
  // the MQTT client queues every broadcast; a wait drops all but this car's grants
  for (const world::Response& response : input.responses) {
    if (response.car == car_id && response.granted) ++s->queued_grants;
  }
  // still in the wait a request began: it returns only with a grant, then the missed tick runs
  if (s->phase == Phase::kWaiting && !TakeQueuedGrant(s)) {
    out.stuck = true;
    out.may_proceed = false;
    out.waiting_for = s->intersection;
    return out;
  }
  const LabZone zone = LocateAsTheLab(intersections, input.p_map);
  if (zone.kind == LabZone::Kind::kOutside && s->phase == Phase::kHolding) {
    out.frees.push_back(world::Free{car_id});  // vtl_free (:211-214): new_intersection again
    s->phase = Phase::kIdle;
    s->intersection = -1;
  } else if (zone.kind == LabZone::Kind::kStopZone && s->phase == Phase::kIdle) {
    s->phase = Phase::kWaiting;  // bt_call(0), the request, then the wait (:69-84)
    s->intersection = zone.intersection;
    s->last_request_sent = input.now;
    out.requests.push_back(world::Request{car_id, zone.intersection});
    TakeQueuedGrant(s);  // a stale grant ends the wait at once
  }
  out.may_proceed = s->phase != Phase::kWaiting;
  if (!out.may_proceed) out.waiting_for = s->intersection;
  return out;
}

}  // namespace

IntersectionClientOutput StepIntersectionClient(
    const IntersectionClientParams& params, int car_id,
    const std::vector<world::IntersectionSpec>& intersections, const IntersectionClientInput& input,
    IntersectionClientState* state) {
  if (car_id < 0 || car_id > world::kMaxV2IId) {
    throw std::invalid_argument("car_id must be a single digit 0..9, got " +
                                std::to_string(car_id));
  }
  if (params.blocking) return StepBlockingClient(car_id, intersections, input, state);
  IntersectionClientOutput out;
  if (state->retired) return out;
  ClientStep step(params, car_id, intersections, input, state, &out);
  if (step.RetireOnFailure()) return out;
  step.ReadResponses();
  // position: leave what we are no longer in, then enter a stop zone
  step.LeaveOrRenew();
  step.EnterStopZone();
  step.SetWaitOutputs();
  step.HoldWhileOccupied();
  return out;
}

}  // namespace autonomsim::stack
