// The lane network: directed lane segments, joined where one ends and another begins. Routes are
// chains of segments through it; their joined path is what a car follows.
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "world/polyline.h"
#include "world/track_spec.h"

namespace autonomsim::world {

// Segments join where one ends and another begins within 1 mm.
class RoadGraph {
 public:
  // assumed: lane ends are typed in to the millimetre; anything closer is one junction.
  static constexpr double kJunctionTolerance_m = 1e-3;

  RoadGraph() = default;
  // Validates each lane and samples it (SampleFilletPolyline, not closed); throws
  // std::invalid_argument naming the lane on bad geometry or a duplicate name.
  explicit RoadGraph(const std::vector<LaneSegmentSpec>& lanes);

  std::size_t segment_count() const { return names_.size(); }
  int SegmentIndex(const std::string& name) const;  // throws, listing known names, if unknown
  const std::string& name(int segment) const;
  const Polyline& path(int segment) const;
  // Segments starting where it ends, ascending index (a segment that ends where it starts is its
  // own successor).
  const std::vector<int>& Successors(int segment) const;
  // from..to inclusive, least total length of the segments on it (Dijkstra); {from} if from ==
  // to; nullopt if to cannot be reached. Ties: the predecessor settled first (shorter, then lower
  // index) wins, so the answer does not depend on anything but the graph.
  std::optional<std::vector<int>> ShortestPath(int from, int to) const;

 private:
  void CheckIndex(int segment) const;

  std::vector<std::string> names_;
  std::vector<Polyline> paths_;
  std::vector<std::vector<int>> successors_;
};

struct Route {
  std::string name;
  std::vector<int> segments;
  bool cyclic{false};  // the last segment leads into the first
  // The segments joined (duplicate junction points removed); cyclic if the route is.
  Polyline path;
  std::vector<double> segment_start_s_m;  // where each segment begins on path
};

// Consecutive segments must connect (else throws std::invalid_argument naming the pair); cyclic
// when the last connects to the first. At a junction the earlier segment's end point is kept; a
// cyclic path's last point is set to its first.
Route MakeRoute(const RoadGraph& graph, const std::string& name,
                const std::vector<std::string>& segment_names);

}  // namespace autonomsim::world
