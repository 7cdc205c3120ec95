#include "sim/core/files.h"

#include <fcntl.h>
#include <stdio.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "sim/core/config.h"

namespace autonomsim::sim {

namespace fs = std::filesystem;

void RequireRegularFile(const std::filesystem::path& file) {
  std::error_code error;
  const fs::file_status status = fs::status(file, error);
  if (status.type() == fs::file_type::regular) return;
  if (status.type() == fs::file_type::not_found) {
    throw ConfigError(file.string() + ": no such file");
  }
  if (status.type() == fs::file_type::directory) {
    throw ConfigError(file.string() + ": is a folder, not a file");
  }
  if (error) throw ConfigError(file.string() + ": cannot read: " + error.message());
  const char* what =
      status.type() == fs::file_type::fifo     ? "a FIFO (named pipe)"
      : status.type() == fs::file_type::socket ? "a socket"
      : status.type() == fs::file_type::block || status.type() == fs::file_type::character
          ? "a device"
          : "something other than a file";
  throw ConfigError(file.string() + ": is " + std::string(what) +
                    ", not a file; give a regular file (a pipe would be waited on for ever)");
}

void ThrowCannotWrite(const fs::path& file) {
  const int error = errno;
  throw OutputError("cannot write " + file.string() + ": " +
                    (error != 0 ? std::string(std::strerror(error)) : "no reason given by the OS"));
}

void WriteFile(const fs::path& file, const std::string& content) {
  errno = 0;
  std::ofstream out(file, std::ios::binary);
  if (!out) ThrowCannotWrite(file);
  out << content;
  if (!out) ThrowCannotWrite(file);
  out.close();
  if (!out) ThrowCannotWrite(file);
}

void WriteFileAtomically(const fs::path& file, const std::string& content) {
  const fs::path tmp = file.string() + ".tmp-" + std::to_string(::getpid());
  try {
    WriteFile(tmp, content);
    fs::rename(tmp, file);
  } catch (...) {
    std::error_code ignored;
    fs::remove(tmp, ignored);
    throw;
  }
}

namespace {

// What stands at `path` (not following a final symbolic link), for messages; empty if nothing.
std::string KindOf(const fs::file_status& status) {
  switch (status.type()) {
    case fs::file_type::not_found:
      return "";
    case fs::file_type::directory:
      return "a folder";
    case fs::file_type::regular:
      return "a file";
    case fs::file_type::symlink:
      return "a symbolic link";
    case fs::file_type::block:
    case fs::file_type::character:
      return "a device node";
    case fs::file_type::fifo:
      return "a FIFO";
    case fs::file_type::socket:
      return "a socket";
    default:
      return "not a folder";
  }
}

// Every existing ancestor of `target` must be a folder (a file in the way is refused).
template <class Refuse>
void CheckAncestors(const fs::path& target, const Refuse& refuse) {
  for (fs::path ancestor = target.parent_path(); !ancestor.empty();
       ancestor = ancestor.parent_path()) {
    const fs::file_status status = fs::status(ancestor);
    if (fs::is_directory(status)) break;
    if (fs::exists(status)) throw refuse(ancestor.string() + " is " + KindOf(status));
    if (ancestor == ancestor.root_path()) break;
  }
}

}  // namespace

std::string MarkerText(OutputKind kind, const std::vector<std::string>& files) {
  const std::string what =
      kind == OutputKind::kSweep
          ? "Later sweeps may add to or replace what is here."
          : "The next " + std::string(ToName(kind)) + " written here may replace it.";
  std::string text =
      "Written by autonomsim. " + what + "\nkind: " + std::string(ToName(kind)) + "\n";
  if (!files.empty()) {
    text += "files:";
    for (const std::string& f : files) text += " " + f;
    text += "\n";
  }
  return text;
}

namespace {

// The kind a marker names; a marker from before kinds: a sweep's said "add to", the others any.
std::optional<OutputKind> MarkerKind(const fs::path& marker) {
  std::ifstream in(marker);
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("kind: ", 0) == 0) return FromName<OutputKind>(line.substr(6));
    if (line.find("add to") != std::string::npos) return OutputKind::kSweep;
  }
  return std::nullopt;
}

