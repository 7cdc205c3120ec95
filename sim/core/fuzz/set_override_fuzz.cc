// libFuzzer target: `--set KEY=VALUE` (sim/core/config.h's ApplyOverride and ParseOverridePath),
// then the strict reader over the result, as the CLI does for a scenario or a profile. The base is
// the shipped lab track (the one schema sim/core holds). tools/fuzz.sh runs it.
//
// Input: one assignment per line, e.g. "lines[0].width_m=0.05" (lines with a NUL byte, which no
// command line can hold, are skipped). Checks:
// - ApplyOverride throws only ConfigError, and its message names the --set key;
// - an assignment it takes puts the parsed value at the key's path, and records that path;
// - the reader's ConfigError names either the --set key or the file and a line.
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "sim/core/config.h"
#include "sim/core/fuzz/fuzz_support.h"
#include "world/track_spec.h"

namespace autonomsim::sim {
namespace {

const std::string& TrackFile() {
  static const std::string file = (fuzz::SourceDir() / "scenarios/tracks/lab.yaml").string();
  return file;
}

// The node at `tokens` below `root` (the path ApplyOverride just wrote).
YAML::Node At(const YAML::Node& root, const std::vector<std::string>& tokens) {
  YAML::Node node;
  node.reset(root);
  for (const std::string& t : tokens) {
    YAML::Node child = t.find_first_not_of("0123456789") == std::string::npos
                           ? node[static_cast<std::size_t>(std::stoul(t))]
                           : node[t];
    node.reset(child);
  }
  return node;
}

// Applies one assignment to `root` (true), or checks that its refusal names the key (false).
bool Apply(YAML::Node& root, const std::string& assignment, ConfigSource* source) {
  const std::string key = assignment.substr(0, assignment.find('='));
  try {
    ApplyOverride(root, assignment, source);
  } catch (const ConfigError& e) {
    if (std::string_view(e.what()).substr(0, 6 + key.size()) != "--set " + key) {
      fuzz::Finding("a --set error that does not name its key", e.what());
    }
    return false;
  }
  const std::vector<std::string> tokens = ParseOverridePath(key);
  std::string canonical;
  for (const std::string& t : tokens) {
    canonical = t.find_first_not_of("0123456789") == std::string::npos
                    ? detail::JoinIndex(canonical, std::stoul(t))
                    : detail::JoinPath(canonical, t);
  }
  if (source->overridden_paths.count(canonical) == 0) {
    fuzz::Finding("--set did not record its path " + canonical, assignment);
  }
  const YAML::Node expected = YAML::Load(assignment.substr(key.size() + 1));
  const YAML::Node got = At(root, tokens);
  // (a null dumps as "" on its own and as "~" inside a mapping)
  if (!(got.IsNull() && expected.IsNull()) && YAML::Dump(got) != YAML::Dump(expected)) {
    fuzz::Finding("--set did not put its value at its key", assignment);
  }
  return true;
}

}  // namespace
}  // namespace autonomsim::sim

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace autonomsim::sim;
  static const YAML::Node kTrack = LoadYamlFile(TrackFile());
  YAML::Node root = YAML::Clone(kTrack);
  ConfigSource source{TrackFile(), {}};
  const std::string_view input(reinterpret_cast<const char*>(data), size);
  std::size_t start = 0;
  bool applied = false;
  while (start < input.size()) {
    const std::size_t end = std::min(input.find('\n', start), input.size());
    const std::string assignment(input.substr(start, end - start));
    start = end + 1;
    if (assignment.find('\0') != std::string::npos) continue;  // a command line has no NUL byte
    applied = Apply(root, assignment, &source) || applied;
  }
  if (!applied) return 0;  // the shipped track as it is: nothing new for the reader
  try {
    ReadConfig<autonomsim::world::TrackSpec>(root, source);
  } catch (const ConfigError& e) {
    const std::string_view message = e.what();
    if (!fuzz::NamesFileAndLine(message, TrackFile()) &&
        message.find("--set ") == std::string_view::npos) {
      fuzz::Finding("a config error that names neither a --set key nor a file and line", message);
    }
  }
  return 0;
}
