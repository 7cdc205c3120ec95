#include "sim/scenario/expect_kinds.h"

#include <fmt/format.h>

#include <vector>

#include "world/validation.h"

namespace autonomsim::sim {
namespace {

// Lists the keys a struct has, as "key=value" for those that have a value.
class NamePartsWriter {
 public:
  template <class T>
  void operator()(const char* key, const T& value, const char* /*meaning*/ = "") {
    if constexpr (detail::IsOptional<T>::value) {
      if (value) parts.push_back(fmt::format("{}={}", key, *value));
    } else {
      parts.push_back(fmt::format("{}={}", key, value));
    }
  }
  template <class T>
  void operator()(const char* key, const T& value, RequiredKey, const char* /*meaning*/ = "") {
    (*this)(key, value);
  }
  std::vector<std::string> parts;
};

void ValidateIntersection(const std::optional<int>& intersection) {
  Require(!intersection || (*intersection >= 0 && *intersection <= 9),
          "intersection must be an id 0..9");
}

}  // namespace

void CompletesExpect::Validate() const {
  Require(laps >= 1, "completes needs laps >= 1");
  Require(!within_s || *within_s > 0.0, "within_s must be > 0");
}
void MaxLateralErrorExpect::Validate() const {
  Require(max_m > 0.0, "max_lateral_error needs max_m > 0");
}
void MinObstacleGapExpect::Validate() const {
  Require(min_m >= 0.0, "min_obstacle_gap needs min_m >= 0");
}
void NodeRateExpect::Validate() const {
  Require(!node.empty(), "node_rate needs car and node");
  Require(min_hz.has_value() || max_hz.has_value(), "node_rate needs min_hz or max_hz");
}
void CpuDemandExpect::Validate() const {
  Require(min_percent.has_value() || max_percent.has_value(),
          "cpu_demand needs min_percent or max_percent");
}
void NoGridlockExpect::Validate() const { Require(!max_s || *max_s > 0.0, "max_s must be > 0"); }
void MaxWaitExpect::Validate() const {
  Require(max_s > 0.0, "max_wait needs max_s > 0");
  ValidateIntersection(intersection);
}
void MinThroughputExpect::Validate() const {
  Require(per_minute >= 0.0, "min_throughput needs per_minute >= 0");
  ValidateIntersection(intersection);
}
void RecoversWithinExpect::Validate() const {
  Require(max_s > 0.0, "recovers_within needs max_s > 0");
}

ExpectKind KindOf(const ExpectClause& expectation) {
  return std::visit([](const auto& e) { return e.kKind; }, expectation);
}

std::optional<int> ExpectedCar(const ExpectClause& expectation) {
  return std::visit(
      [](const auto& e) -> std::optional<int> {
        if constexpr (requires { e.car; }) return e.car;
        return std::nullopt;
      },
      expectation);
}

std::optional<int> ExpectedIntersection(const ExpectClause& expectation) {
  return std::visit(
      [](const auto& e) -> std::optional<int> {
        if constexpr (requires { e.intersection; }) return e.intersection;
        return std::nullopt;
      },
      expectation);
}

std::optional<double> ExpectedWithin_s(const ExpectClause& expectation) {
  return std::visit(
      [](const auto& e) -> std::optional<double> {
        if constexpr (requires { e.within_s; }) return e.within_s;
        return std::nullopt;
      },
      expectation);
}

std::string ExpectationName(const ExpectClause& expectation) {
  return std::visit(
      [](const auto& e) {
        NamePartsWriter writer;
        const_cast<std::remove_cvref_t<decltype(e)>&>(e).Describe(writer);  // reads only
        const std::string_view kind = ToName(e.kKind);
        if (writer.parts.empty()) return std::string(kind);
        return fmt::format("{}({})", kind, fmt::join(writer.parts, ", "));
      },
      expectation);
}

}  // namespace autonomsim::sim
