// Shared by the `autonomsim` subcommands: exit codes, progress, running and judging one scenario.
// The CLI is the only place that reads the wall clock (for progress and the real-time factor),
// besides the pacing of a real-time run (sim/v2i/realtime_pacing.h).
#pragma once

#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "sim/results/expectations.h"
#include "sim/results/mcap_recording.h"
#include "sim/scenario/scenario.h"

namespace autonomsim::cli {

inline constexpr int kExitOk = 0;
inline constexpr int kExitExpectationFailed = 1;
inline constexpr int kExitUnusableInput = 2;

// `--profile`'s help, for the commands that take a platform profile (sim::ResolveShippedFile).
inline constexpr const char* kProfileHelp =
    "Platform profile (YAML); from any folder a shipped one is found by its path in the checkout "
    "or under scenarios/ (platforms/x86_loopback.yaml)";

// A subcommand: its CLI11 app, and what to do when it was the one given.
struct Command {
  CLI::App* app{nullptr};
  std::function<int()> run;
};

Command AddRunCommand(CLI::App& parent);
Command AddCheckCommand(CLI::App& parent);
Command AddTable1Command(CLI::App& parent);
Command AddTransportCommand(CLI::App& parent);
Command AddRenderCommand(CLI::App& parent);
Command AddSweepCommand(CLI::App& parent);
Command AddReportCommand(CLI::App& parent);
Command AddReferenceCommand(CLI::App& parent);
Command AddValidateCommand(CLI::App& parent);
Command AddExportCommand(CLI::App& parent);
// The video command lives in the `autonomsim-video` helper (tools/autonomsim_video.cc);
// `autonomsim video ...` runs it with the same arguments (AddVideoForwarder).
Command AddVideoCommand(CLI::App& parent);
Command AddVideoForwarder(CLI::App& parent);
inline constexpr const char* kVideoDescription =
    "Write the top-down replay of a finished run as an MPEG-4 video: the track to scale, the "
    "cars with their trails, intersections tinted by their holder, collisions and the clock; "
    "with --cameras ID also that car's colour camera (the detected lane drawn in) and depth "
    "camera; with --chase ID and --overview the run in 3D, from behind that car and from above "
    "the track (OpenGL ES in an offscreen EGL context). Frames at FROM + k * SPEED / FPS seconds "
    "of the run";

// Parses the command line and runs the subcommand given: a parse error (or --help) exits as CLI11
// says (2 for an error), an exception from the command is an error message and exit 2.
int ParseAndRun(CLI::App& app, int argc, char** argv, const std::vector<Command>& commands);

// Adds the repeatable --set KEY=VALUE option.
void AddSetOption(CLI::App* command, std::vector<std::string>* overrides);
void AddSeedOption(CLI::App* command, std::optional<std::uint64_t>* seed);

double WallSecondsSince(std::chrono::steady_clock::time_point start);

// --jobs' default for the commands that run scenarios in parallel: every core (at least one).
int DefaultJobs();

// Progress on stderr: a line rewritten in place on a terminal, a line per 10% otherwise. A
// labelled one (runs in parallel, as check's) always writes lines, each naming its run, and
// learns the run's length when it starts (SetTotal).
class Progress {
 public:
  Progress(double total_s, bool quiet);
  Progress(std::string label, bool quiet);
  void SetTotal(double total_s) { total_s_ = total_s; }
  void Update(double sim_s);
  void Done();

 private:
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
  std::string label_;
  double total_s_;
  bool quiet_;
  bool tty_;
  int last_decile_{0};
};

// A recording of the run as MCAP (`run --mcap`, `export --mcap`): where, and what.
struct McapRequest {
  std::filesystem::path file;  // checked (CheckMcapFile) before the run
  sim::McapRecordingOptions options;
};
// What a recording wrote.
struct McapWritten {
  std::filesystem::path file;
  std::vector<sim::McapRecording::ChannelCount> channels;
  std::uint64_t messages{0};
  std::uint64_t bytes{0};              // the file's size
  std::vector<std::string> unmatched;  // --mcap-topics patterns no topic matched
};

// --mcap FILE, --mcap-topics and --mcap-images as given (run and export).
struct McapArgs {
  std::optional<std::string> file;
  std::vector<std::string> topics;
  std::string images{"raw"};
  // The recording they ask for, none without a file; ConfigError for --mcap-topics or
  // --mcap-images without --mcap.
  std::optional<McapRequest> Request() const;
};
// Adds --mcap (with `file_help`; required for export), --mcap-topics and --mcap-images.
void AddMcapOptions(CLI::App* command, McapArgs* args, const std::string& file_help,
                    bool file_required);
// The file `given` checked as an MCAP output: absent, or one this program wrote (else refused
// unless `force`; sim/core/files.h CheckOutputFile). ConfigError.
std::filesystem::path CheckMcapFile(const std::string& given, bool force);
// "mcap: FILE (N channels, M messages, X MB)" and a warning per pattern that matched nothing.
void PrintMcapWritten(const McapWritten& written);

struct Outcome {
  std::string scenario_name;
  std::string file;
  std::optional<std::string> input_error;  // unusable input: nothing ran
  std::uint64_t seed{0};
  std::string scenario_sha256;                      // of the resolved scenario and track
  std::optional<std::filesystem::path> result_dir;  // where its folder was written, if anywhere
  std::vector<sim::ExpectationResult> expectations;
  std::optional<std::filesystem::path> report;  // its replay report, when one was written
  double wall_seconds{0.0};
  double sim_seconds{0.0};
  std::vector<std::string> warnings;  // settings that do not go together (LoadedScenario)
  // A board's trace.json that stops before the run's end (trace_max_events), one line each.
  std::vector<std::string> trace_cuts;
  std::optional<McapWritten> mcap;  // the run's recording, when it made one
  std::string result_sha256;        // of the run's record, when it was recorded as MCAP
  bool passed() const;
};

// Runs and judges one loaded scenario; writes its folder when out_dir is given.
// `force`: replace out_dir even if this program did not write it (--force; see
// sim/core/files.h CheckOutputFolder).
// With `mcap`, records the run into its file (written under a temporary name and renamed when
// complete; removed if the run fails).
Outcome RunLoaded(const sim::LoadedScenario& loaded,
                  const std::optional<std::filesystem::path>& out_dir, Progress* progress,
                  bool force = false, const McapRequest* mcap = nullptr);
// Loads, runs and judges one scenario file; unusable input becomes the outcome's input_error.
Outcome RunFile(const std::filesystem::path& file, const std::vector<std::string>& overrides,
                const std::optional<std::filesystem::path>& out_dir, bool force = false,
                Progress* progress = nullptr);
void PrintVerdicts(const Outcome& outcome);

// Writes the replay report of the run folder of `outcome` (RUN_DIR/report.html) and records it
// in the outcome; a report that cannot be written is a warning on stderr, not a failed run.
void WriteOutcomeReport(Outcome* outcome);
// The address that opens the outcome's replay report at a failure: at its time rounded up to the
// millisecond (the report shows what happened at or before the instant it opens at); none without
// a report or a time.
std::optional<std::string> ReportLink(const Outcome& outcome, const sim::ExpectationResult& e);
// "report: PATH", and for a failed run the address that opens it at the first failure.
void PrintReportPath(const Outcome& outcome);

}  // namespace autonomsim::cli
