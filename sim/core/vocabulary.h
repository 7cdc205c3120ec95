// The run's closed vocabulary: the kinds of events (events.jsonl's `type`), faults (`faults:`) and
// expectations (`expect:`), each an enum with the one table that maps it to and from the names the
// files use (world/enum_names.h). A name of a kind appears nowhere else in the C++ code; the replay
// report's JavaScript takes its names from a table generated from these at build time
// (sim/results/report/kinds.js, tools/gen_report_kinds.cc), and tools/check_kind_literals.py
// fails CI on a kind's name written anywhere else.
#pragma once

#include <array>
#include <string_view>
#include <utility>

#include "world/enum_names.h"
#include "world/traffic_light_server.h"

namespace autonomsim::sim {

// docs/outputs.md#events says what each kind means and which fields it carries.
enum class EventKind {
  kRequest,
  kFree,
  kGrant,
  kDenied,
  kLeaseExpired,
  kQueueDrop,
  kWait,
  kGo,
  kEnter,
  kExit,
  kCollision,
  kLap,
  kParked,
  kBehavior,
  kObstacleAppear,
  kObstacleDisappear,
  kV2iLost,
  kV2iMalformed,
  kFaultBegin,
  kFaultEnd,
  kReconfigureBegin,
  kReconfigureEnd,
};

// docs/faults.md says what each kind does; sim/scenario/fault_kinds.h holds their arguments.
enum class FaultKind {
  kV2iPartition,
  kV2iLossBurst,
  kServerRestart,
  kBrokerOutage,
  kCarStall,
  kNodeCrash,
  kNodeHang,
  kCameraFreeze,
  kCameraBlackout,
  kImuBiasStep,
  kLocalizationJump,
  kRemap,
};

// sim/scenario/expect_kinds.h holds their arguments; sim/results/expectations.cc judges them.
enum class ExpectKind {
  kNoCollision,
  kIntersectionMutex,
  kNoEntryWithoutGrant,
  kCompletes,
  kMaxLateralError,
  kMinObstacleGap,
  kNodeRate,
  kCpuDemand,
  kNoGridlock,
  kMaxWait,
  kMinThroughput,
  kRecoversWithin,
};

// The event a traffic-light server record is (request, free, ...).
EventKind EventKindOf(world::ServerRecord::Kind kind);

}  // namespace autonomsim::sim

namespace autonomsim {

template <>
struct NameTable<sim::EventKind> {
  using K = sim::EventKind;
  static constexpr std::array<std::pair<K, std::string_view>, 22> kEntries{{
      {K::kRequest, "request"},
      {K::kFree, "free"},
      {K::kGrant, "grant"},
      {K::kDenied, "denied"},
      {K::kLeaseExpired, "lease_expired"},
      {K::kQueueDrop, "queue_drop"},
      {K::kWait, "wait"},
      {K::kGo, "go"},
      {K::kEnter, "enter"},
      {K::kExit, "exit"},
      {K::kCollision, "collision"},
      {K::kLap, "lap"},
      {K::kParked, "parked"},
      {K::kBehavior, "behavior"},
      {K::kObstacleAppear, "obstacle_appear"},
      {K::kObstacleDisappear, "obstacle_disappear"},
      {K::kV2iLost, "v2i_lost"},
      {K::kV2iMalformed, "v2i_malformed"},
      {K::kFaultBegin, "fault_begin"},
      {K::kFaultEnd, "fault_end"},
      {K::kReconfigureBegin, "reconfigure_begin"},
      {K::kReconfigureEnd, "reconfigure_end"},
  }};
};

template <>
struct NameTable<sim::FaultKind> {
  using K = sim::FaultKind;
  static constexpr std::array<std::pair<K, std::string_view>, 12> kEntries{{
      {K::kV2iPartition, "v2i_partition"},
      {K::kV2iLossBurst, "v2i_loss_burst"},
      {K::kServerRestart, "server_restart"},
      {K::kBrokerOutage, "broker_outage"},
      {K::kCarStall, "car_stall"},
      {K::kNodeCrash, "node_crash"},
      {K::kNodeHang, "node_hang"},
      {K::kCameraFreeze, "camera_freeze"},
      {K::kCameraBlackout, "camera_blackout"},
      {K::kImuBiasStep, "imu_bias_step"},
      {K::kLocalizationJump, "localization_jump"},
      {K::kRemap, "remap"},
  }};
  static constexpr std::string_view kClause =
      "a faults entry names exactly one fault, e.g. '- car_stall: {car: 1, at_s: 20}'";
};

template <>
struct NameTable<sim::ExpectKind> {
  using K = sim::ExpectKind;
  static constexpr std::array<std::pair<K, std::string_view>, 12> kEntries{{
      {K::kNoCollision, "no_collision"},
      {K::kIntersectionMutex, "intersection_mutex"},
      {K::kNoEntryWithoutGrant, "no_entry_without_grant"},
      {K::kCompletes, "completes"},
      {K::kMaxLateralError, "max_lateral_error"},
      {K::kMinObstacleGap, "min_obstacle_gap"},
      {K::kNodeRate, "node_rate"},
      {K::kCpuDemand, "cpu_demand"},
      {K::kNoGridlock, "no_gridlock"},
      {K::kMaxWait, "max_wait"},
      {K::kMinThroughput, "min_throughput"},
      {K::kRecoversWithin, "recovers_within"},
  }};
  static constexpr std::string_view kClause =
      "an expect entry names exactly one expectation, e.g. '- no_collision: {}'";
};

}  // namespace autonomsim
