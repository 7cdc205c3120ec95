#include "sim/study/sweep.h"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <map>
#include <mutex>
#include <set>
#include <sstream>

#include "sim/core/config.h"
#include "sim/core/files.h"
#include "sim/core/hash.h"
#include "sim/core/parallel.h"
#include "sim/loop/simulation.h"
#include "sim/results/expectations.h"
#include "sim/results/outputs.h"
#include "sim/scenario/scenario.h"
#include "sim/study/sweep_plots.h"

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

nlohmann::json ReadJsonFile(const fs::path& file) {
  std::ifstream in(file);
  if (!in) throw ConfigError(file.string() + ": cannot read");
  try {
    return nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    throw ConfigError(file.string() + ": not valid JSON: " + e.what());
  }
}

std::string CsvField(const std::string& text) {
  if (text.find_first_of(",\"\n") == std::string::npos) return text;
  std::string out = "\"";
  for (char c : text) {
    if (c == '"') out += '"';
    out += c;
  }
  return out + "\"";
}

std::string JsonNumberText(const nlohmann::json& value) {
  if (value.is_null()) return "";
  if (value.is_boolean()) return value.get<bool>() ? "1" : "0";
  if (value.is_number_integer() || value.is_number_unsigned()) return value.dump();
  if (value.is_number()) return NumberText(value.get<double>());
  return value.dump();
}

// The grid's manifest file of a shard: sweep.json for the whole grid, sweep.<k>-of-<n>.json for
// a shard, so shards may share one folder.
std::string ManifestName(const Shard& shard) {
  return shard.n == 1 ? "sweep.json" : fmt::format("sweep.{}-of-{}.json", shard.k, shard.n);
}

fs::path RunFolder(const fs::path& dir, const std::string& id) { return dir / "runs" / id; }

bool RunComplete(const fs::path& dir, const std::string& id) {
  return fs::exists(RunFolder(dir, id) / "summary.json");
}

// What identifies a sweep across shards: everything but the scenario path's spelling.
nlohmann::json SpecIdentity(const SweepSpec& spec) {
  nlohmann::json j = spec.ToJson();
  j.erase("scenario");
  return j;
}

nlohmann::json PointJson(const PointRecord& p) {
  return {{"index", p.index},
          {"run_id", p.run_id},
          {"labels", p.labels},
          {"repeat", p.repeat},
          {"seed", p.seed}};
}

PointRecord PointFromJson(const nlohmann::json& j) {
  return PointRecord{.index = j.at("index").get<std::size_t>(),
                     .run_id = j.at("run_id").get<std::string>(),
                     .labels = j.at("labels").get<std::vector<std::string>>(),
                     .repeat = j.at("repeat").get<int>(),
                     .seed = j.at("seed").get<std::uint64_t>()};
}

std::vector<std::string> AxisKeys(const SweepSpec& spec) {
  std::vector<std::string> keys;
  for (const VaryAxis& axis : spec.axes) keys.push_back(axis.key);
  return keys;
}

