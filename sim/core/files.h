// Files written so that nothing half-written ever looks complete (ARCHITECTURE: results are
// written to a temporary name and renamed when complete).
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "world/enum_names.h"

namespace autonomsim::sim {

// Throws ConfigError naming `file` and what it is unless it is a regular file (or a link to one):
// no such file, a folder, or a FIFO, device or socket (reading a FIFO would wait for ever for a
// writer). Every input file goes through it before it is opened.
void RequireRegularFile(const std::filesystem::path& file);

// The program could not write its output: a full disk, a permission, an I/O error. The CLI exits 2
// (the run could not be made, not "an expectation failed") with the path and the OS's reason.
class OutputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};
// Throws OutputError "cannot write FILE: <the OS's reason>", the reason from errno as it stands
// (call it right after the failed write).
[[noreturn]] void ThrowCannotWrite(const std::filesystem::path& file);

// Writes `content` to `file`; throws OutputError naming the file and the OS's reason on failure.
void WriteFile(const std::filesystem::path& file, const std::string& content);

// Writes `content` to `file` through a sibling "<file>.tmp-<pid>" renamed over it, so a reader
// sees the previous file or the new one, never half of one (one writer per file at a time in a
// process). On failure the temporary is removed and the error (a std::runtime_error naming the
// file) propagates.
void WriteFileAtomically(const std::filesystem::path& file, const std::string& content);
// Output folders. Every folder this program writes (a run, a render, a sweep) carries this marker
// file, which names its kind; only a folder that has it, of the same kind, is ever replaced,
// unless the user says --force. (check's result folders are run folders.) A marker written
// before kinds were recorded: a sweep's says it accumulates ("add to"), the others are taken as
// any kind but a sweep.
inline constexpr const char* kOutputMarker = ".autonomsim";
enum class OutputKind { kRun, kRender, kSweep };
}  // namespace autonomsim::sim

namespace autonomsim {
template <>
struct NameTable<sim::OutputKind> {  // ToName / FromName: "run", "render", "sweep"
  static constexpr std::array<std::pair<sim::OutputKind, std::string_view>, 3> kEntries{
      {{sim::OutputKind::kRun, "run"},
       {sim::OutputKind::kRender, "render"},
       {sim::OutputKind::kSweep, "sweep"}}};
};
}  // namespace autonomsim

namespace autonomsim::sim {
// The marker's text for a folder of `kind` that holds `files` (its own: nothing writes over them
// without --force; CheckOutputFile).
std::string MarkerText(OutputKind kind, const std::vector<std::string>& files = {});

// The folder `given` (as the user wrote it; a trailing slash is allowed) checked as the target of
// an output that replaces it: it may be absent (its parent is created; every existing ancestor
// must be a folder), or a folder this program wrote. Throws ConfigError (exit 2), before anything
// runs, for the filesystem root or a folder holding the working folder (never replaced), a device
// node, FIFO or socket (never replaced), and — unless `force` — a folder without the marker, a
// file or a symbolic link. Returns the path to use.
// A folder with the marker of another kind is refused like one without it (its kind named).
std::filesystem::path CheckOutputFolder(const std::string& given, bool force,
                                        OutputKind kind = OutputKind::kRun);

// The file `given` checked as the target of an output written over it (a report, a video): it may
// be absent (its parent folder is created), or a plain file this program wrote — one whose first
// 4 KiB hold `signature` (when not empty), or one inside a folder with the marker that is not one
// of the folder's own files (a run's summary.json, trajectory.csv, ...: its marker lists them).
// Throws ConfigError (exit 2), before anything is made, for a folder, a device node, FIFO or socket
// (never replaced), and — unless `force` — any other existing file or symbolic link. Returns the
// path to use.
// `option`: the command-line option that named the file, for the messages.
std::filesystem::path CheckOutputFile(const std::string& given, bool force,
                                      const std::string& signature = "",
                                      const std::string& option = "--out");

// A folder that outputs accumulate in (a sweep's: it is resumed, never replaced): created if
// absent and given the marker. An empty folder is taken; one that holds anything without the
// marker is refused unless `force`; otherwise CheckOutputFolder's rules, except that a file is
// refused even with `force`. Returns the path to use.
std::filesystem::path PrepareOutputFolder(const std::string& given, bool force);

// A folder written under a temporary name and renamed to its target when complete, for outputs
// written over time (a run streams its trajectory into its folder): the constructor checks the
// target (CheckOutputFolder, before anything runs) and creates "<target>.partial-<pid>"; Commit
// gives it the marker and renames it to the target, replacing a previous one only then, and only
// if the target is still what the constructor checked (nothing, or the same folder, unchanged): a
// folder that appeared there meanwhile, or replaced or changed the checked one, is left alone, the
// result is renamed to the first free "<target>-2", "<target>-3", ... and Commit throws ConfigError
// (exit 2) saying where it is. Destroyed uncommitted (an error, an exception), it removes the
// partial folder: nothing half-written is left looking complete. A folder's device, inode and
// status-change time (ns): equal while nothing replaced or changed it.
struct FolderState {
  std::uint64_t device{0};
  std::uint64_t inode{0};
  std::int64_t ctime_ns{0};
  friend bool operator==(const FolderState&, const FolderState&) = default;
};

class PartialFolder {
 public:
  PartialFolder(const std::filesystem::path& target, bool force,
                OutputKind kind = OutputKind::kRun);
  ~PartialFolder();
  PartialFolder(const PartialFolder&) = delete;
  PartialFolder& operator=(const PartialFolder&) = delete;

  const std::filesystem::path& path() const { return partial_; }  // write here
  const std::filesystem::path& target() const { return target_; }
  void Commit();

 private:
  std::filesystem::path target_;
  OutputKind kind_;
  std::optional<FolderState> checked_;  // the target when checked (nullopt: nothing was there)
  std::filesystem::path partial_;
  bool committed_{false};
};

// Creates `target` by letting `fill` write into a sibling "<target>.partial-<pid>" folder and
// renaming it to `target` when `fill` returns; a previous `target` is replaced only then, and only
// if CheckOutputFolder(target, force) allows it (checked first, before `fill` runs). The folder
// gets the marker. If `fill` throws, the partial folder is removed and the exception propagates.
void WriteFolderAtomically(const std::filesystem::path& target,
                           const std::function<void(const std::filesystem::path& partial)>& fill,
                           bool force = false, OutputKind kind = OutputKind::kRun);

}  // namespace autonomsim::sim
