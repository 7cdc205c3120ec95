// `autonomsim report RUN_DIR [--out FILE]`: the replay report of a finished run, one
// self-contained HTML file (sim/results/report.h).
#include <fmt/format.h>

#include "sim/core/config.h"
#include "sim/results/report.h"
#include "tools/cli_common.h"

namespace autonomsim::cli {
namespace {

namespace fs = std::filesystem;

int ReportCommand(const std::string& run_dir, const std::string& out, bool force) {
  const auto start = std::chrono::steady_clock::now();
  fs::path written;
  try {
    written = sim::WriteReport(run_dir, out, force);
  } catch (const sim::ConfigError& e) {
    fmt::print(stderr, "error: {}\n", e.what());
    return kExitUnusableInput;
  }
  fmt::print("report: {} ({:.1f} MB, made in {:.2f} s)\n", written.string(),
             static_cast<double>(fs::file_size(written)) / 1e6, WallSecondsSince(start));
  return kExitOk;
}

}  // namespace

Command AddReportCommand(CLI::App& parent) {
  struct Options {
    std::string run_dir;
    std::string out;
    bool force{false};
  };
  auto o = std::make_shared<Options>();
  CLI::App* report = parent.add_subcommand(
      "report",
      "Write the replay report of a finished run: one HTML file that opens from disk with no "
      "network. It replays the cars on the track to scale (time slider, play/pause, speed, "
      "trails), colours each intersection by who holds it and who is queued, puts the events on "
      "a timeline, plots speed, lateral error, commands, CPU load and end-to-end latency over "
      "time, lists the expectations (each failure links to its instant) and shows the cameras "
      "of a car with a board at each failing instant");
  report
      ->add_option("RUN_DIR", o->run_dir,
                   "A run's result folder (run --out, check --out, a sweep's runs/<id>)")
      ->required();
  report
      ->add_option("--out", o->out,
                   "The HTML file (default: RUN_DIR/report.html); replaced only if it is a "
                   "report this program wrote (else refused: see --force)")
      ->type_name("FILE");
  report->add_flag("--force", o->force, "Replace --out even if this program did not write it");
  return {report, [o] { return ReportCommand(o->run_dir, o->out, o->force); }};
}

}  // namespace autonomsim::cli
