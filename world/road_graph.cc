#include "world/road_graph.h"

#include <algorithm>
#include <functional>
#include <limits>
#include <map>
#include <queue>
#include <stdexcept>
#include <utility>

#include "world/validation.h"

namespace autonomsim::world {
namespace {

std::string JoinNames(const std::vector<std::string>& names) {
  std::vector<std::string> sorted = names;
  std::sort(sorted.begin(), sorted.end());
  std::string joined;
  for (const std::string& n : sorted) joined += (joined.empty() ? "" : ", ") + n;
  return joined;
}

}  // namespace

RoadGraph::RoadGraph(const std::vector<LaneSegmentSpec>& lanes) {
  names_.reserve(lanes.size());
  paths_.reserve(lanes.size());
  for (const LaneSegmentSpec& lane : lanes) {
    if (std::find(names_.begin(), names_.end(), lane.name) != names_.end()) {
      throw std::invalid_argument("duplicate lane name '" + lane.name + "'");
    }
    try {
      lane.Validate();
      paths_.push_back(SampleFilletPolyline(lane.points_m, lane.corner_radius_m, false));
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument("lane '" + lane.name + "': " + e.what());
    }
    names_.push_back(lane.name);
  }
  successors_.resize(paths_.size());
  for (std::size_t i = 0; i < paths_.size(); ++i) {
    const Vec2& end = paths_[i].points().back();
    for (std::size_t j = 0; j < paths_.size(); ++j) {
      if ((paths_[j].points().front() - end).norm() <= kJunctionTolerance_m) {
        successors_[i].push_back(static_cast<int>(j));
      }
    }
  }
}

void RoadGraph::CheckIndex(int segment) const {
  if (segment < 0 || static_cast<std::size_t>(segment) >= names_.size()) {
    throw std::out_of_range("lane segment index " + std::to_string(segment) +
                            " out of range (the road graph has " + std::to_string(names_.size()) +
                            " segments)");
  }
}

int RoadGraph::SegmentIndex(const std::string& segment_name) const {
  const auto it = std::find(names_.begin(), names_.end(), segment_name);
  if (it == names_.end()) {
    throw std::invalid_argument("unknown lane '" + segment_name +
                                "'; known lanes: " + JoinNames(names_));
  }
  return static_cast<int>(it - names_.begin());
}

const std::string& RoadGraph::name(int segment) const {
  CheckIndex(segment);
  return names_[segment];
}

const Polyline& RoadGraph::path(int segment) const {
  CheckIndex(segment);
  return paths_[segment];
}

const std::vector<int>& RoadGraph::Successors(int segment) const {
  CheckIndex(segment);
  return successors_[segment];
}

std::optional<std::vector<int>> RoadGraph::ShortestPath(int from, int to) const {
  CheckIndex(from);
  CheckIndex(to);
  if (from == to) return std::vector<int>{from};
  const std::size_t n = names_.size();
  std::vector<double> distance(n, std::numeric_limits<double>::infinity());
  std::vector<int> previous(n, -1);
  std::vector<bool> settled(n, false);
  using Entry = std::pair<double, int>;  // (length so far, segment): ties go to the lower index
  std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> queue;
  distance[from] = paths_[from].length_m();
  queue.emplace(distance[from], from);
  while (!queue.empty()) {
    const auto [d, i] = queue.top();
    queue.pop();
    if (settled[i]) continue;
    settled[i] = true;
    if (i == to) break;
    for (int j : successors_[i]) {
      const double candidate = d + paths_[j].length_m();
      if (candidate < distance[j]) {
        distance[j] = candidate;
        previous[j] = i;
        queue.emplace(candidate, j);
      }
    }
  }
  if (!settled[to]) return std::nullopt;
  std::vector<int> chain;
  for (int i = to; i != -1; i = previous[i]) chain.push_back(i);
  std::reverse(chain.begin(), chain.end());
  return chain;
}

Route MakeRoute(const RoadGraph& graph, const std::string& name,
                const std::vector<std::string>& segment_names) {
  if (segment_names.empty()) throw std::invalid_argument("route '" + name + "' is empty");
  Route route;
  route.name = name;
  for (const std::string& segment_name : segment_names) {
    try {
      route.segments.push_back(graph.SegmentIndex(segment_name));
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument("route '" + name + "': " + e.what());
    }
  }
  auto leads_into = [&graph](int a, int b) {
    const std::vector<int>& next = graph.Successors(a);
    return std::binary_search(next.begin(), next.end(), b);
  };
  for (std::size_t k = 0; k + 1 < route.segments.size(); ++k) {
    const int a = route.segments[k];
    const int b = route.segments[k + 1];
    if (!leads_into(a, b)) {
      const Vec2& end = graph.path(a).points().back();
      const Vec2& start = graph.path(b).points().front();
      throw std::invalid_argument(
          "route '" + name + "': lane '" + graph.name(a) + "' does not lead into lane '" +
          graph.name(b) + "' (it ends at (" + Num(end.x()) + ", " + Num(end.y()) +
          "), the next starts at (" + Num(start.x()) + ", " + Num(start.y()) + "), " +
          Num((end - start).norm()) + " m apart; at most " + Num(RoadGraph::kJunctionTolerance_m) +
          " m allowed)");
    }
  }
  route.cyclic = leads_into(route.segments.back(), route.segments.front());

  std::vector<Vec2> points;
  std::vector<std::size_t> start_index;
  for (int segment : route.segments) {
    const std::vector<Vec2>& segment_points = graph.path(segment).points();
    start_index.push_back(points.empty() ? 0 : points.size() - 1);
    points.insert(points.end(), segment_points.begin() + (points.empty() ? 0 : 1),
                  segment_points.end());
  }
  if (route.cyclic) points.back() = points.front();
  route.path = Polyline(std::move(points), route.cyclic);
  for (std::size_t index : start_index) {
    route.segment_start_s_m.push_back(route.path.arc_lengths_m()[index]);
  }
  return route;
}

}  // namespace autonomsim::world
