// The `autonomsim` command line as a user and a CI job see it: exit codes, the result folder,
// JUnit XML, and the same result from separate processes.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "sim/loop/simulation.h"
#include "sim/results/outputs.h"
#include "tools/tests/cli_testing.h"

namespace autonomsim {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

using testing::Cli;
using testing::Read;
using testing::Result;
using testing::Shell;

fs::path Scratch() { return testing::Scratch("autonomsim_cli"); }

int Count(const std::string& text, const std::string& what) {
  int n = 0;
  for (std::size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

TEST(CliTest, HelpAnswers) {
  const Result top = Cli("--help");
  EXPECT_EQ(top.exit_code, 0);
  EXPECT_THAT(top.output, HasSubstr("run"));
  EXPECT_THAT(top.output, HasSubstr("check"));
  EXPECT_THAT(top.output, HasSubstr("Exit codes"));
  const Result run = Cli("run --help");
  EXPECT_EQ(run.exit_code, 0);
  for (const char* flag : {"--out", "--seed", "--set", "SCENARIO"}) {
    EXPECT_THAT(run.output, HasSubstr(flag));
  }
  const Result check = Cli("check --help");
  EXPECT_THAT(check.output, HasSubstr("--junit"));
}

// Issue 34, item 1: a trace cut at trace_max_events is no longer silent: `run` says so on stderr
// (where it stops, of how long) and summary.json's platform.<board>.trace holds the same. Before,
// the only sign was otherData.truncated inside trace.json (the default run's 31 MB: its first 46
// s).
TEST(CliTest, ARunWhoseTraceIsCutSaysWhereOnStderrAndInItsSummary) {
  const fs::path out = Scratch() / "cut";
  const Result r = Cli("run scenarios/stack_obstacle.yaml -q --out " + out.string() +
                       " --set duration_s=5 --set 'expect=[]'"
                       " --set cars[0].platform.trace_max_events=2000");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("warning: car1's part of trace.json stops at t = "));
  EXPECT_THAT(r.output, HasSubstr("of 5 s: it holds its first 2000 events"));
  const nlohmann::json trace =
      nlohmann::json::parse(Read(out / "summary.json"))["platform"]["car1"]["trace"];
  EXPECT_EQ(trace["events"], 2000);
  EXPECT_EQ(trace["recorded"], true);
  EXPECT_GT(trace["cut_at_s"].get<double>(), 0.0);
  EXPECT_LT(trace["cut_at_s"].get<double>(), 5.0);
  // a trace that holds the whole run says nothing
  const Result whole =
      Cli("run scenarios/stack_obstacle.yaml -q --out " + (Scratch() / "whole").string() +
          " --set duration_s=2 --set 'expect=[]'");
  ASSERT_EQ(whole.exit_code, 0) << whole.output;
  EXPECT_THAT(whole.output, ::testing::Not(HasSubstr("trace.json stops")));
}

TEST(CliTest, RunWritesACompleteResultFolder) {
  const fs::path out = Scratch() / "run";
  const Result r = Cli("run scenarios/lab_two_cars_oracle.yaml -q --out " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("results: " + out.string()));
  for (const char* file :
       {"summary.json", "trajectory.csv", "events.jsonl", "track.png", "scenario.resolved.json"}) {
    EXPECT_TRUE(fs::exists(out / file)) << file;
  }
  const nlohmann::json summary = nlohmann::json::parse(Read(out / "summary.json"));
  for (const char* key : {"scenario", "seed", "scenario_sha256", "sim_seconds", "wall_seconds",
                          "real_time_factor", "expectations", "cars"}) {
    EXPECT_TRUE(summary.contains(key)) << key;
  }
  EXPECT_EQ(summary["scenario"], "lab_two_cars_oracle");
  EXPECT_EQ(summary["sim_seconds"], 120.0);
  for (const nlohmann::json& car : summary["cars"]) {
    for (const char* key : {"laps", "collisions", "max_lateral_error_m"}) {
      EXPECT_TRUE(car.contains(key)) << key;
    }
  }
  for (const nlohmann::json& e : summary["expectations"]) {
    EXPECT_TRUE(e.contains("name") && e.contains("passed") && e.contains("detail"));
  }
  // nothing half-written next to it
  for (const auto& entry : fs::directory_iterator(out.parent_path())) {
    EXPECT_EQ(entry.path().filename(), "run");
  }
  // a second run replaces the first, again leaving only the complete folder
  ASSERT_EQ(
      Cli("run scenarios/lab_two_cars_oracle.yaml -q --seed 5 --out " + out.string()).exit_code, 0);
  EXPECT_EQ(nlohmann::json::parse(Read(out / "summary.json"))["seed"], 5);
  EXPECT_EQ(std::distance(fs::directory_iterator(out.parent_path()), fs::directory_iterator()), 1);
}

// The golden determinism test: separate processes and this process agree bit for bit.
TEST(CliTest, SeparateProcessesGiveTheSameResultAsThisOne) {
  const fs::path dir = Scratch();
  ASSERT_EQ(
      Cli("run scenarios/lab_two_cars_oracle.yaml -q --out " + (dir / "a").string()).exit_code, 0);
  ASSERT_EQ(
      Cli("run scenarios/lab_two_cars_oracle.yaml -q --out " + (dir / "b").string()).exit_code, 0);
  const std::string a = Read(dir / "a" / "trajectory.csv") + Read(dir / "a" / "events.jsonl");
  const std::string b = Read(dir / "b" / "trajectory.csv") + Read(dir / "b" / "events.jsonl");
  EXPECT_EQ(a, b);
  const auto hash = [&](const char* run) {
    return nlohmann::json::parse(Read(dir / run / "summary.json"))["result_sha256"]
        .get<std::string>();
  };
  const sim::RunRecord here =
      sim::RunScenario(sim::LoadScenario("scenarios/lab_two_cars_oracle.yaml"));
  EXPECT_EQ(hash("a"), sim::ResultSha256(here));
  EXPECT_EQ(hash("b"), hash("a"));
}

TEST(CliTest, CheckPassesTheShippedScenariosAndWritesJunit) {
  const fs::path junit = Scratch() / "check.xml";
  const Result r = Cli("check scenarios/ --jobs 2 --junit " + junit.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("PASS  scenarios/lab_two_cars.yaml"));
  const std::string xml = Read(junit);
  EXPECT_THAT(xml, HasSubstr("<testsuites"));
  EXPECT_THAT(xml, HasSubstr("failures=\"0\""));
  EXPECT_THAT(xml, HasSubstr("classname=\"lab_two_cars\" name=\"intersection_mutex\""));
  EXPECT_THAT(xml, ::testing::Not(HasSubstr("<failure")));
  // One testsuite per scenario, named after it, with its seed among its properties.
  int scenarios = 0;
  for (const auto& entry : fs::directory_iterator("scenarios")) {
    scenarios += entry.path().extension() == ".yaml";
  }
  EXPECT_EQ(Count(xml, "<testsuite "), scenarios);
  EXPECT_EQ(Count(xml, "<property name=\"seed\""), scenarios);
  EXPECT_THAT(xml, HasSubstr("<testsuite name=\"lab_two_cars\" tests=\"5\" failures=\"0\""));
  EXPECT_THAT(xml, HasSubstr("<property name=\"seed\" value=\"42\"/>"));
}

// The fault scenarios (docs/faults.md#the-shipped-fault-scenarios) each pass what they expect.
TEST(CliTest, CheckPassesTheShippedFaultScenarios) {
  const Result r = Cli("check scenarios/faults/ --jobs 2");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  int scenarios = 0;
  for (const auto& entry : fs::directory_iterator("scenarios/faults")) {
    if (entry.path().extension() != ".yaml") continue;
    ++scenarios;
    EXPECT_THAT(r.output, HasSubstr("PASS  " + entry.path().string())) << r.output;
  }
  EXPECT_GE(scenarios, 5);
}

// Three scenarios (one driven by the stack on a board) are enough to show that --jobs changes
// nothing; every shipped scenario is checked above.
TEST(CliTest, CheckGivesTheSameResultsWhateverTheNumberOfJobs) {
  const fs::path dir = Scratch();
  const std::string scenarios =
      "scenarios/lab_two_cars_oracle.yaml scenarios/intersection_conflict.yaml "
      "scenarios/stack_obstacle.yaml";
  ASSERT_EQ(Cli("check " + scenarios + " --jobs 1 --out " + (dir / "one").string()).exit_code, 0);
  ASSERT_EQ(Cli("check " + scenarios + " --jobs 2 --out " + (dir / "two").string()).exit_code, 0);
  int compared = 0;
  for (const auto& entry : fs::directory_iterator(dir / "one")) {
    const auto hash = [](const fs::path& run) {
      return nlohmann::json::parse(Read(run / "summary.json"))["result_sha256"];
    };
    EXPECT_EQ(hash(entry.path()), hash(dir / "two" / entry.path().filename()));
    ++compared;
  }
  EXPECT_GE(compared, 3);
}

TEST(CliTest, CheckExitsOneOnAFailedExpectationAndSaysWhich) {
  const fs::path dir = Scratch();
  const fs::path junit = dir / "check.xml";
  const Result r =
      Cli("check scenarios/intersection_conflict.yaml --set expect[3].completes.laps=9 "
          "--junit " +
          junit.string());
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_THAT(r.output, HasSubstr("FAIL completes(laps=9"));
  EXPECT_THAT(r.output, HasSubstr("1 scenario(s): 0 passed, 1 failed (1 expectation(s) failed)"));
  EXPECT_THAT(Read(junit), HasSubstr("<failure message="));
}

// Issue 34: check named a JUnit suite by the scenario's `name:`, so a copied scenario gave two
// suites of one name (and result folders used the file name). Both now carry the file's path
// relative to the argument that named it, and the progress on stderr names each run.
TEST(CliTest, CheckNamesSuitesAndFoldersByTheScenarioFilesPath) {
  const fs::path dir = Scratch();
  fs::create_directories(dir / "copies");
  fs::copy_file("scenarios/intersection_conflict.yaml", dir / "copies" / "first.yaml");
  fs::copy_file("scenarios/intersection_conflict.yaml", dir / "copies" / "second.yaml");
  const fs::path junit = dir / "check.xml";
  const Result r =
      Cli("check " + (dir / "copies").string() + " --set duration_s=5 --jobs 2 --out " +
          (dir / "out").string() + " --junit " + junit.string());
  ASSERT_EQ(r.exit_code, 1) << r.output;  // its laps cannot complete in 5 s
  const std::string xml = Read(junit);
  EXPECT_EQ(Count(xml, "<testsuite name=\"first\" "), 1) << xml;
  EXPECT_EQ(Count(xml, "<testsuite name=\"second\" "), 1) << xml;
  EXPECT_EQ(Count(xml, "<property name=\"scenario_name\" value=\"intersection_conflict\"/>"), 2);
  EXPECT_TRUE(fs::exists(dir / "out" / "first" / "summary.json"));
  EXPECT_TRUE(fs::exists(dir / "out" / "second" / "summary.json"));
  EXPECT_THAT(r.output, HasSubstr("check: first started"));
  EXPECT_THAT(r.output, HasSubstr("check: second FAILED in"));
  EXPECT_THAT(r.output, HasSubstr("  first: 3.0 / 5.0 s simulated (60%)"));
  const Result quiet =
      Cli("check " + (dir / "copies" / "first.yaml").string() + " --set duration_s=5 --quiet");
  EXPECT_THAT(quiet.output, ::testing::Not(HasSubstr("check: first")));
  EXPECT_THAT(quiet.output, ::testing::Not(HasSubstr("s simulated (")));
}

// Issue 34, deliver 1: validate loads, resolves and checks without running; --print shows every
// default; a study resolves every run of its grid.
TEST(CliTest, ValidateChecksWithoutRunningAndPrintsTheResolvedScenario) {
  const fs::path dir = Scratch();
  const Result ok = Cli("validate scenarios/lab_two_cars.yaml --set duration_s=100");
  EXPECT_EQ(ok.exit_code, 0) << ok.output;
  EXPECT_THAT(ok.output, HasSubstr("OK    scenarios/lab_two_cars.yaml: scenario 'lab_two_cars', 2 "
                                   "car(s), 100 s, seed 42, scenario_sha256 "));
  // the warnings a run would print: its deadline past the shortened end, and the keys it sets
  // against its stack preset
  EXPECT_THAT(ok.output, HasSubstr("warning: scenarios/lab_two_cars.yaml:"));
  EXPECT_THAT(ok.output, HasSubstr("is past the run's end (duration_s 100 s)"));
  EXPECT_THAT(ok.output, HasSubstr("option(s) of stack.preset lab itself"));
  EXPECT_THAT(ok.output, ::testing::Not(HasSubstr("simulated")));  // nothing ran

  const Result printed = Cli("validate scenarios/lab_two_cars_oracle.yaml --print --seed 9");
  ASSERT_EQ(printed.exit_code, 0) << printed.output;
  const nlohmann::json resolved =
      nlohmann::json::parse(printed.output.substr(printed.output.find('{')));
  EXPECT_EQ(resolved["scenario"]["seed"].get<int>(), 9);
  EXPECT_TRUE(resolved["scenario"]["cars"][0]["vehicle"].contains("mass_kg"));  // a default
  EXPECT_TRUE(resolved["track"].contains("intersections"));

  std::ofstream(dir / "broken.yaml") << "name: broken\nduration_s: 10\ncars:\n  - id: 0\n"
                                        "    route: south_loop\n    speeed_mps: 1\n";
  const Result broken =
      Cli("validate scenarios/intersection_conflict.yaml " + (dir / "broken.yaml").string());
  EXPECT_EQ(broken.exit_code, 2) << broken.output;
  EXPECT_THAT(broken.output, HasSubstr("OK    scenarios/intersection_conflict.yaml"));
  EXPECT_THAT(broken.output, HasSubstr((dir / "broken.yaml").string() + ":6:"));
  EXPECT_THAT(broken.output, HasSubstr("2 file(s): 1 usable, 1 unusable"));

  const Result study = Cli("validate scenarios/studies/v2i_latency.yaml");
  EXPECT_EQ(study.exit_code, 0) << study.output;
  EXPECT_THAT(study.output, HasSubstr("study of"));
  EXPECT_THAT(study.output, HasSubstr("5 run(s) (1 varied key(s), 1 seed(s) each)"));
  const Result bad_point =
      Cli("validate scenarios/studies/v2i_latency.yaml --set v2i.latency_s=-1 --max-runs 4");
  EXPECT_EQ(bad_point.exit_code, 2) << bad_point.output;
  EXPECT_THAT(bad_point.output, HasSubstr("max-runs"));
}

// The suite carries what a CI page shows next to a failure: where the run's folder is and which
// resolved scenario (seed, hash) gave it; the time is the scenario's, not split over its cases.
TEST(CliTest, CheckJunitSuitesCarryTheRunsIdentityAndTime) {
  const fs::path dir = Scratch();
  const fs::path junit = dir / "check.xml";
  const Result r =
      Cli("check scenarios/intersection_conflict.yaml --set seed=7 --set "
          "expect[3].completes.laps=9 --out " +
          (dir / "out").string() + " --junit " + junit.string());
  ASSERT_EQ(r.exit_code, 1) << r.output;
  const std::string xml = Read(junit);
  const nlohmann::json summary =
      nlohmann::json::parse(Read(dir / "out" / "intersection_conflict" / "summary.json"));
  EXPECT_EQ(Count(xml, "<testsuite "), 1);
  EXPECT_THAT(xml, HasSubstr("<testsuite name=\"intersection_conflict\" tests=\"" +
                             std::to_string(summary["expectations"].size()) +
                             "\" failures=\"1\" errors=\"0\""));
  EXPECT_THAT(xml, HasSubstr("<property name=\"seed\" value=\"7\"/>"));
  EXPECT_THAT(xml, HasSubstr("<property name=\"scenario_sha256\" value=\"" +
                             summary["scenario_sha256"].get<std::string>() + "\"/>"));
  EXPECT_THAT(xml, HasSubstr("<property name=\"result_folder\" value=\"" +
                             (dir / "out" / "intersection_conflict").string() + "\"/>"));
  EXPECT_EQ(Count(xml, "<testcase "), static_cast<int>(summary["expectations"].size()));
  EXPECT_EQ(Count(xml, "<testcase classname=\"intersection_conflict\" name=\"completes(laps=9"), 1);
  EXPECT_THAT(xml, ::testing::Not(HasSubstr("<testcase classname=\"intersection_conflict\" "
                                            "name=\"no_collision\" time=")));
}

TEST(CliTest, UnusableInputExitsTwo) {
  const fs::path broken = Scratch() / "broken.yaml";
  std::ofstream(broken) << "name: broken\ncars: []\n";
  Result r = Cli("run " + broken.string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.output, HasSubstr("cars must not be empty"));
  EXPECT_EQ(Cli("check " + broken.string()).exit_code, 2);
  EXPECT_EQ(Cli("run scenarios/nope.yaml").exit_code, 2);
  EXPECT_EQ(Cli("run scenarios/lab_two_cars_oracle.yaml --bogus").exit_code, 2);
  EXPECT_EQ(Cli("run scenarios/lab_two_cars_oracle.yaml --set cars[0].speed=1").exit_code, 2);
  EXPECT_EQ(Cli("frobnicate").exit_code, 2);
}

TEST(CliTest, ANegativeSeedOrAFolderAsScenarioIsUnusableInput) {
  Result r = Cli("run scenarios/lab_two_cars_oracle.yaml --seed -1");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  // issue 34: a command-line mistake opens with "error: " as every other error does
  EXPECT_THAT(r.output, ::testing::StartsWith("error: --seed: a seed is a whole number >= 0, got "
                                              "'-1'\nRun with --help for more information."));
  r = Cli("run scenarios/lab_two_cars_oracle.yaml --bogus");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_THAT(r.output, ::testing::StartsWith("error: The following argument was not expected: "
                                              "--bogus"));
  r = Cli("run scenarios/tracks");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_THAT(r.output, HasSubstr("scenarios/tracks: is a folder, not a file"));
  r = Cli("run scenarios/lab_two_cars_oracle.yaml --set 'cars.0.route=south_loop'");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_THAT(r.output, HasSubstr("index lists as [N]"));
}

}  // namespace
}  // namespace autonomsim

