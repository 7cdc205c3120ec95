// The expectations a scenario can state (`expect:`), one struct per kind: its keys (Describe) and
// its checks (Validate). An `expect:` entry is an ExpectClause, read as a one-key mapping naming
// the kind (sim/core/config.h), e.g. `- completes: {car: 0, laps: 3}`. sim/results/expectations.cc
// judges each kind with an Evaluate overload, which the compiler asks for when a kind is added
// here (and its name in sim/core/vocabulary.h).
#pragma once

#include <optional>
#include <string>
#include <variant>

#include "sim/core/config.h"
#include "sim/core/vocabulary.h"

namespace autonomsim::sim {

// {car?}: no collision (of that car; of any car).
struct NoCollisionExpect {
  static constexpr ExpectKind kKind = ExpectKind::kNoCollision;
  std::optional<int> car;  // the car it is about (default: every car)
  template <class V>
  void Describe(V& v) {
    v("car", car);
  }
  void Validate() const {}
};

// {}: never two cars inside one intersection area.
struct IntersectionMutexExpect {
  static constexpr ExpectKind kKind = ExpectKind::kIntersectionMutex;
  template <class V>
  void Describe(V&) {}
  void Validate() const {}
};

// {car?}: every entry into an intersection area while the server held it for the car.
struct NoEntryWithoutGrantExpect {
  static constexpr ExpectKind kKind = ExpectKind::kNoEntryWithoutGrant;
  std::optional<int> car;
  template <class V>
  void Describe(V& v) {
    v("car", car);
  }
  void Validate() const {}
};

// {car?, laps, within_s?}: laps finished by within_s (default: the scenario's duration).
struct CompletesExpect {
  static constexpr ExpectKind kKind = ExpectKind::kCompletes;
  std::optional<int> car;
  int laps{1};
  std::optional<double> within_s;
  template <class V>
  void Describe(V& v) {
    v("car", car);
    v("laps", laps, kRequired);
    v("within_s", within_s);
  }
  void Validate() const;
};

// {car?, max_m}: the ground-truth lateral error stays within max_m (m).
struct MaxLateralErrorExpect {
  static constexpr ExpectKind kKind = ExpectKind::kMaxLateralError;
  std::optional<int> car;
  double max_m{0.0};
  template <class V>
  void Describe(V& v) {
    v("car", car);
    v("max_m", max_m, kRequired);
  }
  void Validate() const;
};

// {car?, min_m}: the least free distance to an obstacle stays at least min_m (m).
struct MinObstacleGapExpect {
  static constexpr ExpectKind kKind = ExpectKind::kMinObstacleGap;
  std::optional<int> car;
  double min_m{0.0};
  template <class V>
  void Describe(V& v) {
    v("car", car);
    v("min_m", min_m, kRequired);
  }
  void Validate() const;
};

// {car, node, min_hz and/or max_hz}: the node's jobs per second on the car's board.
struct NodeRateExpect {
  static constexpr ExpectKind kKind = ExpectKind::kNodeRate;
  int car{0};
  std::string node;
  std::optional<double> min_hz;
  std::optional<double> max_hz;
  template <class V>
  void Describe(V& v) {
    v("car", car, kRequired);
    v("node", node, kRequired);
    v("min_hz", min_hz);
    v("max_hz", max_hz);
  }
  void Validate() const;
};

// {car, min_percent and/or max_percent}: the board's CPU demand (% of one core, summed over its
// nodes).
struct CpuDemandExpect {
  static constexpr ExpectKind kKind = ExpectKind::kCpuDemand;
  int car{0};
  std::optional<double> min_percent;
  std::optional<double> max_percent;
  template <class V>
  void Describe(V& v) {
    v("car", car, kRequired);
    v("min_percent", min_percent);
    v("max_percent", max_percent);
  }
  void Validate() const;
};

// {car?, max_s?}: no car stands still longer than max_s (default 30 s) unless a red light holds
// it (sim/results/expectations.cc says exactly when).
struct NoGridlockExpect {
  static constexpr ExpectKind kKind = ExpectKind::kNoGridlock;
  std::optional<int> car;
  std::optional<double> max_s;
  template <class V>
  void Describe(V& v) {
    v("car", car);
    v("max_s", max_s);
  }
  void Validate() const;
};

// {car?, intersection?, max_s}: each wait at a stop zone lasts at most max_s.
struct MaxWaitExpect {
  static constexpr ExpectKind kKind = ExpectKind::kMaxWait;
  std::optional<int> car;
  double max_s{0.0};
  std::optional<int> intersection;  // the one it is about (default: all)
  template <class V>
  void Describe(V& v) {
    v("car", car);
    v("max_s", max_s, kRequired);
    v("intersection", intersection);
  }
  void Validate() const;
};

// {intersection?, per_minute}: crossings per minute of the run.
struct MinThroughputExpect {
  static constexpr ExpectKind kKind = ExpectKind::kMinThroughput;
  std::optional<int> intersection;
  double per_minute{0.0};
  template <class V>
  void Describe(V& v) {
    v("intersection", intersection);
    v("per_minute", per_minute, kRequired);
  }
  void Validate() const;
};

// {car?, max_s}: after each fault ends, every car moves again within max_s.
struct RecoversWithinExpect {
  static constexpr ExpectKind kKind = ExpectKind::kRecoversWithin;
  std::optional<int> car;
  double max_s{0.0};
  template <class V>
  void Describe(V& v) {
    v("car", car);
    v("max_s", max_s, kRequired);
  }
  void Validate() const;
};

// One `expect:` entry.
using ExpectClause =
    std::variant<NoCollisionExpect, IntersectionMutexExpect, NoEntryWithoutGrantExpect,
                 CompletesExpect, MaxLateralErrorExpect, MinObstacleGapExpect, NodeRateExpect,
                 CpuDemandExpect, NoGridlockExpect, MaxWaitExpect, MinThroughputExpect,
                 RecoversWithinExpect>;

ExpectKind KindOf(const ExpectClause& expectation);
// What every kind may have, read the same way for all.
std::optional<int> ExpectedCar(const ExpectClause& expectation);
std::optional<int> ExpectedIntersection(const ExpectClause& expectation);
std::optional<double> ExpectedWithin_s(const ExpectClause& expectation);
// Its name in results: the kind and its keys as given, e.g. "completes(car=0, laps=3)".
std::string ExpectationName(const ExpectClause& expectation);

}  // namespace autonomsim::sim
