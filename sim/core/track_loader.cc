#include "sim/core/track_loader.h"

#include <stdexcept>
#include <string>
#include <utility>

#include "sim/core/config.h"

namespace autonomsim::sim {
namespace {

bool BuildFails(world::TrackSpec spec) {
  try {
    world::Track track(std::move(spec));
    return false;
  } catch (const std::invalid_argument&) {
    return true;
  }
}

// Where a track's geometry fails, for the error message: the entry (lines[i], lanes[i] or
// routes.NAME) that fails when the track is built from it alone (with the colours it may name,
// and every lane for a route), and its node in the file. The whole file when none fails alone.
// Only on the error path: each try builds a small track again.
std::pair<std::string, YAML::Node> FailingEntry(const world::TrackSpec& spec,
                                                const YAML::Node& root) {
  world::TrackSpec empty = spec;
  empty.lines.clear();
  empty.lanes.clear();
  empty.routes.clear();
  empty.intersections.clear();
  empty.start_poses.clear();
  for (std::size_t i = 0; i < spec.lines.size(); ++i) {
    world::TrackSpec alone = empty;
    alone.lines = {spec.lines[i]};
    if (BuildFails(alone)) return {detail::JoinIndex("lines", i), root["lines"][i]};
  }
  for (std::size_t i = 0; i < spec.lanes.size(); ++i) {
    world::TrackSpec alone = empty;
    alone.lanes = {spec.lanes[i]};
    if (BuildFails(alone)) return {detail::JoinIndex("lanes", i), root["lanes"][i]};
  }
  for (const auto& [name, segments] : spec.routes) {
    world::TrackSpec alone = empty;
    alone.lanes = spec.lanes;
    alone.routes = {{name, segments}};
    if (BuildFails(alone)) return {detail::JoinPath("routes", name), root["routes"][name]};
  }
  return {"", root};
}

}  // namespace

world::TrackSpec LoadTrackSpec(const std::filesystem::path& file) {
  const YAML::Node root = LoadYamlFile(file);
  return ReadConfig<world::TrackSpec>(root, ConfigSource{file.string(), {}});
}

world::Track LoadTrack(const std::filesystem::path& file) {
  const YAML::Node root = LoadYamlFile(file);
  const ConfigSource source{file.string(), {}};
  world::TrackSpec spec = ReadConfig<world::TrackSpec>(root, source);
  try {
    return world::Track(spec);
  } catch (const std::invalid_argument& e) {
    // the geometry of one line, lane or route: its key and line, as for any other bad value
    const auto [path, node] = FailingEntry(spec, root);
    detail::Fail(node.IsDefined() ? node : root, path, source, e.what());
  }
}

}  // namespace autonomsim::sim