// results.csv and the plots of `points` (grid order), reading summaries from the first of `dirs`
// that has each run.
std::size_t WriteTableAndPlots(const SweepSpec& spec, const std::vector<PointRecord>& points,
                               const std::vector<fs::path>& dirs, const fs::path& out_dir,
                               bool plots) {
  std::vector<PointRecord> complete;
  std::vector<nlohmann::json> summaries;
  std::map<std::string, nlohmann::json> cache;  // points may share a run
  for (const PointRecord& p : points) {
    auto it = cache.find(p.run_id);
    if (it == cache.end()) {
      for (const fs::path& dir : dirs) {
        if (RunComplete(dir, p.run_id)) {
          it = cache.emplace(p.run_id, ReadJsonFile(RunFolder(dir, p.run_id) / "summary.json"))
                   .first;
          break;
        }
      }
    }
    if (it == cache.end()) continue;
    complete.push_back(p);
    summaries.push_back(it->second);
  }
  const ResultsTable table = BuildResultsTable(AxisKeys(spec), complete, summaries);
  fs::create_directories(out_dir);
  WriteFileAtomically(out_dir / "results.csv", table.Csv());
  if (plots) WriteSweepPlots(spec, complete, summaries, table, out_dir / "plots");
  return points.size() - complete.size();
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
  const bool looks_like_range = range.size() == 3 && rest.find(',') == std::string::npos &&
                                rest.find('{') == std::string::npos;
  if (looks_like_range) {
    const double start = ParseNumber(range[0], spec);
    const double stop = ParseNumber(range[1], spec);
    const double count_d = ParseNumber(range[2], spec);
    if (count_d < 1 || count_d != std::floor(count_d) || count_d > 100000) {
      throw ConfigError("--vary " + spec + ": count must be a whole number >= 1, got '" + range[2] +
                        "'");
    }
    const int count = static_cast<int>(count_d);
    for (int i = 0; i < count; ++i) {
      // the last value is `stop` exactly, not start + (count - 1) * step
      const double value =
          i == count - 1 && count > 1
              ? stop
              : start + (stop - start) * static_cast<double>(i) / std::max(1, count - 1);
      axis.values.push_back({NumberText(value), NumberText(value)});
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

}  // namespace

bool IsStudyFile(const fs::path& file) {
  try {
    const YAML::Node root = YAML::LoadFile(file.string());
    return root.IsMap() && root["scenario"];  // a scenario file has no `scenario:` key
  } catch (const YAML::Exception&) {
    return false;
  }
}

SweepSpec LoadStudy(const fs::path& file) {
  const YAML::Node root = LoadYamlFile(file);
  const std::string where = file.string();
  auto fail = [&](const YAML::Node& node, const std::string& message) -> ConfigError {
    const YAML::Mark mark = node.Mark();
    return ConfigError(fmt::format("{}:{}:{}: {}", where, mark.line + 1, mark.column + 1, message));
  };
  if (!root.IsMap()) throw fail(root, "a study file is a mapping with scenario: (and vary:)");
  for (const auto& item : root) {
    const std::string key = item.first.as<std::string>();
    if (key != "scenario" && key != "description" && key != "set" && key != "repeat" &&
        key != "vary") {
      throw fail(item.first, "unknown key '" + key +
                                 "' (a study has scenario, description, set, repeat, vary)");
    }
  }
  SweepSpec spec;
  if (!root["scenario"] || !root["scenario"].IsScalar()) {
    throw fail(root, "scenario: the scenario file, relative to the study file");
  }
  spec.scenario = (file.parent_path() / root["scenario"].as<std::string>()).lexically_normal();
  if (const YAML::Node set = root["set"]) {
    if (!set.IsSequence()) throw fail(set, "set: a list of key=value");
    for (const YAML::Node& s : set) spec.overrides.push_back(s.as<std::string>());
  }
  if (const YAML::Node repeat = root["repeat"]) {
    try {
      spec.repeat = repeat.as<int>();
    } catch (const YAML::Exception&) {
      throw fail(repeat, "repeat: a whole number >= 1");
    }
    if (spec.repeat < 1) throw fail(repeat, "repeat: a whole number >= 1");
  }
  // No vary: one grid point, `repeat` seeds of it.
  const YAML::Node vary = root["vary"] ? root["vary"] : YAML::Node(YAML::NodeType::Sequence);
  if (!vary.IsSequence()) throw fail(vary, "vary: a list of {key, values} or {key, range}");
  for (const YAML::Node& entry : vary) {
    if (entry.IsScalar()) {
      try {
        spec.axes.push_back(ParseVary(entry.as<std::string>()));
      } catch (const ConfigError& e) {
        throw fail(entry, e.what());
      }
      continue;
    }
    if (!entry.IsMap() || !entry["key"] || (!entry["values"] == !entry["range"])) {
      throw fail(entry, "a vary entry is {key, values} or {key, range: [start, stop, count]}");
    }
    VaryAxis axis{.key = entry["key"].as<std::string>(), .values = {}};
    if (const YAML::Node values = entry["values"]) {
      if (values.IsSequence()) {
        for (const YAML::Node& v : values) {
          const std::string text = v.IsScalar() ? v.as<std::string>() : YamlText(v);
          axis.values.push_back({text, text});
        }
      } else if (values.IsMap()) {
        for (const auto& v : values) {
          const std::string text =
              v.second.IsScalar() ? v.second.as<std::string>() : YamlText(v.second);
          axis.values.push_back({v.first.as<std::string>(), text});
        }
      } else {
        throw fail(values, "values: a list, or a mapping label: value");
      }
    } else {
      const YAML::Node range = entry["range"];
      if (!range.IsSequence() || range.size() != 3) {
        throw fail(range, "range: [start, stop, count]");
      }
      try {
        axis.values = ParseVary(axis.key + "=" + range[0].as<std::string>() + ":" +
                                range[1].as<std::string>() + ":" + range[2].as<std::string>())
                          .values;
      } catch (const ConfigError& e) {
        throw fail(range, e.what());
      }
    }
    if (axis.values.empty()) throw fail(entry, "vary " + axis.key + ": no values");
    spec.axes.push_back(std::move(axis));
  }
  return spec;
}

// ---- The grid ----

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

// ---- The table ----

std::optional<std::size_t> ResultsTable::Column(const std::string& name) const {
  const auto it = std::find(columns.begin(), columns.end(), name);
  if (it == columns.end()) return std::nullopt;
  return static_cast<std::size_t>(it - columns.begin());
}

std::string ResultsTable::Csv() const {
  std::string csv;
  for (std::size_t c = 0; c < columns.size(); ++c) csv += (c ? "," : "") + CsvField(columns[c]);
  csv += "\n";
  for (const auto& row : rows) {
    for (std::size_t c = 0; c < row.size(); ++c) csv += (c ? "," : "") + CsvField(row[c]);
    csv += "\n";
  }
  return csv;
}

namespace {

// The metrics of one run, as (column, value) in a fixed order.
std::vector<std::pair<std::string, std::string>> RunMetricsRow(const nlohmann::json& summary) {
  std::vector<std::pair<std::string, std::string>> row;
  auto add = [&row](const std::string& column, const nlohmann::json& value) {
    row.emplace_back(column, JsonNumberText(value));
  };
  auto get = [](const nlohmann::json& j, const char* key) {
    return j.contains(key) ? j.at(key) : nlohmann::json();
  };
  add("passed", get(summary, "passed"));
  int laps = 0, collisions = 0;
  for (const nlohmann::json& car : summary.at("cars")) {
    laps += car.value("laps", 0);
    collisions += car.value("collisions", 0);
  }
  add("laps_total", laps);
  add("collisions_total", collisions);
  for (const nlohmann::json& car : summary.at("cars")) {
    const std::string c = fmt::format("car{}.", car.at("id").get<int>());
    add(c + "max_lateral_error_m", get(car, "max_lateral_error_m"));
    add(c + "rms_lateral_error_m", get(car, "rms_lateral_error_m"));
    add(c + "min_obstacle_gap_m", get(car, "min_obstacle_gap_m"));
    add(c + "collisions", get(car, "collisions"));
    add(c + "laps", get(car, "laps"));
    // the mean time per lap: the last lap's completion time over the laps completed
    const auto lap_times = car.value("lap_times_s", std::vector<double>{});
    add(c + "mean_lap_time_s",
        lap_times.empty()
            ? nlohmann::json()
            : nlohmann::json(lap_times.back() / static_cast<double>(lap_times.size())));
    add(c + "distance_m", get(car, "distance_m"));
    add(c + "waits", get(car, "waits"));
    add(c + "total_wait_s", get(car, "total_wait_s"));
    add(c + "max_wait_s", get(car, "max_wait_s"));
    if (car.contains("perception")) {
      const nlohmann::json& p = car.at("perception");
      add(c + "lane_error_max_m", get(p, "lane_error_max_m"));
      add(c + "lane_error_rms_m", get(p, "lane_error_rms_m"));
      const double frames = p.value("lane_frames", 0.0);
      add(c + "lane_valid_fraction",
          frames > 0 ? nlohmann::json(p.value("lane_valid_frames", 0.0) / frames)
                     : nlohmann::json());
    }
  }
  if (summary.contains("platform")) {
    for (const auto& [board, report] : summary.at("platform").items()) {
      const std::string b = board + ".";
      add(b + "cpu_percent", get(report, "cpu_percent"));
      add(b + "cpu_demand_percent", get(report, "cpu_demand_percent"));
      for (const auto& [name, column] :
           {std::pair<std::string, std::string>{kCarCommandTopic, "e2e"},
            {kLanePointsTopic, "lanes"}}) {
        for (const nlohmann::json& topic : report.at("topics")) {
          if (topic.at("name") != name) continue;
          add(b + column + "_latency_p50_ms", topic.at("latency_ms").at("p50"));
          add(b + column + "_latency_p99_ms", get(topic.at("latency_ms"), "p99"));
        }
      }
      for (const nlohmann::json& node : report.at("nodes")) {
        const std::string n = b + node.at("name").get<std::string>() + ".";
        add(n + "rate_hz", get(node, "rate_hz"));
        add(n + "turnaround_p50_ms", node.at("turnaround_ms").at("p50"));
        add(n + "cpu_percent", get(node, "cpu_percent"));
      }
    }
  }
  return row;
}

}  // namespace

ResultsTable BuildResultsTable(const std::vector<std::string>& axis_keys,
                               const std::vector<PointRecord>& points,
                               const std::vector<nlohmann::json>& summaries) {
  if (points.size() != summaries.size()) {
    throw std::invalid_argument("BuildResultsTable: one summary per point");
  }
  std::vector<std::size_t> order(points.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return points[a].index < points[b].index; });

  ResultsTable table;
  table.columns = {"index", "run_id"};
  table.columns.insert(table.columns.end(), axis_keys.begin(), axis_keys.end());
  table.columns.insert(table.columns.end(), {"repeat", "seed"});
  const std::size_t fixed = table.columns.size();
  std::map<std::string, std::size_t> metric_column;  // metric columns in first-seen order
  std::vector<std::vector<std::pair<std::string, std::string>>> metrics;
  for (std::size_t i : order) {
    metrics.push_back(RunMetricsRow(summaries[i]));
    for (const auto& [column, unused] : metrics.back()) {
      if (metric_column.emplace(column, table.columns.size()).second) {
        table.columns.push_back(column);
      }
    }
  }
  for (std::size_t r = 0; r < order.size(); ++r) {
    const PointRecord& p = points[order[r]];
    std::vector<std::string> row(table.columns.size());
    row[0] = std::to_string(p.index);
    row[1] = p.run_id;
    for (std::size_t a = 0; a < axis_keys.size(); ++a) {
      row[2 + a] = a < p.labels.size() ? p.labels[a] : "";
    }
    row[fixed - 2] = std::to_string(p.repeat);
    row[fixed - 1] = std::to_string(p.seed);
    for (const auto& [column, value] : metrics[r]) row[metric_column.at(column)] = value;
    table.rows.push_back(std::move(row));
  }
  return table;
}

// ---- Running ----

SweepSummary RunSweep(const SweepSpec& spec, const SweepOptions& options) {
  SweepSummary summary;
  const std::vector<SweepPoint> grid = ExpandGrid(spec);
  summary.grid_points = grid.size();
  std::vector<SweepPoint> selected;
  for (const SweepPoint& p : grid) {
    if (InShard(p.index, options.shard)) selected.push_back(p);
  }
  summary.selected = selected.size();

  // Resolve every point first: unusable input stops the sweep before anything runs.
  std::vector<std::optional<LoadedScenario>> loaded(selected.size());
  std::vector<std::string> errors(selected.size());
  ParallelFor(selected.size(), options.jobs, [&](std::size_t i) {
    const SweepPoint& p = selected[i];
    const std::vector<std::string> overrides = PointOverrides(spec, p);
    try {
      loaded[i].emplace(LoadScenario(spec.scenario, overrides));
      if (p.repeat > 0) {
        const std::uint64_t seed = loaded[i]->scenario.seed + static_cast<std::uint64_t>(p.repeat);
        loaded[i].emplace(LoadScenario(spec.scenario, overrides, seed));
      }
    } catch (const ConfigError& e) {
      std::string values;
      for (std::size_t a = 0; a < spec.axes.size(); ++a) {
        values +=
            (a ? " " : "") + spec.axes[a].key + "=" + spec.axes[a].values[p.value_index[a]].label;
      }
      errors[i] = fmt::format("point {} ({}): {}", p.index, values, e.what());
    }
  });
  for (const std::string& e : errors) {
    if (!e.empty()) throw ConfigError(e);
  }

  std::vector<PointRecord> records;
  for (std::size_t i = 0; i < selected.size(); ++i) {
    PointRecord r{.index = selected[i].index,
                  .run_id = loaded[i]->sha256.substr(0, 16),
                  .labels = {},
                  .repeat = selected[i].repeat,
                  .seed = loaded[i]->scenario.seed};
    for (std::size_t a = 0; a < spec.axes.size(); ++a) {
      r.labels.push_back(spec.axes[a].values[selected[i].value_index[a]].label);
    }
    records.push_back(std::move(r));
  }
  fs::create_directories(options.out_dir / "runs");
  nlohmann::json manifest = {{"spec", spec.ToJson()},
                             {"grid_points", grid.size()},
                             {"shard", fmt::format("{}/{}", options.shard.k, options.shard.n)},
                             {"points", nlohmann::json::array()}};
  for (const PointRecord& r : records) manifest["points"].push_back(PointJson(r));
  WriteFileAtomically(options.out_dir / ManifestName(options.shard), manifest.dump(2) + "\n");

  // The runs to do: one per distinct id whose folder is not complete yet.
  std::vector<std::size_t> todo;
  std::set<std::string> seen;
  for (std::size_t i = 0; i < records.size(); ++i) {
    if (!seen.insert(records[i].run_id).second) continue;
    if (RunComplete(options.out_dir, records[i].run_id)) {
      ++summary.already_done;
    } else {
      todo.push_back(i);
    }
  }
  std::mutex mutex;
  std::size_t done = 0;
  const auto start = std::chrono::steady_clock::now();
  if (options.progress && !todo.empty()) {
    options.progress(SweepProgress{.done = 0, .total = todo.size(), .wall_s = 0.0});
  }
  ParallelFor(todo.size(), options.jobs, [&](std::size_t t) {
    const std::size_t i = todo[t];
    std::string failure;
    bool input_error = false;
    try {
      const auto run_start = std::chrono::steady_clock::now();
      Simulation simulation(*loaded[i]);
      simulation.Run();
      const double wall_s =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - run_start).count();
      const auto expectations = EvaluateExpectations(loaded[i]->scenario, simulation.record());
      WriteRunFolder(*loaded[i], simulation.record(), expectations, wall_s,
                     RunFolder(options.out_dir, records[i].run_id));
    } catch (const ConfigError& e) {
      failure = e.what();
      input_error = true;
    } catch (const std::exception& e) {
      failure = e.what();
    }
    std::lock_guard<std::mutex> lock(mutex);
    ++done;
    if (!failure.empty()) {
      summary.failures.push_back(
          fmt::format("run {} (point {}): {}", records[i].run_id, records[i].index, failure));
      summary.input_error = summary.input_error || input_error;
    } else {
      ++summary.ran;
    }
    if (options.progress) {
      options.progress(SweepProgress{
          .done = done,
          .total = todo.size(),
          .wall_s =
              std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count()});
    }
  });
  std::sort(summary.failures.begin(), summary.failures.end());

  WriteTableAndPlots(spec, records, {options.out_dir}, options.out_dir, options.plots);
  return summary;
}

