#include "sim/scenario/stack_presets.h"

#include <algorithm>
#include <stdexcept>

namespace autonomsim::sim {
namespace {

// Each option's value in the lab's code (reference §5-§7) and with every fix; README "The lab's
// stack and its fixes" gives the reasons. Keep the two in the same order as the README table.
constexpr const char* kLabCar = R"(
stack:
  localization: {use_pose_fix: false}
  follow_path: {pursuit: {lookahead_dist_m: 0.6}}
  planner: {start_escape_m: 0.0}
  controller_selector: {zone_margin_m: 0.0}
  behavior: {patient_in_queue: false}
  emergency_stop: {enabled: false}
intersection_client:
  re_request: false
  release_margin_m: 0.0
  exit_margin_m: 0.0
  latch_wait: false
  release_on_failure: false
)";
constexpr const char* kSafeCar = R"(
stack:
  localization: {use_pose_fix: true}
  follow_path: {pursuit: {lookahead_dist_m: 0.4}}
  planner: {start_escape_m: 0.3}
  controller_selector: {zone_margin_m: 0.3}
  behavior: {patient_in_queue: true}
  emergency_stop: {enabled: true}
intersection_client:
  re_request: true
  release_margin_m: 0.3
  exit_margin_m: 0.15
  latch_wait: true
  release_on_failure: true
)";
constexpr const char* kLabScenario = "traffic_lights: {policy: original}";
constexpr const char* kSafeScenario = "traffic_lights: {policy: fifo}";

const char* Pick(const std::string& name, const char* lab, const char* safe) {
  if (name == "lab") return lab;
  if (name == "safe") return safe;
  throw std::invalid_argument("unknown stack preset '" + name + "' (lab or safe)");
}

// The preset named at `node[key]` (a mapping entry), checked; none when absent.
std::optional<std::string> PresetAt(const YAML::Node& node, const std::string& path,
                                    const ConfigSource& source) {
  if (!node.IsMap()) return std::nullopt;
  const YAML::Node stack = node["stack"];
  if (!stack || !stack.IsMap()) return std::nullopt;  // the strict reader reports a bad `stack`
  const YAML::Node preset = stack["preset"];
  if (!preset || preset.IsNull()) return std::nullopt;
  const std::string where = detail::JoinPath(detail::JoinPath(path, "stack"), "preset");
  const auto& names = StackPresetNames();
  if (!preset.IsScalar() ||
      std::find(names.begin(), names.end(), preset.Scalar()) == names.end()) {
    detail::Fail(preset, where, source,
                 "unknown stack preset " + detail::Describe(preset) +
                     " (lab: the lab's code as published; safe: every fix)");
  }
  return preset.Scalar();
}

}  // namespace

void FleetStackConfig::Validate() const {
  if (preset) Pick(*preset, "", "");
}

const std::vector<std::string>& StackPresetNames() {
  static const std::vector<std::string> names{"lab", "safe"};
  return names;
}

YAML::Node StackPresetForCar(const std::string& name) {
  return YAML::Load(Pick(name, kLabCar, kSafeCar));
}

YAML::Node StackPresetForScenario(const std::string& name) {
  return YAML::Load(Pick(name, kLabScenario, kSafeScenario));
}

void MergeBeneath(YAML::Node target, const YAML::Node& beneath) {
  for (const auto& entry : beneath) {
    const std::string key = entry.first.Scalar();
    YAML::Node mine = target[key];
    if (!mine) {
      target[key] = YAML::Clone(entry.second);
    } else if (mine.IsMap() && entry.second.IsMap()) {
      MergeBeneath(mine, entry.second);
    }
  }
}

void ApplyStackPresets(YAML::Node& root, const ConfigSource& source) {
  const std::optional<std::string> fleet = PresetAt(root, "", source);
  const YAML::Node cars = root["cars"];
  if (cars && cars.IsSequence()) {
    for (std::size_t i = 0; i < cars.size(); ++i) {
      YAML::Node car = cars[i];
      if (!car.IsMap()) continue;  // the strict reader reports it
      const std::optional<std::string> own =
          PresetAt(car, detail::JoinIndex("cars", i), source);
      if (own || fleet) MergeBeneath(car, StackPresetForCar(own ? *own : *fleet));
    }
  }
  if (fleet) MergeBeneath(root, StackPresetForScenario(*fleet));
}

}  // namespace autonomsim::sim
