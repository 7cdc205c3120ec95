#include "sim/scenario/stack_presets.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>

#include "sim/scenario/scenario.h"
#include "sim/scenario/tests/scenario_file.h"

namespace autonomsim::sim {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

using testing::ScenarioFile;

constexpr const char* kPresetTwoStackCars = R"(name: presets
duration_s: 10
track: tracks/lab.yaml
cars:
  - {id: 0, route: south_loop, start: real_car, driver: stack, perception: {enabled: true},
     stack: &s {follow_path: {pursuit: {lookahead_dist_m: 0.5}}}}
  - {id: 1, route: inner_loop, start: inner_north, driver: stack, perception: {enabled: true},
     stack: *s}
)";

TEST(StackPresetsTest, NoPresetLeavesEveryOptionAtItsDefault) {
  ScenarioFile file("preset_none", kPresetTwoStackCars);
  const Scenario s = LoadScenario(file.path()).scenario;
  const CarConfig defaults;
  EXPECT_EQ(s.cars[0].stack.localization.use_pose_fix, defaults.stack.localization.use_pose_fix);
  EXPECT_EQ(s.cars[0].intersection_client.re_request, defaults.intersection_client.re_request);
  EXPECT_EQ(s.traffic_lights.policy, world::ServerPolicy::kFifo);
}

TEST(StackPresetsTest, LabSelectsTheLabsCodeAndTheOriginalServerExceptWhatTheScenarioSets) {
  ScenarioFile file("preset_lab", kPresetTwoStackCars);
  const Scenario s = LoadScenario(file.path(), {"stack.preset=lab"}).scenario;
  EXPECT_EQ(s.traffic_lights.policy, world::ServerPolicy::kOriginal);
  for (const CarConfig& car : s.cars) {
    EXPECT_FALSE(car.stack.localization.use_pose_fix);
    EXPECT_FALSE(car.stack.emergency_stop.enabled);
    EXPECT_FALSE(car.intersection_client.re_request);
    EXPECT_FALSE(car.intersection_client.latch_wait);
    EXPECT_FALSE(car.intersection_client.release_on_failure);
    EXPECT_EQ(car.intersection_client.release_margin_m, 0.0);
    EXPECT_EQ(car.intersection_client.exit_margin_m, 0.0);
    // the scenario's own value beats the preset's 0.6
    EXPECT_EQ(car.stack.follow_path.pursuit.lookahead_dist_m, 0.5);
  }
}

TEST(StackPresetsTest, ACarsOwnPresetBeatsTheFleetsAndAnExplicitPolicyBeatsThePresets) {
  ScenarioFile file("preset_mixed", kPresetTwoStackCars);
  const Scenario s = LoadScenario(file.path(), {"stack.preset=safe", "cars[1].stack={preset: lab}",
                                                "traffic_lights.policy=original"})
                         .scenario;
  EXPECT_EQ(s.traffic_lights.policy, world::ServerPolicy::kOriginal);
  EXPECT_TRUE(s.cars[0].stack.localization.use_pose_fix);
  EXPECT_TRUE(s.cars[0].stack.emergency_stop.enabled);
  EXPECT_TRUE(s.cars[0].intersection_client.latch_wait);
  EXPECT_TRUE(s.cars[0].intersection_client.release_on_failure);
  EXPECT_EQ(s.cars[0].stack.follow_path.pursuit.lookahead_dist_m, 0.5);
  EXPECT_FALSE(s.cars[1].stack.localization.use_pose_fix);
  EXPECT_FALSE(s.cars[1].intersection_client.re_request);
  EXPECT_EQ(s.cars[1].stack.follow_path.pursuit.lookahead_dist_m, 0.6);
}

TEST(StackPresetsTest, AnUnknownPresetIsAnErrorAtItsKey) {
  ScenarioFile file("preset_bad", std::string(kPresetTwoStackCars) + "stack: {preset: fast}\n");
  try {
    LoadScenario(file.path());
    FAIL() << "accepted preset 'fast'";
  } catch (const ConfigError& e) {
    EXPECT_THAT(e.what(), HasSubstr(".test_preset_bad.yaml:9:"));
    EXPECT_THAT(e.what(), HasSubstr("stack.preset"));
    EXPECT_THAT(e.what(), HasSubstr("lab"));
  }
  EXPECT_THROW(LoadScenario(file.path(), {"stack.preset=[lab]"}), ConfigError);
}

