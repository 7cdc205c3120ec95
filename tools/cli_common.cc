#include "tools/cli_common.h"

#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <thread>

#include "sim/core/config.h"
#include "sim/core/files.h"
#include "sim/loop/simulation.h"
#include "sim/mqtt/mqtt_client.h"
#include "sim/mqtt/mqtt_process.h"  // TempDir
#include "sim/results/outputs.h"
#include "sim/results/report.h"
#include "tools/interrupt.h"

namespace autonomsim::cli {

namespace fs = std::filesystem;

namespace {

// Assumed: behind real time by more than this, a simulated car's messages reach the server
// noticeably later than a real car's would (the car client polls every 0.1 s, reference §7).
constexpr double kPacingWarning_s = 0.1;

// One line on how far a real-time run fell behind the wall clock, and a warning when it is far.
void PrintPacing(const sim::RealTimeMetrics& m) {
  fmt::print(stderr,
             "real time: lag behind the wall clock max {:.3f} s, mean {:.4f} s; {} of {} slices "
             "({:.0f} ms) late; {} messages sent, {} responses received\n",
             m.pacing_max_lag_s, m.pacing_mean_lag_s, m.late_slices, m.slices, 1e3 * m.slice_s,
             m.messages_sent, m.messages_received);
  if (m.pacing_max_lag_s > kPacingWarning_s) {
    fmt::print(stderr,
               "warning: the simulation fell up to {:.2f} s behind real time (more than {} s): "
               "its cars' messages went out that much late, unlike a real car's\n",
               m.pacing_max_lag_s, kPacingWarning_s);
  }
}

// A file written under "<file>.partial-<pid>" and renamed to `file` by Commit; removed if
// destroyed uncommitted (a failed or interrupted run leaves nothing half-written).
class PartialFile {
 public:
  explicit PartialFile(fs::path file)
      : file_(std::move(file)),
        partial_(file_.string() + ".partial-" + std::to_string(::getpid())) {}
  ~PartialFile() {
    std::error_code ignored;
    if (!committed_) fs::remove(partial_, ignored);
  }
  PartialFile(const PartialFile&) = delete;
  PartialFile& operator=(const PartialFile&) = delete;
  const fs::path& path() const { return partial_; }
  void Commit() {
    fs::rename(partial_, file_);
    committed_ = true;
  }

 private:
  fs::path file_;
  fs::path partial_;
  bool committed_{false};
};

// A line per board whose part of trace.json stops before the run's end (trace_max_events).
std::vector<std::string> TraceCuts(const sim::RunRecord& record, double sim_seconds) {
  std::vector<std::string> cuts;
  for (const sim::BoardReport& board : record.boards) {
    const sim::TraceCoverage& t = board.report.trace;
    if (!t.recorded || !t.cut_at_s) continue;
    cuts.push_back(fmt::format(
        "{}'s part of trace.json stops at t = {:.1f} s of {:.0f} s: it holds its first {} events "
        "(platform.trace_max_events); nodes.csv and summary.json cover the whole run. Raise "
        "trace_max_events for more, or set platform.trace: false",
        board.board, *t.cut_at_s, sim_seconds, t.max_events));
  }
  return cuts;
}

}  // namespace

void AddMcapOptions(CLI::App* command, McapArgs* args, const std::string& file_help,
                    bool file_required) {
  command->add_option("--mcap", args->file, file_help)->type_name("FILE")->required(file_required);
  command
      ->add_option("--mcap-topics", args->topics,
                   "Record only the topics matching these globs (fnmatch on the full name, e.g. "
                   "'/car0/*,/vtl/*'; '*' takes everything, camera images included); default: "
                   "every topic but the camera images (docs/mcap.md lists them)")
      ->delimiter(',')
      ->type_name("PATTERN,...");
  command
      ->add_option("--mcap-images", args->images,
                   "The camera images as sensor_msgs/Image (raw, default) or "
                   "sensor_msgs/CompressedImage (png: lossless, smaller, slower to write)")
      ->check(CLI::IsMember({"raw", "png"}))
      ->default_str("raw");
}

std::optional<McapRequest> McapArgs::Request() const {
  if (!file) {
    if (!topics.empty() || images != "raw") {
      throw sim::ConfigError("--mcap-topics and --mcap-images go with --mcap FILE");
    }
    return std::nullopt;
  }
  return McapRequest{.file = *file, .options = {.topics = topics, .png_images = images == "png"}};
}

fs::path CheckMcapFile(const std::string& given, bool force) {
  return sim::CheckOutputFile(given, force, sim::McapFileSignature(), "--mcap");
}

void PrintMcapWritten(const McapWritten& written) {
  fmt::print("mcap: {} ({} channels, {} messages, {:.1f} MB)\n", written.file.string(),
             written.channels.size(), written.messages, static_cast<double>(written.bytes) / 1e6);
  for (const std::string& pattern : written.unmatched) {
    fmt::print(stderr, "warning: --mcap-topics '{}' matched no topic of the run\n", pattern);
  }
}

int ParseAndRun(CLI::App& app, int argc, char** argv, const std::vector<Command>& commands) {
  // a mistake on the command line opens with "error: " as every other error does
  app.failure_message([](const CLI::App* failed, const CLI::Error& e) {
    return "error: " + CLI::FailureMessage::simple(failed, e);
  });
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? kExitOk : kExitUnusableInput;
  }
  try {
    for (const Command& command : commands) {
      if (*command.app) return command.run();
    }
    return kExitUnusableInput;
  } catch (const Interrupted&) {
    fmt::print(stderr,
               "autonomsim: interrupted; what it was writing was removed, nothing complete was "
               "touched\n");
    return kExitInterrupted;
  } catch (const std::exception& e) {
    fmt::print(stderr, "error: {}\n", e.what());
    return kExitUnusableInput;
  }
}