namespace autonomsim::cli {
namespace {

// `autonomsim transport` (issue 32): the DDS link alone. A 0.9 MB image at 30 Hz on the x86
// profile fits the receive buffer (2 MiB): every sample offered after the warm-up arrives, nothing
// is dropped; --json carries the keys bench/dds_vs_cyclone.sh reads.
TEST(CliTest, TransportPrintsTheDeliveredRateAsJson) {
  const Result r = testing::Cli(
      "transport --bytes 921600 --rate-hz 30 --seconds 3 --warmup 1 "
      "--profile scenarios/platforms/x86_loopback.yaml --json");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json j = nlohmann::json::parse(r.output);
  for (const char* key :
       {"delivered_hz", "latency_p50_ms", "latency_p95_ms", "dropped_datagrams", "repairs"}) {
    EXPECT_TRUE(j.contains(key)) << key;
  }
  EXPECT_DOUBLE_EQ(j["delivered_hz"].get<double>(), 30.0);
  EXPECT_EQ(j["dropped_datagrams"].get<int>(), 0);
  EXPECT_EQ(j["datagrams_per_sample"].get<int>(), 69);  // 686 fragments of 1 344 B, 10 a datagram
}

TEST(CliTest, TransportRefusesWhatItCannotRun) {
  const Result rate = testing::Cli("transport --bytes 1000 --rate-hz 0");
  EXPECT_EQ(rate.exit_code, 2);
  EXPECT_THAT(rate.output, ::testing::HasSubstr("--rate-hz must be > 0"));
  const Result key = testing::Cli("transport --bytes 1000 --rate-hz 30 --set dds.fragment_bytes=0");
  EXPECT_EQ(key.exit_code, 2);
  EXPECT_THAT(key.output, ::testing::HasSubstr("fragment_bytes must be > 0"));
  const Result missing = testing::Cli("transport --rate-hz 30");
  EXPECT_EQ(missing.exit_code, 2);
  EXPECT_THAT(missing.output, ::testing::HasSubstr("--bytes"));
}

// Issue 34, item 10: `table1` and `transport` find their default profile from any folder, as a
// scenario finds the shipped tracks and profiles (before: "scenarios/platforms/zcu104.yaml: no
// such file" outside the checkout's root). A profile that exists nowhere is still refused.
TEST(CliTest, Table1AndTransportFindTheShippedProfileFromAnyFolder) {
  const std::filesystem::path elsewhere = testing::Scratch("CliTest.ShippedProfile");
  const std::string bin = std::filesystem::absolute(testing::Bin()).string();
  const std::string cd = "cd " + elsewhere.string() + " && " + bin;
  const Result table1 = testing::Shell(cd + " table1 --duration 3 --warmup 1");
  EXPECT_NE(table1.exit_code, 2) << table1.output;
  EXPECT_THAT(table1.output, ::testing::HasSubstr("profile 'zcu104'"));
  const Result transport =
      testing::Shell(cd + " transport --bytes 1000 --rate-hz 10 --seconds 2 --json");
  EXPECT_EQ(transport.exit_code, 0) << transport.output;
  const Result shipped_name = testing::Shell(
      cd +
      " transport --bytes 1000 --rate-hz 10 --seconds 2 --profile platforms/x86_loopback.yaml");
  EXPECT_EQ(shipped_name.exit_code, 0) << shipped_name.output;
  const Result nowhere = testing::Shell(cd + " table1 --profile platforms/nope.yaml");
  EXPECT_EQ(nowhere.exit_code, 2);
  EXPECT_THAT(nowhere.output, ::testing::HasSubstr("platforms/nope.yaml"));
}

}  // namespace
}  // namespace autonomsim::cli

