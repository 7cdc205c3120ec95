// results.csv: one row per point of a sweep, with its varied values and its run's metrics.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "sim/results/summary.h"

namespace autonomsim::sim {

// A point as recorded in sweep.json: what results.csv needs without reloading the scenario.
struct PointRecord {
  std::size_t index{0};
  std::string run_id;
  std::vector<std::string> labels;  // per axis
  int repeat{0};
  std::uint64_t seed{0};
};

// The rows of results.csv: the points that have a summary, in grid order. Columns: index,
// run_id, one per axis (its key), repeat, seed, then the metrics taken from each run's
// summary (sim/results/summary.h; list: docs/outputs.md#a-sweeps-folder). Metric columns some runs
// lack (another mapping has other nodes) are empty for them. Pure: the same inputs give the same
// bytes.
struct ResultsTable {
  std::vector<std::string> columns;
  std::vector<std::vector<std::string>> rows;
  std::string Csv() const;
  // Index of a column, or nullopt.
  std::optional<std::size_t> Column(const std::string& name) const;
};
// Whether a metric column of the table is one node's, <board>.<node>.<metric> (e.g.
// car0.poly_fit.rate_hz), rather than a car's or a board's, <car or board>.<metric>. Not for the
// columns before the metrics (a varied key's name may hold dots).
bool IsNodeColumn(const std::string& metric_column);

// `summaries[i]` belongs to `points[i]` (points in grid order).
ResultsTable BuildResultsTable(const std::vector<std::string>& axis_keys,
                               const std::vector<PointRecord>& points,
                               const std::vector<RunSummary>& summaries);

}  // namespace autonomsim::sim
