// `autonomsim sweep` as a user and a job scheduler see it: help, errors for bad input, and the
// recipe of docs/sweeps.md#beyond-one-machine (shards run by GNU parallel, then `sweep merge`)
// giving the same results.csv as one process.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <regex>
#include <string>
#include <vector>

#include "tools/tests/cli_testing.h"

namespace autonomsim {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

using testing::Bin;
using testing::Cli;
using testing::Read;
using testing::Result;
using testing::Shell;

fs::path Scratch() { return testing::Scratch("autonomsim_sweep_cli"); }

// Four runs of the oracle scenario, 5 s each: a second or two in all.
const std::string kSweep =
    "sweep scenarios/lab_two_cars_oracle.yaml --set duration_s=5 --set 'expect=[]' "
    "--vary 'cars[0].oracle.speed_mps=0.3,0.5' --vary 'v2i.latency_s=0,1' --quiet";

// Issue 15: a sweep whose runs all fail an expectation says so and exits 1 (it said "0 failed").
TEST(SweepCliTest, RunsThatFailAnExpectationAreCountedAndExitOne) {
  const fs::path dir = Scratch();
  const Result r = Cli(kSweep + " --set 'expect=[{max_lateral_error: {max_m: 0.000001}}]' --out " +
                       (dir / "strict").string());
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_THAT(r.output, HasSubstr("4 ran, 0 already complete, 0 failed to run, 4 with failed "
                                  "expectations"));
  EXPECT_THAT(r.output, HasSubstr("FAIL run "));
  EXPECT_THAT(r.output, HasSubstr("max_lateral_error(max_m=1e-06)"));
  // resumed, the complete runs' verdicts still count
  EXPECT_EQ(Cli(kSweep + " --set 'expect=[{max_lateral_error: {max_m: 0.000001}}]' --out " +
                (dir / "strict").string())
                .exit_code,
            1);
  const Result merged = Cli("sweep merge " + (dir / "strict").string() + " --out " +
                            (dir / "merged").string() + " --no-plots");
  EXPECT_EQ(merged.exit_code, 1) << merged.output;
  EXPECT_THAT(merged.output, HasSubstr("4 run(s) with failed expectations"));
}

// Issue 34, item 1: every sweep run wrote some 30 MB of trace (185 MB for six 60 s runs). A
// sweep's runs write trace.json only with --trace; the run ids (what the runs do) are the same.
TEST(SweepCliTest, RunsWriteATraceOnlyWhenAsked) {
  const fs::path dir = Scratch();
  const std::string sweep =
      "sweep scenarios/lab_two_cars.yaml --set duration_s=1 --set 'expect=[]' --vary seed=1,2 "
      "--no-plots --quiet --out ";
  ASSERT_EQ(Cli(sweep + (dir / "plain").string()).exit_code, 0);
  ASSERT_EQ(Cli(sweep + (dir / "traced").string() + " --trace").exit_code, 0);
  std::vector<std::string> plain, traced;
  for (const auto& run : fs::directory_iterator(dir / "plain" / "runs")) {
    plain.push_back(run.path().filename().string());
    EXPECT_TRUE(fs::exists(run.path() / "nodes.csv"));
    EXPECT_FALSE(fs::exists(run.path() / "trace.json")) << run.path();
  }
  for (const auto& run : fs::directory_iterator(dir / "traced" / "runs")) {
    traced.push_back(run.path().filename().string());
    EXPECT_TRUE(fs::exists(run.path() / "trace.json")) << run.path();
  }
  std::sort(plain.begin(), plain.end());
  std::sort(traced.begin(), traced.end());
  EXPECT_EQ(plain.size(), 2u);
  EXPECT_EQ(plain, traced);
}

// Issue 17: the sweep's index.html links each run's replay report, and its rows are the table's.
TEST(SweepCliTest, TheIndexLinksEveryRunsReport) {
  const fs::path scratch = Scratch();
  const fs::path dir = scratch / "sweep";
  const Result r = Cli(kSweep + " --out " + dir.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("index: " + dir.string() + "/index.html"));
  const std::string index = Read(dir / "index.html");
  int runs = 0;
  for (const auto& entry : fs::directory_iterator(dir / "runs")) {
    ++runs;
    EXPECT_TRUE(fs::exists(entry.path() / "report.html")) << entry.path();
    EXPECT_THAT(index, HasSubstr("\"runs/" + entry.path().filename().string() + "/report.html\""));
  }
  EXPECT_EQ(runs, 4);
  // a run from before reports gets one when the index is remade
  const fs::path first = fs::directory_iterator(dir / "runs")->path();
  fs::remove(first / "report.html");
  const Result merged =
      Cli("sweep merge " + dir.string() + " --out " + (scratch / "merged").string());
  EXPECT_EQ(merged.exit_code, 0) << merged.output;
  EXPECT_TRUE(fs::exists(first / "report.html"));
  EXPECT_THAT(Read(scratch / "merged" / "index.html"), HasSubstr("../sweep/runs/"));
}

// Issue 34, smaller items: a board sweep's index.html showed every node's columns (149 in all)
// with no way to hide them. In chromium the page shows the run's and the cars' and boards'
// metrics, and the nodes' once its checkbox is ticked.
TEST(SweepCliTest, TheIndexHidesPerNodeColumnsUntilAsked) {
  ASSERT_EQ(Shell("command -v chromium").exit_code, 0)
      << "chromium is not installed: tools/install_deps.sh installs it (Debian's chromium)";
  const fs::path dir = Scratch();
  const Result r =
      Cli("sweep scenarios/lab_two_cars.yaml --set duration_s=1 --set 'expect=[]' --vary "
          "'v2i.latency_s=0,1' --no-plots -q --out " +
          (dir / "sweep").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const std::string table = Read(dir / "sweep" / "results.csv");
  const std::string header = table.substr(0, table.find('\n'));
  const long columns = std::count(header.begin(), header.end(), ',') + 1;
  long node_columns = 0;  // <board>.<node>.<metric>
  for (std::size_t at = 0, next = 0; at <= header.size(); at = next + 1) {
    next = std::min(header.find(',', at), header.size());
    const std::string column = header.substr(at, next - at);
    node_columns += std::count(column.begin(), column.end(), '.') == 2;
  }
  ASSERT_GT(node_columns, 20);
  fs::create_directories(dir / "profile");
  const Result browser =
      Shell("/usr/bin/python3 tools/tests/chromium_probe.py --timeout 60 --user-data-dir " +
            (dir / "profile").string() + " 'file://" + (dir / "sweep" / "index.html").string() +
            "#probe'");
  const std::size_t json_begin = browser.output.find("{\"probe\"");
  ASSERT_NE(json_begin, std::string::npos) << browser.output;
  const nlohmann::json opened = nlohmann::json::parse(browser.output.substr(json_begin));
  EXPECT_TRUE(opened["exceptions"].empty()) << opened["exceptions"];
  ASSERT_EQ(browser.exit_code, 0) << "the page wrote no probe: " << opened.dump(1);
  const nlohmann::json probe = nlohmann::json::parse(opened["probe"].get<std::string>());
  EXPECT_EQ(probe["columns"], columns);
  EXPECT_EQ(probe["shown"], columns - node_columns);
  EXPECT_EQ(probe["shown_with_nodes"], columns);
}

// Issue 33, item 4: a sweep on a full disk exited 1 (the "an expectation failed" code) and never
// said why. Here the writes fail with the file-size limit (ulimit -f, SIGXFSZ ignored: EFBIG, as a
// full disk gives ENOSPC): exit 2, each run with its path and the OS's reason. 24 blocks of 512
// bytes let the sweep's own files through (index.html is about 9 KB) and stop each run's
// trajectory.csv (about 35 KB).
TEST(SweepCliTest, ARunThatCannotBeWrittenExitsTwoWithTheOsReason) {
  const fs::path dir = Scratch() / "full";
  const Result r = Shell("trap '' XFSZ; ulimit -f 24; " + Bin() + " " + kSweep +
                         " --no-plots --out " + dir.string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_THAT(r.output, HasSubstr("4 failed to run"));
  EXPECT_THAT(r.output, HasSubstr("cannot write " + (dir / "runs").string()));
  EXPECT_THAT(r.output, HasSubstr(": File too large"));
  EXPECT_FALSE(fs::exists(dir / "runs") && !fs::is_empty(dir / "runs"));  // no half-written run
}

// Issue 34, item 8: the sweep was silent for the ≈ 8 s its plots took after the last run. Off a
// terminal it says how many are drawn at each tenth; --quiet says nothing.
TEST(SweepCliTest, ItSaysHowManyPlotsAreDrawnUnlessQuiet) {
  const fs::path dir = Scratch();
  const std::string loud = kSweep.substr(0, kSweep.rfind(" --quiet"));
  const Result r = Cli(loud + " --out " + (dir / "loud").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::smatch last;
  const std::regex line("  plotting: ([0-9]+) of ([0-9]+) plots\n");
  std::vector<std::string> done;
  for (auto it = std::sregex_iterator(r.output.begin(), r.output.end(), line);
       it != std::sregex_iterator(); ++it) {
    done.push_back((*it)[1]);
    last = *it;
  }
  ASSERT_GE(done.size(), 3u) << r.output;
  EXPECT_EQ(done.front(), "0");
  EXPECT_EQ(last[1], last[2]);  // the last line: all drawn
  int pngs = 0;
  for (const auto& entry : fs::directory_iterator(dir / "loud" / "plots")) {
    pngs += entry.path().extension() == ".png";
  }
  EXPECT_EQ(std::to_string(pngs), last[2].str());
  // after the runs, before the table's summary line
  EXPECT_LT(r.output.find("4/4 runs done"), r.output.find("plotting: 0 of"));
  EXPECT_LT(r.output.rfind("plotting: "), r.output.find("run(s)"));
  const Result quiet = Cli(kSweep + " --out " + (dir / "quiet").string());
  EXPECT_THAT(quiet.output, ::testing::Not(HasSubstr("plotting")));
  const Result merged =
      Cli("sweep merge " + (dir / "loud").string() + " --out " + (dir / "merged").string());
  EXPECT_THAT(merged.output, HasSubstr("plotting: " + last[2].str() + " of " + last[2].str()));
}

// Issue 34: "4 run(s) in this shard" was printed for a sweep without shards.
TEST(SweepCliTest, OnlyAShardSaysItIsOne) {
  const fs::path dir = Scratch();
  Result r = Cli(kSweep + " --no-plots --out " + (dir / "whole").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_THAT(r.output, ::testing::StartsWith("4 run(s): 4 ran, 0 already complete,"));
  EXPECT_THAT(r.output, ::testing::Not(HasSubstr("shard")));
  r = Cli(kSweep + " --no-plots --shard 2/2 --out " + (dir / "half").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("2 run(s) in shard 2/2: 2 ran,"));
}

TEST(SweepCliTest, HelpAnswers) {
  const Result sweep = Cli("sweep --help");
  EXPECT_EQ(sweep.exit_code, 0);
  EXPECT_THAT(sweep.output, HasSubstr("--vary"));
  EXPECT_THAT(sweep.output, HasSubstr("--shard"));
  EXPECT_THAT(sweep.output, HasSubstr("Sweep folder, required"));  // issue 34: it did not say
  const Result merge = Cli("sweep merge --help");
  EXPECT_EQ(merge.exit_code, 0);
  EXPECT_THAT(merge.output, HasSubstr("DIR"));
}

TEST(SweepCliTest, BadInputExitsTwoNamingWhatIsWrong) {
  const fs::path dir = Scratch();
  const std::string out = " --out " + (dir / "out").string();
  Result r = Cli(kSweep + " --vary 'v2i.latency_s=0:1'" + out);  // neither list nor range
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.output, HasSubstr("a range is start:stop:count"));  // issue 34: it gave no hint
  r = Cli(kSweep + " --vary 'v2i.latency_s=0:2:x'" + out);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.output, HasSubstr("v2i.latency_s=0:2:x"));
  r = Cli(kSweep + " --vary 'v2i.latnecy_s=0,1'" + out);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.output, HasSubstr("latnecy_s"));
  EXPECT_FALSE(fs::exists(dir / "out" / "runs"));
  r = Cli(kSweep + " --shard 3/2" + out);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.output, HasSubstr("--shard 3/2"));
  r = Cli(kSweep);  // no --out
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.output, HasSubstr("--out"));
  r = Cli("sweep merge " + (dir / "nothing").string());
  EXPECT_EQ(r.exit_code, 2);
}

