// autonomsim: the command-line front end. The only place that reads the wall clock (for progress
// and the real-time factor); everything it prints about a run comes from the run's record.
#include <fmt/format.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <optional>
#include <thread>

#include "sim/config.h"
#include "sim/expectations.h"
#include "sim/outputs.h"
#include "sim/scenario.h"
#include "sim/simulation.h"

namespace fs = std::filesystem;
using namespace autonomsim;

namespace {

constexpr int kExitOk = 0;
constexpr int kExitExpectationFailed = 1;
constexpr int kExitUnusableInput = 2;

double WallSecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// Progress on stderr: a line rewritten in place on a terminal, a line per 10% otherwise.
class Progress {
 public:
  Progress(double total_s, bool quiet)
      : total_s_(total_s), quiet_(quiet), tty_(::isatty(STDERR_FILENO) == 1) {}

  void Update(double sim_s) {
    if (quiet_) return;
    const int percent = static_cast<int>(100.0 * sim_s / total_s_);
    const double wall_s = WallSecondsSince(start_);
    const double rtf = wall_s > 0 ? sim_s / wall_s : 0.0;
    if (tty_) {
      fmt::print(stderr, "\r  {:6.1f} / {:.1f} s simulated ({:3d}%), {:.1f}x real time", sim_s,
                 total_s_, percent, rtf);
      std::fflush(stderr);
    } else if (percent / 10 > last_decile_) {
      last_decile_ = percent / 10;
      fmt::print(stderr, "  {:.1f} / {:.1f} s simulated ({}%), {:.1f}x real time\n", sim_s,
                 total_s_, percent, rtf);
    }
  }
  void Done() {
    if (!quiet_ && tty_) fmt::print(stderr, "\n");
  }

