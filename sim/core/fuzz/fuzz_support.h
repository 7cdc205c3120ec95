// What the libFuzzer targets (<module>/fuzz/*_fuzz.cc, run by tools/fuzz.sh) share: the source
// tree's shipped files, a folder of the process's own to write an input into (the loaders read
// files), and the check that a ConfigError says where the mistake is. A finding is a crash: an
// exception other than the documented ones, a sanitizer report, or Finding() below; libFuzzer
// saves its input as an artifact.
#pragma once

#include <stdlib.h>  // mkdtemp

#include <cctype>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>
#include <system_error>

#include "sim/core/config.h"  // ConfigError

namespace autonomsim::sim::fuzz {

// The repository the target was built from (autonomsim_fuzzer in cmake/autonomsim.cmake).
inline std::filesystem::path SourceDir() { return AUTONOMSIM_SOURCE_DIR; }

// Stops the run as a crash, after saying why on stderr.
[[noreturn]] inline void Finding(std::string_view what, std::string_view detail) {
  std::fprintf(stderr, "FINDING: %.*s\n  %.*s\n", static_cast<int>(what.size()), what.data(),
               static_cast<int>(detail.size()), detail.data());
  std::abort();
}

// A fresh folder under the temp folder ($TMPDIR; tools/fuzz.sh points it into build-fuzz/),
// removed when the process exits normally.
class ScratchDir {
 public:
  ScratchDir() {
    std::string pattern = (std::filesystem::temp_directory_path() / "autonomsim-fuzz-XXXXXX");
    if (mkdtemp(pattern.data()) == nullptr) Finding("cannot make a scratch folder", pattern);
    path_ = pattern;
  }
  ~ScratchDir() {
    std::error_code ignored;
    std::filesystem::remove_all(path_, ignored);
  }
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;

  const std::filesystem::path& path() const { return path_; }

  // `name` in the folder holding exactly `size` bytes of `data`.
  std::filesystem::path Write(const std::string& name, const std::uint8_t* data,
                              std::size_t size) const {
    const std::filesystem::path file = path_ / name;
    std::ofstream out(file, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
    out.close();
    if (!out) Finding("cannot write the input file", file.string());
    return file;
  }

 private:
  std::filesystem::path path_;
};

// A scratch folder laid out like scenarios/: the shipped tracks and profiles, linked, so that a
// scenario written into it finds them as a shipped scenario does.
struct ScenarioFolder {
  ScenarioFolder() {
    for (const char* shipped : {"tracks", "platforms"}) {
      std::filesystem::create_directory_symlink(SourceDir() / "scenarios" / shipped,
                                                dir.path() / shipped);
    }
  }
  ScratchDir dir;
};

// Whether `message` begins "<file>:<line>:" (sim/core/config.h's "file:line:column: key: what").
inline bool NamesFileAndLine(std::string_view message, std::string_view file) {
  if (message.substr(0, file.size()) != file || message.size() < file.size() + 3 ||
      message[file.size()] != ':') {
    return false;
  }
  std::size_t i = file.size() + 1;
  const std::size_t digits = i;
  while (i < message.size() && std::isdigit(static_cast<unsigned char>(message[i])) != 0) ++i;
  return i > digits && i < message.size() && message[i] == ':';
}

// Whether a loader's ConfigError for `file` says where the mistake is: a file and line, or the
// whole file when it is empty (there is no line to name).
inline bool SaysWhere(std::string_view message, const std::string& file) {
  return NamesFileAndLine(message, file) || message == file + ": the file is empty";
}

// Loads `file` with `load` (a loader: LoadTrack, LoadScenario); its ConfigError must say where
// (SaysWhere), else a finding named `what`. ConfigError is the loaders' one documented error.
template <class Load>
void LoadSayingWhere(Load load, const std::filesystem::path& file, std::string_view what) {
  try {
    load(file);
  } catch (const ConfigError& e) {
    if (!SaysWhere(e.what(), file.string())) Finding(what, e.what());
  }
}

}  // namespace autonomsim::sim::fuzz