void AddSetOption(CLI::App* command, std::vector<std::string>* overrides) {
  command
      ->add_option("--set", *overrides,
                   "Override a scenario field, e.g. --set cars[0].oracle.speed_mps=0.3 or "
                   "--set v2i.loss=0.1 (repeatable)")
      ->type_name("KEY=VALUE");
}

void AddSeedOption(CLI::App* command, std::optional<std::uint64_t>* seed) {
  // CLI11 would read "-1" as 2^64 - 1: only digits are a seed
  const CLI::Validator digits(
      [](std::string& text) -> std::string {
        if (text.empty() || text.find_first_not_of("0123456789") != std::string::npos) {
          return "a seed is a whole number >= 0, got '" + text + "'";
        }
        return "";
      },
      "N");
  command->add_option("--seed", *seed, "Override the scenario's seed (a whole number >= 0)")
      ->check(digits)
      ->type_name("N");
}

int DefaultJobs() { return static_cast<int>(std::max(1u, std::thread::hardware_concurrency())); }

double WallSecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

Progress::Progress(double total_s, bool quiet)
    : total_s_(total_s), quiet_(quiet), tty_(::isatty(STDERR_FILENO) == 1) {}

Progress::Progress(std::string label, bool quiet)
    : label_(std::move(label)), total_s_(0.0), quiet_(quiet), tty_(false) {}

void Progress::Update(double sim_s) {
  if (quiet_ || total_s_ <= 0.0) return;
  const int percent = static_cast<int>(100.0 * sim_s / total_s_);
  const double wall_s = WallSecondsSince(start_);
  const double rtf = wall_s > 0 ? sim_s / wall_s : 0.0;
  if (tty_) {
    fmt::print(stderr, "\r  {:6.1f} / {:.1f} s simulated ({:3d}%), {:.1f}x real time", sim_s,
               total_s_, percent, rtf);
    std::fflush(stderr);
  } else if (percent / 10 > last_decile_) {
    last_decile_ = percent / 10;
    fmt::print(stderr, "  {}{:.1f} / {:.1f} s simulated ({}%), {:.1f}x real time\n",
               label_.empty() ? "" : label_ + ": ", sim_s, total_s_, percent, rtf);
  }
}

void Progress::Done() {
  if (!quiet_ && tty_) fmt::print(stderr, "\n");
}

bool Outcome::passed() const {
  return !input_error && std::all_of(expectations.begin(), expectations.end(),
                                     [](const auto& e) { return e.passed; });
}

Outcome RunLoaded(const sim::LoadedScenario& loaded, const std::optional<fs::path>& out_dir,
                  Progress* progress, bool force, const McapRequest* mcap) {
  Outcome outcome;
  outcome.file = loaded.file.string();
  outcome.scenario_name = loaded.scenario.name;
  outcome.seed = loaded.scenario.seed;
  outcome.scenario_sha256 = loaded.sha256;
  outcome.warnings = loaded.warnings;
  outcome.result_dir = out_dir;
  // The run streams its trajectory and events into its folder, or without one into a scratch
  // folder that goes with the run: memory stays bounded however long it runs.
  std::optional<sim::RunFolder> folder;
  std::optional<sim::TempDir> scratch;
  std::shared_ptr<sim::RecordStore> store;
  if (out_dir) {
    folder.emplace(*out_dir, force);
    store = folder->store();
  } else {
    scratch.emplace("autonomsim_run_");
    store = std::make_shared<sim::RecordFiles>(scratch->path());
  }
  // the recording before the simulation, whose taps point into it: it outlives them
  std::optional<PartialFile> partial;
  std::optional<sim::McapRecording> recording;
  if (mcap) {
    partial.emplace(mcap->file);
    recording.emplace(loaded, partial->path(), mcap->options);
  }
  const auto start = std::chrono::steady_clock::now();
  sim::Simulation simulation(loaded, store);
  if (recording) simulation.AddObserver(&*recording);
  // every simulated second: Ctrl-C stops the run there, and its partial folder goes with it
  simulation.Run([progress](Time t) {
    ThrowIfInterrupted();
    if (progress) progress->Update(ToSeconds(t));
  });
  if (progress) progress->Done();
  outcome.wall_seconds = WallSecondsSince(start);
  if (simulation.record().realtime) PrintPacing(*simulation.record().realtime);
  outcome.sim_seconds = ToSeconds(loaded.scenario.duration);
  outcome.expectations = sim::EvaluateExpectations(loaded.scenario, simulation.record());
  if (recording) {  // the file's metadata names the result (summary.json hashes it again)
    outcome.result_sha256 = sim::ResultSha256(simulation.record());
    recording->Close(outcome.expectations, outcome.result_sha256);
  }
  if (folder) {
    folder->Complete(loaded, simulation.record(), outcome.expectations, outcome.wall_seconds);
    outcome.trace_cuts = TraceCuts(simulation.record(), outcome.sim_seconds);
  }
  if (recording) {  // the file last: a folder that could not be written takes the file with it
    partial->Commit();
    outcome.mcap = McapWritten{.file = mcap->file,
                               .channels = recording->channels(),
                               .messages = recording->counts().messages,
                               .bytes = static_cast<std::uint64_t>(fs::file_size(mcap->file)),
                               .unmatched = recording->unmatched_patterns()};
  }
  return outcome;
}