// The files a marker lists as its folder's own.
bool MarkerOwns(const fs::path& marker, const std::string& name) {
  std::ifstream in(marker);
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("files:", 0) != 0) continue;
    std::istringstream words(line.substr(6));
    for (std::string word; words >> word;) {
      if (word == name) return true;
    }
  }
  return false;
}

bool MarkerAllows(const fs::path& marker, OutputKind kind) {
  const std::optional<OutputKind> found = MarkerKind(marker);
  return found ? *found == kind : kind != OutputKind::kSweep;
}

}  // namespace

fs::path CheckOutputFolder(const std::string& given, bool force, OutputKind kind) {
  const auto refuse = [&](const std::string& why) -> ConfigError {
    return ConfigError("--out " + given + ": " + why);
  };
  if (given.empty()) throw refuse("empty path");
  std::string trimmed = given;
  while (trimmed.size() > 1 && trimmed.back() == '/') trimmed.pop_back();
  fs::path target = fs::absolute(trimmed).lexically_normal();
  // "." and ".." normalise to "/work/" style paths: the folder is the one before the slash
  if (target != target.root_path() && target.filename().empty()) target = target.parent_path();
  const fs::path cwd = fs::current_path();
  if (target == target.root_path()) {
    throw refuse("the filesystem root is never replaced");
  }
  const auto [first_difference, unused] =
      std::mismatch(target.begin(), target.end(), cwd.begin(), cwd.end());
  if (first_difference == target.end()) {
    throw refuse("holds the working folder (" + cwd.string() + "): never replaced");
  }
  CheckAncestors(target, refuse);
  const fs::file_status status = fs::symlink_status(target);
  const std::string what_is = KindOf(status);
  if (what_is.empty()) return target;
  const bool marked = fs::is_directory(status) && fs::exists(target / kOutputMarker);
  if (marked && MarkerAllows(target / kOutputMarker, kind)) return target;
  if (fs::is_block_file(status) || fs::is_character_file(status) || fs::is_fifo(status) ||
      fs::is_socket(status)) {
    throw refuse("is " + what_is + ", never replaced");
  }
  if (force) return target;
  const std::string what =
      marked
          ? "is a " + std::string(ToName(*MarkerKind(target / kOutputMarker))) + " folder (its " +
                kOutputMarker + " marker says so), and a " + std::string(ToName(kind)) +
                " replaces only a " + std::string(ToName(kind)) + " folder"
      : fs::is_directory(status) ? "is a folder this program did not write (it has no " +
                                       std::string(kOutputMarker) + " marker)"
                                 : "is " + what_is;
  throw refuse(what + "; choose another --out, or add --force to replace it and all it holds");
}

fs::path PrepareOutputFolder(const std::string& given, bool force) {
  std::string trimmed = given;
  while (trimmed.size() > 1 && trimmed.back() == '/') trimmed.pop_back();
  const bool empty_folder = fs::is_directory(fs::symlink_status(trimmed)) && fs::is_empty(trimmed);
  const fs::path target = CheckOutputFolder(given, force || empty_folder, OutputKind::kSweep);
  if (fs::exists(fs::symlink_status(target)) && !fs::is_directory(fs::symlink_status(target))) {
    throw ConfigError("--out " + given + ": is not a folder; choose another --out");
  }
  fs::create_directories(target);
  if (!fs::exists(target / kOutputMarker) || !MarkerKind(target / kOutputMarker)) {
    WriteFile(target / kOutputMarker, MarkerText(OutputKind::kSweep));
  }
  return target;
}

fs::path CheckOutputFile(const std::string& given, bool force, const std::string& signature,
                         const std::string& option) {
  const auto refuse = [&](const std::string& why) -> ConfigError {
    return ConfigError(option + " " + given + ": " + why);
  };
  if (given.empty()) throw refuse("empty path");
  const fs::path target = fs::absolute(given).lexically_normal();
  if (target.filename().empty()) throw refuse("names a folder; give a file name");
  CheckAncestors(target, refuse);
  const fs::file_status status = fs::symlink_status(target);
  const std::string kind = KindOf(status);
  if (kind.empty()) {
    fs::create_directories(target.parent_path());
    return target;
  }
  if (fs::is_directory(status) || fs::is_block_file(status) || fs::is_character_file(status) ||
      fs::is_fifo(status) || fs::is_socket(status)) {
    throw refuse("is " + kind + ", never replaced by a file");
  }
  if (force) return target;
  if (fs::is_regular_file(status)) {
    if (!signature.empty()) {
      std::ifstream in(target, std::ios::binary);
      std::string head(4096, '\0');
      in.read(head.data(), static_cast<std::streamsize>(head.size()));
      head.resize(static_cast<std::size_t>(in.gcount()));
      if (head.find(signature) != std::string::npos) return target;
    }
    const fs::path marker = target.parent_path() / kOutputMarker;
    if (fs::exists(marker)) {
      if (MarkerOwns(marker, target.filename().string())) {
        throw refuse("is one of its run's own files; choose another " + option);
      }
      return target;
    }
  }
  throw refuse("is " + kind + " this program did not write; choose another " + option +
               ", or add --force to replace it");
}

