// The faults a scenario can strike (`faults:`), one struct per kind: what it does (kMeaning, for
// the scenario reference), its keys (Describe), its checks (Validate), and its arguments in words
// for the fault_begin event (Detail). A `faults:` entry is a FaultClause, read as a one-key mapping
// naming the kind (sim/core/config.h), e.g.
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
#include "sim/platform/platform_profile.h"

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
  static constexpr std::string_view kMeaning =
      "The car's messages to and from the traffic-light server (as `direction` says) are lost, "
      "those in flight included";
  static constexpr bool kLastsWithoutEnd = true;
  double at_s{0.0};
  std::optional<double> for_s;
  std::optional<int> car;  // default: every car
  std::optional<LinkDirection> direction;

  template <class V>
  void Describe(V& v) {
    v("at_s", at_s, "when it strikes");
    v("for_s", for_s, "how long it lasts (default: to the run's end)");
    v("car", car, "the car whose link it cuts (default: every car)");
    v("direction", direction, "`up` (car to server), `down` or `both` (default both)");
  }
  void Validate() const { ValidateFaultTiming(at_s, for_s); }
  std::string Detail() const;
};

// {car?, loss in (0, 1], for_s?}
struct V2iLossBurstFault {
  static constexpr FaultKind kKind = FaultKind::kV2iLossBurst;
  static constexpr std::string_view kMeaning =
      "Each of the car's messages is lost with probability `loss`, on top of `v2i.loss`; delays "
      "are unchanged";
  static constexpr bool kLastsWithoutEnd = true;
  double at_s{0.0};
  std::optional<double> for_s;
  std::optional<int> car;  // default: every car
  double loss{1.0};        // probability that a message is lost, on top of the modeled loss

  template <class V>
  void Describe(V& v) {
    v("at_s", at_s, "when it strikes");
    v("for_s", for_s, "how long it lasts (default: to the run's end)");
    v("car", car, "the car whose link it strikes (default: every car)");
    v("loss", loss, kRequired,
      "probability that a message is lost, on top of `v2i.loss`, in (0, 1]");
  }
  void Validate() const;
  std::string Detail() const;
};

// {for_s?}: a fault of the whole fleet (server_restart: without for_s the server is back at once;
// broker_outage: without for_s it lasts to the run's end).
template <FaultKind Kind, bool LastsWithoutEndOfRun>
struct FleetFault {
  static constexpr FaultKind kKind = Kind;
  static constexpr std::string_view kMeaning =
      Kind == FaultKind::kServerRestart
          ? "The traffic-light server forgets every holder, queue and lease, as the lab's vtl.py "
            "does; with `for_s` it is down that long first and what reaches it is lost"
          : "Every message of every car is lost, both ways; the `fifo` server, cut off too, "
            "pauses its leases and gives each holder and queued car a full lease when the broker "
            "is back";
  static constexpr bool kLastsWithoutEnd = LastsWithoutEndOfRun;
  double at_s{0.0};
  std::optional<double> for_s;

  template <class V>
  void Describe(V& v) {
    v("at_s", at_s, "when it strikes");
    v("for_s", for_s,
      "how long it lasts (default: `server_restart` at once, `broker_outage` to the run's end)");
  }
  void Validate() const { ValidateFaultTiming(at_s, for_s); }
  std::string Detail() const;
};
using ServerRestartFault = FleetFault<FaultKind::kServerRestart, false>;
using BrokerOutageFault = FleetFault<FaultKind::kBrokerOutage, true>;

// {car, for_s?}
struct CarStallFault {
  static constexpr FaultKind kKind = FaultKind::kCarStall;
  static constexpr std::string_view kMeaning =
      "The car's motor is dead: no throttle whatever the driver commands (steering works), so it "
      "rolls to a stop; its board and client run on";
  static constexpr bool kLastsWithoutEnd = true;
  double at_s{0.0};
  std::optional<double> for_s;
  int car{0};

  template <class V>
  void Describe(V& v) {
    v("at_s", at_s, "when it strikes");
    v("for_s", for_s, "how long it lasts (default: to the run's end)");
    v("car", car, kRequired, "the car it strikes");
  }
  void Validate() const { ValidateFaultTiming(at_s, for_s); }
  std::string Detail() const;
};

// {car, node}: a crashed node stays down (node_hang has for_s).
struct NodeCrashFault {
  static constexpr FaultKind kKind = FaultKind::kNodeCrash;
  static constexpr std::string_view kMeaning =
      "The node dies for the rest of the run: its running job publishes nothing, nothing reaches "
      "it";
  static constexpr bool kLastsWithoutEnd = true;
  double at_s{0.0};
  int car{0};
  std::string node;  // a node on the car's board

  template <class V>
  void Describe(V& v) {
    v("at_s", at_s, "when it strikes");
    v("car", car, kRequired, "the car it strikes");
    v("node", node, kRequired, "a node on the car's board (a wrong name lists them)");
  }
  void Validate() const;
  std::string Detail() const;
};

// {car, node, for_s?}
struct NodeHangFault {
  static constexpr FaultKind kKind = FaultKind::kNodeHang;
  static constexpr std::string_view kMeaning =
      "The node's executor blocks: its outputs wait, messages pile up in its queues, timer ticks "
      "are overruns; it catches up when the hang ends";
  static constexpr bool kLastsWithoutEnd = true;
  double at_s{0.0};
  std::optional<double> for_s;
  int car{0};
  std::string node;  // a node on the car's board

