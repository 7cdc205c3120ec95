#include "sim/scenario/stack_presets.h"

#include <algorithm>
#include <stdexcept>

namespace autonomsim::sim {
namespace {

const char* Pick(const std::string& name, const char* lab, const char* safe) {
  if (name == "lab") return lab;
  if (name == "safe") return safe;
  throw std::invalid_argument("unknown stack preset '" + name + "' (lab or safe)");
}

// Each option's value in the lab's code (reference §5-§7) and with every fix, by its key path in
// a car entry; docs/lab-stack.md#the-options gives the reasons, in the same order.
struct PresetOption {
  const char* key;
  const char* lab;
  const char* safe;
};
constexpr PresetOption kCarOptions[] = {
    {"stack.localization.use_pose_fix", "false", "true"},
    {"stack.localization.fuse_imu_yaw", "true", "false"},
    {"stack.follow_path.pursuit.lookahead_dist_m", "0.6", "0.4"},
    {"stack.planner.start_escape_m", "0.0", "0.3"},
    {"stack.controller_selector.zone_margin_m", "0.0", "0.3"},
    {"stack.behavior.patient_in_queue", "false", "true"},
    {"stack.behavior.intersection_free_timeout_s", "0", "1.0"},
    {"stack.emergency_stop.enabled", "false", "true"},
    {"stack.lane_controller.collision.horizon_s", "1.0", "2.0"},
    {"stack.follow_path.collision.horizon_s", "1.0", "2.0"},
    {"intersection_client.re_request", "false", "true"},
    {"intersection_client.release_margin_m", "0.0", "0.3"},
    {"intersection_client.exit_margin_m", "0.0", "0.15"},
    {"intersection_client.latch_wait", "false", "true"},
    {"intersection_client.release_on_failure", "false", "true"},
};
// The scenario-level option a top-level preset sets: the lab's vtl.py, or ours.
constexpr PresetOption kScenarioOptions[] = {{"traffic_lights.policy", "original", "fifo"}};

// A mapping with each option's value for `name` at its dotted key path.
template <std::size_t N>
YAML::Node Build(const PresetOption (&options)[N], const std::string& name) {
  YAML::Node root(YAML::NodeType::Map);
  for (const PresetOption& option : options) {
    const std::vector<std::string> parts = ParseOverridePath(option.key);
    YAML::Node node = root;
    for (std::size_t i = 0; i + 1 < parts.size(); ++i) {
      if (!node[parts[i]]) node[parts[i]] = YAML::Node(YAML::NodeType::Map);
      node.reset(node[parts[i]]);
    }
    node[parts.back()] = YAML::Load(Pick(name, option.lab, option.safe));
  }
  return root;
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
  if (!preset.IsScalar() || std::find(names.begin(), names.end(), preset.Scalar()) == names.end()) {
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

YAML::Node StackPresetForCar(const std::string& name) { return Build(kCarOptions, name); }

YAML::Node StackPresetForScenario(const std::string& name) { return Build(kScenarioOptions, name); }

std::vector<std::string> StackPresetKeys() {
  std::vector<std::string> keys;
  for (const PresetOption& option : kCarOptions) keys.emplace_back(option.key);
  for (const PresetOption& option : kScenarioOptions) keys.emplace_back(option.key);
  return keys;
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
      const std::optional<std::string> own = PresetAt(car, detail::JoinIndex("cars", i), source);
      if (own || fleet) MergeBeneath(car, StackPresetForCar(own ? *own : *fleet));
    }
  }
  if (fleet) MergeBeneath(root, StackPresetForScenario(*fleet));
}

}  // namespace autonomsim::sim
