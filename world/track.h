// The track with everything derived from its spec: the sampled painted lines, the road graph and
// its routes, and the intersection and stop-zone look-ups the cars make (reference §1).
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "world/geometry.h"
#include "world/polyline.h"
#include "world/road_graph.h"
#include "world/track_spec.h"

namespace autonomsim::world {

class Track {
 public:
  // spec.Validate() and each line, lane and intersection's Validate(), then derives everything
  // below (lines and lanes sampled at 1 cm, every route joined); throws std::invalid_argument
  // naming the line, lane or route on bad geometry.
  explicit Track(TrackSpec spec);

  const TrackSpec& spec() const { return spec_; }
  const std::vector<Polyline>& line_paths() const { return line_paths_; }  // per spec.lines entry
  const RoadGraph& road_graph() const { return road_graph_; }
  Route RouteByName(const std::string& name) const;  // spec.routes; throws listing known routes
  // The first intersection (spec order) whose area contains p (strictly, like the real cars), or
  // nullptr. The pointer is into this Track's spec(): it lives as long as the Track.
  const IntersectionSpec* IntersectionAt(const Vec2& p_map) const;
  struct StopZoneHit {
    int intersection_id;  // IntersectionSpec::id, the /vtl/ digit
    int zone_index;       // into that intersection's stop_zones
  };
  // The first stop zone (spec order) containing p (strictly).
  std::optional<StopZoneHit> StopZoneAt(const Vec2& p_map) const;
  std::optional<Pose2> StartPose(const std::string& name) const;

 private:
  TrackSpec spec_;
  std::vector<Polyline> line_paths_;
  RoadGraph road_graph_;
  std::map<std::string, Route> routes_;
};

}  // namespace autonomsim::world
