// `autonomsim run SCENARIO`: one scenario, one result folder.
#include <fmt/format.h>

#include "sim/core/config.h"
#include "sim/core/files.h"
#include "sim/mqtt/mqtt_client.h"
#include "tools/cli_common.h"

namespace autonomsim::cli {
namespace {

namespace fs = std::filesystem;

int RunCommand(const std::string& scenario_file, const std::optional<std::string>& out,
               std::optional<std::uint64_t> seed, const std::vector<std::string>& overrides,
               bool quiet, bool force, bool report) {
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
  } catch (const sim::ConfigError& e) {
    fmt::print(stderr, "error: {}\n", e.what());
    return kExitUnusableInput;
  }
  const double duration_s = ToSeconds(loaded->scenario.duration);
  if (!quiet) {
    fmt::print(stderr, "autonomsim: running {} ({} cars, {:.0f} s simulated, seed {})\n",
               scenario_file, loaded->scenario.cars.size(), duration_s, loaded->scenario.seed);
  }
  Progress progress(duration_s, quiet);
  Outcome outcome;
  try {
    outcome = RunLoaded(*loaded, out_dir, &progress, force);
  } catch (const sim::MqttError& e) {  // the broker or tlserver of v2i.link: mqtt failed us
    fmt::print(stderr, "error: {}\n", e.what());
    return kExitUnusableInput;
  }
  PrintVerdicts(outcome);
  if (report) WriteOutcomeReport(&outcome);
  fmt::print("{:.1f} s simulated in {:.2f} s wall ({:.1f}x real time)\n", outcome.sim_seconds,
             outcome.wall_seconds,
             outcome.wall_seconds > 0 ? outcome.sim_seconds / outcome.wall_seconds : 0.0);
  fmt::print("results: {}\n", out_dir.string());
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
    bool quiet{false};
    bool force{false};
    bool report{false};
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
                "Replace --out even if this program did not write it (a folder and all it holds, "
                "or a file; never a device)");
  AddSeedOption(run, &o->seed);
  AddSetOption(run, &o->overrides);
  run->add_option("--broker", o->broker,
                  "Send the cars' V2I traffic through this MQTT broker to the `tlserver "
                  "--sim-clock` serving it (same as --set v2i.link=mqtt --set "
                  "v2i.mqtt.broker=HOST:PORT); credentials and TLS via --set v2i.mqtt.*")
      ->type_name("HOST:PORT");
  run->add_flag("--quiet,-q", o->quiet, "No progress output");
  run->add_flag("--report", o->report,
                "Also write the replay report, RESULTS/report.html (see `autonomsim report`)");
  return {run, [o] {
            std::vector<std::string> overrides = o->overrides;
            if (o->broker) {
              overrides.push_back("v2i.link=mqtt");
              overrides.push_back("v2i.mqtt.broker=" + *o->broker);
            }
            return RunCommand(o->scenario, o->out, o->seed, overrides, o->quiet, o->force,
                              o->report);
          }};
}

}  // namespace autonomsim::cli
