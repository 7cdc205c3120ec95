// libFuzzer target: the scenario loader (sim/scenario/scenario.h's LoadScenario) on any scenario
// file, beside the shipped tracks/ and platforms/ as a scenario in scenarios/ sees them. It may
// only throw ConfigError (the CLI's exit code 2), and the message must name the file and a line
// ("file:line:column: key: what") so that a user can find the mistake; the one exception is an
// empty file, which has no line to name. tools/fuzz.sh runs it with the shipped scenarios as its
// seed corpus and the config keys as its dictionary.
#include <cstddef>
#include <cstdint>
#include <filesystem>

#include "sim/core/config.h"
#include "sim/core/fuzz/fuzz_support.h"
#include "sim/scenario/scenario.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace autonomsim::sim;
  static const fuzz::ScenarioFolder folder;
  const std::filesystem::path file = folder.dir.Write("fuzz.yaml", data, size);
  fuzz::LoadSayingWhere([](const auto& f) { LoadScenario(f); }, file,
                        "a scenario error that names no file and line");
  return 0;
}
