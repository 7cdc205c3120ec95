// Sweeps (issue 8): a grid of --set overrides expanded into independent runs, run in parallel,
// shardable (--shard k/n) across processes or machines, resumable (a run whose folder is complete
// is never redone), and joined into one table (results.csv) and plots.
//
// The pure parts are free functions of their own headers: the grid (parsing --vary and study
// files, expanding, sharding) in sweep_spec.h, the table in results_table.h. RunSweep and
// MergeSweeps below do the I/O.
//
// Layout of a sweep folder DIR:
//   DIR/sweep.json       the sweep's spec and its points (this shard's), with their run ids
//   DIR/runs/<id>/       one run folder per point (sim/results/outputs.h) with its replay report
//                        (report.html, sim/results/report.h), id = the first 16 hex
//                        digits of the run's resolved-scenario hash (LoadedScenario::sha256): two
//                        points that resolve to the same scenario share one run
//   DIR/results.csv      one row per point in grid order; DIR/plots/*.png
//   DIR/index.html       the table in the browser, sortable, each run linking its report
#pragma once

#include <chrono>
#include <cstddef>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "sim/scenario/scenario.h"
#include "sim/study/results_table.h"
#include "sim/study/sweep_spec.h"

namespace autonomsim::sim {

// Progress of a running sweep, for the CLI's bar.
struct SweepProgress {
  std::size_t done{0};   // runs finished (this call)
  std::size_t total{0};  // runs to do (this call)
  double wall_s{0.0};    // since the runs began, on SweepOptions::wall_clock
};

// Progress of a sweep's plots: `done` of `total` drawn (0 before the first). Drawing them takes
// seconds (47 plots of a two-car sweep: ≈ 8 s), after the last run's progress.
using PlotProgress = std::function<void(std::size_t done, std::size_t total)>;

// The wall clock as a sweep reads it, for progress and each run's wall_seconds: a monotonic time
// from any fixed origin, called from the worker threads. No module under sim/ reads the wall
// clock itself (ARCHITECTURE): the CLI passes std::chrono::steady_clock, tests a fake.
using WallClock = std::function<std::chrono::nanoseconds()>;

struct SweepOptions {
  std::filesystem::path out_dir;
  int jobs{1};
  Shard shard;
  bool plots{true};
  // Whether each run writes trace.json (its cars' platform.trace): off unless asked (sweep
  // --trace).
  bool trace{false};
  std::uint64_t max_runs{kDefaultMaxRuns};  // more runs in the grid: ConfigError (CheckSweepSize)
  // Polled before each run and every simulated second within one (from any thread): true stops
  // the sweep there, the runs in flight unwound (their partial folders removed), the complete ones
  // kept and tabled (SweepSummary::stopped). None: never.
  std::function<bool()> stop_requested;
  std::function<void(const SweepProgress&)> progress;  // called after each run, from any thread
  PlotProgress plot_progress;  // called as the plots are drawn, from the calling thread
  // None: every wall time is 0 (no elapsed time in progress; summary.json: wall_seconds 0,
  // real_time_factor null).
  WallClock wall_clock;
};

struct SweepSummary {
  std::size_t grid_points{0};  // the whole grid
  std::size_t selected{0};     // in this shard
  std::size_t already_done{0};
  std::size_t ran{0};
  std::vector<std::string> failures;  // "run <id> (point <index>): message"
  // A failure was unusable input (ConfigError) or output that could not be written
  // (OutputError: a full disk, a permission): the CLI exits 2, not 1.
  bool cannot_run{false};
  // The shard's complete runs (ran now or before) whose expectations did not all hold:
  // "run <id> (point <index>): <each failed expectation's name>".
  std::vector<std::string> failed_expectations;
  std::string plots_error;  // as in SweepTableSummary
  // The table it wrote: results.csv for the whole grid; a shard's own results.<k>-of-<n>.csv
  // (never results.csv, which only the whole grid or `sweep merge` writes), with no plots or index.
  std::filesystem::path table;
  bool stopped{false};  // options.stop_requested stopped it: runs are missing, resume to finish
};

// What the results table of a sweep (or of merged shards) found.
struct SweepTableSummary {
  std::size_t missing{0};   // grid points without a complete run
  std::string plots_error;  // why there are no plots (gnuplot failed); empty when they were drawn
  std::vector<std::string> failed_expectations;  // as in SweepSummary
};

// Loads every point of this shard (ConfigError for unusable input, before anything runs), writes
// sweep.json, runs the points whose run folder is not complete on `jobs` threads, and writes
// results.csv (this shard's points) and the plots.
SweepSummary RunSweep(const SweepSpec& spec, const SweepOptions& options);

// Every run of the sweep's grid resolved to its scenario (its repeat's seed applied), in grid
// order, on `jobs` threads, as RunSweep does before its first run: unusable input at any point is
// a ConfigError naming the point and its values. Runs nothing, writes nothing.
std::vector<LoadedScenario> ResolveSweep(const SweepSpec& spec, int jobs);

// Joins sweep folders (shards of one sweep: same spec, else ConfigError) into `out_dir`: the
// union of their points in sweep.json, results.csv over every complete run found in any of them,
// and the plots. Returns how many grid points have no complete run (warned about) and the runs
// whose expectations failed.
SweepTableSummary MergeSweeps(const std::vector<std::filesystem::path>& dirs,
                              const std::filesystem::path& out_dir, bool plots = true,
                              const PlotProgress& plot_progress = {});

}  // namespace autonomsim::sim