 private:
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
  double total_s_;
  bool quiet_;
  bool tty_;
  int last_decile_{0};
};

struct Outcome {
  std::string scenario_name;
  std::string file;
  std::optional<std::string> input_error;  // unusable input: nothing ran
  std::vector<sim::ExpectationResult> expectations;
  double wall_seconds{0.0};
  double sim_seconds{0.0};
  bool passed() const {
    return !input_error && std::all_of(expectations.begin(), expectations.end(),
                                       [](const auto& e) { return e.passed; });
  }
};

// Runs and judges one loaded scenario; writes its folder when out_dir is given.
Outcome RunLoaded(const sim::LoadedScenario& loaded, const std::optional<fs::path>& out_dir,
                  Progress* progress) {
  Outcome outcome;
  outcome.file = loaded.file.string();
  outcome.scenario_name = loaded.scenario.name;
  const auto start = std::chrono::steady_clock::now();
  sim::Simulation simulation(loaded);
  if (progress) {
    simulation.Run([progress](Time t) { progress->Update(ToSeconds(t)); });
    progress->Done();
  } else {
    simulation.Run();
  }
  outcome.wall_seconds = WallSecondsSince(start);
  outcome.sim_seconds = ToSeconds(loaded.scenario.duration);
  outcome.expectations = sim::EvaluateExpectations(loaded.scenario, simulation.record());
  if (out_dir) {
    sim::WriteRunFolder(loaded, simulation.record(), outcome.expectations, outcome.wall_seconds,
                        *out_dir);
  }
  return outcome;
}

// Loads, runs and judges one scenario file; unusable input becomes the outcome's input_error.
Outcome RunFile(const fs::path& file, const std::vector<std::string>& overrides,
                const std::optional<fs::path>& out_dir) {
  try {
    return RunLoaded(sim::LoadScenario(file, overrides), out_dir, nullptr);
  } catch (const sim::ConfigError& e) {
    Outcome outcome;
    outcome.file = file.string();
    outcome.scenario_name = file.stem().string();
    outcome.input_error = e.what();
    return outcome;
  }
}

void PrintVerdicts(const Outcome& outcome) {
  for (const sim::ExpectationResult& e : outcome.expectations) {
    fmt::print("  {} {}: {}\n", e.passed ? "pass" : "FAIL", e.name, e.detail);
  }
}

std::string XmlEscape(const std::string& text) {
  std::string out;
  for (char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&apos;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

void WriteJunit(const fs::path& file, const std::vector<Outcome>& outcomes) {
  int tests = 0, failures = 0, errors = 0;
  std::string cases;
  for (const Outcome& o : outcomes) {
    const std::string suite = XmlEscape(o.scenario_name);
    if (o.input_error) {
      ++tests;
      ++errors;
      cases += fmt::format(
          "    <testcase classname=\"{}\" name=\"load\" time=\"0\">\n"
          "      <error message=\"unusable input\">{}</error>\n    </testcase>\n",
          suite, XmlEscape(*o.input_error));
      continue;
    }
    const double per_case =
        o.expectations.empty() ? 0.0 : o.wall_seconds / static_cast<double>(o.expectations.size());
    for (const sim::ExpectationResult& e : o.expectations) {
      ++tests;
      cases += fmt::format("    <testcase classname=\"{}\" name=\"{}\" time=\"{:.3f}\">\n", suite,
                           XmlEscape(e.name), per_case);
      if (!e.passed) {
        ++failures;
        cases += fmt::format("      <failure message=\"{}\">{}</failure>\n", XmlEscape(e.detail),
                             XmlEscape(e.detail));
      } else {
        cases += fmt::format("      <system-out>{}</system-out>\n", XmlEscape(e.detail));
      }
      cases += "    </testcase>\n";
    }
  }
  std::ofstream out(file);
  out << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
      << fmt::format("<testsuites tests=\"{}\" failures=\"{}\" errors=\"{}\">\n", tests, failures,
                     errors)
      << fmt::format(
             "  <testsuite name=\"autonomsim check\" tests=\"{}\" failures=\"{}\" "
             "errors=\"{}\">\n",
             tests, failures, errors)
      << cases << "  </testsuite>\n</testsuites>\n";
  if (!out) throw std::runtime_error("cannot write " + file.string());
}

// SCENARIO|DIR... -> scenario files; a folder contributes the *.yaml files directly inside it,
// except hidden ones (editor and tool droppings).
std::vector<fs::path> ExpandScenarioArgs(const std::vector<std::string>& args) {
  std::vector<fs::path> files;
  for (const std::string& arg : args) {
    const fs::path path(arg);
    if (fs::is_directory(path)) {
      std::vector<fs::path> found;
      for (const auto& entry : fs::directory_iterator(path)) {
        const std::string name = entry.path().filename().string();
        if (entry.is_regular_file() && entry.path().extension() == ".yaml" && name[0] != '.') {
          found.push_back(entry.path());
        }
      }
      std::sort(found.begin(), found.end());
      if (found.empty()) throw sim::ConfigError(arg + ": no *.yaml scenario files in this folder");
      files.insert(files.end(), found.begin(), found.end());
    } else {
      files.push_back(path);
    }
  }
  return files;
}

int RunCommand(const std::string& scenario_file, const std::optional<std::string>& out,
               std::optional<std::uint64_t> seed, const std::vector<std::string>& overrides,
               bool quiet) {
  std::optional<sim::LoadedScenario> loaded;
  try {
    loaded.emplace(sim::LoadScenario(scenario_file, overrides, seed));
  } catch (const sim::ConfigError& e) {
    fmt::print(stderr, "error: {}\n", e.what());
    return kExitUnusableInput;
  }
  const fs::path out_dir = out ? fs::path(*out) : fs::path("runs") / loaded->scenario.name;
  const double duration_s = ToSeconds(loaded->scenario.duration);
  if (!quiet) {
    fmt::print(stderr, "autonomsim: running {} ({} cars, {:.0f} s simulated, seed {})\n",
               scenario_file, loaded->scenario.cars.size(), duration_s, loaded->scenario.seed);
  }
  Progress progress(duration_s, quiet);
  const Outcome outcome = RunLoaded(*loaded, out_dir, &progress);
  PrintVerdicts(outcome);
  fmt::print("{:.1f} s simulated in {:.2f} s wall ({:.1f}x real time)\n", outcome.sim_seconds,
             outcome.wall_seconds,
             outcome.wall_seconds > 0 ? outcome.sim_seconds / outcome.wall_seconds : 0.0);
  fmt::print("results: {}\n", out_dir.string());
  return outcome.passed() ? kExitOk : kExitExpectationFailed;
}

int CheckCommand(const std::vector<std::string>& args, const std::optional<std::string>& junit,
                 const std::optional<std::string>& out, const std::vector<std::string>& overrides,
                 int jobs) {
  std::vector<fs::path> files;
  try {
    files = ExpandScenarioArgs(args);
  } catch (const sim::ConfigError& e) {
    fmt::print(stderr, "error: {}\n", e.what());
    return kExitUnusableInput;
  }
  // Each scenario is an independent run: spread them over `jobs` threads; the verdicts do not
  // depend on the order or the thread a run lands on.
  std::vector<Outcome> outcomes(files.size());
  std::atomic<std::size_t> next{0};
  auto worker = [&] {
    for (std::size_t i = next++; i < files.size(); i = next++) {
      std::optional<fs::path> dir;
      if (out) dir = fs::path(*out) / files[i].stem();
      try {
        outcomes[i] = RunFile(files[i], overrides, dir);
      } catch (const std::exception& e) {
        outcomes[i].file = files[i].string();
        outcomes[i].scenario_name = files[i].stem().string();
        outcomes[i].input_error = std::string("run failed: ") + e.what();
      }
    }
  };
  std::vector<std::thread> threads;
  for (int t = 1; t < std::min<int>(jobs, static_cast<int>(files.size())); ++t) {
    threads.emplace_back(worker);
  }
  worker();
  for (std::thread& t : threads) t.join();

  int failed = 0, unusable = 0;
  for (const Outcome& o : outcomes) {
    if (o.input_error) {
      ++unusable;
      fmt::print("ERROR {}\n  {}\n", o.file, *o.input_error);
      continue;
    }
    if (!o.passed()) ++failed;
    fmt::print("{} {} ({} expectation(s), {:.0f} s simulated in {:.2f} s)\n",
               o.passed() ? "PASS " : "FAIL ", o.file, o.expectations.size(), o.sim_seconds,
               o.wall_seconds);
    if (o.expectations.empty()) fmt::print("  warning: this scenario has no expectations\n");
    if (!o.passed()) PrintVerdicts(o);
  }
  fmt::print("{} scenario(s): {} passed, {} failed, {} unusable\n", outcomes.size(),
             outcomes.size() - static_cast<std::size_t>(failed + unusable), failed, unusable);
  if (junit) {
    WriteJunit(*junit, outcomes);
    fmt::print("JUnit XML: {}\n", *junit);
  }
  if (unusable > 0) return kExitUnusableInput;
  return failed > 0 ? kExitExpectationFailed : kExitOk;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "autonomsim: closed-loop simulator of the AutonomROS model-car fleet.\n"
      "Exit codes: 0 all expectations held, 1 an expectation failed, 2 unusable input."};
  app.set_version_flag("--version", std::string("autonomsim ") + AUTONOMSIM_VERSION);
  app.require_subcommand(1);

  std::vector<std::string> overrides;
  auto add_set = [&](CLI::App* cmd) {
    cmd->add_option("--set", overrides,
                    "Override a scenario field, e.g. --set cars[0].oracle.speed_mps=0.3 or "
                    "--set v2i.loss=0.1 (repeatable)")
        ->type_name("KEY=VALUE");
  };

  CLI::App* run = app.add_subcommand(
      "run",
      "Run one scenario and write its result folder (summary.json, trajectory.csv, "
      "events.jsonl, track.png, scenario.resolved.json)");
  std::string run_scenario;
  std::optional<std::string> run_out;
  std::optional<std::uint64_t> run_seed;
  bool quiet = false;
  run->add_option("SCENARIO", run_scenario,
                  "Scenario file (YAML), e.g. scenarios/lab_two_cars.yaml")
      ->required();
  run->add_option("--out", run_out,
                  "Result folder (default: runs/<scenario name>); replaced "
                  "when the run completes")
      ->type_name("DIR");
  run->add_option("--seed", run_seed, "Override the scenario's seed")->type_name("N");
  add_set(run);
  run->add_flag("--quiet,-q", quiet, "No progress output");

  CLI::App* check = app.add_subcommand(
      "check", "Run scenarios and judge their expect: clauses (for CI): exit 0 when all hold");
  std::vector<std::string> check_args;
  std::optional<std::string> junit;
  std::optional<std::string> check_out;
  int jobs = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  check
      ->add_option("SCENARIO_OR_DIR", check_args,
                   "Scenario files, or folders whose *.yaml files are scenarios")
      ->required();
  check->add_option("--junit", junit, "Also write the verdicts as JUnit XML")->type_name("FILE");
  check->add_option("--out", check_out, "Keep each run's result folder under DIR/<scenario>")
      ->type_name("DIR");
  check->add_option("--jobs,-j", jobs, "Scenarios run in parallel (default: all cores)")
      ->check(CLI::PositiveNumber);
  add_set(check);

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? kExitOk : kExitUnusableInput;
  }
  try {
    if (*run) return RunCommand(run_scenario, run_out, run_seed, overrides, quiet);
    return CheckCommand(check_args, junit, check_out, overrides, jobs);
  } catch (const std::exception& e) {
    fmt::print(stderr, "error: {}\n", e.what());
    return kExitUnusableInput;
  }
}