namespace {

// What identifies the folder at `path` and its state: device, inode and status-change time (a new
// folder in the place of a removed one may get the same inode; one whose entries changed has
// another ctime), or nullopt when nothing is there.
std::optional<FolderState> StateOf(const fs::path& path) {
  struct stat st {};
  if (::lstat(path.c_str(), &st) != 0) return std::nullopt;
  return FolderState{static_cast<std::uint64_t>(st.st_dev), static_cast<std::uint64_t>(st.st_ino),
                     static_cast<std::int64_t>(st.st_ctim.tv_sec) * 1'000'000'000 +
                         static_cast<std::int64_t>(st.st_ctim.tv_nsec)};
}

// "<target>-2", "<target>-3", ...: the first that nothing holds.
fs::path FreeSibling(const fs::path& target) {
  for (int n = 2;; ++n) {
    fs::path candidate = target.string() + "-" + std::to_string(n);
    if (!fs::exists(fs::symlink_status(candidate))) return candidate;
  }
}

}  // namespace

PartialFolder::PartialFolder(const fs::path& target, bool force, OutputKind kind)
    : target_(CheckOutputFolder(target.string(), force, kind)),
      kind_(kind),
      checked_(StateOf(target_)) {
  fs::create_directories(target_.parent_path());
  // a name of its own, also beside another PartialFolder of this process for the same target
  for (int k = 0;; ++k) {
    partial_ = target_.string() + ".partial-" + std::to_string(::getpid()) +
               (k == 0 ? std::string() : "-" + std::to_string(k));
    if (fs::create_directory(partial_)) break;
  }
}

PartialFolder::~PartialFolder() {
  if (committed_) return;
  std::error_code ignored;
  fs::remove_all(partial_, ignored);
}

void PartialFolder::Commit() {
  std::vector<std::string> own;
  for (const auto& entry : fs::directory_iterator(partial_)) {
    if (entry.is_regular_file()) own.push_back(entry.path().filename().string());
  }
  std::sort(own.begin(), own.end());
  WriteFile(partial_ / kOutputMarker, MarkerText(kind_, own));
  // The target is replaced only if it is still what was checked before the run: nothing, or the
  // same folder, unchanged. Whatever appeared or changed there meanwhile is left alone, and the
  // result is kept beside it.
  const std::optional<FolderState> now = StateOf(target_);
  const auto keep_beside = [&](const char* why) {
    const fs::path kept = FreeSibling(target_);
    fs::rename(partial_, kept);
    committed_ = true;
    throw ConfigError("--out " + target_.string() + ": " + why +
                      ", so it is left as it is; the results are in " + kept.string());
  };
  if (now != checked_) keep_beside(checked_ ? "changed during the run" : "appeared during the run");
  if (now) {
    const fs::path old = target_.string() + ".old-" + std::to_string(::getpid());
    fs::rename(target_, old);
    fs::rename(partial_, target_);
    fs::remove_all(old);
  } else if (::renameat2(AT_FDCWD, partial_.c_str(), AT_FDCWD, target_.c_str(), RENAME_NOREPLACE) !=
             0) {
    keep_beside("appeared during the run");
  }
  committed_ = true;
}

void WriteFolderAtomically(const fs::path& target_dir,
                           const std::function<void(const fs::path& partial)>& fill, bool force,
                           OutputKind kind) {
  PartialFolder folder(target_dir, force, kind);
  fill(folder.path());
  folder.Commit();
}

}  // namespace autonomsim::sim
