#include "sim/core/files.h"

#include <unistd.h>

#include <algorithm>
#include <fstream>
#include <stdexcept>

#include "sim/core/config.h"

namespace autonomsim::sim {

namespace fs = std::filesystem;

void WriteFile(const fs::path& file, const std::string& content) {
  std::ofstream out(file, std::ios::binary);
  out << content;
  out.close();
  if (!out) throw std::runtime_error("cannot write " + file.string());
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

fs::path CheckOutputFolder(const std::string& given, bool force) {
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
  const std::string kind = KindOf(status);
  if (kind.empty()) return target;
  if (fs::is_directory(status) && fs::exists(target / kOutputMarker)) return target;
  if (fs::is_block_file(status) || fs::is_character_file(status) || fs::is_fifo(status) ||
      fs::is_socket(status)) {
    throw refuse("is " + kind + ", never replaced");
  }
  if (force) return target;
  const std::string what = fs::is_directory(status)
                               ? "is a folder this program did not write (it has no " +
                                     std::string(kOutputMarker) + " marker)"
                               : "is " + kind;
  throw refuse(what + "; choose another --out, or add --force to replace it and all it holds");
}

fs::path PrepareOutputFolder(const std::string& given, bool force) {
  std::string trimmed = given;
  while (trimmed.size() > 1 && trimmed.back() == '/') trimmed.pop_back();
  const bool empty_folder = fs::is_directory(fs::symlink_status(trimmed)) && fs::is_empty(trimmed);
  const fs::path target = CheckOutputFolder(given, force || empty_folder);
  if (fs::exists(fs::symlink_status(target)) && !fs::is_directory(fs::symlink_status(target))) {
    throw ConfigError("--out " + given + ": is not a folder; choose another --out");
  }
  fs::create_directories(target);
  if (!fs::exists(target / kOutputMarker)) {
    WriteFile(target / kOutputMarker,
              "Written by autonomsim. Later outputs may add to or replace what is here.\n");
  }
  return target;
}

fs::path CheckOutputFile(const std::string& given, bool force, const std::string& signature) {
  const auto refuse = [&](const std::string& why) -> ConfigError {
    return ConfigError("--out " + given + ": " + why);
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
    if (fs::exists(target.parent_path() / kOutputMarker)) return target;
    if (!signature.empty()) {
      std::ifstream in(target, std::ios::binary);
      std::string head(4096, '\0');
      in.read(head.data(), static_cast<std::streamsize>(head.size()));
      head.resize(static_cast<std::size_t>(in.gcount()));
      if (head.find(signature) != std::string::npos) return target;
    }
  }
  throw refuse("is " + kind +
               " this program did not write; choose another --out, or add --force to replace it");
}

PartialFolder::PartialFolder(const fs::path& target, bool force)
    : target_(CheckOutputFolder(target.string(), force)),
      partial_(target_.string() + ".partial-" + std::to_string(::getpid())) {
  fs::create_directories(target_.parent_path());
  fs::remove_all(partial_);
  fs::create_directory(partial_);
}

PartialFolder::~PartialFolder() {
  if (committed_) return;
  std::error_code ignored;
  fs::remove_all(partial_, ignored);
}

void PartialFolder::Commit() {
  WriteFile(partial_ / kOutputMarker,
            "Written by autonomsim. The next output written here may replace this folder.\n");
  if (fs::exists(fs::symlink_status(target_))) {
    const fs::path old = target_.string() + ".old-" + std::to_string(::getpid());
    fs::rename(target_, old);
    fs::rename(partial_, target_);
    fs::remove_all(old);
  } else {
    fs::rename(partial_, target_);
  }
  committed_ = true;
}

void WriteFolderAtomically(const fs::path& target_dir,
                           const std::function<void(const fs::path& partial)>& fill, bool force) {
  PartialFolder folder(target_dir, force);
  fill(folder.path());
  folder.Commit();
}

}  // namespace autonomsim::sim
