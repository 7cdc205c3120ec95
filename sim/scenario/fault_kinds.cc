#include "sim/scenario/fault_kinds.h"

#include <fmt/format.h>

#include <cmath>
#include <vector>

#include "world/validation.h"

namespace autonomsim::sim {
namespace {

// The detail's last part, which every kind has: how long the fault lasts.
template <class Fault>
std::string Lasting(const Fault& fault) {
  if constexpr (requires { fault.for_s; }) {
    if (fault.for_s) return fmt::format("for {} s", *fault.for_s);
  }
  return Fault::kLastsWithoutEnd ? "to the end" : "instantaneous";
}

template <class Fault>
std::string Join(const Fault& fault, std::vector<std::string> parts) {
  parts.push_back(Lasting(fault));
  return fmt::format("{}", fmt::join(parts, ", "));
}

}  // namespace

void ValidateFaultTiming(double at_s, const std::optional<double>& for_s) {
  Require(std::isfinite(at_s) && at_s >= 0.0,
          [&] { return "at_s must be >= 0, got " + Num(at_s); });
  Require(!for_s || (std::isfinite(*for_s) && *for_s > 0.0),
          "for_s must be > 0 (leave it out for a fault that lasts to the end of the run)");
}

void V2iLossBurstFault::Validate() const {
  ValidateFaultTiming(at_s, for_s);
  Require(loss > 0.0 && loss <= 1.0, "loss must be in (0, 1], got " + Num(loss));
}

void NodeCrashFault::Validate() const {
  ValidateFaultTiming(at_s, std::nullopt);
  Require(!node.empty(), "node must name a node of the car's board");
}

void NodeHangFault::Validate() const {
  ValidateFaultTiming(at_s, for_s);
  Require(!node.empty(), "node must name a node of the car's board");
}

void RemapFault::Validate() const {
  ValidateFaultTiming(at_s, std::nullopt);
  Require(!node.empty(), "node must name a node of the car's board");
}

void ImuBiasStepFault::Validate() const {
  ValidateFaultTiming(at_s, for_s);
  Require(std::isfinite(gyro_bias_rad_per_s) && gyro_bias_rad_per_s != 0.0,
          "gyro_bias_rad_per_s must be finite and not 0, got " + Num(gyro_bias_rad_per_s));
}

void LocalizationJumpFault::Validate() const {
  ValidateFaultTiming(at_s, std::nullopt);
  Require(dx_m || dy_m || dyaw_deg, "localization_jump needs at least one of dx_m, dy_m, dyaw_deg");
  for (const auto& v : {dx_m, dy_m, dyaw_deg}) {
    Require(!v || std::isfinite(*v), "the jump must be finite");
  }
}

std::string V2iPartitionFault::Detail() const {
  if (!direction) return Join(*this, {});
  return Join(*this, {"direction " + std::string(ToName(*direction))});
}
std::string V2iLossBurstFault::Detail() const {
  return Join(*this, {fmt::format("loss {}", loss)});
}
template <FaultKind Kind, bool LastsWithoutEndOfRun>
std::string FleetFault<Kind, LastsWithoutEndOfRun>::Detail() const {
  return Join(*this, {});
}
template struct FleetFault<FaultKind::kServerRestart, false>;
template struct FleetFault<FaultKind::kBrokerOutage, true>;
std::string CarStallFault::Detail() const { return Join(*this, {}); }
std::string NodeCrashFault::Detail() const { return Join(*this, {"node " + node}); }
std::string NodeHangFault::Detail() const { return Join(*this, {"node " + node}); }
std::string RemapFault::Detail() const {
  return Join(*this, {"node " + node + " to " + std::string(ToName(target))});
}
template <FaultKind Kind>
std::string CameraFault<Kind>::Detail() const {
  return Join(*this, {"camera " + std::string(ToName(camera))});
}
template struct CameraFault<FaultKind::kCameraFreeze>;
template struct CameraFault<FaultKind::kCameraBlackout>;
std::string ImuBiasStepFault::Detail() const {
  return Join(*this, {fmt::format("gyro bias {:+} rad/s", gyro_bias_rad_per_s)});
}
std::string LocalizationJumpFault::Detail() const {
  return Join(*this, {fmt::format("jump ({}, {}) m, {} deg", dx_m.value_or(0.0), dy_m.value_or(0.0),
                                  dyaw_deg.value_or(0.0))});
}

FaultKind KindOf(const FaultClause& fault) {
  return std::visit([](const auto& f) { return f.kKind; }, fault);
}

double FaultStart_s(const FaultClause& fault) {
  return std::visit([](const auto& f) { return f.at_s; }, fault);
}

std::optional<double> FaultDuration_s(const FaultClause& fault) {
  return std::visit(
      [](const auto& f) -> std::optional<double> {
        if constexpr (requires { f.for_s; }) return f.for_s;
        return std::nullopt;
      },
      fault);
}

std::optional<int> FaultCar(const FaultClause& fault) {
  return std::visit(
      [](const auto& f) -> std::optional<int> {
        if constexpr (requires { f.car; }) return f.car;
        return std::nullopt;
      },
      fault);
}

bool LastsWithoutEnd(const FaultClause& fault) {
  return std::visit([](const auto& f) { return f.kLastsWithoutEnd; }, fault);
}

std::string DescribeFault(const FaultClause& fault) {
  return std::visit([](const auto& f) { return f.Detail(); }, fault);
}

}  // namespace autonomsim::sim
