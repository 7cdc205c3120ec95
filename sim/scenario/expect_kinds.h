// The expectations a scenario can state (`expect:`), one struct per kind: what it checks
// (kMeaning, for the scenario reference), its keys (Describe) and its checks (Validate). An
// `expect:` entry is an ExpectClause, read as a one-key mapping naming the kind
// (sim/core/config.h), e.g. `- completes: {car: 0, laps: 3}`. sim/results/expectations.cc judges
// each kind with an Evaluate overload, which the compiler asks for when a kind is added here (and
// its name in sim/core/vocabulary.h).
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <variant>

#include "sim/core/config.h"
#include "sim/core/vocabulary.h"

namespace autonomsim::sim {

// {car?}: no collision (of that car; of any car).
struct NoCollisionExpect {
  static constexpr ExpectKind kKind = ExpectKind::kNoCollision;
  static constexpr std::string_view kMeaning =
      "No collision of the car, with another car or an obstacle";
  std::optional<int> car;  // the car it is about (default: every car)
  template <class V>
  void Describe(V& v) {
    v("car", car, "the car it is about (default: every car)");
  }
  void Validate() const {}
};

// {}: never two cars inside one intersection area.
struct IntersectionMutexExpect {
  static constexpr ExpectKind kKind = ExpectKind::kIntersectionMutex;
  static constexpr std::string_view kMeaning =
      "Never two cars' centres inside one intersection's area";
  template <class V>
  void Describe(V&) {}
  void Validate() const {}
};

// {car?}: every entry into an intersection area while the server held it for the car.
struct NoEntryWithoutGrantExpect {
  static constexpr ExpectKind kKind = ExpectKind::kNoEntryWithoutGrant;
  static constexpr std::string_view kMeaning =
      "The car enters an intersection's area only while the server holds the intersection for it";
  std::optional<int> car;
  template <class V>
  void Describe(V& v) {
    v("car", car, "the car it is about (default: every car)");
  }
  void Validate() const {}
};

// {car?, laps, within_s?}: laps finished by within_s (default: the scenario's duration).
struct CompletesExpect {
  static constexpr ExpectKind kKind = ExpectKind::kCompletes;
  static constexpr std::string_view kMeaning = "The car finishes `laps` laps by `within_s`";
  std::optional<int> car;
  int laps{1};
  std::optional<double> within_s;
  template <class V>
  void Describe(V& v) {
    v("car", car, "the car it is about (default: every car)");
    v("laps", laps, kRequired, "laps each car must finish");
    v("within_s", within_s, "by this time (default: the run's end)");
  }
  void Validate() const;
};

// {car?, max_m}: the ground-truth lateral error stays within max_m (m).
struct MaxLateralErrorExpect {
  static constexpr ExpectKind kKind = ExpectKind::kMaxLateralError;
  static constexpr std::string_view kMeaning =
      "The car's true distance from its lane's centre stays within `max_m`";
  std::optional<int> car;
  double max_m{0.0};
  template <class V>
  void Describe(V& v) {
    v("car", car, "the car it is about (default: every car)");
    v("max_m", max_m, kRequired, "the largest distance from the lane's centre allowed");
  }
  void Validate() const;
};

// {car?, min_m}: the least free distance to an obstacle stays at least min_m (m).
struct MinObstacleGapExpect {
  static constexpr ExpectKind kKind = ExpectKind::kMinObstacleGap;
  static constexpr std::string_view kMeaning =
      "The car's least free distance to an obstacle stays at least `min_m`";
  std::optional<int> car;
  double min_m{0.0};
  template <class V>
  void Describe(V& v) {
    v("car", car, "the car it is about (default: every car)");
    v("min_m", min_m, kRequired, "the least free distance to an obstacle allowed");
  }
  void Validate() const;
};

// {car, node, min_hz and/or max_hz}: the node's jobs per second on the car's board.
struct NodeRateExpect {
  static constexpr ExpectKind kKind = ExpectKind::kNodeRate;
  static constexpr std::string_view kMeaning =
      "The node's jobs per second on the car's board stay within `min_hz` and/or `max_hz`";
  int car{0};
  std::string node;
  std::optional<double> min_hz;
  std::optional<double> max_hz;
  template <class V>
  void Describe(V& v) {
    v("car", car, kRequired, "the car whose board runs the node");
    v("node", node, kRequired, "a node on the car's board");
    v("min_hz", min_hz, "its jobs per second at least");
    v("max_hz", max_hz, "its jobs per second at most");
  }
  void Validate() const;
};

// {car, min_percent and/or max_percent}: the board's CPU demand (% of one core, summed over its
// nodes).
struct CpuDemandExpect {
  static constexpr ExpectKind kKind = ExpectKind::kCpuDemand;
  static constexpr std::string_view kMeaning =
      "The board's CPU demand (% of one core, summed over its nodes) stays within `min_percent` "
      "and/or `max_percent`";
  int car{0};
  std::optional<double> min_percent;
  std::optional<double> max_percent;
  template <class V>
  void Describe(V& v) {
    v("car", car, kRequired, "the car whose board it is about");
    v("min_percent", min_percent, "the board's CPU demand at least (100 = one core)");
    v("max_percent", max_percent, "the board's CPU demand at most");
  }
  void Validate() const;
};

// {car?, max_s?}: no car stands still longer than max_s (default 30 s) unless a red light holds
// it (sim/results/expectations.cc says exactly when).
struct NoGridlockExpect {
  static constexpr ExpectKind kKind = ExpectKind::kNoGridlock;
  static constexpr std::string_view kMeaning =
      "No car stands still (under 2 cm/s) longer than `max_s` unless excused: parked after its "
      "laps, held at a red light, or stalled by a fault ([writing "
      "scenarios](writing-scenarios.md#expectations) says exactly when)";
  std::optional<int> car;
  std::optional<double> max_s;
  template <class V>
  void Describe(V& v) {
    v("car", car, "the car it is about (default: every car)");
    v("max_s", max_s, "the longest a car may stand still unexcused (default 30 s)");
  }
  void Validate() const;
};

// {car?, intersection?, max_s}: each wait at a stop zone lasts at most max_s.
struct MaxWaitExpect {
  static constexpr ExpectKind kKind = ExpectKind::kMaxWait;
  static constexpr std::string_view kMeaning =
      "Every wait at a stop zone, from `wait` to `go` (an unfinished one to the run's end), lasts "
      "at most `max_s`";
  std::optional<int> car;
  double max_s{0.0};
  std::optional<int> intersection;  // the one it is about (default: all)
  template <class V>
  void Describe(V& v) {
    v("car", car, "the car it is about (default: every car)");
    v("max_s", max_s, kRequired, "the longest one wait at a stop zone may last");
    v("intersection", intersection, "the intersection it is about (default: every one)");
  }
  void Validate() const;
};

// {intersection?, per_minute}: crossings per minute of the run.
struct MinThroughputExpect {
  static constexpr ExpectKind kKind = ExpectKind::kMinThroughput;
  static constexpr std::string_view kMeaning =
      "At least `per_minute` crossings (`enter` events) per minute of the run at each intersection";
  std::optional<int> intersection;
  double per_minute{0.0};
  template <class V>
  void Describe(V& v) {
    v("intersection", intersection, "the intersection it is about (default: each one)");
    v("per_minute", per_minute, kRequired, "crossings per minute of the run at least");
  }
  void Validate() const;
};

// {car?, max_s}: after each fault ends, every car moves again within max_s.
struct RecoversWithinExpect {
  static constexpr ExpectKind kKind = ExpectKind::kRecoversWithin;
  static constexpr std::string_view kMeaning =
      "After each fault ends, every car moves again within `max_s` (a standstill that overlaps the "
      "fault must be over by then)";
  std::optional<int> car;
  double max_s{0.0};
  template <class V>
  void Describe(V& v) {
    v("car", car, "the car it is about (default: every car)");
    v("max_s", max_s, kRequired, "every car moves again within this of each fault's end");
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
