#include "sim/study/sweep_spec.h"

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "sim/core/config.h"
#include "sim/core/files.h"

namespace autonomsim::sim {

namespace fs = std::filesystem;

namespace {

std::string Trim(const std::string& s) {
  const auto begin = s.find_first_not_of(" \t");
  if (begin == std::string::npos) return "";
  const auto end = s.find_last_not_of(" \t");
  return s.substr(begin, end - begin + 1);
}

double ParseNumber(const std::string& text, const std::string& spec) {
  if (const std::optional<double> value = ParseFiniteNumber(text)) return *value;
  throw ConfigError("--vary " + spec + ": '" + text + "' is not a number");
}

// The shortest text that reads back as `value` (fmt's default for doubles).
std::string NumberText(double value) { return fmt::format("{}", value); }

// A range point as text: rounded to the fewest decimals that hold it within 5e-7 of a step, so
// that 0.1 + 2 × 0.1 is 0.3, not the sum's 0.30000000000000004, and a third of a step 0.3333333.
// The ends, as typed, need no more decimals than typed.
std::string RangePointText(double value, double step) {
  const double tolerance = 5e-7 * std::abs(step);
  for (int decimals = 0; decimals <= std::numeric_limits<double>::max_digits10; ++decimals) {
    const double rounded = std::stod(fmt::format("{:.{}f}", value, decimals));
    if (std::abs(rounded - value) <= tolerance) return NumberText(rounded + 0.0);  // not -0
  }
  return NumberText(value);
}

// "K=0:1" or "K=0:1:5:2": numbers split by colons, but not three of them: meant as a range.
bool LooksLikeABadRange(const std::vector<std::string>& parts) {
  return parts.size() >= 2 && parts.size() != 3 &&
         std::all_of(parts.begin(), parts.end(),
                     [](const std::string& p) { return ParseFiniteNumber(p).has_value(); });
}

}  // namespace

// ---- Parsing ----

std::optional<double> ParseFiniteNumber(const std::string& text) {
  try {
    std::size_t used = 0;
    const double value = std::stod(text, &used);
    if (used == text.size() && std::isfinite(value)) return value;
  } catch (const std::exception&) {
  }
  return std::nullopt;
}

std::vector<std::string> SplitTopLevel(const std::string& text, char separator) {
  std::vector<std::string> parts;
  std::string current;
  int depth = 0;
  char quote = 0;
  for (char c : text) {
    if (quote) {
      if (c == quote) quote = 0;
    } else if (c == '"' || c == '\'') {
      quote = c;
    } else if (c == '[' || c == '{') {
      ++depth;
    } else if (c == ']' || c == '}') {
      --depth;
    } else if (c == separator && depth == 0) {
      parts.push_back(Trim(current));
      current.clear();
      continue;
    }
    current += c;
  }
  parts.push_back(Trim(current));
  return parts;
}

VaryAxis ParseVary(const std::string& spec) {
  const auto eq = spec.find('=');
  if (eq == std::string::npos || eq == 0) {
    throw ConfigError("--vary " + spec +
                      ": expected KEY=a,b,c or KEY=start:stop:count, e.g. v2i.latency_s=0:2:5");
  }
  VaryAxis axis{.key = Trim(spec.substr(0, eq)), .values = {}};
  const std::string rest = spec.substr(eq + 1);
  const std::vector<std::string> range = SplitTopLevel(rest, ':');
  const bool no_list = rest.find(',') == std::string::npos && rest.find('{') == std::string::npos;
  if (no_list && LooksLikeABadRange(range)) {
    throw ConfigError(fmt::format(
        "--vary {}: a range is start:stop:count, three numbers (e.g. {}=0:1:5 for 0, 0.25, 0.5, "
        "0.75, 1); a list is a,b,c",
        spec, axis.key));
  }
  if (no_list && range.size() == 3) {
    const double start = ParseNumber(range[0], spec);
    const double stop = ParseNumber(range[1], spec);
    const double count_d = ParseNumber(range[2], spec);
    if (count_d < 1 || count_d != std::floor(count_d) || count_d > kMaxRangeCount) {
      throw ConfigError(fmt::format(
          "--vary {}: count must be a whole number in [1, {}], got '{}' (a sweep has at most "
          "--max-runs runs in all, {} unless raised)",
          spec, kMaxRangeCount, range[2], kDefaultMaxRuns));
    }
    const int count = static_cast<int>(count_d);
    const double step = (stop - start) / std::max(1, count - 1);
    for (int i = 0; i < count; ++i) {
      // the last value is `stop` exactly, not start + (count - 1) * step
      const double value =
          i == count - 1 && count > 1
              ? stop
              : start + (stop - start) * static_cast<double>(i) / std::max(1, count - 1);
      // the run is given the value its row shows
      const std::string text = RangePointText(value, step);
      axis.values.push_back({text, text});
    }
  } else {
    for (const std::string& value : SplitTopLevel(rest, ',')) {
      if (value.empty()) throw ConfigError("--vary " + spec + ": an empty value");
      axis.values.push_back({value, value});
    }
  }
  return axis;
}

nlohmann::json SweepSpec::ToJson() const {
  nlohmann::json axes_json = nlohmann::json::array();
  for (const VaryAxis& axis : axes) {
    nlohmann::json values = nlohmann::json::array();
    for (const VaryValue& v : axis.values) values.push_back({{"label", v.label}, {"yaml", v.yaml}});
    axes_json.push_back({{"key", axis.key}, {"values", values}});
  }
  return {{"scenario", scenario.string()},
          {"overrides", overrides},
          {"vary", axes_json},
          {"repeat", repeat}};
}

SweepSpec SweepSpec::FromJson(const nlohmann::json& j) {
  SweepSpec spec;
  spec.scenario = j.at("scenario").get<std::string>();
  spec.overrides = j.at("overrides").get<std::vector<std::string>>();
  spec.repeat = j.at("repeat").get<int>();
  for (const nlohmann::json& a : j.at("vary")) {
    VaryAxis axis{.key = a.at("key").get<std::string>(), .values = {}};
    for (const nlohmann::json& v : a.at("values")) {
      axis.values.push_back({v.at("label").get<std::string>(), v.at("yaml").get<std::string>()});
    }
    spec.axes.push_back(std::move(axis));
  }
  return spec;
}

namespace {

std::string YamlText(const YAML::Node& node) {
  YAML::Emitter out;
  out.SetMapFormat(YAML::Flow);
  out.SetSeqFormat(YAML::Flow);
  out << node;
  return out.c_str();
}

// An error at `node` of a study file: "file:line:column: message".
ConfigError StudyError(const fs::path& file, const YAML::Node& node, const std::string& message) {
  const YAML::Mark mark = node.Mark();
  return ConfigError(
      fmt::format("{}:{}:{}: {}", file.string(), mark.line + 1, mark.column + 1, message));
}

// Throws for a key of `node` not in `known`, naming the closest known key for a typo, as a
// scenario's keys do (sim/core/config.h ClosestName), and listing them all. `what`: "a study",
// "a vary entry".
void CheckKnownKeys(const fs::path& file, const YAML::Node& node,
                    const std::vector<std::string>& known, const std::string& what) {
  for (const auto& item : node) {
    const std::string key = item.first.as<std::string>();
    if (std::find(known.begin(), known.end(), key) != known.end()) continue;
    const std::string closest = detail::ClosestName(key, known);
    throw StudyError(file, item.first,
                     fmt::format("unknown key '{}' ({}{} has {})", key,
                                 closest.empty() ? "" : "did you mean '" + closest + "'? ", what,
                                 fmt::join(known, ", ")));
  }
}

void CheckStudyKeys(const fs::path& file, const YAML::Node& root) {
  CheckKnownKeys(file, root, {"scenario", "description", "set", "repeat", "vary"}, "a study");
}

// A vary entry's `values`: a list of YAML values (each its own label), or a mapping label: value.
std::vector<VaryValue> StudyValues(const fs::path& file, const YAML::Node& values) {
  std::vector<VaryValue> out;
  if (values.IsSequence()) {
    for (const YAML::Node& v : values) {
      const std::string text = v.IsScalar() ? v.as<std::string>() : YamlText(v);
      out.push_back({text, text});
    }
  } else if (values.IsMap()) {
    for (const auto& v : values) {
      const std::string text =
          v.second.IsScalar() ? v.second.as<std::string>() : YamlText(v.second);
      out.push_back({v.first.as<std::string>(), text});
    }
  } else {
    throw StudyError(file, values, "values: a list, or a mapping label: value");
  }
  return out;
}

// One entry of a study's `vary`: "key=..." as on the command line, {key, values} or
// {key, range: [start, stop, count]}.
VaryAxis StudyAxis(const fs::path& file, const YAML::Node& entry) {
  if (entry.IsScalar()) {
    try {
      return ParseVary(entry.as<std::string>());
    } catch (const ConfigError& e) {
      throw StudyError(file, entry, e.what());
    }
  }
  if (entry.IsMap()) CheckKnownKeys(file, entry, {"key", "values", "range"}, "a vary entry");
  if (!entry.IsMap() || !entry["key"] || (!entry["values"] == !entry["range"])) {
    throw StudyError(file, entry,
                     "a vary entry is {key, values} or {key, range: [start, stop, count]}");
  }
  VaryAxis axis{.key = entry["key"].as<std::string>(), .values = {}};
  if (const YAML::Node values = entry["values"]) {
    axis.values = StudyValues(file, values);
  } else {
    const YAML::Node range = entry["range"];
    if (!range.IsSequence() || range.size() != 3) {
      throw StudyError(file, range, "range: [start, stop, count]");
    }
    try {
      axis.values = ParseVary(axis.key + "=" + range[0].as<std::string>() + ":" +
                              range[1].as<std::string>() + ":" + range[2].as<std::string>())
                        .values;
    } catch (const ConfigError& e) {
      throw StudyError(file, range, e.what());
    }
  }
  if (axis.values.empty()) throw StudyError(file, entry, "vary " + axis.key + ": no values");
  return axis;
}

}  // namespace

bool IsStudyFile(const fs::path& file) {
  RequireRegularFile(file);  // (a FIFO would block YAML::LoadFile for ever)
  try {
    const YAML::Node root = YAML::LoadFile(file.string());
    return root.IsMap() && root["scenario"];  // a scenario file has no `scenario:` key
  } catch (const YAML::Exception&) {
    return false;
  }
}

SweepSpec LoadStudy(const fs::path& file) {
  const YAML::Node root = LoadYamlFile(file);
  if (!root.IsMap()) {
    throw StudyError(file, root, "a study file is a mapping with scenario: (and vary:)");
  }
  CheckStudyKeys(file, root);
  SweepSpec spec;
  if (!root["scenario"] || !root["scenario"].IsScalar()) {
    throw StudyError(file, root, "scenario: the scenario file, relative to the study file");
  }
  spec.scenario = (file.parent_path() / root["scenario"].as<std::string>()).lexically_normal();
  if (const YAML::Node set = root["set"]) {
    if (!set.IsSequence()) throw StudyError(file, set, "set: a list of key=value");
    for (const YAML::Node& s : set) spec.overrides.push_back(s.as<std::string>());
  }
  if (const YAML::Node repeat = root["repeat"]) {
    try {
      spec.repeat = repeat.as<int>();
    } catch (const YAML::Exception&) {
      throw StudyError(file, repeat, "repeat: a whole number >= 1");
    }
    if (spec.repeat < 1) throw StudyError(file, repeat, "repeat: a whole number >= 1");
  }
  // No vary: one grid point, `repeat` seeds of it.
  const YAML::Node vary = root["vary"] ? root["vary"] : YAML::Node(YAML::NodeType::Sequence);
  if (!vary.IsSequence())
    throw StudyError(file, vary, "vary: a list of {key, values} or {key, range}");
  for (const YAML::Node& entry : vary) spec.axes.push_back(StudyAxis(file, entry));
  try {
    CheckAxesDistinct(spec.axes);
  } catch (const ConfigError& e) {
    throw StudyError(file, vary, e.what());
  }
  return spec;
}

void CheckAxesDistinct(const std::vector<VaryAxis>& axes) {
  for (std::size_t a = 0; a < axes.size(); ++a) {
    for (std::size_t b = 0; b < a; ++b) {
      if (axes[a].key == axes[b].key) {
        throw ConfigError("--vary " + axes[a].key +
                          " is varied twice (two columns of one name, the same runs twice): give "
                          "all its values in one --vary " +
                          axes[a].key + "=...");
      }
    }
  }
}

// ---- The grid ----

std::uint64_t CheckSweepSize(const SweepSpec& spec, std::uint64_t max_runs) {
  // in double: a product of sizes cannot overflow it, and below 2^53 it is exact
  double grid = 1.0;
  for (const VaryAxis& axis : spec.axes) grid *= static_cast<double>(axis.values.size());
  const double runs = grid * std::max(1, spec.repeat);
  if (runs > static_cast<double>(max_runs)) {
    throw ConfigError(fmt::format(
        "the sweep has {:.0f} runs ({:.0f} grid point(s) × {} seed(s)); the limit is --max-runs "
        "{}: narrow the grid, or raise --max-runs (each run takes a fraction of a core-second "
        "to minutes, and the sweep's table of runs is built before the first)",
        runs, grid, std::max(1, spec.repeat), max_runs));
  }
  return static_cast<std::uint64_t>(runs);
}

std::vector<SweepPoint> ExpandGrid(const SweepSpec& spec) {
  std::size_t total = static_cast<std::size_t>(std::max(1, spec.repeat));
  for (const VaryAxis& axis : spec.axes) total *= axis.values.size();
  std::vector<SweepPoint> points;
  points.reserve(total);
  for (std::size_t index = 0; index < total; ++index) {
    SweepPoint p{
        .index = index, .value_index = std::vector<std::size_t>(spec.axes.size()), .repeat = 0};
    std::size_t rest = index;
    p.repeat = static_cast<int>(rest % static_cast<std::size_t>(std::max(1, spec.repeat)));
    rest /= static_cast<std::size_t>(std::max(1, spec.repeat));
    for (std::size_t a = spec.axes.size(); a-- > 0;) {  // the last axis varies fastest
      p.value_index[a] = rest % spec.axes[a].values.size();
      rest /= spec.axes[a].values.size();
    }
    points.push_back(std::move(p));
  }
  return points;
}

std::vector<std::string> PointOverrides(const SweepSpec& spec, const SweepPoint& point) {
  std::vector<std::string> overrides = spec.overrides;
  for (std::size_t a = 0; a < spec.axes.size(); ++a) {
    overrides.push_back(spec.axes[a].key + "=" + spec.axes[a].values[point.value_index[a]].yaml);
  }
  return overrides;
}

Shard ParseShard(const std::string& text) {
  const auto slash = text.find('/');
  Shard shard;
  try {
    std::size_t used_k = 0, used_n = 0;
    if (slash == std::string::npos) throw std::invalid_argument("no slash");
    const std::string k = text.substr(0, slash), n = text.substr(slash + 1);
    shard.k = std::stoi(k, &used_k);
    shard.n = std::stoi(n, &used_n);
    if (used_k != k.size() || used_n != n.size()) throw std::invalid_argument("trailing");
  } catch (const std::exception&) {
    throw ConfigError("--shard " + text + ": expected k/n, e.g. 2/4");
  }
  if (shard.n < 1 || shard.k < 1 || shard.k > shard.n) {
    throw ConfigError("--shard " + text + ": need 1 <= k <= n");
  }
  return shard;
}

bool InShard(std::size_t index, const Shard& shard) {
  return index % static_cast<std::size_t>(shard.n) == static_cast<std::size_t>(shard.k - 1);
}

}  // namespace autonomsim::sim
