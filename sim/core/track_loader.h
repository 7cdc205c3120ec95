// Reads a track file (scenarios/tracks/*.yaml) into a world::Track.
#pragma once

#include <filesystem>

#include "world/track.h"
#include "world/track_spec.h"

namespace autonomsim::sim {

// Throws ConfigError naming the file (and line and key where it can) on any bad input, including
// geometry the track cannot be built from.
world::TrackSpec LoadTrackSpec(const std::filesystem::path& file);
world::Track LoadTrack(const std::filesystem::path& file);

}  // namespace autonomsim::sim