  template <class V>
  void Describe(V& v) {
    v("at_s", at_s, "when it strikes");
    v("for_s", for_s, "how long it lasts (default: to the run's end)");
    v("car", car, kRequired, "the car it strikes");
    v("node", node, kRequired, "a node on the car's board (a wrong name lists them)");
  }
  void Validate() const;
  std::string Detail() const;
};

// {car, camera: color|depth (default color), for_s?}: camera_freeze and camera_blackout.
template <FaultKind Kind>
struct CameraFault {
  static constexpr FaultKind kKind = Kind;
  static constexpr std::string_view kMeaning =
      Kind == FaultKind::kCameraFreeze
          ? "The camera publishes its last picture again and again under new stamps"
          : "The camera publishes black frames (the depth camera: no return)";
  static constexpr bool kLastsWithoutEnd = true;
  double at_s{0.0};
  std::optional<double> for_s;
  int car{0};
  CameraChoice camera{CameraChoice::kColor};

  template <class V>
  void Describe(V& v) {
    v("at_s", at_s, "when it strikes");
    v("for_s", for_s, "how long it lasts (default: to the run's end)");
    v("car", car, kRequired, "the car it strikes");
    v("camera", camera, "`color` or `depth`");
  }
  void Validate() const { ValidateFaultTiming(at_s, for_s); }
  std::string Detail() const;
};
using CameraFreezeFault = CameraFault<FaultKind::kCameraFreeze>;
using CameraBlackoutFault = CameraFault<FaultKind::kCameraBlackout>;

// {car, gyro_bias_rad_per_s (finite, not 0), for_s?}: without for_s the bias stays.
struct ImuBiasStepFault {
  static constexpr FaultKind kKind = FaultKind::kImuBiasStep;
  static constexpr std::string_view kMeaning =
      "The gyro's bias steps by `gyro_bias_rad_per_s`, so its yaw rate reads that much more; the "
      "heading drifts with it only where the IMU integrates its gyro "
      "(`sensors.imu.imu.heading_source: gyro`)";
  static constexpr bool kLastsWithoutEnd = false;
  double at_s{0.0};
  std::optional<double> for_s;
  int car{0};
  double gyro_bias_rad_per_s{0.0};  // added to the gyro's z bias

  template <class V>
  void Describe(V& v) {
    v("at_s", at_s, "when it strikes");
    v("for_s", for_s, "how long it lasts (default: to the run's end)");
    v("car", car, kRequired, "the car it strikes");
    v("gyro_bias_rad_per_s", gyro_bias_rad_per_s, kRequired,
      "the step in the gyro's z bias (finite, not 0)");
  }
  void Validate() const;
  std::string Detail() const;
};

// {car, dx_m?, dy_m?, dyaw_deg?}: the estimate's jump, map frame; instantaneous.
struct LocalizationJumpFault {
  static constexpr FaultKind kKind = FaultKind::kLocalizationJump;
  static constexpr std::string_view kMeaning =
      "The EKF's estimate jumps by `dx_m`, `dy_m` and `dyaw_deg` (map frame), at once";
  static constexpr bool kLastsWithoutEnd = false;
  double at_s{0.0};
  int car{0};
  std::optional<double> dx_m;
  std::optional<double> dy_m;
  std::optional<double> dyaw_deg;

  template <class V>
  void Describe(V& v) {
    v("at_s", at_s, "when it strikes");
    v("car", car, kRequired, "the car it strikes");
    v("dx_m", dx_m, "the estimate's jump east");
    v("dy_m", dy_m, "its jump north");
    v("dyaw_deg", dyaw_deg, "its turn, counter-clockwise");
  }
  void Validate() const;
  std::string Detail() const;
};

// {car, node, target}: the node moves between software and hardware at at_s (run-time remapping);
// instantaneous, the new mapping stays.
struct RemapFault {
  static constexpr FaultKind kKind = FaultKind::kRemap;
  static constexpr std::string_view kMeaning =
      "The node moves to `target` (`sw` or `hw`) from its next job on: to software it runs on the "
      "cores at its software cost; to hardware it takes a slot as the ReconROS executor gives one, "
      "reconfiguring it (needs `platform.slot_policy: executor` and a cost of the target's kind)";
  static constexpr bool kLastsWithoutEnd = false;
  double at_s{0.0};
  int car{0};
  std::string node;  // a node on the car's board
  Target target{Target::kSw};

  template <class V>
  void Describe(V& v) {
    v("at_s", at_s, "when it strikes");
    v("car", car, kRequired, "the car it strikes");
    v("node", node, kRequired, "a node on the car's board (a wrong name lists them)");
    v("target", target, kRequired, "where it runs from then on: `sw` or `hw`");
  }
  void Validate() const;
  std::string Detail() const;
};

// One `faults:` entry.
using FaultClause =
    std::variant<V2iPartitionFault, V2iLossBurstFault, ServerRestartFault, BrokerOutageFault,
                 CarStallFault, NodeCrashFault, NodeHangFault, CameraFreezeFault,
                 CameraBlackoutFault, ImuBiasStepFault, LocalizationJumpFault, RemapFault>;

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
