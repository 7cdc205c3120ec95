// `autonomsim sweep SCENARIO|STUDY --vary KEY=VALUES ... --out DIR` and
// `autonomsim sweep merge DIR...`: latency what-if studies (sim/study/sweep.h does the work).
#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>

#include "sim/core/config.h"
#include "sim/core/files.h"
#include "sim/mqtt/mqtt_client.h"
#include "sim/study/sweep.h"
#include "tools/cli_common.h"
#include "tools/interrupt.h"

namespace autonomsim::cli {
namespace {

namespace fs = std::filesystem;

std::string FormatSeconds(double seconds) {
  const long s = std::lround(std::max(0.0, seconds));
  if (s >= 3600) return fmt::format("{}h{:02}m", s / 3600, (s % 3600) / 60);
  if (s >= 60) return fmt::format("{}m{:02}s", s / 60, s % 60);
  return fmt::format("{}s", s);
}

// A bar rewritten in place on a terminal; a line per run otherwise (logs, CI).
class SweepProgressPrinter {
 public:
  explicit SweepProgressPrinter(bool quiet) : quiet_(quiet), tty_(::isatty(STDERR_FILENO) == 1) {}

  void Update(const sim::SweepProgress& p) {
    if (quiet_ || p.total == 0) return;
    const double eta_s =
        p.done > 0 ? p.wall_s / static_cast<double>(p.done) * static_cast<double>(p.total - p.done)
                   : 0.0;
    const std::string eta = p.done > 0 ? FormatSeconds(eta_s) : std::string("--");
    if (tty_) {
      constexpr int kWidth = 30;
      const int filled = static_cast<int>(kWidth * p.done / p.total);
      fmt::print(stderr, "\r  [{}{}] {}/{} runs, {} elapsed, ETA {}   ", std::string(filled, '#'),
                 std::string(kWidth - filled, '.'), p.done, p.total, FormatSeconds(p.wall_s), eta);
      if (p.done == p.total) fmt::print(stderr, "\n");
      std::fflush(stderr);
    } else {
      fmt::print(stderr, "  {}/{} runs done, {} elapsed, ETA {}\n", p.done, p.total,
                 FormatSeconds(p.wall_s), eta);
    }
  }

  // Drawing the plots takes seconds after the last run: a count rewritten in place on a terminal,
  // a line at each tenth otherwise.
  void Plots(std::size_t done, std::size_t total) {
    if (quiet_ || total == 0) return;
    if (tty_) {
      fmt::print(stderr, "\r  plotting: {} of {} plots   ", done, total);
      if (done == total) fmt::print(stderr, "\n");
      std::fflush(stderr);
    } else if (done == 0 || done == total || done * 10 / total != (done - 1) * 10 / total) {
      fmt::print(stderr, "  plotting: {} of {} plots\n", done, total);
    }
  }

