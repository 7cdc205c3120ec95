// libFuzzer target: a scenario loaded and then run for one simulated second, in process. What the
// loader refuses is scenario_loader_fuzz's to judge; what it accepts must run: building the cars'
// boards may throw only a ConfigError that names the file and a line (LoadedScenario::ErrorAt),
// and the run nothing at all (no exception, no sanitizer report, no hang: libFuzzer's -timeout).
// The run is cut to one second, and the V2I link and camera backend set to the in-process ones
// (no broker, no network, no OpenGL), so that an input is a fraction of a second. tools/fuzz.sh
// runs it with the shipped scenarios as its seed corpus; the sanitizer build replays them
// (FuzzReplay.scenario_run_fuzz).
#include <algorithm>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <optional>

#include "sim/core/config.h"
#include "sim/core/fuzz/fuzz_support.h"
#include "sim/loop/simulation.h"
#include "sim/scenario/scenario.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace autonomsim::sim;
  static const fuzz::ScenarioFolder folder;
  const std::filesystem::path file = folder.dir.Write("fuzz.yaml", data, size);
  std::optional<LoadedScenario> loaded;
  try {
    loaded.emplace(LoadScenario(file));
  } catch (const ConfigError&) {
    return 0;  // refused at load: scenario_loader_fuzz checks that the message says where
  }
  Scenario& scenario = loaded->scenario;
  scenario.duration = std::min<autonomsim::Duration>(scenario.duration, std::chrono::seconds(1));
  scenario.v2i.link = V2ILinkKind::kEmbedded;
  scenario.camera_backend = CameraBackend::kRayCast;
  try {
    RunScenario(*loaded);
  } catch (const ConfigError& e) {
    if (!fuzz::NamesFileAndLine(e.what(), file.string())) {
      fuzz::Finding("a board error that names no file and line", e.what());
    }
  }
  return 0;
}