// Issue 30 item 2: a key the scenario sets beats the preset, and the run says which.
TEST(StackPresetsTest, TheKeysAScenarioSetsAgainstItsPresetAreListed) {
  ScenarioFile file("preset_overrides", kPresetTwoStackCars);
  // lookahead 0.5 against the lab's 0.6 on both cars; a value equal to the preset's is no
  // override; a car's own preset is the one it is compared with
  const LoadedScenario loaded = LoadScenario(
      file.path(), {"stack.preset=lab", "cars[0].stack.localization.use_pose_fix=false",
                    "cars[1].stack.preset=safe", "traffic_lights.policy=fifo"});
  std::vector<std::string> lines;
  for (const PresetOverride& o : loaded.preset_overrides) {
    lines.push_back(o.key + "=" + o.value + " (" + o.preset + ": " + o.preset_value + ")");
  }
  EXPECT_THAT(lines, ::testing::ElementsAre(
                         "cars[0].stack.follow_path.pursuit.lookahead_dist_m=0.5 (lab: 0.6)",
                         "cars[1].stack.follow_path.pursuit.lookahead_dist_m=0.5 (safe: 0.4)",
                         "traffic_lights.policy=fifo (lab: original)"));
  EXPECT_EQ(DescribePresetOverrides(loaded.preset_overrides),
            "the scenario sets 3 option(s) of stack.preset lab and safe itself (summary.json "
            "preset_overrides): cars[0].stack.follow_path.pursuit.lookahead_dist_m=0.5 (lab: "
            "0.6); cars[1].stack.follow_path.pursuit.lookahead_dist_m=0.5 (safe: 0.4); "
            "traffic_lights.policy=fifo (lab: original)");
  // no preset: nothing to override
  EXPECT_TRUE(LoadScenario(file.path()).preset_overrides.empty());
}

// Issue 30 item 7: `--set stack.preset=lab` on a scenario that names the fifo server gives the
// lab's client (it never renews a grant) a server whose lease expires under it.
TEST(StackPresetsTest, ALabClientAgainstTheFifoServerIsWarnedAbout) {
  ScenarioFile file("preset_mix", kPresetTwoStackCars);
  const LoadedScenario mixed =
      LoadScenario(file.path(), {"stack.preset=lab", "traffic_lights.policy=fifo"});
  ASSERT_EQ(mixed.warnings.size(), 1u);
  EXPECT_THAT(mixed.warnings[0], HasSubstr("cars[0,1] run the lab's intersection client"));
  EXPECT_THAT(mixed.warnings[0], HasSubstr("traffic_lights.policy: original"));
  EXPECT_TRUE(LoadScenario(file.path(), {"stack.preset=lab"}).warnings.empty());
  EXPECT_TRUE(LoadScenario(file.path(), {"stack.preset=safe"}).warnings.empty());
  EXPECT_TRUE(LoadScenario(file.path(), {"stack.preset=lab", "traffic_lights.policy=fifo",
                                         "cars[0].intersection_client={blocking: false, "
                                         "re_request: true}",
                                         "cars[1].intersection_client={blocking: false, "
                                         "re_request: true}"})
                  .warnings.empty());
}

// Every leaf of a preset's YAML, as (dotted path, scalar text).
void Leaves(const YAML::Node& node, const std::string& path,
            std::vector<std::pair<std::string, std::string>>* out) {
  if (!node.IsMap()) {
    out->emplace_back(path, node.Scalar());
    return;
  }
  for (const auto& entry : node) {
    const std::string key = entry.first.Scalar();
    Leaves(entry.second, path.empty() ? key : path + "." + key, out);
  }
}

// Whether a resolved JSON value says the same as a preset's YAML text.
bool SameValue(const nlohmann::json& value, const std::string& text) {
  if (value.is_boolean()) return value.get<bool>() == (text == "true");
  if (value.is_number()) return value.get<double>() == std::stod(text);
  return value.is_string() && value.get<std::string>() == text;
}

