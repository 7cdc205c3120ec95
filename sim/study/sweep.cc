#include "sim/study/sweep.h"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <fstream>
#include <map>
#include <mutex>
#include <optional>
#include <set>

#include "sim/core/config.h"
#include "sim/core/files.h"
#include "sim/core/parallel.h"
#include "sim/loop/simulation.h"
#include "sim/results/expectations.h"
#include "sim/results/outputs.h"
#include "sim/results/report.h"
#include "sim/results/summary.h"
#include "sim/scenario/scenario.h"
#include "sim/study/sweep_index.h"
#include "sim/study/sweep_plots.h"

namespace autonomsim::sim {

namespace fs = std::filesystem;

namespace {

nlohmann::json ReadJsonFile(const fs::path& file) {
  std::ifstream in(file);
  if (!in) throw ConfigError(file.string() + ": cannot read");
  try {
    return nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    throw ConfigError(file.string() + ": not valid JSON: " + e.what());
  }
}

// The grid's manifest file of a shard: sweep.json for the whole grid, sweep.<k>-of-<n>.json for
// a shard, so shards may share one folder.
// A file of the whole grid, `stem.ext`, or of one shard, `stem.<k>-of-<n>.ext`.
std::string ShardFileName(const Shard& shard, std::string_view stem, std::string_view ext) {
  return shard.n == 1 ? fmt::format("{}.{}", stem, ext)
                      : fmt::format("{}.{}-of-{}.{}", stem, shard.k, shard.n, ext);
}

std::string ManifestName(const Shard& shard) { return ShardFileName(shard, "sweep", "json"); }

fs::path RunFolderOf(const fs::path& dir, const std::string& id) { return dir / "runs" / id; }

bool RunComplete(const fs::path& dir, const std::string& id) {
  return fs::exists(RunFolderOf(dir, id) / "summary.json");
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

// A manifest (sweep.json): the spec, the grid's size, the shard ("k/n") and its points.
nlohmann::json ManifestJson(const SweepSpec& spec, std::size_t grid_points,
                            const std::string& shard, const std::vector<PointRecord>& records) {
  nlohmann::json manifest = {{"spec", spec.ToJson()},
                             {"grid_points", grid_points},
                             {"shard", shard},
                             {"points", nlohmann::json::array()}};
  for (const PointRecord& r : records) manifest["points"].push_back(PointJson(r));
  return manifest;
}

std::vector<std::string> AxisKeys(const SweepSpec& spec) {
  std::vector<std::string> keys;
  for (const VaryAxis& axis : spec.axes) keys.push_back(axis.key);
  return keys;
}

// index.html: the table with a link to each run's report, written now for a run that has none (a
// run from before reports, or one whose report failed), and the plots.
void WriteIndex(const SweepSpec& spec, const ResultsTable& table,
                const std::map<std::string, fs::path>& folders, const fs::path& out_dir,
                std::size_t missing, std::size_t failed) {
  SweepIndexInput index{.title = spec.scenario.stem().string() + " sweep",
                        .axis_keys = AxisKeys(spec),
                        .table = &table,
                        .missing = missing};
  index.failed = failed;
  for (const auto& [id, folder] : folders) {
    fs::path target = folder / kReportFileName;
    if (!fs::exists(target)) {
      try {
        WriteReport(folder);
      } catch (const std::exception&) {
        target = folder;  // no report: the index links the folder
      }
    }
    index.links[id] = fs::relative(target, out_dir).generic_string();
  }
  if (fs::is_directory(out_dir / "plots")) {
    for (const auto& entry : fs::directory_iterator(out_dir / "plots")) {
      if (entry.path().extension() == ".png") {
        index.plots.push_back(fs::relative(entry.path(), out_dir).generic_string());
      }
    }
    std::sort(index.plots.begin(), index.plots.end());
  }
  WriteFileAtomically(out_dir / "index.html", SweepIndexHtml(index));
}

// The table of a shard: its own file, so that a shard run into a complete sweep's folder never
// rewrites that sweep's results.csv.
std::string TableName(const Shard& shard) { return ShardFileName(shard, "results", "csv"); }

// A table of `points` (grid order), reading summaries from the first of `dirs` that has each run:
// results.csv with the plots and the index, or (a shard's, `table_name` another name) that file
// alone.
SweepTableSummary WriteTableAndPlots(const SweepSpec& spec, const std::vector<PointRecord>& points,
                                     const std::vector<fs::path>& dirs, const fs::path& out_dir,
                                     bool plots, const std::string& table_name = "results.csv",
                                     const PlotProgress& plot_progress = {}) {
  std::vector<PointRecord> complete;
  std::vector<RunSummary> summaries;
  std::map<std::string, RunSummary> cache;  // points may share a run
  std::map<std::string, fs::path> folders;  // run id -> its folder
  for (const PointRecord& p : points) {
    auto it = cache.find(p.run_id);
    if (it == cache.end()) {
      for (const fs::path& dir : dirs) {
        if (RunComplete(dir, p.run_id)) {
          folders[p.run_id] = RunFolderOf(dir, p.run_id);
          it = cache.emplace(p.run_id, ReadSummaryFile(folders[p.run_id] / "summary.json")).first;
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
  WriteFileAtomically(out_dir / table_name, table.Csv());
  SweepTableSummary result{.missing = points.size() - complete.size()};
  const bool whole = table_name == "results.csv";
  if (plots && whole) {
    try {
      WriteSweepPlots(spec, complete, summaries, table, out_dir / "plots", plot_progress);
    } catch (const std::runtime_error& e) {  // the table stands without them
      result.plots_error = e.what();
    }
  }
  if (whole) {
    WriteIndex(
        spec, table, folders, out_dir, result.missing,
        static_cast<std::size_t>(std::count_if(summaries.begin(), summaries.end(),
                                               [](const RunSummary& r) { return !r.passed; })));
  }
  for (std::size_t i = 0; i < complete.size(); ++i) {
    if (summaries[i].passed) continue;
    std::vector<std::string> names;
    for (const ExpectationResult& e : summaries[i].expectations) {
      if (!e.passed) names.push_back(e.name);
    }
    result.failed_expectations.push_back(fmt::format("run {} (point {}): {}", complete[i].run_id,
                                                     complete[i].index, fmt::join(names, ", ")));
  }
  return result;
}

}  // namespace

// ---- Running ----

namespace {

// "key=label ..." of a point's varied values, for messages.
std::string PointValues(const SweepSpec& spec, const SweepPoint& p) {
  std::string values;
  for (std::size_t a = 0; a < spec.axes.size(); ++a) {
    values += (a ? " " : "") + spec.axes[a].key + "=" + spec.axes[a].values[p.value_index[a]].label;
  }
  return values;
}

// Resolves every point to its scenario (its repeat's seed applied), on `jobs` threads. Unusable
// input at any point is a ConfigError naming the point and its values, before anything runs.
std::vector<LoadedScenario> LoadPoints(const SweepSpec& spec, const std::vector<SweepPoint>& points,
                                       int jobs) {
  std::vector<std::optional<LoadedScenario>> loaded(points.size());
  std::vector<std::string> errors(points.size());
  ParallelFor(points.size(), jobs, [&](std::size_t i) {
    const SweepPoint& p = points[i];
    const std::vector<std::string> overrides = PointOverrides(spec, p);
    try {
      loaded[i].emplace(LoadScenario(spec.scenario, overrides));
      if (p.repeat > 0) {
        const std::uint64_t seed = loaded[i]->scenario.seed + static_cast<std::uint64_t>(p.repeat);
        loaded[i].emplace(LoadScenario(spec.scenario, overrides, seed));
      }
    } catch (const ConfigError& e) {
      errors[i] = fmt::format("point {} ({}): {}", p.index, PointValues(spec, p), e.what());
    }
  });
  for (const std::string& e : errors) {
    if (!e.empty()) throw ConfigError(e);
  }
  std::vector<LoadedScenario> scenarios;
  scenarios.reserve(points.size());
  for (std::optional<LoadedScenario>& l : loaded) scenarios.push_back(std::move(*l));
  return scenarios;
}

std::vector<PointRecord> RecordPoints(const SweepSpec& spec, const std::vector<SweepPoint>& points,
                                      const std::vector<LoadedScenario>& loaded) {
  std::vector<PointRecord> records;
  for (std::size_t i = 0; i < points.size(); ++i) {
    PointRecord r{.index = points[i].index,
                  .run_id = loaded[i].sha256.substr(0, 16),
                  .labels = {},
                  .repeat = points[i].repeat,
                  .seed = loaded[i].scenario.seed};
    for (std::size_t a = 0; a < spec.axes.size(); ++a) {
      r.labels.push_back(spec.axes[a].values[points[i].value_index[a]].label);
    }
    records.push_back(std::move(r));
  }
  return records;
}

// The runs to do, as indices into `records`: one per distinct run id whose folder in `dir` is not
// complete yet. Counts the complete ones into *already_done.
std::vector<std::size_t> RunsToDo(const std::vector<PointRecord>& records, const fs::path& dir,
                                  std::size_t* already_done) {
  std::vector<std::size_t> todo;
  std::set<std::string> seen;
  for (std::size_t i = 0; i < records.size(); ++i) {
    if (!seen.insert(records[i].run_id).second) continue;
    if (RunComplete(dir, records[i].run_id)) {
      ++*already_done;
    } else {
      todo.push_back(i);
    }
  }
  return todo;
}

std::chrono::nanoseconds Now(const WallClock& clock) {
  return clock ? clock() : std::chrono::nanoseconds(0);
}

double SecondsSince(std::chrono::nanoseconds start, const WallClock& clock) {
  return std::chrono::duration<double>(Now(clock) - start).count();
}

// Runs one point and writes its folder. Its wall time is the simulation's alone: not loading the
// scenario, judging it or writing the folder.
// A stop request (SweepOptions::stop_requested) ends it at the next simulated second: RunStopped
// unwinds it, and its partial folder goes with it.
struct RunStopped {};

void RunPoint(const LoadedScenario& loaded, const SweepOptions& options, const fs::path& folder) {
  const WallClock& clock = options.wall_clock;
  RunFolder run_folder(folder);
  const std::chrono::nanoseconds start = Now(clock);
  Simulation simulation(loaded, run_folder.store());
  simulation.Run([&options](Time) {
    if (options.stop_requested && options.stop_requested()) throw RunStopped{};
  });
  const double wall_s = SecondsSince(start, clock);
  const auto expectations = EvaluateExpectations(loaded.scenario, simulation.record());
  run_folder.Complete(loaded, simulation.record(), expectations, wall_s);
  try {
    WriteReport(folder);
  } catch (const std::exception&) {
    // the run is complete without it; the index tries again and links the folder if it fails
  }
}

// Runs the points `todo` (indices into `loaded` and `records`) on options.jobs threads, counting
// into *summary and reporting progress before the first and after each.
void RunPoints(const std::vector<LoadedScenario>& loaded, const std::vector<PointRecord>& records,
               const std::vector<std::size_t>& todo, const SweepOptions& options,
               SweepSummary* summary) {
  std::mutex mutex;
  std::size_t done = 0;
  const std::chrono::nanoseconds start = Now(options.wall_clock);
  if (options.progress && !todo.empty()) {
    options.progress(SweepProgress{.done = 0, .total = todo.size(), .wall_s = 0.0});
  }
  ParallelFor(todo.size(), options.jobs, [&](std::size_t t) {
    const std::size_t i = todo[t];
    const auto stop = [&] { return options.stop_requested && options.stop_requested(); };
    std::string failure;
    bool cannot_run = false;
    try {
      if (stop()) throw RunStopped{};  // start nothing more
      RunPoint(loaded[i], options, RunFolderOf(options.out_dir, records[i].run_id));
    } catch (const RunStopped&) {
      std::lock_guard<std::mutex> lock(mutex);
      summary->stopped = true;
      return;
    } catch (const ConfigError& e) {
      failure = e.what();
      cannot_run = true;
    } catch (const OutputError& e) {  // a full disk, a permission: with the path and the reason
      failure = e.what();
      cannot_run = true;
    } catch (const std::exception& e) {
      failure = e.what();
    }
    std::lock_guard<std::mutex> lock(mutex);
    ++done;
    if (!failure.empty()) {
      summary->failures.push_back(
          fmt::format("run {} (point {}): {}", records[i].run_id, records[i].index, failure));
      summary->cannot_run = summary->cannot_run || cannot_run;
    } else {
      ++summary->ran;
    }
    if (options.progress) {
      options.progress(SweepProgress{
          .done = done, .total = todo.size(), .wall_s = SecondsSince(start, options.wall_clock)});
    }
  });
  std::sort(summary->failures.begin(), summary->failures.end());
}

}  // namespace

std::vector<LoadedScenario> ResolveSweep(const SweepSpec& spec, int jobs) {
  return LoadPoints(spec, ExpandGrid(spec), jobs);
}

SweepSummary RunSweep(const SweepSpec& spec, const SweepOptions& options) {
  SweepSummary summary;
  CheckSweepSize(spec, options.max_runs);
  const std::vector<SweepPoint> grid = ExpandGrid(spec);
  summary.grid_points = grid.size();
  std::vector<SweepPoint> selected;
  for (const SweepPoint& p : grid) {
    if (InShard(p.index, options.shard)) selected.push_back(p);
  }
  summary.selected = selected.size();

  // resolve every point first: unusable input stops the sweep before anything runs
  std::vector<LoadedScenario> loaded = LoadPoints(spec, selected, options.jobs);
  // A trace is some 10 MB a run and rarely read across a sweep: only when asked. Its run ids (the
  // resolved scenarios' hashes) stay: whether a trace is written is not what a run does.
  if (!options.trace) {
    for (LoadedScenario& l : loaded) {
      for (CarConfig& car : l.scenario.cars) car.platform.trace = false;
    }
  }
  const std::vector<PointRecord> records = RecordPoints(spec, selected, loaded);
  fs::create_directories(options.out_dir / "runs");
  WriteFileAtomically(options.out_dir / ManifestName(options.shard),
                      ManifestJson(spec, grid.size(),
                                   fmt::format("{}/{}", options.shard.k, options.shard.n), records)
                              .dump(2) +
                          "\n");

  const std::vector<std::size_t> todo = RunsToDo(records, options.out_dir, &summary.already_done);
  RunPoints(loaded, records, todo, options, &summary);
  summary.table = options.out_dir / TableName(options.shard);
  SweepTableSummary table =
      WriteTableAndPlots(spec, records, {options.out_dir}, options.out_dir, options.plots,
                         TableName(options.shard), options.plot_progress);
  summary.failed_expectations = std::move(table.failed_expectations);
  summary.plots_error = std::move(table.plots_error);
  return summary;
}

SweepTableSummary MergeSweeps(const std::vector<fs::path>& dirs, const fs::path& out_dir,
                              bool plots, const PlotProgress& plot_progress) {
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
  nlohmann::json manifest = ManifestJson(*spec, grid_points, "1/1", ordered);
  manifest["merged_from"] = nlohmann::json::array();
  for (const fs::path& dir : dirs) manifest["merged_from"].push_back(dir.string());
  WriteFileAtomically(out_dir / "sweep.json", manifest.dump(2) + "\n");
  SweepTableSummary table =
      WriteTableAndPlots(*spec, ordered, dirs, out_dir, plots, "results.csv", plot_progress);
  table.missing += grid_points - ordered.size();
  return table;
}

}  // namespace autonomsim::sim
