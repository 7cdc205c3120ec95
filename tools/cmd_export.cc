// `autonomsim export RUN_DIR --mcap FILE`: a finished run recorded as MCAP after the fact, by
// running it again from its scenario.resolved.json; refused when the new run's result differs.
#include <fmt/format.h>
#include <unistd.h>

#include "sim/core/config.h"
#include "sim/core/files.h"
#include "sim/results/summary.h"
#include "tools/cli_common.h"
#include "tools/interrupt.h"

namespace autonomsim::cli {
namespace {

namespace fs = std::filesystem;

struct ExportArgs {
  std::string run_dir;
  McapArgs mcap;
  bool quiet{false};
  bool force{false};
};

// The run to export, checked before anything runs: its summary and its resolved scenario, which
// must reproduce it (not a real-time run; the same scenario hash).
struct RunToExport {
  sim::RunSummary summary;
  sim::LoadedScenario loaded;
};
RunToExport ReadRunToExport(const fs::path& dir) {
  if (!fs::is_directory(dir)) throw sim::ConfigError(dir.string() + ": not a folder");
  if (!fs::exists(dir / "summary.json")) {
    throw sim::ConfigError(dir.string() + ": no summary.json, so not a finished run's folder");
  }
  sim::RunSummary summary = sim::ReadSummaryFile(dir / "summary.json");
  if (summary.realtime) {
    throw sim::ConfigError(dir.string() +
                           ": a real-time run (v2i.link: realtime) cannot be run again bit for "
                           "bit; record it while it runs with `run --mcap`");
  }
  sim::LoadedScenario loaded = sim::LoadResolvedScenario(dir / "scenario.resolved.json");
  if (loaded.sha256 != summary.scenario_sha256) {
    throw sim::ConfigError(fmt::format(
        "{}: scenario.resolved.json reads back as a different scenario (sha256 {} where "
        "summary.json has {}): this build does not read that run's settings as the build that "
        "ran it did",
        dir.string(), loaded.sha256, summary.scenario_sha256));
  }
  return {std::move(summary), std::move(loaded)};
}

int ExportCommand(const ExportArgs& a) {
  InstallInterruptHandlers();
  std::optional<RunToExport> run;
  McapRequest request = *a.mcap.Request();
  try {
    run.emplace(ReadRunToExport(a.run_dir));
    request.file = CheckMcapFile(request.file.string(), a.force);
  } catch (const sim::ConfigError& e) {
    fmt::print(stderr, "error: {}\n", e.what());
    return kExitUnusableInput;
  }
  if (!a.quiet) {
    fmt::print(stderr, "autonomsim: running {} again ({:.0f} s simulated, seed {}) to record it\n",
               a.run_dir, run->summary.sim_seconds, run->loaded.scenario.seed);
  }
  Progress progress(run->summary.sim_seconds, a.quiet);
  // the recording goes to a temporary name; it becomes FILE only if the run is the same
  McapRequest scratch = request;
  scratch.file = request.file.string() + ".rerun-" + std::to_string(::getpid());
  const Outcome outcome = RunLoaded(run->loaded, std::nullopt, &progress, false, &scratch);
  if (outcome.result_sha256 != run->summary.result_sha256) {
    std::error_code ignored;
    fs::remove(scratch.file, ignored);
    fmt::print(stderr,
               "error: running {} again gives another result (result_sha256 {} where its "
               "summary.json has {}): this build drives differently from the one that made the "
               "run, so its recording would not be that run's. Nothing written; record a new "
               "run with `autonomsim run SCENARIO --mcap FILE`\n",
               a.run_dir, outcome.result_sha256, run->summary.result_sha256);
    return kExitUnusableInput;
  }
  std::error_code renamed;
  fs::rename(scratch.file, request.file, renamed);
  if (renamed) {
    std::error_code ignored;
    fs::remove(scratch.file, ignored);
    fmt::print(stderr, "error: --mcap {}: cannot write: {}\n", request.file.string(),
               renamed.message());
    return kExitUnusableInput;
  }
  McapWritten written = *outcome.mcap;
  written.file = request.file;
  PrintMcapWritten(written);
  return kExitOk;
}

}  // namespace

Command AddExportCommand(CLI::App& parent) {
  auto a = std::make_shared<ExportArgs>();
  CLI::App* cmd = parent.add_subcommand(
      "export",
      "Record a finished run as MCAP: runs it again from RUN_DIR/scenario.resolved.json (the "
      "same result, checked by its result_sha256; refused if it differs) and writes what `run "
      "--mcap` would have written, byte for byte");
  cmd->add_option("RUN_DIR", a->run_dir, "A finished run's folder (run, check --out or sweep)")
      ->required();
  AddMcapOptions(cmd, &a->mcap,
                 "The MCAP file to write (replaced if this program wrote it; else see --force)",
                 true);
  cmd->add_flag("--quiet,-q", a->quiet, "No progress output");
  cmd->add_flag("--force", a->force,
                "Replace FILE even if this program did not write it (never a folder or device)");
  return {cmd, [a] { return ExportCommand(*a); }};
}

}  // namespace autonomsim::cli