 private:
  bool quiet_;
  bool tty_;
};

struct SweepOptions {
  std::string scenario;
  std::vector<std::string> vary;
  std::vector<std::string> overrides;
  int repeat{1};
  std::uint64_t max_runs{sim::kDefaultMaxRuns};
  std::string out;
  int jobs = DefaultJobs();
  std::string shard{"1/1"};
  bool no_plots{false};
  bool trace{false};
  bool quiet{false};
  std::vector<std::string> merge_dirs;
  std::string merge_out;
  bool force{false};
};

// What a finished sweep prints on stdout (a stop and missing plots on stderr), and its exit code.
int ReportSweep(const sim::SweepSummary& summary, const sim::Shard& shard, const std::string& out) {
  if (summary.stopped) {
    fmt::print(stderr,
               "autonomsim sweep: interrupted after {} run(s); the runs in flight were removed, "
               "the complete ones kept and tabled: the same command resumes where it stopped\n",
               summary.ran);
  }
  fmt::print(
      "{} run(s){}: {} ran, {} already complete, {} failed to run, {} with failed expectations\n",
      summary.selected,
      shard.n > 1 ? fmt::format(" in shard {}/{}", shard.k, shard.n) : std::string(), summary.ran,
      summary.already_done, summary.failures.size(), summary.failed_expectations.size());
  for (const std::string& f : summary.failures) fmt::print("  FAILED {}\n", f);
  for (const std::string& f : summary.failed_expectations) fmt::print("  FAIL {}\n", f);
  if (!summary.plots_error.empty())
    fmt::print(stderr, "warning: no plots: {}\n", summary.plots_error);
  fmt::print("results: {}\n", summary.table.string());
  if (shard.n == 1) {
    fmt::print("index: {}\n", (fs::path(out) / "index.html").string());
  } else {
    fmt::print("(a shard's table: `sweep merge` joins the shards' folders into results.csv)\n");
  }
  if (summary.stopped) return kExitInterrupted;
  if (!summary.failures.empty()) {
    return summary.cannot_run ? kExitUnusableInput : kExitExpectationFailed;
  }
  return summary.failed_expectations.empty() ? kExitOk : kExitExpectationFailed;
}

int SweepCommand(const SweepOptions& o, bool repeat_given) {
  InstallInterruptHandlers();  // Ctrl-C: stop at the next simulated second
  sim::SweepSpec spec;
  sim::SweepOptions options;
  try {
    if (o.scenario.empty()) throw sim::ConfigError("sweep: give a SCENARIO or study file");
    if (o.out.empty()) throw sim::ConfigError("sweep: --out DIR is required");
    if (sim::IsStudyFile(o.scenario)) {
      spec = sim::LoadStudy(o.scenario);
    } else {
      spec.scenario = o.scenario;
    }
    spec.overrides.insert(spec.overrides.end(), o.overrides.begin(), o.overrides.end());
    for (const std::string& v : o.vary) spec.axes.push_back(sim::ParseVary(v));
    sim::CheckAxesDistinct(spec.axes);
    if (repeat_given) spec.repeat = o.repeat;
    options.max_runs = o.max_runs;
    sim::CheckSweepSize(spec, options.max_runs);  // before the folder is made
    options.jobs = o.jobs;
    options.shard = sim::ParseShard(o.shard);
    options.plots = !o.no_plots;
    options.trace = o.trace;
    // last: refused, or created and marked, once the rest of the command is known to be usable
    options.out_dir = sim::PrepareOutputFolder(o.out, o.force);
  } catch (const sim::ConfigError& e) {
    fmt::print(stderr, "error: {}\n", e.what());
    return kExitUnusableInput;
  }
  options.stop_requested = InterruptRequested;  // Ctrl-C: stop, keep the complete runs
  SweepProgressPrinter printer(o.quiet);
  options.progress = [&printer](const sim::SweepProgress& p) { printer.Update(p); };
  options.plot_progress = [&printer](std::size_t done, std::size_t total) {
    printer.Plots(done, total);
  };
  options.wall_clock = [] {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(
        std::chrono::steady_clock::now().time_since_epoch());
  };

  std::size_t grid = 1;
  for (const sim::VaryAxis& axis : spec.axes) grid *= axis.values.size();
  if (!o.quiet) {
    fmt::print(stderr, "autonomsim sweep: {} ({} grid point(s) x {} seed(s){}, {} job(s))\n",
               spec.scenario.string(), grid, spec.repeat,
               options.shard.n > 1 ? fmt::format(", shard {}/{}", options.shard.k, options.shard.n)
                                   : std::string(),
               options.jobs);
  }
  sim::SweepSummary summary;
  try {
    summary = sim::RunSweep(spec, options);
  } catch (const sim::ConfigError& e) {
    fmt::print(stderr, "error: {}\n", e.what());
    return kExitUnusableInput;
  }
  return ReportSweep(summary, options.shard, o.out);
}

int MergeCommand(const SweepOptions& o) {
  std::vector<fs::path> dirs(o.merge_dirs.begin(), o.merge_dirs.end());
  fs::path out = dirs.front();
  sim::SweepTableSummary merged;
  try {
    if (!o.merge_out.empty()) out = sim::PrepareOutputFolder(o.merge_out, o.force);
    SweepProgressPrinter printer(o.quiet);
    merged = sim::MergeSweeps(
        dirs, out, !o.no_plots,
        [&printer](std::size_t done, std::size_t total) { printer.Plots(done, total); });
  } catch (const sim::ConfigError& e) {
    fmt::print(stderr, "error: {}\n", e.what());
    return kExitUnusableInput;
  }
  if (merged.missing > 0) {
    fmt::print(stderr, "warning: {} grid point(s) have no complete run in these folders\n",
               merged.missing);
  }
  fmt::print("{} run(s) with failed expectations\n", merged.failed_expectations.size());
  for (const std::string& f : merged.failed_expectations) fmt::print("  FAIL {}\n", f);
  if (!merged.plots_error.empty())
    fmt::print(stderr, "warning: no plots: {}\n", merged.plots_error);
  fmt::print("results: {}\n", (out / "results.csv").string());
  fmt::print("index: {}\n", (out / "index.html").string());
  return merged.failed_expectations.empty() ? kExitOk : kExitExpectationFailed;
}

}  // namespace

Command AddSweepCommand(CLI::App& parent) {
  auto o = std::make_shared<SweepOptions>();
  CLI::App* sweep = parent.add_subcommand(
      "sweep",
      "Run a grid of scenario variants (a latency what-if study) in parallel: one run folder per "
      "variant under DIR/runs/<id> (with its replay report, report.html), DIR/results.csv (one "
      "row per run, grid order), DIR/plots and DIR/index.html (the table in the browser, "
      "sortable, each run linking its report). "
      "Resumes: runs already complete in DIR are not redone.");
  sweep->add_option("SCENARIO", o->scenario,
                    "Scenario file, or a study file (scenarios/studies/*.yaml: scenario, set, "
                    "vary, repeat) whose grid the --vary options extend");
  sweep
      ->add_option("--vary", o->vary,
                   "KEY=a,b,c or KEY=start:stop:count; KEY is any --set path, e.g. "
                   "v2i.latency_s=0:2:5 or cars[0].platform.cost_scale.lane_planner=1,2,4 "
                   "(repeatable; the grid is the product, the last --vary varying fastest)")
      ->type_name("KEY=VALUES");
  AddSetOption(sweep, &o->overrides);
  CLI::Option* repeat =
      sweep
          ->add_option("--repeat", o->repeat, "Seeds per grid point: seed, seed+1, ... (default 1)")
          ->check(CLI::PositiveNumber);
  sweep
      ->add_option("--max-runs", o->max_runs,
                   "The most runs (grid points x seeds) the sweep may have; more is refused before "
                   "anything runs (default 100000)")
      ->check(CLI::PositiveNumber);
  sweep
      ->add_option("--out", o->out,
                   "Sweep folder, required (shared by its shards and resumed runs); an existing "
                   "folder that this program did not write is refused unless empty (see --force)")
      ->type_name("DIR");
  sweep->add_flag("--force", o->force,
                  "Write into --out even if this program did not write it (never a device)");
  sweep->add_option("--jobs,-j", o->jobs, "Runs in parallel (default: all cores)")
      ->check(CLI::PositiveNumber);
  sweep
      ->add_option("--shard", o->shard,
                   "Run only the grid points whose index % n == k-1 (for job arrays); join the "
                   "shards' folders with `sweep merge`")
      ->type_name("k/n");
  sweep->add_flag("--no-plots", o->no_plots, "Write results.csv only");
  sweep->add_flag("--trace", o->trace,
                  "Also write each run's trace.json (cars with a board; some 10 MB a run): "
                  "without it a sweep's runs write none");
  sweep->add_flag("--quiet,-q", o->quiet, "No progress output");

  CLI::App* merge = sweep->add_subcommand(
      "merge",
      "Join sweep folders (the shards of one sweep) into one results.csv and plots; on one "
      "folder, rebuild its table");
  merge->add_option("DIR", o->merge_dirs, "Sweep folders")->required();
  merge->add_option("--out", o->merge_out, "Where to write (default: the first DIR)")
      ->type_name("DIR");
  merge->add_flag("--force", o->force,
                  "Write into --out even if this program did not write it (never a device)");
  merge->add_flag("--no-plots", o->no_plots, "Write results.csv only");
  merge->add_flag("--quiet,-q", o->quiet, "No progress output");

  return {sweep, [o, merge, repeat] {
            if (*merge) return MergeCommand(*o);
            return SweepCommand(*o, repeat->count() > 0);
          }};
}

}  // namespace autonomsim::cli
