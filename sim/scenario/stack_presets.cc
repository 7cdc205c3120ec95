#include "sim/scenario/stack_presets.h"

#include <algorithm>
#include <set>
#include <stdexcept>

namespace autonomsim::sim {
namespace {

const char* Pick(const std::string& name, const char* lab, const char* safe) {
  const std::optional<StackPreset> preset = FromName<StackPreset>(name);
  if (!preset) throw std::invalid_argument("unknown stack preset '" + name + "' (lab or safe)");
  return *preset == StackPreset::kLab ? lab : safe;
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
    {"stack.follow_path.pursuit.lookahead_dist_m", "0.6", "0.4"},
    {"stack.planner.start_escape_m", "0.0", "0.3"},
    {"stack.controller_selector.zone_margin_m", "0.0", "0.3"},
    {"stack.controller_selector.follow_path_without_line", "false", "true"},
    {"stack.behavior.patient_in_queue", "false", "true"},
    {"stack.behavior.recovery_reset_m", "0", "0.5"},
    {"stack.behavior.queue_wait_s", "5", "2"},
    {"stack.behavior.intersection_free_timeout_s", "0", "1.0"},
    {"stack.emergency_stop.enabled", "false", "true"},
    {"stack.lane_controller.collision.horizon_s", "1.0", "2.0"},
    {"stack.follow_path.collision.horizon_s", "1.0", "2.0"},
    {"stack.lane_controller.collision.model", "centre", "footprint"},
    {"stack.follow_path.collision.model", "centre", "footprint"},
    {"intersection_client.blocking", "true", "false"},
    {"intersection_client.re_request", "false", "true"},
    {"intersection_client.release_margin_m", "0.0", "0.3"},
    {"intersection_client.exit_margin_m", "0.0", "0.15"},
    {"intersection_client.latch_wait", "false", "true"},
    {"intersection_client.release_on_failure", "false", "true"},
    {"intersection_client.enter_only_if_clear", "false", "true"},
    {"perception.lane_detection.hw_pixel_classes", "exact", "non_zero"},
    {"perception.lane_detection.hw_no_line", "both_below_min", "white_below_min"},
    {"perception.lane_detection.hw_truncate_points", "true", "false"},
    {"perception.lane_detection.hw_valid_overwrite", "true", "false"},
    {"perception.lane_detection.projection", "pnp_swapped", "ideal"},
    {"perception.lane_detection.sw_no_line", "silent", "invalid"},
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

// Whether two YAML scalars say the same value: as numbers when both are, else as text.
bool SameScalar(const YAML::Node& a, const std::string& b_text) {
  const YAML::Node b = YAML::Load(b_text);
  if (!a.IsScalar() || !b.IsScalar()) return false;
  double x = 0.0;
  double y = 0.0;
  if (YAML::convert<double>::decode(a, x) && YAML::convert<double>::decode(b, y)) return x == y;
  bool p = false;
  bool q = false;
  if (YAML::convert<bool>::decode(a, p) && YAML::convert<bool>::decode(b, q)) return p == q;
  return a.Scalar() == b.Scalar();
}

// The node at a dotted key path under `node`, or an invalid node.
YAML::Node At(YAML::Node node, const std::vector<std::string>& parts) {
  for (const std::string& part : parts) {
    if (!node.IsMap()) return YAML::Node(YAML::NodeType::Undefined);
    const YAML::Node next = node[part];
    if (!next) return YAML::Node(YAML::NodeType::Undefined);
    node.reset(next);
  }
  return node;
}

// The options of `options` that `node` (before the preset is merged) sets to another value.
template <std::size_t N>
void CollectOverrides(const PresetOption (&options)[N], const YAML::Node& node,
                      const std::string& prefix, const std::string& preset,
                      std::vector<PresetOverride>* out) {
  for (const PresetOption& option : options) {
    const YAML::Node mine = At(node, ParseOverridePath(option.key));
    if (!mine.IsDefined() || mine.IsNull()) continue;
    const std::string preset_value = Pick(preset, option.lab, option.safe);
    if (SameScalar(mine, preset_value)) continue;
    out->push_back({.key = detail::JoinPath(prefix, option.key),
                    .preset = preset,
                    .preset_value = preset_value,
                    .value = mine.IsScalar() ? mine.Scalar() : YAML::Dump(mine)});
  }
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

void FleetStackConfig::Validate() const {}

const std::vector<std::string>& StackPresetNames() {
  static const std::vector<std::string> names = NamesOf<StackPreset>();
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

std::vector<PresetOverride> ApplyStackPresets(YAML::Node& root, const ConfigSource& source) {
  std::vector<PresetOverride> overrides;
  const std::optional<std::string> fleet = PresetAt(root, "", source);
  const YAML::Node cars = root["cars"];
  if (cars && cars.IsSequence()) {
    for (std::size_t i = 0; i < cars.size(); ++i) {
      YAML::Node car = cars[i];
      if (!car.IsMap()) continue;  // the strict reader reports it
      const std::string path = detail::JoinIndex("cars", i);
      const std::optional<std::string> own = PresetAt(car, path, source);
      if (!own && !fleet) continue;
      const std::string& preset = own ? *own : *fleet;
      CollectOverrides(kCarOptions, car, path, preset, &overrides);
      MergeBeneath(car, StackPresetForCar(preset));
    }
  }
  if (fleet) {
    CollectOverrides(kScenarioOptions, root, "", *fleet, &overrides);
    MergeBeneath(root, StackPresetForScenario(*fleet));
  }
  return overrides;
}

std::string DescribePresetOverrides(const std::vector<PresetOverride>& overrides) {
  // group the cars that set one key to one value: "cars[0,1].stack.x=v (lab: w)"
  struct Group {
    std::string prefix, rest, value, preset, preset_value;
    std::vector<std::string> cars;
  };
  std::vector<Group> groups;
  std::set<std::string> presets;
  for (const PresetOverride& o : overrides) {
    presets.insert(o.preset);
    std::string car, rest = o.key;
    if (o.key.rfind("cars[", 0) == 0) {
      const std::size_t close = o.key.find(']');
      car = o.key.substr(5, close - 5);
      rest = o.key.substr(close + 2);
    }
    auto same = [&](const Group& g) {
      return !car.empty() && !g.cars.empty() && g.rest == rest && g.value == o.value &&
             g.preset == o.preset;
    };
    const auto found = std::find_if(groups.begin(), groups.end(), same);
    if (found != groups.end()) {
      found->cars.push_back(car);
    } else {
      groups.push_back({car.empty() ? "" : "cars", rest, o.value, o.preset, o.preset_value,
                        car.empty() ? std::vector<std::string>{} : std::vector<std::string>{car}});
    }
  }
  std::string names;
  for (const std::string& p : presets) names += (names.empty() ? "" : " and ") + p;
  std::string line = "the scenario sets " + std::to_string(overrides.size()) +
                     " option(s) of stack.preset " + names +
                     " itself (summary.json preset_overrides):";
  for (const Group& g : groups) {
    std::string cars;
    for (const std::string& c : g.cars) cars += (cars.empty() ? "" : ",") + c;
    line += " " + (g.cars.empty() ? g.rest : "cars[" + cars + "]." + g.rest) + "=" + g.value +
            " (" + g.preset + ": " + g.preset_value + ");";
  }
  line.pop_back();
  return line;
}

}  // namespace autonomsim::sim
