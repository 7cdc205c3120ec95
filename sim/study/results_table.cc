#include "sim/study/results_table.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <concepts>
#include <map>
#include <stdexcept>
#include <utility>

#include "sim/car/perception_nodes.h"
#include "sim/car/stack_nodes.h"

namespace autonomsim::sim {

namespace {

std::string CsvField(const std::string& text) {
  if (text.find_first_of(",\"\n") == std::string::npos) return text;
  std::string out = "\"";
  for (char c : text) {
    if (c == '"') out += '"';
    out += c;
  }
  return out + "\"";
}

// A results.csv cell: a number as its shortest text that reads back the same (fmt's default for
// doubles), a bool as 1 or 0, nothing for a missing value (an empty optional, NaN, JSON null).
std::string Cell(double value) { return std::isfinite(value) ? fmt::format("{}", value) : ""; }
std::string Cell(bool value) { return value ? "1" : "0"; }
template <std::integral T>
std::string Cell(T value) {
  return std::to_string(value);
}
std::string Cell(const std::optional<double>& value) { return value ? Cell(*value) : ""; }
// A value of a board's platform report (sim/platform's ReportJson, kept as JSON in the summary).
std::string Cell(const nlohmann::json& value) {
  if (value.is_null()) return "";
  if (value.is_boolean()) return Cell(value.get<bool>());
  if (value.is_number_integer() || value.is_number_unsigned()) return value.dump();
  if (value.is_number()) return Cell(value.get<double>());
  return value.dump();
}

}  // namespace

// ---- The table ----

bool IsNodeColumn(const std::string& metric_column) {
  // a board's name (carN) and a node's (a ROS name part) hold no dot: AddBoardColumns below
  return std::count(metric_column.begin(), metric_column.end(), '.') == 2;
}

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

using Row = std::vector<std::pair<std::string, std::string>>;  // (column, value)

// One car's columns, each named car<id>.<metric>.
void AddCarColumns(const CarMetrics& car, Row* row) {
  const std::string c = fmt::format("car{}.", car.id);
  auto add = [&](const std::string& metric, std::string value) {
    row->emplace_back(c + metric, std::move(value));
  };
  add("max_lateral_error_m", Cell(car.max_lateral_error_m));
  add("rms_lateral_error_m", Cell(car.rms_lateral_error_m));
  add("min_obstacle_gap_m", Cell(car.min_obstacle_gap_m));
  add("collisions", Cell(car.collisions));
  add("laps", Cell(car.laps));
  // the mean time per lap: the last lap's completion time over the laps completed
  add("mean_lap_time_s",
      car.lap_times_s.empty()
          ? ""
          : Cell(car.lap_times_s.back() / static_cast<double>(car.lap_times_s.size())));
  add("distance_m", Cell(car.distance_m));
  add("waits", Cell(car.waits));
  add("total_wait_s", Cell(car.total_wait_s));
  add("max_wait_s", Cell(car.max_wait_s));
  if (car.perception) {
    const PerceptionMetrics& p = *car.perception;
    add("lane_error_max_m", Cell(p.lane_error_max_m));
    add("lane_error_rms_m", Cell(p.lane_error_rms_m));
    add("lane_valid_fraction", p.lane_frames > 0 ? Cell(static_cast<double>(p.lane_valid_frames) /
                                                        static_cast<double>(p.lane_frames))
                                                 : "");
  }
}

// One board's columns, each named <board>.<metric> or <board>.<node>.<metric>. `report` is
// sim/platform's ReportJson (its keys are that module's).
void AddBoardColumns(const std::string& board, const nlohmann::json& report, Row* row) {
  const std::string b = board + ".";
  auto add = [&](const std::string& column, const nlohmann::json& value) {
    row->emplace_back(b + column, Cell(value));
  };
  auto get = [](const nlohmann::json& j, const char* key) {
    return j.contains(key) ? j.at(key) : nlohmann::json();
  };
  add("cpu_percent", get(report, "cpu_percent"));
  add("cpu_demand_percent", get(report, "cpu_demand_percent"));
  if (report.contains("slots")) {  // slot_policy executor
    const nlohmann::json& slots = report.at("slots");
    add("reconfigurations", get(slots, "reconfigurations"));
    add("reconfiguring_s", get(slots, "reconfiguring_s"));
    add("slot_waits", get(slots, "waits"));
    add("slot_wait_s", get(slots, "wait_s"));
  }
  for (const auto& [name, column] : {std::pair<std::string, std::string>{kCarCommandTopic, "e2e"},
                                     {kLanePointsTopic, "lanes"},
                                     {kObstaclesTopic, "obstacles"}}) {
    for (const nlohmann::json& topic : report.at("topics")) {
      if (topic.at("name") != name) continue;
      add(column + "_latency_p50_ms", topic.at("latency_ms").at("p50"));
      add(column + "_latency_p99_ms", get(topic.at("latency_ms"), "p99"));
    }
  }
  for (const nlohmann::json& node : report.at("nodes")) {
    const std::string n = node.at("name").get<std::string>() + ".";
    add(n + "rate_hz", get(node, "rate_hz"));
    add(n + "turnaround_p50_ms", node.at("turnaround_ms").at("p50"));
    add(n + "cpu_percent", get(node, "cpu_percent"));
  }
}

// The metrics of one run, as (column, value) in a fixed order.
Row RunMetricsRow(const RunSummary& summary) {
  Row row;
  row.emplace_back("passed", Cell(summary.passed));
  int laps = 0, collisions = 0;
  for (const CarMetrics& car : summary.cars) {
    laps += car.laps;
    collisions += car.collisions;
  }
  row.emplace_back("laps_total", Cell(laps));
  row.emplace_back("collisions_total", Cell(collisions));
  for (const CarMetrics& car : summary.cars) AddCarColumns(car, &row);
  if (summary.platform) {
    for (const auto& [board, report] : *summary.platform) AddBoardColumns(board, report, &row);
  }
  return row;
}

}  // namespace

ResultsTable BuildResultsTable(const std::vector<std::string>& axis_keys,
                               const std::vector<PointRecord>& points,
                               const std::vector<RunSummary>& summaries) {
  if (points.size() != summaries.size()) {
    throw std::invalid_argument("BuildResultsTable: one summary per point");
  }
  std::vector<std::size_t> order(points.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return points[a].index < points[b].index; });

  ResultsTable table;
  table.columns = {"index", "run_id"};
  // a varied key that is also a fixed column's name (--vary seed=...) is "vary.<key>": one table
  // of two `seed` columns confuses every reader (the run's seed is the varied one plus its repeat)
  const std::vector<std::string> fixed_columns = {"index", "run_id", "repeat", "seed"};
  for (const std::string& key : axis_keys) {
    const bool taken =
        std::find(fixed_columns.begin(), fixed_columns.end(), key) != fixed_columns.end();
    table.columns.push_back(taken ? "vary." + key : key);
  }
  table.columns.insert(table.columns.end(), {"repeat", "seed"});
  const std::size_t fixed = table.columns.size();
  std::map<std::string, std::size_t> metric_column;  // metric columns in first-seen order
  std::vector<Row> metrics;
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

}  // namespace autonomsim::sim
