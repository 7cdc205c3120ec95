// `autonomsim run SCENARIO`: one scenario, one result folder.
#include <fmt/format.h>

#include <algorithm>

#include "sim/core/config.h"
#include "sim/core/files.h"
#include "sim/mqtt/mqtt_client.h"
#include "tools/cli_common.h"
#include "tools/interrupt.h"

namespace autonomsim::cli {
namespace {

namespace fs = std::filesystem;

int RunCommand(const std::string& scenario_file, const std::optional<std::string>& out,
               std::optional<std::uint64_t> seed, const std::vector<std::string>& overrides,
               bool quiet, bool force, bool report, std::optional<McapRequest> mcap) {
  InstallInterruptHandlers();  // Ctrl-C: stop at the next simulated second
  std::optional<sim::LoadedScenario> loaded;
  try {
    loaded.emplace(sim::LoadScenario(scenario_file, overrides, seed));
  } catch (const sim::ConfigError& e) {
    fmt::print(stderr, "error: {}\n", e.what());
    return kExitUnusableInput;
  }
  fs::path out_dir;
  try {  // refused before anything runs
    out_dir = sim::CheckOutputFolder(
        out ? *out : (fs::path("runs") / loaded->scenario.name).string(), force);
    if (mcap) {  // before CheckMcapFile, which makes the file's folder
      const fs::path dir = fs::weakly_canonical(out_dir);
      const fs::path file = fs::weakly_canonical(mcap->file);
      if (std::mismatch(dir.begin(), dir.end(), file.begin(), file.end()).first == dir.end()) {
        throw sim::ConfigError("--mcap " + mcap->file.string() + " lies inside the result folder " +
                               out_dir.string() +
                               ", which the run replaces when it completes: put it elsewhere");
      }
      mcap->file = CheckMcapFile(mcap->file.string(), force);
    }
  } catch (const sim::ConfigError& e) {
    fmt::print(stderr, "error: {}\n", e.what());
    return kExitUnusableInput;
  }
  const double duration_s = ToSeconds(loaded->scenario.duration);
  for (const std::string& w : loaded->warnings) fmt::print(stderr, "warning: {}\n", w);
  if (!quiet && !loaded->preset_overrides.empty()) {
    fmt::print(stderr, "autonomsim: {}\n", sim::DescribePresetOverrides(loaded->preset_overrides));
  }
  if (!quiet) {
    const sim::V2IConfig& v2i = loaded->scenario.v2i;
    fmt::print(stderr, "autonomsim: running {} ({} cars, {:.0f} s simulated{}, seed {})\n",
               scenario_file, loaded->scenario.cars.size(), duration_s,
               v2i.link == sim::V2ILinkKind::kRealtime
                   ? " in real time against broker " + v2i.mqtt.broker
                   : "",
               loaded->scenario.seed);
  }
  Progress progress(duration_s, quiet);
  Outcome outcome;
  try {
    outcome = RunLoaded(*loaded, out_dir, &progress, force, mcap ? &*mcap : nullptr);
  } catch (const sim::MqttError& e) {  // the broker or server of v2i.link: mqtt or realtime
    fmt::print(stderr, "error: {}\n", e.what());
    return kExitUnusableInput;
  }
  PrintVerdicts(outcome);
  for (const std::string& cut : outcome.trace_cuts) fmt::print(stderr, "warning: {}\n", cut);
  if (report) WriteOutcomeReport(&outcome);
  fmt::print("{:.1f} s simulated in {:.2f} s wall ({:.1f}x real time)\n", outcome.sim_seconds,
             outcome.wall_seconds,
             outcome.wall_seconds > 0 ? outcome.sim_seconds / outcome.wall_seconds : 0.0);
  fmt::print("results: {}\n", out_dir.string());
  if (outcome.mcap) PrintMcapWritten(*outcome.mcap);
  PrintReportPath(outcome);
  return outcome.passed() ? kExitOk : kExitExpectationFailed;
}

}  // namespace

Command AddRunCommand(CLI::App& parent) {
  struct Options {
    std::string scenario;
    std::optional<std::string> out;
    std::optional<std::uint64_t> seed;
    std::vector<std::string> overrides;
    std::optional<std::string> broker;
    bool realtime{false};
    bool quiet{false};
    bool force{false};
    bool report{false};
    McapArgs mcap;
  };
  auto o = std::make_shared<Options>();
  CLI::App* run = parent.add_subcommand(
      "run",
      "Run one scenario and write its result folder (summary.json, trajectory.csv, "
      "events.jsonl, track.png, scenario.resolved.json)");
  run->add_option("SCENARIO", o->scenario, "Scenario file (YAML), e.g. scenarios/lab_two_cars.yaml")
      ->required();
  run->add_option("--out", o->out,
                  "Result folder (default: runs/<scenario name>); replaced when the run completes "
                  "if an earlier run, render, check or sweep wrote it (else refused: see --force)")
      ->type_name("DIR");
  run->add_flag("--force", o->force,
                "Replace --out (and --mcap's file) even if this program did not write it (a "
                "folder and all it holds, or a file; never a device)");
  AddSeedOption(run, &o->seed);
  AddSetOption(run, &o->overrides);
  run->add_option("--broker", o->broker,
                  "Send the cars' V2I traffic through this MQTT broker to the `tlserver "
                  "--sim-clock` serving it (same as --set v2i.link=mqtt --set "
                  "v2i.mqtt.broker=HOST:PORT); with --realtime, to the traffic-light server "
                  "outside the run instead; credentials and TLS via --set v2i.mqtt.*")
      ->type_name("HOST:PORT");
  run->add_flag("--realtime", o->realtime,
                "Run in real time against the traffic-light server on --broker (the lab's "
                "vtl.py, or tlserver without --sim-clock), possibly beside real cars: the run is "
                "paced to the wall clock and the cars send the lab's plain /vtl/request and "
                "/vtl/free and hear /vtl/response. Reports how far it fell behind real time "
                "(summary.json's `realtime`); results are not reproducible bit for bit (same as "
                "--set v2i.link=realtime --set v2i.mqtt.broker=HOST:PORT)");
  run->add_flag("--quiet,-q", o->quiet, "No progress output");
  run->add_flag("--report", o->report,
                "Also write the replay report, RESULTS/report.html (see `autonomsim report`)");
  AddMcapOptions(run, &o->mcap,
                 "Also record the run as MCAP into FILE while it goes (ROS 2 messages, /carN/... "
                 "topics: open it in Foxglove or Lichtblick, or `ros2 bag play` it; docs/mcap.md)",
                 false);
  return {run, [o] {
            std::vector<std::string> overrides = o->overrides;
            if (o->realtime && !o->broker) {
              fmt::print(stderr,
                         "error: --realtime needs --broker HOST:PORT, the MQTT broker of the "
                         "traffic-light server to run against (a real-time run starts no "
                         "broker or server of its own)\n");
              return kExitUnusableInput;
            }
            if (o->broker) {
              overrides.push_back(o->realtime ? "v2i.link=realtime" : "v2i.link=mqtt");
              overrides.push_back("v2i.mqtt.broker=" + *o->broker);
            }
            std::optional<McapRequest> mcap;
            try {
              mcap = o->mcap.Request();
            } catch (const sim::ConfigError& e) {
              fmt::print(stderr, "error: {}\n", e.what());
              return kExitUnusableInput;
            }
            return RunCommand(o->scenario, o->out, o->seed, overrides, o->quiet, o->force,
                              o->report, std::move(mcap));
          }};
}

}  // namespace autonomsim::cli
