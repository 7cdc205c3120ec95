// --out never destroys what this program did not write (issue 15): a folder of someone's notes, a
// file, a device node, the working folder. Each refusal comes before the simulation runs.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>

#include <filesystem>
#include <fstream>

#include "tools/tests/cli_testing.h"

namespace autonomsim::testing {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using ::testing::Not;

constexpr const char* kQuick = "scenarios/intersection_conflict.yaml -q";

fs::path Scratch() { return testing::Scratch("output_safety"); }

void WriteText(const fs::path& file, const std::string& text) { std::ofstream(file) << text; }

TEST(OutputSafety, AFolderItDidNotWriteIsRefusedUnlessForced) {
  const fs::path notes = Scratch() / "notes";
  fs::create_directories(notes);
  WriteText(notes / "ideas.txt", "precious");
  const Result refused = Cli(std::string("run ") + kQuick + " --out " + notes.string());
  EXPECT_EQ(refused.exit_code, 2) << refused.output;
  EXPECT_THAT(refused.output, HasSubstr("did not write"));
  EXPECT_THAT(refused.output, HasSubstr("--force"));
  EXPECT_THAT(refused.output, Not(HasSubstr("simulated in")));  // refused before the run
  EXPECT_EQ(Read(notes / "ideas.txt"), "precious");
  EXPECT_EQ(std::distance(fs::directory_iterator(notes.parent_path()), fs::directory_iterator()),
            1);  // nothing half-written beside it

  const Result forced = Cli(std::string("run ") + kQuick + " --force --out " + notes.string());
  EXPECT_EQ(forced.exit_code, 0) << forced.output;
  EXPECT_FALSE(fs::exists(notes / "ideas.txt"));
  EXPECT_TRUE(fs::exists(notes / "summary.json"));
  // now it is ours: replaced without --force
  EXPECT_EQ(Cli(std::string("run ") + kQuick + " --out " + notes.string()).exit_code, 0);
}

TEST(OutputSafety, AFileIsRefusedUnlessForced) {
  const fs::path file = Scratch() / "thesis.tex";
  WriteText(file, "chapter 1");
  const Result refused = Cli(std::string("run ") + kQuick + " --out " + file.string());
  EXPECT_EQ(refused.exit_code, 2) << refused.output;
  EXPECT_THAT(refused.output, HasSubstr("is a file"));
  EXPECT_EQ(Read(file), "chapter 1");
  EXPECT_EQ(Cli(std::string("run ") + kQuick + " --force --out " + file.string()).exit_code, 0);
  EXPECT_TRUE(fs::is_directory(file));
}

TEST(OutputSafety, ADeviceNodeIsNeverReplaced) {
  const fs::path device = Scratch() / "null";
  // the same device as /dev/null, made in the scratch folder (never touch /dev itself)
  if (::mknod(device.c_str(), S_IFCHR | 0666, ::makedev(1, 3)) != 0) {
    GTEST_SKIP() << "mknod needs root here";
  }
  for (const char* force : {"", " --force"}) {
    const Result r = Cli(std::string("run ") + kQuick + force + " --out " + device.string());
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_THAT(r.output, HasSubstr("device node"));
    EXPECT_TRUE(fs::is_character_file(device));
  }
}

TEST(OutputSafety, TheWorkingFolderAndTheRootAreRefusedAtOnce) {
  for (const char* out : {".", "./", "..", "/"}) {
    const Result r = Cli(std::string("run ") + kQuick + " --force --out " + out);
    EXPECT_EQ(r.exit_code, 2) << out << ": " << r.output;
    EXPECT_THAT(r.output, Not(HasSubstr("simulated in"))) << out;
    // the reason given is the true one
    EXPECT_THAT(r.output, HasSubstr(std::string(out) == "/" ? "the filesystem root"
                                                            : "holds the working folder"))
        << out;
  }
  EXPECT_TRUE(fs::exists("CMakeLists.txt"));  // still here
}

TEST(OutputSafety, ATrailingSlashNamesTheSameFolder) {
  const fs::path out = Scratch() / "results";
  const Result r = Cli(std::string("run ") + kQuick + " --out " + out.string() + "/");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(fs::exists(out / "summary.json"));
  EXPECT_EQ(std::distance(fs::directory_iterator(out.parent_path()), fs::directory_iterator()), 1);
}

TEST(OutputSafety, APathThroughAFileIsRefusedBeforeTheRun) {
  const fs::path file = Scratch() / "a_file";
  WriteText(file, "x");
  const Result r = Cli(std::string("run ") + kQuick + " --out " + (file / "sub").string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_THAT(r.output, HasSubstr("is a file"));
  EXPECT_THAT(r.output, Not(HasSubstr("simulated in")));
}

TEST(OutputSafety, RenderAndCheckRefuseToo) {
  const fs::path dir = Scratch();
  const fs::path notes = dir / "notes";
  fs::create_directories(notes / "intersection_conflict");
  WriteText(notes / "intersection_conflict" / "keep.txt", "mine");
  const Result check = Cli("check scenarios/intersection_conflict.yaml --out " + notes.string());
  EXPECT_EQ(check.exit_code, 2) << check.output;
  EXPECT_EQ(Read(notes / "intersection_conflict" / "keep.txt"), "mine");
  const Result render = Cli("render scenarios/intersection_conflict.yaml --car 0 --at 1 --out " +
                            (notes / "intersection_conflict").string());
  EXPECT_EQ(render.exit_code, 2) << render.output;
  EXPECT_EQ(Read(notes / "intersection_conflict" / "keep.txt"), "mine");
  // check's folders are its own afterwards
  const fs::path ours = dir / "ours";
  ASSERT_EQ(Cli("check scenarios/intersection_conflict.yaml --out " + ours.string()).exit_code, 0);
  EXPECT_EQ(Cli("check scenarios/intersection_conflict.yaml --out " + ours.string()).exit_code, 0);
}

// Issue 33: two scenario files of one name in different folders wrote one result folder through
// one temporary name (with --jobs 2 a false "cannot write", or a folder mixing one run's summary
// with the other's trajectory). check now refuses them before anything runs.
TEST(OutputSafety, CheckRefusesTwoScenariosThatWouldWriteOneResultFolder) {
  const fs::path dir = Scratch();
  fs::create_directories(dir / "a");
  fs::create_directories(dir / "b");
  fs::copy_file("scenarios/intersection_conflict.yaml", dir / "a" / "x.yaml");
  fs::copy_file("scenarios/intersection_conflict.yaml", dir / "b" / "x.yaml");
  const Result both =
      Cli("check " + (dir / "a" / "x.yaml").string() + " " + (dir / "b" / "x.yaml").string() +
          " --jobs 2 --out " + (dir / "out").string());
  EXPECT_EQ(both.exit_code, 2) << both.output;
  EXPECT_THAT(both.output, HasSubstr("both have the name 'x'"));
  EXPECT_THAT(both.output, Not(HasSubstr("pass ")));  // refused before anything ran
  EXPECT_FALSE(fs::exists(dir / "out"));
  // without --out nothing is written, so nothing can mix: both run
  EXPECT_NE(Cli("check " + (dir / "a").string() + " " + (dir / "b").string()).exit_code, 2);
}

// Issue 33: `run --out` at a sweep's folder replaced the whole sweep (with the notes a user added);
// `report RUN --out RUN/trajectory.csv` overwrote the trajectory.
TEST(OutputSafety, ACommandReplacesOnlyItsOwnKindAndNeverARunsFiles) {
  const fs::path dir = Scratch();
  const fs::path sweep = dir / "sweep";
  fs::create_directories(sweep);
  WriteText(sweep / ".autonomsim", "Written by autonomsim.\nkind: sweep\n");
  WriteText(sweep / "notes.txt", "precious");
  const Result run = Cli(std::string("run ") + kQuick + " --out " + sweep.string());
  EXPECT_EQ(run.exit_code, 2) << run.output;
  EXPECT_THAT(run.output, HasSubstr("is a sweep folder"));
  EXPECT_EQ(Read(sweep / "notes.txt"), "precious");

  const fs::path ours = dir / "run";
  ASSERT_EQ(Cli(std::string("run ") + kQuick + " --out " + ours.string()).exit_code, 0);
  const std::string trajectory = Read(ours / "trajectory.csv");
  const Result report =
      Cli("report " + ours.string() + " --out " + (ours / "trajectory.csv").string());
  EXPECT_EQ(report.exit_code, 2) << report.output;
  EXPECT_THAT(report.output, HasSubstr("own files"));
  EXPECT_EQ(Read(ours / "trajectory.csv"), trajectory);
  EXPECT_EQ(Cli("report " + ours.string()).exit_code, 0);  // its report.html, again and again
  EXPECT_EQ(Cli("report " + ours.string()).exit_code, 0);
}

// Issue 33, item 2: Ctrl-C left `.partial-<pid>` folders that only the sweep section of the docs
// explained. The first SIGINT stops the command at the next simulated second: exit 130, the run in
// flight unwound with its partial folder, a sweep's complete runs kept (and resumed from). The
// signal is sent once the command has said it is under way, so no timing is assumed.
std::string Interrupt(const std::string& args, const std::string& under_way, const fs::path& log) {
  return "(" + testing::Bin() + " " + args + " > " + log.string() +
         " 2>&1 & pid=$!; for i in $(seq 1200); do grep -q '" + under_way + "' " + log.string() +
         " && break; sleep 0.05; done; kill -INT $pid; wait $pid; echo \"exit $?\")";
}

TEST(OutputSafety, CtrlCLeavesNoPartialFolderAndASweepResumes) {
  const fs::path dir = Scratch() / "interrupted";
  fs::create_directories(dir);
  const Result run =
      Shell(Interrupt("run scenarios/lab_two_cars_oracle.yaml --set duration_s=2000 "
                      "--set 'expect=[]' --out " +
                          (dir / "run").string(),
                      "s simulated", dir / "run.log"));
  EXPECT_THAT(run.output, HasSubstr("exit 130"));
  EXPECT_THAT(testing::Read(dir / "run.log"), HasSubstr("interrupted"));
  EXPECT_FALSE(fs::exists(dir / "run"));
  for (const auto& entry : fs::directory_iterator(dir)) {
    EXPECT_EQ(entry.path().filename().string().find(".partial"), std::string::npos) << entry.path();
  }
  const std::string sweep =
      "sweep scenarios/lab_two_cars_oracle.yaml --set duration_s=600 --set "
      "'expect=[]' --vary seed=1,2,3 --jobs 1 --no-plots --out " +
      (dir / "sweep").string();
  const Result stopped = Shell(Interrupt(sweep, "1/3 runs done", dir / "sweep.log"));
  EXPECT_THAT(stopped.output, HasSubstr("exit 130"));
  EXPECT_THAT(testing::Read(dir / "sweep.log"), HasSubstr("interrupted after 1 run(s)"));
  std::size_t runs = 0;
  for (const auto& entry : fs::directory_iterator(dir / "sweep" / "runs")) {
    EXPECT_EQ(entry.path().filename().string().find(".partial"), std::string::npos) << entry.path();
    ++runs;
  }
  EXPECT_EQ(runs, 1u);
  const Result resumed = Cli(sweep + " --quiet");
  EXPECT_EQ(resumed.exit_code, 0) << resumed.output;
  EXPECT_THAT(resumed.output, HasSubstr("2 ran, 1 already complete"));
}

}  // namespace
}  // namespace autonomsim::testing
