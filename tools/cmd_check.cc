// `autonomsim check SCENARIO|DIR...`: judge scenarios' expectations, for CI.
#include <fmt/format.h>

#include <algorithm>
#include <atomic>
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

// A scenario file check was given, and its name (ExpandScenarioArgs).
struct ScenarioArg {
  fs::path file;
  std::string name;
};

// A failure's text in JUnit: what stdout prints for it, the detail with its time and car, and the
// replay report at that instant when one was written.
std::string FailureText(const Outcome& o, const sim::ExpectationResult& e) {
  std::string text;
  if (e.at_s) text += fmt::format("at t = {:.3f} s", *e.at_s);
  if (e.car) text += fmt::format("{}car {}", text.empty() ? "" : ", ", *e.car);
  if (!text.empty()) text += ": ";
  text += e.detail;
  if (const std::optional<std::string> link = ReportLink(o, e)) text += "\nreport: " + *link;
  return text;
}

// JUnit XML as CI servers read it (Jenkins, GitLab): one testsuite per scenario, named by its
// file's path relative to the argument given to check (as its result folder is), carrying the
// scenario's wall time and its identity as properties (its name, its result folder and replay
// report when written); one testcase per expectation. A testcase has no time of its own: the
// expectations are judged together after one run.
std::string JunitXml(const std::vector<Outcome>& outcomes, const std::vector<ScenarioArg>& files) {
  int tests = 0, failures = 0, errors = 0;
  double seconds = 0.0;
  std::string suites;
  for (std::size_t i = 0; i < outcomes.size(); ++i) {
    const Outcome& o = outcomes[i];
    const std::string name = sim::XmlEscape(files[i].name);
    std::string properties = fmt::format(
        "      <property name=\"scenario_file\" value=\"{}\"/>\n"
        "      <property name=\"scenario_name\" value=\"{}\"/>\n",
        sim::XmlEscape(o.file), sim::XmlEscape(o.scenario_name));
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
                               sim::XmlEscape(e.detail), sim::XmlEscape(FailureText(o, e)));
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

// SCENARIO|DIR... -> scenario files, each with its name: its path relative to the argument that
// named it (a folder's *.yaml files directly inside it, except hidden ones: editor and tool
// droppings; a file argument: its file name), without ".yaml". Its JUnit suite and its result
// folder under --out carry that name, so two copies of one scenario under different file names
// stay apart.
std::vector<ScenarioArg> ExpandScenarioArgs(const std::vector<std::string>& args) {
  std::vector<ScenarioArg> files;
  const auto named = [](const fs::path& file, const fs::path& relative) {
    fs::path name = relative;
    if (name.extension() == ".yaml") name.replace_extension();
    return ScenarioArg{file, name.generic_string()};
  };
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
      for (const fs::path& file : found)
        files.push_back(named(file, file.lexically_relative(path)));
    } else {
      files.push_back(named(path, path.filename()));
    }
  }
  return files;
}

// Two scenarios of one name would write one JUnit suite name twice and mix their results in one
// folder under --out: ConfigError before anything runs (with --out or --junit). Each result folder
// is checked as an output.
void CheckNames(const std::vector<ScenarioArg>& files, const std::optional<std::string>& out,
                bool force) {
  std::map<std::string, fs::path> by_name;
  for (const ScenarioArg& file : files) {
    const auto [it, added] = by_name.emplace(file.name, file.file);
    if (!added) {
      throw sim::ConfigError(
          it->second.string() + " and " + file.file.string() + " both have the name '" + file.name +
          "' (check names a scenario's JUnit suite and result folder by its file's path relative "
          "to the argument that named it): check them in separate calls, or copy one under "
          "another name");
    }
  }
  if (!out) return;
  for (const ScenarioArg& file : files) {
    sim::CheckOutputFolder((fs::path(*out) / file.name).string(), force);
  }
}

struct CheckOptions {
  std::vector<std::string> args;
  std::optional<std::string> junit;
  std::optional<std::string> out;
  std::vector<std::string> overrides;
  int jobs = DefaultJobs();
  bool force{false};
  bool report{false};
  bool quiet{false};
};