std::size_t MergeSweeps(const std::vector<fs::path>& dirs, const fs::path& out_dir, bool plots) {
  if (dirs.empty()) throw ConfigError("sweep merge: no folders given");
  std::optional<SweepSpec> spec;
  std::optional<nlohmann::json> identity;
  std::size_t grid_points = 0;
  std::map<std::size_t, PointRecord> points;
  for (const fs::path& dir : dirs) {
    if (!fs::is_directory(dir)) throw ConfigError(dir.string() + ": no such folder");
    std::vector<fs::path> manifests;
    for (const auto& entry : fs::directory_iterator(dir)) {
      const std::string name = entry.path().filename().string();
      if (name.rfind("sweep", 0) == 0 && entry.path().extension() == ".json" &&
          name.find(".tmp-") == std::string::npos) {
        manifests.push_back(entry.path());
      }
    }
    std::sort(manifests.begin(), manifests.end());
    if (manifests.empty()) {
      throw ConfigError(dir.string() + ": not a sweep folder (no sweep.json or sweep.K-of-N.json)");
    }
    for (const fs::path& file : manifests) {
      const nlohmann::json manifest = ReadJsonFile(file);
      try {
        const SweepSpec this_spec = SweepSpec::FromJson(manifest.at("spec"));
        const nlohmann::json this_identity = SpecIdentity(this_spec);
        if (identity && *identity != this_identity) {
          throw ConfigError(file.string() + ": a different sweep than " + dirs.front().string() +
                            " (the varied keys, values, --set or --repeat differ)");
        }
        if (!spec) {
          spec = this_spec;
          identity = this_identity;
          grid_points = manifest.at("grid_points").get<std::size_t>();
        }
        for (const nlohmann::json& p : manifest.at("points")) {
          PointRecord record = PointFromJson(p);
          const auto [it, inserted] = points.emplace(record.index, record);
          if (!inserted && it->second.run_id != record.run_id) {
            throw ConfigError(file.string() + ": point " + std::to_string(record.index) +
                              " has run " + record.run_id + " here but " + it->second.run_id +
                              " elsewhere (was the scenario changed between shards?)");
          }
        }
      } catch (const nlohmann::json::exception& e) {
        throw ConfigError(file.string() + ": not a sweep manifest: " + e.what());
      }
    }
  }
  std::vector<PointRecord> ordered;
  for (const auto& [index, record] : points) ordered.push_back(record);
  fs::create_directories(out_dir);
  nlohmann::json manifest = {{"spec", spec->ToJson()},
                             {"grid_points", grid_points},
                             {"shard", "1/1"},
                             {"merged_from", nlohmann::json::array()},
                             {"points", nlohmann::json::array()}};
  for (const fs::path& dir : dirs) manifest["merged_from"].push_back(dir.string());
  for (const PointRecord& r : ordered) manifest["points"].push_back(PointJson(r));
  WriteFileAtomically(out_dir / "sweep.json", manifest.dump(2) + "\n");
  const std::size_t missing_runs = WriteTableAndPlots(*spec, ordered, dirs, out_dir, plots);
  return missing_runs + (grid_points - ordered.size());
}

}  // namespace autonomsim::sim