// Issue 30 item 2: each shipped scenario's header (its leading comment) names every option on
// which its run departs from the lab's code, whether it sets it or leaves it at a default that is
// not the lab's.
TEST(StackPresetsTest, EveryShippedScenarioHeaderNamesItsDeparturesFromTheLab) {
  std::vector<std::pair<std::string, std::string>> car_keys, scenario_keys, car_safe, scenario_safe;
  Leaves(StackPresetForCar("lab"), "", &car_keys);
  Leaves(StackPresetForScenario("lab"), "", &scenario_keys);
  Leaves(StackPresetForCar("safe"), "", &car_safe);
  Leaves(StackPresetForScenario("safe"), "", &scenario_safe);
  std::vector<fs::path> files;
  for (const char* dir : {"scenarios", "scenarios/faults"}) {
    for (const auto& entry : fs::directory_iterator(dir)) {
      // (other tests write hidden scratch scenarios there: .test_*.yaml)
      const std::string name = entry.path().filename().string();
      if (entry.path().extension() == ".yaml" && name[0] != '.') files.push_back(entry.path());
    }
  }
  ASSERT_GT(files.size(), 8u) << "run from the repository root";
  for (const fs::path& file : files) {
    std::ifstream in(file);
    std::string header, line;
    while (std::getline(in, line) && line.rfind("#", 0) == 0) header += line + "\n";
    const LoadedScenario loaded = LoadScenario(file);
    const nlohmann::json& scenario = loaded.resolved["scenario"];
    // a value that `stack.preset: safe` sets is named by the preset (docs/lab-stack.md)
    auto check = [&](const nlohmann::json& root, const auto& keys, const auto& safe_keys, bool safe,
                     const std::string& where) {
      for (std::size_t k = 0; k < keys.size(); ++k) {
        const auto& [key, lab] = keys[k];
        nlohmann::json value = root;
        for (const std::string& part : ParseOverridePath(key)) value = value.at(part);
        if (SameValue(value, lab) || (safe && SameValue(value, safe_keys[k].second))) continue;
        const std::string name = key.substr(key.rfind('.') + 1);
        EXPECT_NE(header.find(name), std::string::npos)
            << file << ": " << where << key << " is " << value.dump() << " (lab: " << lab
            << "), and the header does not name `" << name << "`";
      }
    };
    const std::optional<StackPreset>& fleet = loaded.scenario.stack.preset;
    for (std::size_t i = 0; i < loaded.scenario.cars.size(); ++i) {
      const CarConfig& car = loaded.scenario.cars[i];
      if (car.driver != Driver::kStack) continue;
      const std::optional<StackPreset>& own = car.stack.preset ? car.stack.preset : fleet;
      check(scenario["cars"][i], car_keys, car_safe, own == StackPreset::kSafe,
            "cars[" + std::to_string(i) + "].");
    }
    check(scenario, scenario_keys, scenario_safe, fleet == StackPreset::kSafe, "");
  }
}

TEST(StackPresetsTest, MergeBeneathFillsOnlyMissingKeys) {
  YAML::Node target = YAML::Load("{a: 1, b: {c: 2}}");
  MergeBeneath(target, YAML::Load("{a: 9, b: {c: 9, d: 3}, e: {f: 4}}"));
  EXPECT_EQ(target["a"].as<int>(), 1);
  EXPECT_EQ(target["b"]["c"].as<int>(), 2);
  EXPECT_EQ(target["b"]["d"].as<int>(), 3);
  EXPECT_EQ(target["e"]["f"].as<int>(), 4);
}

TEST(StackPresetsTest, ReadmeListsEveryOptionAPresetSets) {
  std::ifstream readme("docs/lab-stack.md");
  ASSERT_TRUE(readme) << "run from the repository root";
  const std::string text((std::istreambuf_iterator<char>(readme)), {});
  const std::size_t section = text.find("## The options");
  ASSERT_NE(section, std::string::npos);
  for (const std::string& key : StackPresetKeys()) {
    EXPECT_NE(text.find("| `" + key + "`", section), std::string::npos) << key;
  }
}

// The text of every test source under the module folders, for looking tests up by name.
std::string AllTestSources() {
  std::string all;
  for (const char* dir : {"sim", "stack", "world", "vehicle", "tools"}) {
    for (const auto& entry : fs::recursive_directory_iterator(dir)) {
      const std::string name = entry.path().filename().string();
      if (!entry.is_regular_file() || name.size() < 8 ||
          name.substr(name.size() - 8) != "_test.cc") {
        continue;
      }
      std::ifstream in(entry.path());
      all.append(std::istreambuf_iterator<char>(in), {});
    }
  }
  return all;
}

