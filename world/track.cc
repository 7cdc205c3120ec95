#include "world/track.h"

#include <stdexcept>
#include <utility>

namespace autonomsim::world {
namespace {

template <class Spec>
void ValidateNamed(const Spec& spec, const std::string& what) {
  try {
    spec.Validate();
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(what + ": " + e.what());
  }
}

}  // namespace

Track::Track(TrackSpec spec) : spec_(std::move(spec)) {
  spec_.Validate();
  for (const TrackLineSpec& line : spec_.lines) ValidateNamed(line, "line '" + line.name + "'");
  for (const IntersectionSpec& intersection : spec_.intersections) {
    ValidateNamed(intersection, "intersection " + std::to_string(intersection.id));
  }
  line_paths_.reserve(spec_.lines.size());
  for (const TrackLineSpec& line : spec_.lines) {
    try {
      line_paths_.push_back(SampleFilletPolyline(line.points_m, line.corner_radius_m, line.closed));
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument("line '" + line.name + "': " + e.what());
    }
  }
  road_graph_ = RoadGraph(spec_.lanes);
  for (const auto& [name, segments] : spec_.routes) {
    routes_.emplace(name, MakeRoute(road_graph_, name, segments));
  }
}

Route Track::RouteByName(const std::string& name) const {
  const auto it = routes_.find(name);
  if (it == routes_.end()) {
    std::string known;
    for (const auto& [route_name, route] : routes_)
      known += (known.empty() ? "" : ", ") + route_name;
    throw std::invalid_argument("unknown route '" + name +
                                "'; known routes: " + (known.empty() ? "(none)" : known));
  }
  return it->second;
}

const IntersectionSpec* Track::IntersectionAt(const Vec2& p_map) const {
  for (const IntersectionSpec& intersection : spec_.intersections) {
    if (intersection.area.Contains(p_map)) return &intersection;
  }
  return nullptr;
}

std::optional<Track::StopZoneHit> Track::StopZoneAt(const Vec2& p_map) const {
  for (const IntersectionSpec& intersection : spec_.intersections) {
    for (std::size_t k = 0; k < intersection.stop_zones.size(); ++k) {
      if (intersection.stop_zones[k].Contains(p_map)) {
        return StopZoneHit{intersection.id, static_cast<int>(k)};
      }
    }
  }
  return std::nullopt;
}

std::optional<Pose2> Track::StartPose(const std::string& name) const {
  const auto it = spec_.start_poses.find(name);
  if (it == spec_.start_poses.end()) return std::nullopt;
  return it->second.ToPose();
}

}  // namespace autonomsim::world
