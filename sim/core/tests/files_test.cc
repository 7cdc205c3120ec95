// Atomic files and folders: a reader finds the old content or the new, and nothing is left behind.
#include "sim/core/files.h"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>

#include "sim/core/config.h"

namespace autonomsim::sim {
namespace {

namespace fs = std::filesystem;

std::string ReadText(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

struct TempDir {
  TempDir() {
    path = fs::temp_directory_path() /
           ("autonomsim_files_test_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~TempDir() { fs::remove_all(path); }
  fs::path path;
};

std::size_t Entries(const fs::path& dir) {
  return static_cast<std::size_t>(
      std::distance(fs::directory_iterator(dir), fs::directory_iterator()));
}

// Issue 33, item 4: a FIFO given as scenario or track hung for ever (a read waits for a writer).
std::string RegularFileError(const fs::path& file) {
  try {
    RequireRegularFile(file);
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "(accepted)";
}

TEST(Files, OnlyARegularFileIsAnInput) {
  TempDir dir;
  std::ofstream(dir.path / "x.yaml") << "a: 1\n";
  fs::create_symlink(dir.path / "x.yaml", dir.path / "link.yaml");
  ASSERT_EQ(::mkfifo((dir.path / "pipe.yaml").c_str(), 0600), 0);
  EXPECT_EQ(RegularFileError(dir.path / "x.yaml"), "(accepted)");
  EXPECT_EQ(RegularFileError(dir.path / "link.yaml"), "(accepted)");  // a link to a file
  EXPECT_NE(RegularFileError(dir.path / "pipe.yaml")
                .find("pipe.yaml: is a FIFO (named pipe), not "
                      "a file"),
            std::string::npos);
  EXPECT_NE(RegularFileError("/dev/null").find("/dev/null: is a device"), std::string::npos);
  EXPECT_NE(RegularFileError(dir.path).find(": is a folder"), std::string::npos);
  EXPECT_NE(RegularFileError(dir.path / "none.yaml").find("none.yaml: no such file"),
            std::string::npos);
  // the YAML reader (scenarios, tracks, profiles, studies) refuses it at once
  EXPECT_THROW(LoadYamlFile(dir.path / "pipe.yaml"), ConfigError);
}

// Issue 33, item 4: a write that fails says the OS's reason (/dev/full: a disk with no room).
TEST(Files, AFailedWriteSaysThePathAndTheOsReason) {
  try {
    WriteFile("/dev/full", std::string(1 << 16, 'x'));
    FAIL() << "a write to /dev/full succeeded";
  } catch (const OutputError& e) {
    EXPECT_STREQ(e.what(), "cannot write /dev/full: No space left on device");
  }
}

TEST(Files, AnAtomicWriteReplacesTheFileAndLeavesNoTemporary) {
  TempDir dir;
  const fs::path file = dir.path / "results.csv";
  WriteFileAtomically(file, "a,b\n");
  EXPECT_EQ(ReadText(file), "a,b\n");
  WriteFileAtomically(file, "c\n");
  EXPECT_EQ(ReadText(file), "c\n");
  EXPECT_EQ(Entries(dir.path), 1u);
}

TEST(Files, AFailedAtomicWriteThrowsNamingTheFileAndKeepsTheOldOne) {
  TempDir dir;
  const fs::path file = dir.path / "sweep.json";
  WriteFileAtomically(file, "old");
  fs::create_directory(dir.path / "in_the_way");
  try {
    // a folder where the file should go: the rename fails after the temporary is written
    WriteFileAtomically(dir.path / "in_the_way", "new");
    FAIL() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("in_the_way"), std::string::npos) << e.what();
  }
  EXPECT_EQ(ReadText(file), "old");
  EXPECT_EQ(Entries(dir.path), 2u);  // sweep.json and the folder, no temporary
  EXPECT_THROW(WriteFileAtomically(dir.path / "no" / "such" / "folder", "x"), std::runtime_error);
}

TEST(Files, AnOutputFileReplacesOnlyWhatThisProgramWrote) {
  TempDir dir;
  const fs::path fresh = dir.path / "new" / "report.html";
  EXPECT_EQ(CheckOutputFile(fresh.string(), false), fresh);
  EXPECT_TRUE(fs::is_directory(fresh.parent_path()));  // made for the file
  WriteFile(dir.path / "notes.html", "<p>my notes</p>");
  EXPECT_THROW(CheckOutputFile((dir.path / "notes.html").string(), false, "autonomsim report"),
               ConfigError);
  EXPECT_NO_THROW(CheckOutputFile((dir.path / "notes.html").string(), true));  // --force
  WriteFile(dir.path / "old.html", "<meta name=generator content=\"autonomsim report\">");
  EXPECT_NO_THROW(CheckOutputFile((dir.path / "old.html").string(), false, "autonomsim report"));
  EXPECT_THROW(CheckOutputFile((dir.path / "old.html").string(), false), ConfigError);
  try {  // a folder is never replaced by a file, even with --force
    CheckOutputFile(dir.path.string(), true);
    FAIL() << "no error";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("a folder, never replaced"), std::string::npos)
        << e.what();
  }
  fs::create_directory(dir.path / "run");
  WriteFile(dir.path / "run" / kOutputMarker, "");
  WriteFile(dir.path / "run" / "video.mp4", "x");
  EXPECT_NO_THROW(CheckOutputFile((dir.path / "run" / "video.mp4").string(), false));
  EXPECT_THROW(CheckOutputFile((dir.path / "notes.html" / "x").string(), true), ConfigError);
}

TEST(Files, AFolderWrittenAtomicallyAppearsWhole) {
  TempDir dir;
  const fs::path target = dir.path / "run";
  WriteFolderAtomically(target, [](const fs::path& partial) { WriteFile(partial / "a", "1"); });
  EXPECT_EQ(ReadText(target / "a"), "1");
  EXPECT_THROW(WriteFolderAtomically(target,
                                     [](const fs::path& partial) {
                                       WriteFile(partial / "a", "2");
                                       throw std::runtime_error("killed");
                                     }),
               std::runtime_error);
  EXPECT_EQ(ReadText(target / "a"), "1");  // the previous folder stays
  EXPECT_EQ(Entries(dir.path), 1u);        // and no partial one
}

// Issue 33: --out was checked only before the run; a folder that appeared there during the run
// was deleted when the run finished. Now it is left alone and the result goes beside it.
TEST(Files, AFolderThatAppearsDuringTheRunIsNeverReplaced) {
  TempDir dir;
  const fs::path target = dir.path / "run";
  PartialFolder folder(target, false);
  WriteFile(folder.path() / "a", "result");
  fs::create_directory(target);  // someone else's, meanwhile
  WriteFile(target / "notes.txt", "mine");
  try {
    folder.Commit();
    ADD_FAILURE() << "Commit replaced a folder that appeared during the run";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("appeared during the run"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find((dir.path / "run-2").string()), std::string::npos)
        << e.what();
  }
  EXPECT_EQ(ReadText(target / "notes.txt"), "mine");
  EXPECT_EQ(ReadText(dir.path / "run-2" / "a"), "result");
  EXPECT_TRUE(fs::exists(dir.path / "run-2" / kOutputMarker));
  EXPECT_EQ(Entries(dir.path), 2u);  // no partial folder left
}

TEST(Files, AFolderReplacedDuringTheRunIsNeverReplacedInTurn) {
  TempDir dir;
  const fs::path target = dir.path / "run";
  WriteFolderAtomically(target, [](const fs::path& partial) { WriteFile(partial / "a", "old"); });
  WriteFolderAtomically(dir.path / "run-2", [](const fs::path& p) { WriteFile(p / "a", "x"); });
  PartialFolder folder(target, false);  // checked: our old run, replaceable
  WriteFile(folder.path() / "a", "new");
  fs::remove_all(target);  // meanwhile another program's output takes its place
  fs::create_directory(target);
  WriteFile(target / "a", "theirs");
  EXPECT_THROW(folder.Commit(), ConfigError);
  EXPECT_EQ(ReadText(target / "a"), "theirs");
  EXPECT_EQ(ReadText(dir.path / "run-3" / "a"), "new");  // run-2 was taken
  // unchanged since the check: replaced as before
  PartialFolder again(target / ".." / "run-3", false);
  WriteFile(again.path() / "a", "newer");
  again.Commit();
  EXPECT_EQ(ReadText(dir.path / "run-3" / "a"), "newer");
}

// Issue 33: `run --out` at a sweep's folder replaced the whole sweep, and `report RUN --out
// RUN/trajectory.csv` wrote over the run's trajectory. The marker names the folder's kind and
// its own files.
TEST(Files, ACommandReplacesOnlyAFolderOfItsKindAndNeverARunsOwnFiles) {
  TempDir dir;
  const fs::path sweep = PrepareOutputFolder((dir.path / "sweep").string(), false);
  EXPECT_THROW(CheckOutputFolder(sweep.string(), false), ConfigError);  // a run
  EXPECT_THROW(CheckOutputFolder(sweep.string(), false, OutputKind::kRender), ConfigError);
  try {
    CheckOutputFolder(sweep.string(), false);
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("is a sweep folder"), std::string::npos) << e.what();
  }
  EXPECT_NO_THROW(CheckOutputFolder(sweep.string(), true));     // --force
  EXPECT_NO_THROW(PrepareOutputFolder(sweep.string(), false));  // a sweep resumes it

  const fs::path run = dir.path / "run";
  WriteFolderAtomically(run, [](const fs::path& p) { WriteFile(p / "trajectory.csv", "t"); });
  EXPECT_NO_THROW(CheckOutputFolder(run.string(), false));
  EXPECT_THROW(CheckOutputFolder(run.string(), false, OutputKind::kRender), ConfigError);
  EXPECT_THROW(PrepareOutputFolder(run.string(), false), ConfigError);
  EXPECT_THROW(CheckOutputFile((run / "trajectory.csv").string(), false), ConfigError);
  EXPECT_NO_THROW(CheckOutputFile((run / "replay.mp4").string(), false));  // not its own
  EXPECT_NO_THROW(CheckOutputFile((run / "trajectory.csv").string(), true));

  // markers from before kinds: a sweep's said "add to"; the others serve run and render
  fs::create_directory(dir.path / "old_sweep");
  WriteFile(dir.path / "old_sweep" / kOutputMarker,
            "Written by autonomsim. Later outputs may add to or replace what is here.\n");
  EXPECT_THROW(CheckOutputFolder((dir.path / "old_sweep").string(), false), ConfigError);
  fs::create_directory(dir.path / "old_run");
  WriteFile(dir.path / "old_run" / kOutputMarker,
            "Written by autonomsim. The next output written here may replace this folder.\n");
  EXPECT_NO_THROW(CheckOutputFolder((dir.path / "old_run").string(), false));
  EXPECT_NO_THROW(CheckOutputFolder((dir.path / "old_run").string(), false, OutputKind::kRender));
  EXPECT_THROW(PrepareOutputFolder((dir.path / "old_run").string(), false), ConfigError);
}

TEST(Files, TwoPartialFoldersOfOneProcessForOneTargetDoNotShareTheirFolder) {
  TempDir dir;
  PartialFolder a(dir.path / "x", false);
  PartialFolder b(dir.path / "x", false);
  EXPECT_NE(a.path(), b.path());
  WriteFile(a.path() / "f", "a");
  WriteFile(b.path() / "f", "b");
  a.Commit();
  EXPECT_THROW(b.Commit(), ConfigError);  // a's result appeared meanwhile: b's goes beside it
  EXPECT_EQ(ReadText(dir.path / "x" / "f"), "a");
  EXPECT_EQ(ReadText(dir.path / "x-2" / "f"), "b");
}

}  // namespace
}  // namespace autonomsim::sim
