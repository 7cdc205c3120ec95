#include "sim/study/results_table.h"

#include <fmt/format.h>

#include <algorithm>
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

std::string JsonNumberText(const nlohmann::json& value) {
  if (value.is_null()) return "";
  if (value.is_boolean()) return value.get<bool>() ? "1" : "0";
  if (value.is_number_integer() || value.is_number_unsigned()) return value.dump();
  // the shortest text that reads back as the value (fmt's default for doubles)
  if (value.is_number()) return fmt::format("{}", value.get<double>());
  return value.dump();
}

}  // namespace

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

}  // namespace autonomsim::sim
