// What the command-line tests share: running `autonomsim` (or any shell command) and reading what
// it wrote. Header-only, for the test executables under tools/tests/.
#pragma once

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace autonomsim::testing {

struct Result {
  int exit_code{-1};
  std::string output;  // stdout and stderr together
};

// The binary under test: $AUTONOMSIM_BIN_DIR/autonomsim (set by ctest), else build/bin.
inline std::string Bin() {
  const char* bin_dir = std::getenv("AUTONOMSIM_BIN_DIR");
  return std::string(bin_dir ? bin_dir : "build/bin") + "/autonomsim";
}

inline Result Shell(const std::string& command) {
  Result result;
  FILE* pipe = ::popen((command + " 2>&1").c_str(), "r");
  if (pipe == nullptr) return result;
  std::array<char, 4096> buffer;
  while (std::fgets(buffer.data(), buffer.size(), pipe) != nullptr) result.output += buffer.data();
  const int status = ::pclose(pipe);
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return result;
}

inline Result Cli(const std::string& args) { return Shell(Bin() + " " + args); }

inline std::string Read(const std::filesystem::path& file) {
  std::ifstream in(file);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// A fresh folder per test under `suite` (ctest runs tests in parallel).
inline std::filesystem::path Scratch(const std::string& suite) {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  const std::filesystem::path dir =
      std::filesystem::path(::testing::TempDir()) / suite / info->name();
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

}  // namespace autonomsim::testing