Outcome RunFile(const fs::path& file, const std::vector<std::string>& overrides,
                const std::optional<fs::path>& out_dir, bool force, Progress* progress) {
  // a scenario that could not run: its outcome carries the reason
  const auto cannot_run = [&](const std::exception& e) {
    Outcome outcome;
    outcome.file = file.string();
    outcome.scenario_name = file.stem().string();
    outcome.input_error = e.what();
    return outcome;
  };
  try {
    if (out_dir) sim::CheckOutputFolder(out_dir->string(), force);  // before the run
    const sim::LoadedScenario loaded = sim::LoadScenario(file, overrides);
    if (progress) progress->SetTotal(ToSeconds(loaded.scenario.duration));
    return RunLoaded(loaded, out_dir, progress, force);
  } catch (const sim::ConfigError& e) {
    return cannot_run(e);
  } catch (const sim::MqttError& e) {  // v2i.link: mqtt, and the broker or tlserver failed us
    return cannot_run(e);
  } catch (const sim::OutputError& e) {  // its results could not be written (disk full, ...)
    return cannot_run(e);
  }
}

void PrintVerdicts(const Outcome& outcome) {
  for (const sim::ExpectationResult& e : outcome.expectations) {
    fmt::print("  {} {}: {}\n", e.passed ? "pass" : "FAIL", e.name, e.detail);
  }
}

void WriteOutcomeReport(Outcome* outcome) {
  if (!outcome->result_dir || outcome->input_error) return;
  try {
    outcome->report = sim::WriteReport(*outcome->result_dir);
  } catch (const std::exception& e) {
    fmt::print(stderr, "warning: no report for {}: {}\n", outcome->file, e.what());
  }
}

std::optional<std::string> ReportLink(const Outcome& outcome, const sim::ExpectationResult& e) {
  if (!outcome.report || !e.at_s) return std::nullopt;
  return fmt::format("file://{}#t={:.3f}", fs::absolute(*outcome.report).string(),
                     std::ceil(*e.at_s * 1e3) / 1e3);
}

void PrintReportPath(const Outcome& outcome) {
  if (!outcome.report) return;
  const auto first_failure =
      std::find_if(outcome.expectations.begin(), outcome.expectations.end(),
                   [](const sim::ExpectationResult& e) { return !e.passed && e.at_s; });
  if (first_failure == outcome.expectations.end()) {
    fmt::print("  report: {}\n", outcome.report->string());
  } else {
    fmt::print("  report: {} (at the first failure: {})\n", outcome.report->string(),
               *ReportLink(outcome, *first_failure));
  }
}

Command AddVideoForwarder(CLI::App& parent) {
  CLI::App* video = parent.add_subcommand("video", kVideoDescription);
  // every argument, --help included, goes to the helper, which parses them
  video->prefix_command();
  video->set_help_flag();
  return {video, [video] {
            std::error_code error;
            const fs::path helper =
                fs::read_symlink("/proc/self/exe", error).parent_path() / "autonomsim-video";
            if (error || !fs::exists(helper)) {
              fmt::print(stderr,
                         "error: the video helper {} is not there (build it: it is built "
                         "with autonomsim)\n",
                         helper.string());
              return kExitUnusableInput;
            }
            std::vector<std::string> args{helper.string(), "video"};
            for (const std::string& a : video->remaining()) args.push_back(a);
            std::vector<char*> argv;
            for (std::string& a : args) argv.push_back(a.data());
            argv.push_back(nullptr);
            std::fflush(stdout);
            ::execv(helper.c_str(), argv.data());
            fmt::print(stderr, "error: cannot run {}\n", helper.string());
            return kExitUnusableInput;
          }};
}

}  // namespace autonomsim::cli
