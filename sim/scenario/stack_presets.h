// `stack.preset`: one key that selects the lab's stack as published (`lab`) or every fix this
// simulator offers (`safe`). A preset is a set of option values beneath what the scenario says:
// it fills only the keys the scenario (with its --set overrides) leaves out, so single options may
// still be overridden. docs/lab-stack.md#the-options lists every option, what the lab's
// code does, what the fix does and why.
//
// Where it applies:
//   cars[i].stack.preset   that car's `stack:` and `intersection_client:` options;
//   stack.preset           (top level) every car's, unless the car names its own, and the traffic
//                          light server's policy (the lab's vtl.py: `original`).
#pragma once

#include <yaml-cpp/yaml.h>

#include <string>
#include <vector>

#include "sim/car/stack_config.h"
#include "sim/core/config.h"

namespace autonomsim::sim {

// The scenario's top-level `stack:` entry.
struct FleetStackConfig {
  std::optional<StackPreset> preset;  // none: each option at its default

  template <class V>
  void Describe(V& v) {
    v("preset", preset,
      "the lab's stack as published (`lab`) or every fix (`safe`), for every car and the server, "
      "filling only what the scenario leaves out ([the lab's stack](lab-stack.md))");
  }
  void Validate() const;
};

// The names a preset may have (NameTable<StackPreset>), in the order docs/lab-stack.md#presets
// lists them.
const std::vector<std::string>& StackPresetNames();

// The option values a preset sets, as the YAML a car entry (`car`) or the scenario's root
// (`scenario`) would carry. Throws std::invalid_argument for an unknown name.
YAML::Node StackPresetForCar(const std::string& name);
YAML::Node StackPresetForScenario(const std::string& name);

// Every option a preset sets, as key paths (car's, then scenario's), in docs/lab-stack.md's order.
std::vector<std::string> StackPresetKeys();

// A key the scenario sets itself, beating its preset's value (a different one): the run says so on
// stderr and in summary.json `preset_overrides`.
struct PresetOverride {
  std::string key;           // the key path, e.g. "cars[0].stack.localization.use_pose_fix"
  std::string preset;        // "lab" or "safe"
  std::string preset_value;  // the preset's value, as YAML text ("false")
  std::string value;         // the scenario's ("true")
};

// Fills `root` (a scenario, overrides applied) from its presets, as described above, and returns
// the keys it set itself that beat them, cars first, in preset-option order. A preset that is not
// a known name is a ConfigError at its key.
std::vector<PresetOverride> ApplyStackPresets(YAML::Node& root, const ConfigSource& source);

// One line for stderr: how many options of which preset the scenario sets itself, and each, with
// the cars that share a key and value grouped ("cars[0,1].stack...=true (lab: false)").
std::string DescribePresetOverrides(const std::vector<PresetOverride>& overrides);

// Copies into `target` every key of `beneath` it lacks, recursively through mappings; keys
// `target` has keep their values.
void MergeBeneath(YAML::Node target, const YAML::Node& beneath);

}  // namespace autonomsim::sim
