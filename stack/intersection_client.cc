#include "stack/intersection_client.h"

#include <stdexcept>
#include <string>

namespace autonomsim::stack {
namespace {

using Phase = IntersectionClientState::Phase;

void RequirePositive(Duration d, const char* key) {
  if (d <= Duration::zero()) {
    throw std::invalid_argument(std::string(key) + " must be > 0 s, got " +
                                std::to_string(ToSeconds(d)) + " s");
  }
}

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
  RequirePositive(tick_period, "tick_period_s");
  RequirePositive(retry_period, "retry_period_s");
  RequirePositive(keepalive_period, "keepalive_period_s");
  for (const auto& [value, key] : {std::pair{release_margin_m, "release_margin_m"},
                                   std::pair{exit_margin_m, "exit_margin_m"}}) {
    if (!(value >= 0.0 && value <= 2.0)) {
      throw std::invalid_argument(std::string(key) + " must be in [0, 2] m, got " +
                                  std::to_string(value));
    }
  }
}

void ValidateAgainstLease(const IntersectionClientParams& params, Duration server_lease) {
  auto require_shorter = [&](Duration d, const char* key) {
    if (d >= server_lease) {
      throw std::invalid_argument(std::string(key) + " (" + std::to_string(ToSeconds(d)) +
                                  " s) must be shorter than the server's lease_s (" +
                                  std::to_string(ToSeconds(server_lease)) + " s)");
    }
  };
  require_shorter(params.retry_period, "retry_period_s");
  require_shorter(params.keepalive_period, "keepalive_period_s");
}

IntersectionClientOutput StepIntersectionClient(
    const IntersectionClientParams& params, int car_id,
    const std::vector<world::IntersectionSpec>& intersections, const IntersectionClientInput& input,
    IntersectionClientState* state) {
  if (car_id < 0 || car_id > world::kMaxV2IId) {
    throw std::invalid_argument("car_id must be a single digit 0..9, got " +
                                std::to_string(car_id));
  }
  IntersectionClientState& s = *state;
  IntersectionClientOutput out;
  auto send_free = [&] {
    if (out.frees.empty()) out.frees.push_back(world::Free{car_id});
  };
  auto send_request = [&] {
    out.requests.push_back(world::Request{car_id, s.intersection});
    s.last_request_sent = input.now;
  };
  auto go_idle = [&] {
    s.phase = Phase::kIdle;
    s.intersection = -1;
    s.crossed = false;
    s.held = false;
  };

  if (s.retired) return out;
  if (input.navigation_failed && params.release_on_failure) {
    // A car that died inside an intersection's area blocks it: it keeps its grant alive rather
    // than let the next car drive into it.
    const world::IntersectionSpec* held =
        s.phase == Phase::kIdle ? nullptr : Find(intersections, s.intersection);
    if (held == nullptr || !ContainsClosed(held->area, input.p_map)) {
      if (s.phase != Phase::kIdle) send_free();
      go_idle();
      s.retired = true;
      return out;
    }
  }

  // responses: a response names no intersection, so it answers the pending one
  for (const world::Response& response : input.responses) {
    if (response.car != car_id) continue;
    if (response.granted) {
      if (s.phase == Phase::kWaiting) {
        s.phase = Phase::kHolding;
        s.held = false;
      }
      if (s.phase == Phase::kIdle) send_free();  // a grant we no longer want
    } else if (s.phase == Phase::kHolding) {
      s.phase = Phase::kWaiting;  // the server let our lease lapse and queued our keepalive
    }
  }

  // position: leave what we are no longer in, then enter a stop zone
  if (s.phase != Phase::kIdle) {
    const world::IntersectionSpec* spec = Find(intersections, s.intersection);
    if (spec != nullptr && ContainsClosed(spec->area, input.p_map)) s.crossed = true;
    // Until the car has been in the area, gaps between its boxes do not count as leaving; after,
    // the estimate's noise on the area's edge does not either.
    const double margin = s.crossed ? params.exit_margin_m : params.release_margin_m;
    const bool inside = spec != nullptr && (InStopZoneClosed(*spec, input.p_map, margin) ||
                                            ContainsClosed(spec->area, input.p_map, margin));
    if (!inside) {
      send_free();
      go_idle();
    } else {
      const Duration period =
          s.phase == Phase::kHolding ? params.keepalive_period : params.retry_period;
      if (params.re_request && input.now - s.last_request_sent >= period) send_request();
    }
  }
  if (s.phase == Phase::kIdle) {
    if (std::optional<int> id = StopZoneAt(intersections, input.p_map)) {
      s.phase = Phase::kWaiting;
      s.intersection = *id;
      send_request();
    }
  }

  // outputs
  if (s.phase == Phase::kWaiting) {
    out.waiting_for = s.intersection;
    const world::IntersectionSpec* spec = Find(intersections, s.intersection);
    const bool in_zone = spec != nullptr && InStopZoneClosed(*spec, input.p_map);
    if (params.latch_wait && in_zone) s.held = true;
    out.may_proceed = !(in_zone || s.held);
  }
  return out;
}

}  // namespace autonomsim::stack