// Issue 15: a sweep writes into a folder that is absent, empty, or its own; never into someone's.
TEST(SweepCliTest, AFolderItDidNotWriteIsRefusedUnlessEmptyOrForced) {
  const fs::path dir = Scratch();
  const fs::path notes = dir / "notes";
  fs::create_directories(notes);
  std::ofstream(notes / "results.csv") << "mine\n";
  const std::string vary = " --vary 'v2i.loss=0,0.1' --set duration_s=1 -q --no-plots";
  Result r = Cli(kSweep + vary + " --out " + notes.string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_THAT(r.output, HasSubstr("did not write"));
  EXPECT_EQ(Read(notes / "results.csv"), "mine\n");
  const fs::path empty = dir / "empty";
  fs::create_directories(empty);
  r = Cli(kSweep + vary + " --out " + empty.string());
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(fs::exists(empty / ".autonomsim"));
  r = Cli(kSweep + vary + " --out " + empty.string());  // its own now: resumed
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr(" 0 ran,"));
}

TEST(SweepCliTest, ShardsRunByGnuParallelMergeToTheSameTable) {
  if (Shell("command -v parallel").exit_code != 0) {
    GTEST_SKIP() << "GNU parallel is not installed (tools/install_deps.sh installs it)";
  }
  const fs::path dir = Scratch();
  const Result one = Cli(kSweep + " --jobs 2 --no-plots --out " + (dir / "one").string());
  ASSERT_EQ(one.exit_code, 0) << one.output;
  const std::string table = Read(dir / "one" / "results.csv");
  EXPECT_EQ(std::count(table.begin(), table.end(), '\n'), 5);  // header + 4 runs

  // docs/sweeps.md#beyond-one-machine's recipe: one process per shard, two at a time, one job each.
  const Result shards = Shell("parallel --will-cite --halt now,fail=1 -j 2 \"" + Bin() + " " +
                              kSweep + " --jobs 1 --no-plots --shard {}/4 --out " +
                              (dir / "shard{}").string() + "\" ::: 1 2 3 4");
  ASSERT_EQ(shards.exit_code, 0) << shards.output;
  const Result merge = Cli("sweep merge --no-plots " + (dir / "shard1").string() + " " +
                           (dir / "shard2").string() + " " + (dir / "shard3").string() + " " +
                           (dir / "shard4").string() + " --out " + (dir / "merged").string());
  ASSERT_EQ(merge.exit_code, 0) << merge.output;
  EXPECT_THAT(merge.output, ::testing::Not(HasSubstr("warning")));
  EXPECT_EQ(Read(dir / "merged" / "results.csv"), table);
}

}  // namespace
}  // namespace autonomsim