namespace autonomsim::cli {
namespace {

namespace fs = std::filesystem;
using testing::Cli;
using ::testing::HasSubstr;
using testing::Read;
using testing::Result;

fs::path Scratch() { return testing::Scratch("autonomsim_cli"); }

// `run --mcap` and `export --mcap`'s refusals: nothing of a user's is replaced, nothing
// half-written is left, and an export whose run no longer gives the run's result writes nothing.
// (What a recording holds: tools/tests/mcap_e2e.sh, ctest Mcap.run_and_export.)
TEST(CliTest, McapOutputsAreRefusedWhereTheyWouldReplaceOrMisrepresent) {
  const fs::path dir = Scratch();
  const std::string run =
      "run scenarios/lab_two_cars_oracle.yaml --set duration_s=3 --set expect=null -q ";
  // a file this program did not write is refused (exit 2), and stays as it was
  std::ofstream(dir / "mine.mcap") << "a user's file";
  const Result foreign =
      Cli(run + "--out " + (dir / "a").string() + " --mcap " + (dir / "mine.mcap").string());
  EXPECT_EQ(foreign.exit_code, 2) << foreign.output;
  EXPECT_THAT(foreign.output, HasSubstr("--mcap " + (dir / "mine.mcap").string() +
                                        ": is a file this program did not write"));
  EXPECT_THAT(foreign.output, HasSubstr("--force"));
  EXPECT_EQ(Read(dir / "mine.mcap"), "a user's file");
  // --mcap-topics without --mcap, and --mcap inside the folder the run replaces
  EXPECT_EQ(Cli(run + "--mcap-topics '*'").exit_code, 2);
  const Result inside =
      Cli(run + "--out " + (dir / "a").string() + " --mcap " + (dir / "a" / "run.mcap").string());
  EXPECT_EQ(inside.exit_code, 2) << inside.output;
  EXPECT_THAT(inside.output, HasSubstr("inside the result folder"));
  // one it wrote is replaced without --force
  const std::string to_ours = " --mcap " + (dir / "ours.mcap").string();
  const Result first = Cli(run + "--out " + (dir / "a").string() + to_ours);
  ASSERT_EQ(first.exit_code, 0) << first.output;
  const Result again = Cli(run + "--out " + (dir / "b").string() + to_ours);
  EXPECT_EQ(again.exit_code, 0) << again.output;
  EXPECT_THAT(again.output, HasSubstr("mcap: "));
  // an export whose run gives another result writes nothing
  nlohmann::json summary = nlohmann::json::parse(Read(dir / "a" / "summary.json"));
  summary["result_sha256"] = std::string(64, '0');
  std::ofstream(dir / "a" / "summary.json") << summary.dump(2);
  const Result differs =
      Cli("export " + (dir / "a").string() + " --mcap " + (dir / "export.mcap").string() + " -q");
  EXPECT_EQ(differs.exit_code, 2) << differs.output;
  EXPECT_THAT(differs.output, HasSubstr("gives another result"));
  EXPECT_FALSE(fs::exists(dir / "export.mcap"));
  for (const auto& entry : fs::directory_iterator(dir)) {  // no partial file left either
    EXPECT_EQ(entry.path().string().find(".partial"), std::string::npos) << entry.path();
    EXPECT_EQ(entry.path().string().find(".rerun"), std::string::npos) << entry.path();
  }
}

}  // namespace
}  // namespace autonomsim::cli
