// libFuzzer target: the track loader (sim/core/track_loader.h) on any track file. LoadTrack may
// only throw ConfigError, and its message must name the file and a line (config.h's
// "file:line:column: key: what"), so that a user can find the mistake. tools/fuzz.sh runs it with
// the shipped tracks as its seed corpus. (An empty file has no line to name: its error names the
// file alone.)
#include <cstddef>
#include <cstdint>

#include "sim/core/config.h"
#include "sim/core/fuzz/fuzz_support.h"
#include "sim/core/track_loader.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace autonomsim::sim;
  static const fuzz::ScratchDir scratch;
  const std::filesystem::path file = scratch.Write("track.yaml", data, size);
  fuzz::LoadSayingWhere([](const auto& f) { LoadTrack(f); }, file,
                        "a track error that names no file and line");
  return 0;
}
