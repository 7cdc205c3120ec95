// A scenario file written into scenarios/ for one test (so that `track: tracks/lab.yaml` and the
// profiles resolve as they do for users), removed again when the test ends.
#pragma once

#include <filesystem>
#include <fstream>
#include <string>

namespace autonomsim::sim::testing {

class ScenarioFile {
 public:
  ScenarioFile(const std::string& name, const std::string& text)
      : path_(std::filesystem::path("scenarios") / (".test_" + name + ".yaml")) {
    std::ofstream(path_) << text;
  }
  ~ScenarioFile() { std::filesystem::remove(path_); }
  ScenarioFile(const ScenarioFile&) = delete;
  ScenarioFile& operator=(const ScenarioFile&) = delete;
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

}  // namespace autonomsim::sim::testing
