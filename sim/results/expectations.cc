#include "sim/results/expectations.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>

namespace autonomsim::sim {
namespace {

// Whether an expectation about `about` (every car when empty) concerns `car`.
bool Concerns(const std::optional<int>& about, int car) { return !about || *about == car; }

std::string At(const Event& e) { return fmt::format("t={:.3f} s", ToSeconds(e.t)); }

// A failed verdict pinned to the instant and car of its first violation.
ExpectationResult Failed(std::string detail, const std::optional<Event>& first) {
  ExpectationResult r{"", false, std::move(detail)};
  if (first) {
    r.at_s = ToSeconds(first->t);
    r.car = first->car;
  }
  return r;
}

ExpectationResult Evaluate(const NoCollisionExpect& args, const RunRecord& record) {
  int count = 0;
  std::string first;
  std::optional<Event> first_event;
  ForEachEvent(record, [&](const Event& e) {
    if (e.type != EventKind::kCollision) return;
    if (!Concerns(args.car, e.car) && !(e.other_car >= 0 && Concerns(args.car, e.other_car)))
      return;
    if (count++ == 0) {
      first_event = e;
      first = fmt::format("car {} hit {} at {}", e.car,
                          e.other_car >= 0 ? fmt::format("car {}", e.other_car)
                                           : fmt::format("obstacle '{}'", e.obstacle),
                          At(e));
    }
  });
  if (count == 0) return {"", true, "no collision"};
  return Failed(fmt::format("{} collision(s); first: {}", count, first), first_event);
}

// Never two cars inside one intersection area: replays the enter/exit events.
ExpectationResult Evaluate(const IntersectionMutexExpect&, const RunRecord& record) {
  std::map<int, std::map<int, bool>> inside;  // intersection -> car -> inside
  int violations = 0;
  std::string first;
  std::optional<Event> first_event;
  ForEachEvent(record, [&](const Event& e) {
    if (e.type == EventKind::kExit) inside[e.intersection][e.car] = false;
    if (e.type != EventKind::kEnter) return;
    for (const auto& [other, in] : inside[e.intersection]) {
      if (in && other != e.car) {
        if (violations++ == 0) {
          first_event = e;
          first = fmt::format("car {} entered intersection {} at {} while car {} was inside", e.car,
                              e.intersection, At(e), other);
        }
      }
    }
    inside[e.intersection][e.car] = true;
  });
  if (violations == 0) return {"", true, "never two cars in one intersection area"};
  return Failed(fmt::format("{} violation(s); first: {}", violations, first), first_event);
}

ExpectationResult Evaluate(const NoEntryWithoutGrantExpect& args, const RunRecord& record) {
  int entries = 0;
  int violations = 0;
  std::string first;
  std::optional<Event> first_event;
  ForEachEvent(record, [&](const Event& e) {
    if (e.type != EventKind::kEnter || !Concerns(args.car, e.car)) return;
    ++entries;
    if (e.granted.value_or(false)) return;
    if (violations++ == 0) {
      first_event = e;
      first = fmt::format("car {} entered intersection {} at {} without holding it", e.car,
                          e.intersection, At(e));
    }
  });
  if (violations == 0) return {"", true, fmt::format("{} entries, all granted", entries)};
  return Failed(
      fmt::format("{} of {} entries without grant; first: {}", violations, entries, first),
      first_event);
}

ExpectationResult Evaluate(const CompletesExpect& args, const RunRecord& record) {
  const int laps = args.laps;
  const double end_s = ToSeconds(record.sim_duration);
  const double within_s = args.within_s.value_or(end_s);
  // a deadline past the end (a warning at load) is judged on the run's time
  const std::string by = within_s > end_s ? fmt::format("the run's end at {:.1f} s", end_s)
                                          : fmt::format("{:.1f} s", within_s);
  std::vector<std::string> misses;
  std::vector<std::string> times;
  std::optional<int> first_miss;
  for (const CarMetrics& car : record.cars) {
    if (!Concerns(args.car, car.id)) continue;
    if (car.laps >= laps && car.lap_times_s[static_cast<std::size_t>(laps - 1)] <= within_s) {
      times.push_back(fmt::format("car {}: lap {} at {:.1f} s", car.id, laps,
                                  car.lap_times_s[static_cast<std::size_t>(laps - 1)]));
    } else {
      if (!first_miss) first_miss = car.id;
      misses.push_back(fmt::format("car {}: {} lap(s) by {}", car.id, car.laps, by));
    }
  }
  ExpectationResult r{"", misses.empty(),
                      fmt::format("{}", fmt::join(misses.empty() ? times : misses, "; "))};
  if (first_miss) {  // the deadline it missed
    r.at_s = std::min(within_s, ToSeconds(record.sim_duration));
    r.car = first_miss;
  }
  return r;
}

ExpectationResult Evaluate(const MaxLateralErrorExpect& args, const RunRecord& record) {
  bool passed = true;
  std::vector<std::string> parts;
  for (const CarMetrics& car : record.cars) {
    if (!Concerns(args.car, car.id)) continue;
    passed = passed && car.max_lateral_error_m <= args.max_m;
    parts.push_back(fmt::format("car {}: max {:.3f} m", car.id, car.max_lateral_error_m));
  }
  ExpectationResult r{"", passed,
                      fmt::format("{} (bound {} m)", fmt::join(parts, "; "), args.max_m)};
  if (!passed) {  // the first sample over the bound
    ForEachSample(record, [&](const TrajectorySample& s) {
      if (r.at_s || !Concerns(args.car, s.car) || std::abs(s.lateral_error_m) <= args.max_m) return;
      r.at_s = ToSeconds(s.t);
      r.car = s.car;
    });
  }
  return r;
}

ExpectationResult Evaluate(const MinObstacleGapExpect& args, const RunRecord& record) {
  bool passed = true;
  std::vector<std::string> parts;
  for (const CarMetrics& car : record.cars) {
    if (!Concerns(args.car, car.id)) continue;
    if (!car.min_obstacle_gap_m) {
      parts.push_back(
          fmt::format("car {}: no obstacle within {} m", car.id, kObstacleGapHorizon_m));
      continue;
    }
    passed = passed && *car.min_obstacle_gap_m >= args.min_m;
    parts.push_back(fmt::format("car {}: least gap {:.3f} m", car.id, *car.min_obstacle_gap_m));
  }
  return {"", passed, fmt::format("{} (bound {} m)", fmt::join(parts, "; "), args.min_m)};
}

const BoardReport* BoardOf(const RunRecord& record, int car) {
  const std::string name = fmt::format("car{}", car);
  for (const BoardReport& b : record.boards) {
    if (b.board == name) return &b;
  }
  return nullptr;
}

bool Within(double value, const std::optional<double>& lo, const std::optional<double>& hi) {
  return (!lo || value >= *lo) && (!hi || value <= *hi);
}

ExpectationResult Evaluate(const NodeRateExpect& args, const RunRecord& record) {
  const BoardReport* board = BoardOf(record, args.car);
  const NodeReport* node = board ? board->report.FindNode(args.node) : nullptr;
  if (!node) {
    return {"", false, fmt::format("car {} runs no node '{}'", args.car, args.node)};
  }
  return {"", Within(node->rate_hz, args.min_hz, args.max_hz),
          fmt::format("car {}: {} at {:.1f} Hz, {} dropped", args.car, args.node, node->rate_hz,
                      node->drops)};
}

ExpectationResult Evaluate(const CpuDemandExpect& args, const RunRecord& record) {
  const BoardReport* board = BoardOf(record, args.car);
  if (!board) return {"", false, fmt::format("car {} has no board", args.car)};
  const MetricsReport& r = board->report;
  return {"", Within(r.cpu_demand_percent, args.min_percent, args.max_percent),
          fmt::format("car {}: CPU demand {:.0f} %, load {:.0f} % of {} cores", args.car,
                      r.cpu_demand_percent, r.cpu_percent, r.cores)};
}

// A wait at a stop zone: from a `wait` event to the car's next `go` (or the run's end).
struct Wait {
  int car{-1};
  int intersection{-1};
  Time start{0};
  Time end{0};
};

std::vector<Wait> Waits(const RunRecord& record) {
  std::vector<Wait> waits;
  std::map<int, std::size_t> open;  // car -> its open wait
  ForEachEvent(record, [&](const Event& e) {
    if (e.type == EventKind::kWait) {
      open[e.car] = waits.size();
      waits.push_back({e.car, e.intersection, e.t, record.sim_duration});
    } else if (e.type == EventKind::kGo) {
      if (auto it = open.find(e.car); it != open.end()) {
        waits[it->second].end = e.t;
        open.erase(it);
      }
    }
  });
  return waits;
}

// A fault of the run, from its fault_begin and fault_end events (sim/loop/faults.h).
ExpectationResult Evaluate(const MaxWaitExpect& args, const RunRecord& record) {
  std::optional<Wait> longest;
  std::optional<Wait> first_over;
  int over = 0;
  int count = 0;
  std::string first;
  for (const Wait& w : Waits(record)) {
    if (!Concerns(args.car, w.car) || (args.intersection && *args.intersection != w.intersection)) {
      continue;
    }
    ++count;
    const double s = ToSeconds(w.end - w.start);
    if (!longest || s > ToSeconds(longest->end - longest->start)) longest = w;
    if (s > args.max_s && over++ == 0) {
      first_over = w;
      first = fmt::format("car {} waited {:.1f} s at intersection {} from t={:.3f} s", w.car, s,
                          w.intersection, ToSeconds(w.start));
    }
  }
  if (!longest) return {"", true, "no waits"};
  const double s = ToSeconds(longest->end - longest->start);
  if (over == 0) {
    return {"", true,
            fmt::format("{} waits, longest {:.1f} s (car {}, intersection {})", count, s,
                        longest->car, longest->intersection)};
  }
  ExpectationResult r{
      "", false,
      fmt::format("{} of {} waits over {} s; first: {}", over, count, args.max_s, first)};
  r.at_s = ToSeconds(first_over->start) + args.max_s;  // when the wait passed its bound
  r.car = first_over->car;
  return r;
}

// Crossings (enter events) per minute of the run, per intersection: the one given, or each one a
// car entered or asked for.
ExpectationResult Evaluate(const MinThroughputExpect& args, const RunRecord& record) {
  std::map<int, int> crossings;  // intersection -> enter events
  ForEachEvent(record, [&](const Event& e) {
    if (e.type == EventKind::kEnter) ++crossings[e.intersection];
    if (e.type == EventKind::kRequest && e.intersection >= 0)
      crossings.try_emplace(e.intersection, 0);
  });
  const double minutes = ToSeconds(record.sim_duration) / 60.0;
  bool passed = true;
  std::vector<std::string> parts;
  std::vector<int> ids;
  if (args.intersection) {
    ids.push_back(*args.intersection);
  } else {
    for (const auto& [id, n] : crossings) ids.push_back(id);
  }
  for (int id : ids) {
    const double rate = crossings[id] / minutes;
    passed = passed && rate >= args.per_minute;
    parts.push_back(
        fmt::format("intersection {}: {} crossings, {:.2f}/min", id, crossings[id], rate));
  }
  if (parts.empty()) return {"", args.per_minute <= 0.0, "no crossings"};
  return {"", passed, fmt::format("{} (bound {}/min)", fmt::join(parts, "; "), args.per_minute)};
}

// no_gridlock: a car stands still (trajectory speed below kStillSpeed_mps) for longer than max_s,
// counting only the time it is not excused. Excused: after it parked (laps done), and while it
// waits at a stop zone (`wait` to `go`) for an intersection the server has granted to another car
// (red light, by the server's grant, free and lease_expired events). Not excused: a wait for an
// intersection nobody holds (a request lost, or a denial the car never repeats), a car whose
// navigation failed, a car held by a car ahead that is itself stuck, a car in recovery.
constexpr double kStillSpeed_mps = 0.02;  // assumed: 2 cm/s, below any driving speed
constexpr double kDefaultGridlock_s = 30.0;

// Per car, the intervals in which standing still is excused (see no_gridlock above), in time
// order.
std::map<int, std::vector<std::pair<Time, Time>>> ExcusedStandstills(const RunRecord& record) {
  // the holder timeline of each intersection, and the parked instants
  std::map<int, std::vector<std::pair<Time, int>>> holders;  // intersection -> (since, holder)
  std::map<int, Time> parked;
  ForEachEvent(record, [&](const Event& e) {
    if (e.type == EventKind::kGrant) holders[e.intersection].emplace_back(e.t, e.car);
    if ((e.type == EventKind::kFree && e.intersection >= 0) || e.type == EventKind::kLeaseExpired) {
      holders[e.intersection].emplace_back(e.t, -1);
    }
    if (e.type == EventKind::kParked && !parked.count(e.car)) parked[e.car] = e.t;
  });
  // per car, the intervals in which it is excused, in time order
  std::map<int, std::vector<std::pair<Time, Time>>> excused;
  for (const Wait& w : Waits(record)) {
    const auto& timeline = holders[w.intersection];
    int holder = -1;
    Time since = w.start;
    auto flush = [&](Time until) {
      if (holder >= 0 && holder != w.car && until > since)
        excused[w.car].emplace_back(since, until);
    };
    for (const auto& [t, h] : timeline) {
      if (t <= w.start) {
        holder = h;
        continue;
      }
      if (t >= w.end) break;
      flush(t);
      holder = h;
      since = t;
    }
    flush(w.end);
  }
  for (const auto& [car, t] : parked) excused[car].emplace_back(t, record.sim_duration);
  // a car whose motor a fault killed cannot move: that is car_stall's effect, not a gridlock
  for (const FaultSpan& f : FaultSpans(record)) {
    if (f.kind == FaultKind::kCarStall)
      excused[f.car].emplace_back(f.begin, f.end.value_or(record.sim_duration));
  }
  for (auto& [car, intervals] : excused) std::sort(intervals.begin(), intervals.end());
  return excused;
}

ExpectationResult Evaluate(const NoGridlockExpect& args, const RunRecord& record) {
  const double bound_s = args.max_s.value_or(kDefaultGridlock_s);
  std::map<int, std::vector<std::pair<Time, Time>>> excused = ExcusedStandstills(record);

  struct Still {
    std::optional<Time> since;  // unexcused standstill began
    std::size_t next{0};        // the first excused interval not yet over
    bool reported{false};
  };
  std::map<int, Still> still;
  int episodes = 0;
  std::string first;
  std::optional<std::pair<Time, int>> first_at;
  ForEachSample(record, [&](const TrajectorySample& s) {
    if (!Concerns(args.car, s.car)) return;
    Still& c = still[s.car];
    const auto& intervals = excused[s.car];
    while (c.next < intervals.size() && intervals[c.next].second <= s.t) ++c.next;
    const bool is_excused = c.next < intervals.size() && intervals[c.next].first <= s.t;
    if (std::abs(s.speed_mps) >= kStillSpeed_mps || is_excused) {
      c.since.reset();
      c.reported = false;
      return;
    }
    if (!c.since) c.since = s.t;
    if (!c.reported && ToSeconds(s.t - *c.since) > bound_s) {
      c.reported = true;
      if (episodes++ == 0) {
        first_at = {*c.since, s.car};
        first = fmt::format("car {} stood still from t={:.1f} s at ({:.2f}, {:.2f}) m", s.car,
                            ToSeconds(*c.since), s.x_m, s.y_m);
      }
    }
  });
  if (episodes == 0) {
    return {"", true,
            fmt::format("no car stood still over {} s unless held by a red light", bound_s)};
  }
  ExpectationResult r{
      "", false, fmt::format("{} standstill(s) over {} s; first: {}", episodes, bound_s, first)};
  r.at_s = ToSeconds(first_at->first);  // when the standstill began
  r.car = first_at->second;
  return r;
}

// A standing car has an obstacle in its way when one of the scenario's obstacles, present then,
// lies ahead of it within kObstacleAhead_m and across its path (the obstacle's half diagonal
// plus half the car's width to either side of its heading). Assumed: the stack stops a car
// 0.14-0.42 m before a box (stack_obstacle's gaps on the two presets, from the bumper, which is
// 0.26 m ahead of the centre), so 1 m from the centre to the box's nearest reach holds every such
// stop.
constexpr double kObstacleAhead_m = 1.0;

// A car's width as its scenario gives it (vehicle.width_m); the vehicle's default (the lab car's,
// reference §2) for a car the scenario does not name.
double CarWidth_m(const Scenario& scenario, int car) {
  const CarConfig* config = scenario.FindCar(car);
  return config ? config->vehicle.width_m : CarConfig{}.vehicle.width_m;
}

bool ObstacleAhead(const TrajectorySample& s, const std::vector<ObstacleConfig>& obstacles,
                   double car_width_m) {
  for (const ObstacleConfig& o : obstacles) {
    if (!o.PresentAt(s.t)) continue;
    const double ex = o.x_m - s.x_m;
    const double ey = o.y_m - s.y_m;
    const double ahead = std::cos(s.yaw_rad) * ex + std::sin(s.yaw_rad) * ey;
    const double across = -std::sin(s.yaw_rad) * ex + std::cos(s.yaw_rad) * ey;
    const double half_diagonal = 0.5 * std::hypot(o.length_m, o.width_m);
    if (ahead > 0.0 && ahead - half_diagonal <= kObstacleAhead_m &&
        std::abs(across) <= half_diagonal + car_width_m / 2) {
      return true;
    }
  }
  return false;
}

// recovers_within: after each fault ends, every car moves again within max_s. Judged on the cars'
// standstills (speed below kStillSpeed_mps) that overlap the fault or the max_s after its end: each
// must be over within max_s of the fault's end (of its own start, if it starts later). A fault that
// lasts to the run's end is judged from its begin, and the car it strikes is not judged for it (a
// dead motor, a crashed node). Standstills after a car parked do not count, nor those that begin
// with an obstacle in the car's way (ObstacleAhead): the obstacle holds the car, not the fault.
// A car's standstills (speed below kStillSpeed_mps) for recovers_within, each from its first
// still sample to the first moving one (or the run's end); every judged car has an entry. Those
// that begin with an obstacle in the car's way are left out and counted in *held_by_obstacles.
struct Standstill {
  Time begin{0};
  Time end{0};
};
std::map<int, std::vector<Standstill>> StandstillsNotHeldByObstacles(
    const RecoversWithinExpect& args, const RunRecord& record, const Scenario& scenario,
    std::size_t* held_by_obstacles) {
  std::map<int, std::vector<Standstill>> standstills;
  std::map<int, std::optional<Time>> since;  // car -> the open standstill's start
  std::map<int, bool> held;  // car -> its open standstill began with an obstacle in its way
  const auto close = [&](int car, Time begin, Time end) {
    if (held[car]) {
      ++*held_by_obstacles;
    } else {
      standstills[car].push_back({begin, end});
    }
  };
  ForEachSample(record, [&](const TrajectorySample& s) {
    if (!Concerns(args.car, s.car)) return;
    std::optional<Time>& open = since[s.car];
    standstills[s.car];
    if (std::abs(s.speed_mps) < kStillSpeed_mps) {
      if (!open) {
        open = s.t;
        held[s.car] = ObstacleAhead(s, scenario.obstacles, CarWidth_m(scenario, s.car));
      }
    } else if (open) {
      close(s.car, *open, s.t);
      open.reset();
    }
  });
  for (const auto& [car, open] : since) {
    if (open) close(car, *open, record.sim_duration);
  }
  return standstills;
}

ExpectationResult Evaluate(const RecoversWithinExpect& args, const RunRecord& record,
                           const Scenario& scenario) {
  const double bound_s = args.max_s;
  const std::vector<FaultSpan> faults = FaultSpans(record);
  if (faults.empty()) return {"", true, "no fault in the run"};
  std::size_t held_by_obstacles = 0;
  const std::map<int, std::vector<Standstill>> standstills =
      StandstillsNotHeldByObstacles(args, record, scenario, &held_by_obstacles);
  std::map<int, Time> parked;
  ForEachEvent(record, [&](const Event& e) {
    if (e.type == EventKind::kParked && !parked.count(e.car)) parked[e.car] = e.t;
  });

  double slowest_s = 0.0;
  for (const FaultSpan& f : faults) {
    const Time from = f.end.value_or(f.begin);
    const Time horizon = from + FromSeconds(bound_s);
    for (const auto& [car, list] : standstills) {
      if (!f.end && f.car == car) continue;  // struck for good
      const auto p = parked.find(car);
      for (const Standstill& still : list) {
        if (still.end <= f.begin || still.begin >= horizon) continue;
        if (p != parked.end() && still.begin >= p->second) continue;
        const Time counted_from = std::max(still.begin, from);
        const double stood_s = ToSeconds(still.end - counted_from);
        if (stood_s <= bound_s) {
          slowest_s = std::max(slowest_s, stood_s);
          continue;
        }
        ExpectationResult r{
            "", false,
            fmt::format("car {} stood still from t={:.1f} s to {}, over {} s after {} {} at "
                        "t={:.1f} s",
                        car, ToSeconds(still.begin),
                        still.end >= record.sim_duration
                            ? std::string("the run's end")
                            : fmt::format("t={:.1f} s", ToSeconds(still.end)),
                        bound_s, ToName(f.kind), f.end ? "ended" : "began", ToSeconds(from))};
        r.at_s = ToSeconds(counted_from);
        r.car = car;
        return r;
      }
    }
  }
  return {"", true,
          fmt::format("{} fault(s): every car moved again within {:.1f} s of a fault's end "
                      "(bound {} s){}",
                      faults.size(), slowest_s, bound_s,
                      held_by_obstacles == 0
                          ? ""
                          : fmt::format("; {} standstill(s) before an obstacle not judged",
                                        held_by_obstacles))};
}

}  // namespace

std::vector<FaultSpan> FaultSpans(const RunRecord& record) {
  std::vector<FaultSpan> faults;
  ForEachEvent(record, [&](const Event& e) {
    if (!e.fault) return;
    if (e.type == EventKind::kFaultBegin) faults.push_back({*e.fault, e.car, e.t, std::nullopt});
    if (e.type != EventKind::kFaultEnd) return;
    for (FaultSpan& f : faults) {  // the earliest open one of its kind and car
      if (!f.end && f.kind == *e.fault && f.car == e.car) {
        f.end = e.t;
        break;
      }
    }
  });
  return faults;
}

std::vector<ExpectationResult> EvaluateExpectations(const Scenario& scenario,
                                                    const RunRecord& record) {
  std::vector<ExpectationResult> results;
  for (const ExpectClause& clause : scenario.expect) {
    ExpectationResult result = std::visit(
        [&](const auto& expectation) {
          if constexpr (std::is_same_v<std::decay_t<decltype(expectation)>, RecoversWithinExpect>) {
            return Evaluate(expectation, record, scenario);
          } else {
            return Evaluate(expectation, record);
          }
        },
        clause);
    result.name = ExpectationName(clause);
    results.push_back(std::move(result));
  }
  return results;
}

}  // namespace autonomsim::sim
