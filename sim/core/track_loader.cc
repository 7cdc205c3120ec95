#include "sim/core/track_loader.h"

#include "sim/core/config.h"

namespace autonomsim::sim {

world::TrackSpec LoadTrackSpec(const std::filesystem::path& file) {
  const YAML::Node root = LoadYamlFile(file);
  return ReadConfig<world::TrackSpec>(root, ConfigSource{file.string(), {}});
}

world::Track LoadTrack(const std::filesystem::path& file) {
  world::TrackSpec spec = LoadTrackSpec(file);
  try {
    return world::Track(std::move(spec));
  } catch (const std::invalid_argument& e) {
    throw ConfigError(file.string() + ": " + e.what());
  }
}

}  // namespace autonomsim::sim
