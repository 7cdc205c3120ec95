// `autonomsim check SCENARIO|DIR...`: judge scenarios' expectations, for CI.
#include <fmt/format.h>

#include <algorithm>
#include <map>

#include "sim/core/config.h"
#include "sim/core/files.h"
#include "sim/core/parallel.h"
#include "sim/results/report.h"
#include "tools/cli_common.h"
#include "tools/interrupt.h"

namespace autonomsim::cli {
namespace {

namespace fs = std::filesystem;

// JUnit XML as CI servers read it (Jenkins, GitLab): one testsuite per scenario, carrying the
// scenario's wall time and its identity as properties (with its result folder and replay report
// when written); one testcase per expectation. A testcase
// has no time of its own: the expectations are judged together after one run.
std::string JunitXml(const std::vector<Outcome>& outcomes) {
  int tests = 0, failures = 0, errors = 0;
  double seconds = 0.0;
  std::string suites;
  for (const Outcome& o : outcomes) {
    const std::string name = sim::XmlEscape(o.scenario_name);
    std::string properties = fmt::format("      <property name=\"scenario_file\" value=\"{}\"/>\n",
                                         sim::XmlEscape(o.file));
    std::string cases;
    int suite_failures = 0;
    if (o.input_error) {
      cases = fmt::format(
          "    <testcase classname=\"{}\" name=\"load\">\n"
          "      <error message=\"unusable input\">{}</error>\n    </testcase>\n",
          name, sim::XmlEscape(*o.input_error));
    } else {
      properties += fmt::format(
          "      <property name=\"seed\" value=\"{}\"/>\n"
          "      <property name=\"scenario_sha256\" value=\"{}\"/>\n",
          o.seed, o.scenario_sha256);
      if (o.result_dir) {
        properties += fmt::format("      <property name=\"result_folder\" value=\"{}\"/>\n",
                                  sim::XmlEscape(o.result_dir->string()));
      }
      if (o.report) {
        properties += fmt::format("      <property name=\"report\" value=\"{}\"/>\n",
                                  sim::XmlEscape(o.report->string()));
      }
      for (const sim::ExpectationResult& e : o.expectations) {
        cases += fmt::format("    <testcase classname=\"{}\" name=\"{}\">\n", name,
                             sim::XmlEscape(e.name));
        if (!e.passed) {
          ++suite_failures;
          cases += fmt::format("      <failure message=\"{}\">{}</failure>\n",
                               sim::XmlEscape(e.detail), sim::XmlEscape(e.detail));
        } else {
          cases += fmt::format("      <system-out>{}</system-out>\n", sim::XmlEscape(e.detail));
        }
        cases += "    </testcase>\n";
      }
    }
    const int suite_tests = o.input_error ? 1 : static_cast<int>(o.expectations.size());
    const int suite_errors = o.input_error ? 1 : 0;
    tests += suite_tests;
    failures += suite_failures;
    errors += suite_errors;
    seconds += o.wall_seconds;
    suites += fmt::format(
        "  <testsuite name=\"{}\" tests=\"{}\" failures=\"{}\" errors=\"{}\" "
        "time=\"{:.3f}\">\n    <properties>\n{}    </properties>\n{}  </testsuite>\n",
        name, suite_tests, suite_failures, suite_errors, o.wall_seconds, properties, cases);
  }
  return "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n" +
         fmt::format(
             "<testsuites name=\"autonomsim check\" tests=\"{}\" failures=\"{}\" "
             "errors=\"{}\" time=\"{:.3f}\">\n",
             tests, failures, errors, seconds) +
         suites + "</testsuites>\n";
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

// Each scenario's result folder under `out`, named by its file name, checked as an output (before
// anything runs); two scenarios of one file name would mix their results in one: ConfigError.
void CheckResultFolders(const std::vector<fs::path>& files, const std::string& out, bool force) {
  std::map<std::string, fs::path> by_name;
  for (const fs::path& file : files) {
    const auto [it, added] = by_name.emplace(file.stem().string(), file);
    if (!added) {
      throw sim::ConfigError(it->second.string() + " and " + file.string() + " would both write " +
                             (fs::path(out) / file.stem()).string() +
                             " (check names a result folder by its scenario's file name): check "
                             "them with different --out folders, or copy one under another name");
    }
  }
  for (const fs::path& file : files) {
    sim::CheckOutputFolder((fs::path(out) / file.stem()).string(), force);
  }
}

int CheckCommand(const std::vector<std::string>& args, const std::optional<std::string>& junit,
                 const std::optional<std::string>& out, const std::vector<std::string>& overrides,
                 int jobs, bool force, bool report) {
  InstallInterruptHandlers();  // Ctrl-C: stop at the next simulated second
  std::vector<fs::path> files;
  try {
    files = ExpandScenarioArgs(args);
  } catch (const sim::ConfigError& e) {
    fmt::print(stderr, "error: {}\n", e.what());
    return kExitUnusableInput;
  }
  if (out) {  // every result folder is refused before anything runs
    try {
      CheckResultFolders(files, *out, force);
    } catch (const sim::ConfigError& e) {
      fmt::print(stderr, "error: {}\n", e.what());
      return kExitUnusableInput;
    }
  }
  // Each scenario is an independent run: spread them over `jobs` threads; the verdicts do not
  // depend on the order or the thread a run lands on.
  std::vector<Outcome> outcomes(files.size());
  sim::ParallelFor(files.size(), jobs, [&](std::size_t i) {
    if (InterruptRequested()) return;  // Ctrl-C: start nothing more
    std::optional<fs::path> dir;
    if (out) dir = fs::path(*out) / files[i].stem();
    try {
      outcomes[i] = RunFile(files[i], overrides, dir, force);
      if (report) WriteOutcomeReport(&outcomes[i]);
    } catch (const std::exception& e) {
      outcomes[i].file = files[i].string();
      outcomes[i].scenario_name = files[i].stem().string();
      outcomes[i].input_error = std::string("run failed: ") + e.what();
    }
  });

  if (InterruptRequested()) {
    fmt::print(stderr,
               "autonomsim check: interrupted; the result folders it was writing were removed, "
               "no verdicts are given\n");
    return kExitInterrupted;
  }
  int failed = 0, unusable = 0, failed_expectations = 0;
  for (const Outcome& o : outcomes) {
    if (o.input_error) {
      ++unusable;
      fmt::print("ERROR {}\n  {}\n", o.file, *o.input_error);
      continue;
    }
    if (!o.passed()) ++failed;
    for (const sim::ExpectationResult& e : o.expectations) failed_expectations += !e.passed;
    fmt::print("{} {} ({} expectation(s), {:.0f} s simulated in {:.2f} s)\n",
               o.passed() ? "PASS " : "FAIL ", o.file, o.expectations.size(), o.sim_seconds,
               o.wall_seconds);
    if (o.expectations.empty()) fmt::print("  warning: this scenario has no expectations\n");
    for (const std::string& w : o.warnings) fmt::print("  warning: {}\n", w);
    if (!o.passed()) PrintVerdicts(o);
    if (!o.passed()) PrintReportPath(o);
  }
  fmt::print("{} scenario(s): {} passed, {} failed ({} expectation(s) failed), {} unusable\n",
             outcomes.size(), outcomes.size() - static_cast<std::size_t>(failed + unusable), failed,
             failed_expectations, unusable);
  if (junit) {
    sim::WriteFileAtomically(*junit, JunitXml(outcomes));
    fmt::print("JUnit XML: {}\n", *junit);
  }
  if (unusable > 0) return kExitUnusableInput;
  return failed > 0 ? kExitExpectationFailed : kExitOk;
}

}  // namespace

Command AddCheckCommand(CLI::App& parent) {
  struct Options {
    std::vector<std::string> args;
    std::optional<std::string> junit;
    std::optional<std::string> out;
    std::vector<std::string> overrides;
    int jobs = DefaultJobs();
    bool force{false};
    bool report{false};
  };
  auto o = std::make_shared<Options>();
  CLI::App* check = parent.add_subcommand(
      "check", "Run scenarios and judge their expect: clauses (for CI): exit 0 when all hold");
  check
      ->add_option("SCENARIO_OR_DIR", o->args,
                   "Scenario files, or folders whose *.yaml files are scenarios")
      ->required();
  check
      ->add_option("--junit", o->junit,
                   "Also write the verdicts as JUnit XML: a testsuite per scenario (its wall time; "
                   "properties scenario_file, seed, scenario_sha256, result_folder with --out, "
                   "report with --report), a testcase per expectation")
      ->type_name("FILE");
  CLI::Option* out =
      check
          ->add_option("--out", o->out,
                       "Keep each run's result folder under DIR/<scenario> (each replaced only if "
                       "this program wrote it, else refused: see --force)")
          ->type_name("DIR");
  check->add_flag("--force", o->force,
                  "Replace DIR/<scenario> even if this program did not write it (never a device)");
  check
      ->add_flag("--report", o->report,
                 "Also write each run's replay report, DIR/<scenario>/report.html (see "
                 "`autonomsim report`); a failed scenario prints its path")
      ->needs(out);
  check->add_option("--jobs,-j", o->jobs, "Scenarios run in parallel (default: all cores)")
      ->check(CLI::PositiveNumber);
  AddSetOption(check, &o->overrides);
  return {check, [o] {
            return CheckCommand(o->args, o->junit, o->out, o->overrides, o->jobs, o->force,
                                o->report);
          }};
}

}  // namespace autonomsim::cli
