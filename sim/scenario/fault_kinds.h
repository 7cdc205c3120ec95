// The faults a scenario can strike (`faults:`), one struct per kind: its keys (Describe), its
// checks (Validate), and its arguments in words for the fault_begin event (Detail). A `faults:`
// entry is a FaultClause, read as a one-key mapping naming the kind (sim/core/config.h), e.g.
// `- car_stall: {car: 1, at_s: 20}`. What each kind does, and how it is scheduled, is in
// sim/loop/faults.h; adding a kind is one struct here, its name in sim/core/vocabulary.h and
// its Schedule overload in sim/loop/faults.cc, which the compiler asks for.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <variant>

#include "sim/core/config.h"
#include "sim/core/vocabulary.h"

namespace autonomsim::sim {

// v2i_partition: which way messages are lost.
enum class LinkDirection { kUp, kDown, kBoth };
// camera_freeze, camera_blackout: which camera.
enum class CameraChoice { kColor, kDepth };

}  // namespace autonomsim::sim

namespace autonomsim {
template <>
struct NameTable<sim::LinkDirection> {
  using K = sim::LinkDirection;
  static constexpr std::array<std::pair<K, std::string_view>, 3> kEntries{
      {{K::kUp, "up"}, {K::kDown, "down"}, {K::kBoth, "both"}}};
};
template <>
struct NameTable<sim::CameraChoice> {
  using K = sim::CameraChoice;
  static constexpr std::array<std::pair<K, std::string_view>, 2> kEntries{
      {{K::kColor, "color"}, {K::kDepth, "depth"}}};
};
}  // namespace autonomsim

namespace autonomsim::sim {

// Every fault starts at at_s (s, >= 0); for_s (s, > 0), where the kind has it, is how long it
// lasts (absent: to the run's end for a fault that disables something, kLastsWithoutEnd, and
// done at once for an instantaneous one).
void ValidateFaultTiming(double at_s, const std::optional<double>& for_s);

// {car?, direction: up|down|both (default both), for_s?}
struct V2iPartitionFault {
  static constexpr FaultKind kKind = FaultKind::kV2iPartition;
  static constexpr bool kLastsWithoutEnd = true;
  double at_s{0.0};
  std::optional<double> for_s;
  std::optional<int> car;  // default: every car
  std::optional<LinkDirection> direction;

  template <class V>
  void Describe(V& v) {
    v("at_s", at_s);
    v("for_s", for_s);
    v("car", car);
    v("direction", direction);
  }
  void Validate() const { ValidateFaultTiming(at_s, for_s); }
  std::string Detail() const;
};

// {car?, loss in (0, 1], for_s?}
struct V2iLossBurstFault {
  static constexpr FaultKind kKind = FaultKind::kV2iLossBurst;
  static constexpr bool kLastsWithoutEnd = true;
  double at_s{0.0};
  std::optional<double> for_s;
  std::optional<int> car;  // default: every car
  double loss{1.0};        // probability that a message is lost, on top of the modeled loss

  template <class V>
  void Describe(V& v) {
    v("at_s", at_s);
    v("for_s", for_s);
    v("car", car);
    v("loss", loss, kRequired);
  }
  void Validate() const;
  std::string Detail() const;
};

// {for_s?}: a fault of the whole fleet (server_restart: without for_s the server is back at once;
// broker_outage: without for_s it lasts to the run's end).
template <FaultKind Kind, bool LastsWithoutEndOfRun>
struct FleetFault {
  static constexpr FaultKind kKind = Kind;
  static constexpr bool kLastsWithoutEnd = LastsWithoutEndOfRun;
  double at_s{0.0};
  std::optional<double> for_s;

  template <class V>
  void Describe(V& v) {
    v("at_s", at_s);
    v("for_s", for_s);
  }
  void Validate() const { ValidateFaultTiming(at_s, for_s); }
  std::string Detail() const;
};
using ServerRestartFault = FleetFault<FaultKind::kServerRestart, false>;
using BrokerOutageFault = FleetFault<FaultKind::kBrokerOutage, true>;

// {car, for_s?}
struct CarStallFault {
  static constexpr FaultKind kKind = FaultKind::kCarStall;
  static constexpr bool kLastsWithoutEnd = true;
  double at_s{0.0};
  std::optional<double> for_s;
  int car{0};