int CheckCommand(const CheckOptions& options) {
  const auto& [args, junit, out, overrides, jobs, force, report, quiet] = options;
  InstallInterruptHandlers();  // Ctrl-C: stop at the next simulated second
  std::vector<ScenarioArg> files;
  try {
    files = ExpandScenarioArgs(args);
    if (out || junit) CheckNames(files, out, force);  // before anything runs
  } catch (const sim::ConfigError& e) {
    fmt::print(stderr, "error: {}\n", e.what());
    return kExitUnusableInput;
  }
  // Each scenario is an independent run: spread them over `jobs` threads; the verdicts do not
  // depend on the order or the thread a run lands on. Progress on stderr names the scenario on
  // each line (runs in parallel share the stream).
  std::vector<Outcome> outcomes(files.size());
  std::atomic<std::size_t> finished{0};
  sim::ParallelFor(files.size(), jobs, [&](std::size_t i) {
    if (InterruptRequested()) return;  // Ctrl-C: start nothing more
    std::optional<fs::path> dir;
    if (out) dir = fs::path(*out) / files[i].name;
    if (!quiet) {
      fmt::print(stderr, "check: {} started ({} of {})\n", files[i].name, i + 1, files.size());
    }
    try {
      Progress progress(files[i].name, quiet);
      outcomes[i] = RunFile(files[i].file, overrides, dir, force, &progress);
      if (report) WriteOutcomeReport(&outcomes[i]);
    } catch (const std::exception& e) {
      outcomes[i].file = files[i].file.string();
      outcomes[i].scenario_name = files[i].name;
      outcomes[i].input_error = std::string("run failed: ") + e.what();
    }
    if (!quiet) {
      const Outcome& o = outcomes[i];
      fmt::print(stderr, "check: {} {} in {:.1f} s ({} of {} done)\n", files[i].name,
                 o.input_error ? "unusable" : (o.passed() ? "passed" : "FAILED"), o.wall_seconds,
                 ++finished, files.size());
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
    sim::WriteFileAtomically(*junit, JunitXml(outcomes, files));
    fmt::print("JUnit XML: {}\n", *junit);
  }
  if (unusable > 0) return kExitUnusableInput;
  return failed > 0 ? kExitExpectationFailed : kExitOk;
}

}  // namespace

Command AddCheckCommand(CLI::App& parent) {
  auto o = std::make_shared<CheckOptions>();
  CLI::App* check = parent.add_subcommand(
      "check", "Run scenarios and judge their expect: clauses (for CI): exit 0 when all hold");
  check
      ->add_option("SCENARIO_OR_DIR", o->args,
                   "Scenario files, or folders whose *.yaml files are scenarios")
      ->required();
  check
      ->add_option("--junit", o->junit,
                   "Also write the verdicts as JUnit XML: a testsuite per scenario, named by its "
                   "file's path relative to the argument that named it, without .yaml (its wall "
                   "time; properties scenario_file, scenario_name, seed, scenario_sha256, "
                   "result_folder with --out, report with --report), a testcase per expectation "
                   "(a failure's text: its time, car and report link)")
      ->type_name("FILE");
  CLI::Option* out =
      check
          ->add_option(
              "--out", o->out,
              "Keep each run's result folder under DIR/<name> (<name>: the scenario file's "
              "path relative to the argument that named it, without .yaml; each replaced "
              "only if this program wrote it, else refused: see --force)")
          ->type_name("DIR");
  check->add_flag("--force", o->force,
                  "Replace DIR/<name> even if this program did not write it (never a device)");
  check
      ->add_flag("--report", o->report,
                 "Also write each run's replay report, DIR/<name>/report.html (see "
                 "`autonomsim report`); a failed scenario prints its path")
      ->needs(out);
  check->add_option("--jobs,-j", o->jobs, "Scenarios run in parallel (default: all cores)")
      ->check(CLI::PositiveNumber);
  AddSetOption(check, &o->overrides);
  check->add_flag("--quiet,-q", o->quiet,
                  "No progress on stderr (by default: a line when each scenario starts and ends, "
                  "and one per 10 % of its simulated time)");
  return {check, [o] { return CheckCommand(*o); }};
}

}  // namespace autonomsim::cli
