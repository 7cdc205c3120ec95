// Sweeps (issue 8): a grid of --set overrides expanded into independent runs, run in parallel,
// shardable (--shard k/n) across processes or machines, resumable (a run whose folder is complete
// is never redone), and joined into one table (results.csv) and plots.
//
// The pure parts (parsing a --vary spec, expanding the grid, selecting a shard, building the
// table) are free functions; RunSweep and MergeSweeps do the I/O.
//
// Layout of a sweep folder DIR:
//   DIR/sweep.json       the sweep's spec and its points (this shard's), with their run ids
//   DIR/runs/<id>/       one run folder per point (sim/results/outputs.h), id = the first 16 hex
//   digits of
//                        the run's resolved-scenario hash (LoadedScenario::sha256): two points that
//                        resolve to the same scenario share one run
//   DIR/results.csv      one row per point in grid order; DIR/plots/*.png
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

namespace autonomsim::sim {

// One value of a varied key: the YAML text given to ApplyOverride, and how tables and plots name
// it (the text itself unless a study file gives labels).
struct VaryValue {
  std::string label;
  std::string yaml;
};

// One --vary: a --set path (sim/core/config.h ApplyOverride) and its values.
struct VaryAxis {
  std::string key;
  std::vector<VaryValue> values;
};

// Splits `text` at `separator` where it is not inside [], {} or quotes (so YAML flow values such
// as {target: sw} or [1, 2] stay whole); parts are trimmed of surrounding spaces.
std::vector<std::string> SplitTopLevel(const std::string& text, char separator);

// The whole text as a finite number, or nullopt (empty, trailing characters, inf, nan).
std::optional<double> ParseFiniteNumber(const std::string& text);

// "key=a,b,c" (each value YAML) or "key=start:stop:count" (count >= 2 evenly spaced numbers from
// start to stop inclusive, or count = 1: start). ConfigError naming the spec when malformed.
VaryAxis ParseVary(const std::string& spec);

struct SweepSpec {
  std::filesystem::path scenario;
  std::vector<std::string> overrides;  // --set, applied to every run before the varied keys
  std::vector<VaryAxis> axes;
  int repeat{1};  // seeds per grid point: the scenario's seed, seed + 1, ..., seed + repeat - 1

  nlohmann::json ToJson() const;
  static SweepSpec FromJson(const nlohmann::json& json);
};

// A study file (scenarios/studies/*.yaml): `scenario` (relative to the study file's folder),
// optional `description`, `set` (list of key=value), `repeat`, and `vary` (none: one point,
// `repeat` seeds of it): a list of
// {key, values} (values a list of YAML values, or a mapping label: value) or {key, range:
// [start, stop, count]}, or a string "key=..." as on the command line. ConfigError on bad input.
SweepSpec LoadStudy(const std::filesystem::path& file);
// Whether `file` is a study file (a YAML mapping with a top-level `scenario` key) rather than a
// scenario.
bool IsStudyFile(const std::filesystem::path& file);

// One run of the grid: its place in grid order (the axes in the order given, the last varying
// fastest, repeats innermost), the value chosen on each axis, and its repeat number.
struct SweepPoint {
  std::size_t index{0};
  std::vector<std::size_t> value_index;  // per axis
  int repeat{0};
};
std::vector<SweepPoint> ExpandGrid(const SweepSpec& spec);
// The --set list of one point (the spec's overrides, then one per axis).
std::vector<std::string> PointOverrides(const SweepSpec& spec, const SweepPoint& point);

// --shard k/n (1 <= k <= n): this process runs the points whose index % n == k - 1.
struct Shard {
  int k{1};
  int n{1};
};
Shard ParseShard(const std::string& text);  // "k/n"; ConfigError when malformed
bool InShard(std::size_t index, const Shard& shard);

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
// summary.json (see README "Sweeps" for the list). Metric columns that some runs lack (another
// mapping has other nodes) are empty for them. Pure: the same inputs give the same bytes.
struct ResultsTable {
  std::vector<std::string> columns;
  std::vector<std::vector<std::string>> rows;
  std::string Csv() const;
  // Index of a column, or nullopt.
  std::optional<std::size_t> Column(const std::string& name) const;
};
// `summaries[i]` belongs to `points[i]` (points in grid order).
ResultsTable BuildResultsTable(const std::vector<std::string>& axis_keys,
                               const std::vector<PointRecord>& points,
                               const std::vector<nlohmann::json>& summaries);

// Progress of a running sweep, for the CLI's bar.
struct SweepProgress {
  std::size_t done{0};   // runs finished (this call)
  std::size_t total{0};  // runs to do (this call)
  double wall_s{0.0};
};

struct SweepOptions {
  std::filesystem::path out_dir;
  int jobs{1};
  Shard shard;
  bool plots{true};
  std::function<void(const SweepProgress&)> progress;  // called after each run, from any thread
};

struct SweepSummary {
  std::size_t grid_points{0};  // the whole grid
  std::size_t selected{0};     // in this shard
  std::size_t already_done{0};
  std::size_t ran{0};
  std::vector<std::string> failures;  // "run <id> (point <index>): message"
  bool input_error{false};            // a failure was unusable input (ConfigError)
};

// Loads every point of this shard (ConfigError for unusable input, before anything runs), writes
// sweep.json, runs the points whose run folder is not complete on `jobs` threads, and writes
// results.csv (this shard's points) and the plots.
SweepSummary RunSweep(const SweepSpec& spec, const SweepOptions& options);

// Joins sweep folders (shards of one sweep: same spec, else ConfigError) into `out_dir`: the
// union of their points in sweep.json, results.csv over every complete run found in any of them,
// and the plots. Returns the number of grid points that have no complete run (warned about).
std::size_t MergeSweeps(const std::vector<std::filesystem::path>& dirs,
                        const std::filesystem::path& out_dir, bool plots = true);

}  // namespace autonomsim::sim
