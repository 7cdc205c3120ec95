#include "sim/results/expectations.h"

#include <fmt/format.h>

#include <map>
#include <optional>

namespace autonomsim::sim {
namespace {

std::string Name(const ExpectClause& clause) {
  const ExpectArgs& a = clause.args();
  std::vector<std::string> parts;
  if (a.car) parts.push_back(fmt::format("car={}", *a.car));
  if (a.laps) parts.push_back(fmt::format("laps={}", *a.laps));
  if (a.within_s) parts.push_back(fmt::format("within_s={}", *a.within_s));
  if (a.max_m) parts.push_back(fmt::format("max_m={}", *a.max_m));
  if (a.min_m) parts.push_back(fmt::format("min_m={}", *a.min_m));
  if (a.node) parts.push_back(fmt::format("node={}", *a.node));
  if (a.min_hz) parts.push_back(fmt::format("min_hz={}", *a.min_hz));
  if (a.max_hz) parts.push_back(fmt::format("max_hz={}", *a.max_hz));
  if (a.min_percent) parts.push_back(fmt::format("min_percent={}", *a.min_percent));
  if (a.max_percent) parts.push_back(fmt::format("max_percent={}", *a.max_percent));
  return parts.empty() ? clause.kind()
                       : fmt::format("{}({})", clause.kind(), fmt::join(parts, ", "));
}

bool Concerns(const ExpectArgs& args, int car) { return !args.car || *args.car == car; }

std::string At(const Event& e) { return fmt::format("t={:.3f} s", ToSeconds(e.t)); }

ExpectationResult NoCollision(const ExpectArgs& args, const RunRecord& record) {
  int count = 0;
  std::string first;
  ForEachEvent(record, [&](const Event& e) {
    if (e.type != "collision") return;
    if (!Concerns(args, e.car) && !(e.other_car >= 0 && Concerns(args, e.other_car))) return;
    if (count++ == 0) {
      first = fmt::format("car {} hit {} at {}", e.car,
                          e.other_car >= 0 ? fmt::format("car {}", e.other_car)
                                           : fmt::format("obstacle '{}'", e.obstacle),
                          At(e));
    }
  });
  return {"", count == 0,
          count == 0 ? "no collision" : fmt::format("{} collision(s); first: {}", count, first)};
}

// Never two cars inside one intersection area: replays the enter/exit events.
ExpectationResult IntersectionMutex(const RunRecord& record) {
  std::map<int, std::map<int, bool>> inside;  // intersection -> car -> inside
  int violations = 0;
  std::string first;
  ForEachEvent(record, [&](const Event& e) {
    if (e.type == "exit") inside[e.intersection][e.car] = false;
    if (e.type != "enter") return;
    for (const auto& [other, in] : inside[e.intersection]) {
      if (in && other != e.car) {
        if (violations++ == 0) {
          first = fmt::format("car {} entered intersection {} at {} while car {} was inside", e.car,
                              e.intersection, At(e), other);
        }
      }
    }
    inside[e.intersection][e.car] = true;
  });
  return {"", violations == 0,
          violations == 0 ? "never two cars in one intersection area"
                          : fmt::format("{} violation(s); first: {}", violations, first)};
}

ExpectationResult NoEntryWithoutGrant(const ExpectArgs& args, const RunRecord& record) {
  int entries = 0;
  int violations = 0;
  std::string first;
  ForEachEvent(record, [&](const Event& e) {
    if (e.type != "enter" || !Concerns(args, e.car)) return;
    ++entries;
    if (e.granted.value_or(false)) return;
    if (violations++ == 0) {
      first = fmt::format("car {} entered intersection {} at {} without holding it", e.car,
                          e.intersection, At(e));
    }
  });
  return {"", violations == 0,
          violations == 0 ? fmt::format("{} entries, all granted", entries)
                          : fmt::format("{} of {} entries without grant; first: {}", violations,
                                        entries, first)};
}

ExpectationResult Completes(const ExpectArgs& args, const RunRecord& record) {
  const int laps = *args.laps;
  const double within_s = args.within_s.value_or(ToSeconds(record.sim_duration));
  std::vector<std::string> misses;
  std::vector<std::string> times;
  for (const CarMetrics& car : record.cars) {
    if (!Concerns(args, car.id)) continue;
    if (car.laps >= laps && car.lap_times_s[static_cast<std::size_t>(laps - 1)] <= within_s) {
      times.push_back(fmt::format("car {}: lap {} at {:.1f} s", car.id, laps,
                                  car.lap_times_s[static_cast<std::size_t>(laps - 1)]));
    } else {
      misses.push_back(fmt::format("car {}: {} lap(s) by {:.1f} s", car.id, car.laps, within_s));
    }
  }
  return {"", misses.empty(), fmt::format("{}", fmt::join(misses.empty() ? times : misses, "; "))};
}

ExpectationResult MaxLateralError(const ExpectArgs& args, const RunRecord& record) {
  bool passed = true;
  std::vector<std::string> parts;
  for (const CarMetrics& car : record.cars) {
    if (!Concerns(args, car.id)) continue;
    passed = passed && car.max_lateral_error_m <= *args.max_m;
    parts.push_back(fmt::format("car {}: max {:.3f} m", car.id, car.max_lateral_error_m));
  }
  return {"", passed, fmt::format("{} (bound {} m)", fmt::join(parts, "; "), *args.max_m)};
}

ExpectationResult MinObstacleGap(const ExpectArgs& args, const RunRecord& record) {
  bool passed = true;
  std::vector<std::string> parts;
  for (const CarMetrics& car : record.cars) {
    if (!Concerns(args, car.id)) continue;
    if (!car.min_obstacle_gap_m) {
      parts.push_back(
          fmt::format("car {}: no obstacle within {} m", car.id, kObstacleGapHorizon_m));
      continue;
    }
    passed = passed && *car.min_obstacle_gap_m >= *args.min_m;
    parts.push_back(fmt::format("car {}: least gap {:.3f} m", car.id, *car.min_obstacle_gap_m));
  }
  return {"", passed, fmt::format("{} (bound {} m)", fmt::join(parts, "; "), *args.min_m)};
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

ExpectationResult NodeRate(const ExpectArgs& args, const RunRecord& record) {
  const BoardReport* board = BoardOf(record, *args.car);
  const NodeReport* node = board ? board->report.FindNode(*args.node) : nullptr;
  if (!node) {
    return {"", false, fmt::format("car {} runs no node '{}'", *args.car, *args.node)};
  }
  return {"", Within(node->rate_hz, args.min_hz, args.max_hz),
          fmt::format("car {}: {} at {:.1f} Hz, {} dropped", *args.car, *args.node, node->rate_hz,
                      node->drops)};
}

ExpectationResult CpuDemand(const ExpectArgs& args, const RunRecord& record) {
  const BoardReport* board = BoardOf(record, *args.car);
  if (!board) return {"", false, fmt::format("car {} has no board", *args.car)};
  const MetricsReport& r = board->report;
  return {"", Within(r.cpu_demand_percent, args.min_percent, args.max_percent),
          fmt::format("car {}: CPU demand {:.0f} %, load {:.0f} % of {} cores", *args.car,
                      r.cpu_demand_percent, r.cpu_percent, r.cores)};
}

}  // namespace

std::vector<ExpectationResult> EvaluateExpectations(const Scenario& scenario,
                                                    const RunRecord& record) {
  std::vector<ExpectationResult> results;
  for (const ExpectClause& clause : scenario.expect) {
    const std::string kind = clause.kind();
    const ExpectArgs& args = clause.args();
    ExpectationResult result;
    if (kind == "no_collision") result = NoCollision(args, record);
    if (kind == "intersection_mutex") result = IntersectionMutex(record);
    if (kind == "no_entry_without_grant") result = NoEntryWithoutGrant(args, record);
    if (kind == "completes") result = Completes(args, record);
    if (kind == "max_lateral_error") result = MaxLateralError(args, record);
    if (kind == "min_obstacle_gap") result = MinObstacleGap(args, record);
    if (kind == "node_rate") result = NodeRate(args, record);
    if (kind == "cpu_demand") result = CpuDemand(args, record);
    result.name = Name(clause);
    results.push_back(std::move(result));
  }
  return results;
}

}  // namespace autonomsim::sim