  template <class V>
  void Describe(V& v) {
    v("at_s", at_s);
    v("for_s", for_s);
    v("car", car, kRequired);
  }
  void Validate() const { ValidateFaultTiming(at_s, for_s); }
  std::string Detail() const;
};

// {car, node}: a crashed node stays down (node_hang has for_s).
struct NodeCrashFault {
  static constexpr FaultKind kKind = FaultKind::kNodeCrash;
  static constexpr bool kLastsWithoutEnd = true;
  double at_s{0.0};
  int car{0};
  std::string node;  // a node on the car's board

  template <class V>
  void Describe(V& v) {
    v("at_s", at_s);
    v("car", car, kRequired);
    v("node", node, kRequired);
  }
  void Validate() const;
  std::string Detail() const;
};

// {car, node, for_s?}
struct NodeHangFault {
  static constexpr FaultKind kKind = FaultKind::kNodeHang;
  static constexpr bool kLastsWithoutEnd = true;
  double at_s{0.0};
  std::optional<double> for_s;
  int car{0};
  std::string node;  // a node on the car's board

  template <class V>
  void Describe(V& v) {
    v("at_s", at_s);
    v("for_s", for_s);
    v("car", car, kRequired);
    v("node", node, kRequired);
  }
  void Validate() const;
  std::string Detail() const;
};

// {car, camera: color|depth (default color), for_s?}: camera_freeze and camera_blackout.
template <FaultKind Kind>
struct CameraFault {
  static constexpr FaultKind kKind = Kind;
  static constexpr bool kLastsWithoutEnd = true;
  double at_s{0.0};
  std::optional<double> for_s;
  int car{0};
  CameraChoice camera{CameraChoice::kColor};

  template <class V>
  void Describe(V& v) {
    v("at_s", at_s);
    v("for_s", for_s);
    v("car", car, kRequired);
    v("camera", camera);
  }
  void Validate() const { ValidateFaultTiming(at_s, for_s); }
  std::string Detail() const;
};
using CameraFreezeFault = CameraFault<FaultKind::kCameraFreeze>;
using CameraBlackoutFault = CameraFault<FaultKind::kCameraBlackout>;

// {car, gyro_bias_rad_per_s (finite, not 0), for_s?}: without for_s the bias stays.
struct ImuBiasStepFault {
  static constexpr FaultKind kKind = FaultKind::kImuBiasStep;
  static constexpr bool kLastsWithoutEnd = false;
  double at_s{0.0};
  std::optional<double> for_s;
  int car{0};
  double gyro_bias_rad_per_s{0.0};  // added to the gyro's z bias

  template <class V>
  void Describe(V& v) {
    v("at_s", at_s);
    v("for_s", for_s);
    v("car", car, kRequired);
    v("gyro_bias_rad_per_s", gyro_bias_rad_per_s, kRequired);
  }
  void Validate() const;
  std::string Detail() const;
};

// {car, dx_m?, dy_m?, dyaw_deg?}: the estimate's jump, map frame; instantaneous.
struct LocalizationJumpFault {
  static constexpr FaultKind kKind = FaultKind::kLocalizationJump;
  static constexpr bool kLastsWithoutEnd = false;
  double at_s{0.0};
  int car{0};
  std::optional<double> dx_m;
  std::optional<double> dy_m;
  std::optional<double> dyaw_deg;

  template <class V>
  void Describe(V& v) {
    v("at_s", at_s);
    v("car", car, kRequired);
    v("dx_m", dx_m);
    v("dy_m", dy_m);
    v("dyaw_deg", dyaw_deg);
  }
  void Validate() const;
  std::string Detail() const;
};

// One `faults:` entry.
using FaultClause =
    std::variant<V2iPartitionFault, V2iLossBurstFault, ServerRestartFault, BrokerOutageFault,
                 CarStallFault, NodeCrashFault, NodeHangFault, CameraFreezeFault,
                 CameraBlackoutFault, ImuBiasStepFault, LocalizationJumpFault>;

// What every kind has, read the same way for all.
FaultKind KindOf(const FaultClause& fault);
double FaultStart_s(const FaultClause& fault);
std::optional<double> FaultDuration_s(const FaultClause& fault);  // for_s, where the kind has it
std::optional<int> FaultCar(const FaultClause& fault);            // the car it strikes, if one
// Whether the fault, without for_s, lasts to the run's end (true) or is done at once (false).
bool LastsWithoutEnd(const FaultClause& fault);
// The fault_begin event's detail: the fault's arguments in words, e.g. "node lane_planner, for 2
// s".
std::string DescribeFault(const FaultClause& fault);

}  // namespace autonomsim::sim
