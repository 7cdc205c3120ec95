// `autonomsim validate SCENARIO|STUDY...`: load, resolve and check without running: every error
// `run` or `sweep` would give before the first simulated instant, and the warnings they would
// print; --print writes the resolved scenario with every default.
#include <fmt/format.h>

#include <set>

#include "sim/core/config.h"
#include "sim/scenario/stack_presets.h"
#include "sim/study/sweep.h"
#include "sim/study/sweep_spec.h"
#include "tools/cli_common.h"

namespace autonomsim::cli {
namespace {

namespace fs = std::filesystem;

struct ValidateOptions {
  std::vector<std::string> files;
  std::vector<std::string> overrides;
  std::optional<std::uint64_t> seed;
  std::uint64_t max_runs{sim::kDefaultMaxRuns};
  int jobs = DefaultJobs();
  bool print{false};
};

// The warnings a run of `loaded` prints, and the keys it sets against its stack preset (run prints
// these as information; validate warns, since mixing a preset with explicit keys is easy to miss).
std::vector<std::string> WarningsOf(const sim::LoadedScenario& loaded) {
  std::vector<std::string> warnings = loaded.warnings;
  if (!loaded.preset_overrides.empty()) {
    warnings.push_back(sim::DescribePresetOverrides(loaded.preset_overrides));
  }
  return warnings;
}

void PrintWarnings(const std::vector<std::string>& warnings) {
  for (const std::string& w : warnings) fmt::print("  warning: {}\n", w);
}

// A scenario: one line on what it is, its warnings, and with --print its resolved form.
void ValidateScenario(const std::string& file, const ValidateOptions& o) {
  const sim::LoadedScenario loaded = sim::LoadScenario(file, o.overrides, o.seed);
  const sim::Scenario& s = loaded.scenario;
  fmt::print("OK    {}: scenario '{}', {} car(s), {:g} s, seed {}, scenario_sha256 {}\n", file,
             s.name, s.cars.size(), ToSeconds(s.duration), s.seed, loaded.sha256);
  PrintWarnings(WarningsOf(loaded));
  if (o.print) fmt::print("{}\n", loaded.resolved.dump(2));
}

// A study: every point of its grid resolved, as `sweep` does before its first run; each warning
// once, with the number of points that give it. With --print, the first point's resolved form (the
// others differ only in the varied keys and the seed).
void ValidateStudy(const std::string& file, const ValidateOptions& o) {
  sim::SweepSpec spec = sim::LoadStudy(file);
  spec.overrides.insert(spec.overrides.end(), o.overrides.begin(), o.overrides.end());
  if (o.seed) spec.overrides.push_back(fmt::format("seed={}", *o.seed));
  sim::CheckSweepSize(spec, o.max_runs);
  const std::vector<sim::LoadedScenario> points = sim::ResolveSweep(spec, o.jobs);
  std::map<std::string, std::size_t> warnings;  // sorted: the same order however many jobs
  for (const sim::LoadedScenario& p : points) {
    for (const std::string& w : WarningsOf(p)) ++warnings[w];
  }
  fmt::print("OK    {}: study of {}, {} run(s) ({} varied key(s), {} seed(s) each)\n", file,
             spec.scenario.string(), points.size(), spec.axes.size(), spec.repeat);
  for (const auto& [w, count] : warnings) {
    fmt::print("  warning ({} of {} runs): {}\n", count, points.size(), w);
  }
  if (o.print && !points.empty()) {
    fmt::print("the first run's resolved scenario:\n{}\n", points.front().resolved.dump(2));
  }
}

int ValidateCommand(const ValidateOptions& o) {
  int unusable = 0;
  for (const std::string& file : o.files) {
    try {
      if (sim::IsStudyFile(file)) {
        ValidateStudy(file, o);
      } else {
        ValidateScenario(file, o);
      }
    } catch (const sim::ConfigError& e) {
      ++unusable;
      fmt::print("ERROR {}\n  error: {}\n", file, e.what());
    }
  }
  if (o.files.size() > 1) {
    fmt::print("{} file(s): {} usable, {} unusable\n", o.files.size(), o.files.size() - unusable,
               unusable);
  }
  return unusable > 0 ? kExitUnusableInput : kExitOk;
}

}  // namespace

Command AddValidateCommand(CLI::App& parent) {
  auto o = std::make_shared<ValidateOptions>();
  CLI::App* validate = parent.add_subcommand(
      "validate",
      "Load, resolve and check scenarios and study files without running them: every error run or "
      "sweep would give before the first simulated instant (exit 2), and the warnings they would "
      "print (a stack preset mixed with explicit keys, a fault or deadline at or after the end); "
      "exit 0 when every file is usable");
  validate
      ->add_option("FILE", o->files,
                   "Scenario files, or study files (scenarios/studies/*.yaml: every run of the "
                   "grid is resolved)")
      ->required();
  validate->add_flag("--print", o->print,
                     "Also print the resolved scenario with every default, as JSON (the run's "
                     "scenario.resolved.json; a study: its first run's)");
  AddSeedOption(validate, &o->seed);
  AddSetOption(validate, &o->overrides);
  validate
      ->add_option("--max-runs", o->max_runs,
                   "A study of more runs is refused, as sweep refuses it (default 100000)")
      ->check(CLI::PositiveNumber);
  validate
      ->add_option("--jobs,-j", o->jobs, "Study points resolved in parallel (default: all cores)")
      ->check(CLI::PositiveNumber);
  return {validate, [o] { return ValidateCommand(*o); }};
}

}  // namespace autonomsim::cli