// Whether `text` has a "path:line" (a non-space character, a colon, a digit).
bool HasPathLine(const std::string& text) {
  for (std::size_t i = 1; i + 1 < text.size(); ++i) {
    if (text[i] == ':' && text[i - 1] != ' ' &&
        std::isdigit(static_cast<unsigned char>(text[i + 1]))) {
      return true;
    }
  }
  return false;
}

// The `Suite.Name` words between backticks in `text`.
std::vector<std::string> TestNames(const std::string& text) {
  std::vector<std::string> names;
  for (std::size_t open = text.find('`'); open != std::string::npos;) {
    const std::size_t close = text.find('`', open + 1);
    if (close == std::string::npos) break;
    const std::string word = text.substr(open + 1, close - open - 1);
    const std::size_t dot = word.find('.');
    const bool identifier = std::all_of(word.begin(), word.end(), [](char c) {
      return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '.';
    });
    if (identifier && dot != std::string::npos && dot > 0 && dot + 1 < word.size() &&
        word.find('.', dot + 1) == std::string::npos &&
        std::isupper(static_cast<unsigned char>(word[0]))) {
      names.push_back(word);
    }
    open = text.find('`', close + 1);
  }
  return names;
}

// Issue 30 item 3: docs/lab-stack.md's fidelity table has a row for every preset option, and
// every row a source (path:line, or "unknown" with why) and tests that exist.
TEST(StackPresetsTest, TheFidelityTableCoversEveryOptionWithASourceAndATest) {
  std::ifstream page("docs/lab-stack.md");
  ASSERT_TRUE(page) << "run from the repository root";
  const std::string text((std::istreambuf_iterator<char>(page)), {});
  const std::size_t section = text.find("## Fidelity");
  ASSERT_NE(section, std::string::npos);
  std::istringstream table(text.substr(section));
  std::vector<std::vector<std::string>> rows;
  for (std::string line; std::getline(table, line);) {
    if (line.rfind("| ", 0) != 0 || line.rfind("| behaviour", 0) == 0) continue;
    std::vector<std::string> cells;
    std::size_t at = 1;
    for (std::size_t bar; (bar = line.find(" | ", at)) != std::string::npos; at = bar + 3) {
      cells.push_back(line.substr(at, bar - at));
    }
    cells.push_back(line.substr(at, line.size() - at - 2));
    ASSERT_EQ(cells.size(), 6u) << line;
    rows.push_back(cells);
  }
  ASSERT_GT(rows.size(), 10u);
  for (const std::string& key : StackPresetKeys()) {
    const bool has_row = std::any_of(rows.begin(), rows.end(), [&](const auto& row) {
      return row[0].find("`" + key + "`") != std::string::npos;
    });
    EXPECT_TRUE(has_row) << "no fidelity row for " << key;
  }
  const std::string tests = AllTestSources();
  for (const auto& row : rows) {
    EXPECT_TRUE(HasPathLine(row[1]) || row[1].find("unknown") != std::string::npos)
        << row[0] << ": no path:line and no \"unknown\"";
    const std::vector<std::string> named = TestNames(row[5]);
    for (const std::string& test : named) {
      const std::size_t dot = test.find('.');
      EXPECT_NE(tests.find(test.substr(0, dot) + ", " + test.substr(dot + 1) + ")"),
                std::string::npos)
          << row[0] << ": no test " << test;
    }
    EXPECT_FALSE(named.empty()) << row[0] << ": no test named";
  }
}

TEST(StackPresetsTest, EveryPresetNamesOnlyKeysTheReaderKnows) {
  for (const std::string& name : StackPresetNames()) {
    YAML::Node car = StackPresetForCar(name);
    car["route"] = "south_loop";
    EXPECT_NO_THROW(ReadConfig<CarConfig>(car, ConfigSource{name, {}})) << name;
  }
  EXPECT_THROW(StackPresetForCar("fast"), std::invalid_argument);
}

}  // namespace
}  // namespace autonomsim::sim
