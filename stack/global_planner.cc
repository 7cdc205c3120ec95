#include "stack/global_planner.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

#include "world/validation.h"

namespace autonomsim::stack {
namespace {

// assumed: far below a cell (0.05 m), far above the rounding of cell-centre coordinates.
constexpr double kSameDistance_m = 1e-9;

using OpenEntry = PlannerScratch::OpenEntry;

// The open list is a heap with the least (f, h, index) on top (std::push_heap and pop_heap with
// "greater", as std::priority_queue would order it).
struct WorseEntry {
  bool operator()(const OpenEntry& a, const OpenEntry& b) const {
    if (a.f != b.f) return a.f > b.f;
    if (a.h != b.h) return a.h > b.h;
    return a.index > b.index;
  }
};

std::vector<world::Vec2> Backtrace(const Costmap2D& costmap, const int* parent, int end) {
  std::vector<world::Vec2> path;
  for (int i = end; i >= 0; i = parent[i]) {
    const CellIndex cell = costmap.Cell(static_cast<std::size_t>(i));
    path.push_back(costmap.MapToWorld(cell.mx, cell.my));
  }
  return {path.rbegin(), path.rend()};
}

double Length_m(const std::vector<world::Vec2>& path) {
  double length = 0.0;
  for (std::size_t i = 1; i < path.size(); ++i) length += (path[i] - path[i - 1]).norm();
  return length;
}

}  // namespace

void GlobalPlannerParams::Validate() const {
  Require(std::isfinite(tolerance_m) && tolerance_m >= 0.0,
          [&] { return "tolerance_m must be >= 0, got " + Num(tolerance_m); });
  Require(std::isfinite(cost_travel_multiplier) && cost_travel_multiplier >= 0.0, [&] {
    return "cost_travel_multiplier must be >= 0, got " + Num(cost_travel_multiplier);
  });
  Require(max_expansions > 0,
          [&] { return "max_expansions must be > 0, got " + Num(max_expansions); });
  Require(start_escape_m >= 0.0 && start_escape_m <= 2.0,
          [&] { return "start_escape_m must be in [0, 2] m, got " + Num(start_escape_m); });
}

std::string ToString(PlanStatus status) {
  switch (status) {
    case PlanStatus::kOk:
      return "ok";
    case PlanStatus::kStartOutsideMap:
      return "start outside the costmap";
    case PlanStatus::kGoalOutsideMap:
      return "goal outside the costmap";
    case PlanStatus::kNoPath:
      return "no path within tolerance of the goal";
    case PlanStatus::kExpansionLimit:
      return "expansion limit reached";
  }
  return "unknown";
}

GlobalPlan PlanGlobalPath(const GlobalPlannerParams& params, const Costmap2D& costmap,
                          const world::Vec2& start, const world::Vec2& goal,
                          PlannerScratch* scratch) {
  params.Validate();
  GlobalPlan plan;
  const auto start_cell = costmap.WorldToMap(start);
  if (!start_cell) {
    plan.status = PlanStatus::kStartOutsideMap;
    return plan;
  }
  const auto goal_cell = costmap.WorldToMap(goal);
  if (!goal_cell) {
    plan.status = PlanStatus::kGoalOutsideMap;
    return plan;
  }

  const int nx = costmap.size_x_cells();
  const int ny = costmap.size_y_cells();
  const double resolution_m = costmap.resolution_m();
  const std::vector<std::uint8_t>& costs = costmap.costs();
  const int start_index = static_cast<int>(costmap.Index(start_cell->mx, start_cell->my));
  const int goal_index = static_cast<int>(costmap.Index(goal_cell->mx, goal_cell->my));

  const double escape_cells_sq =
      (params.start_escape_m / resolution_m) * (params.start_escape_m / resolution_m);
  auto near_start = [&](int i) {
    const double dx = i % nx - static_cast<int>(start_cell->mx);
    const double dy = i / nx - static_cast<int>(start_cell->my);
    return dx * dx + dy * dy <= escape_cells_sq;
  };
  auto traversable = [&](int i) {
    const std::uint8_t c = costs[i];
    if (c == kNoInformation) return params.allow_unknown;
    return c < kInscribedInflatedObstacle ||
           (c == kInscribedInflatedObstacle && params.start_escape_m > 0.0 && near_start(i));
  };
  auto heuristic_m = [&](int mx, int my) {
    const double dx = mx - goal_cell->mx;
    const double dy = my - goal_cell->my;
    return resolution_m * std::sqrt(dx * dx + dy * dy);
  };
  // Smac's neighbour order (cardinal moves first), as (dx, dy, step in cells).
  struct Move {
    int dx;
    int dy;
    double step;
  };
  const double diagonal = std::sqrt(2.0);
  const Move moves[8] = {{-1, 0, 1.0},      {1, 0, 1.0},        {0, -1, 1.0},
                         {0, 1, 1.0},       {-1, -1, diagonal}, {1, -1, diagonal},
                         {-1, 1, diagonal}, {1, 1, diagonal}};

  PlannerScratch local;
  PlannerScratch& memory = scratch != nullptr ? *scratch : local;
  const std::size_t n = costs.size();
  if (memory.g_.size() != n || ++memory.search_ == 0) {  // a new size, or the stamps wrapped
    memory.g_.assign(n, 0.0);
    memory.parent_.assign(n, -1);
    memory.reached_.assign(n, 0);
    memory.closed_.assign(n, 0);
    memory.search_ = 1;
  }
  const std::uint32_t search = memory.search_;
  double* g_cells = memory.g_.data();
  int* parent = memory.parent_.data();
  std::uint32_t* reached = memory.reached_.data();
  std::uint32_t* closed = memory.closed_.data();
  // The cost so far of cell i: +inf until this search reaches it.
  const auto g = [&](int i) {
    return reached[i] == search ? g_cells[i] : std::numeric_limits<double>::infinity();
  };
  std::vector<OpenEntry>& open = memory.open_;
  open.clear();
  const auto push = [&](const OpenEntry& entry) {
    open.push_back(entry);
    std::push_heap(open.begin(), open.end(), WorseEntry{});
  };

  g_cells[start_index] = 0.0;
  parent[start_index] = -1;
  reached[start_index] = search;
  const double h_start = heuristic_m(start_cell->mx, start_cell->my);
  push({h_start, h_start, start_index});

  // The closed cell nearest the goal point (among equals the cheapest, then the lowest index),
  // for the tolerance.
  int nearest = -1;
  double nearest_distance_m = std::numeric_limits<double>::infinity();
  auto finish = [&](int end, bool exact) {
    plan.status = PlanStatus::kOk;
    plan.path_m = Backtrace(costmap, parent, end);
    plan.cost = g(end);
    plan.length_m = Length_m(plan.path_m);
    plan.exact_goal = exact;
  };
  auto finish_within_tolerance = [&](PlanStatus otherwise) {
    if (nearest >= 0 && nearest_distance_m <= params.tolerance_m) {
      finish(nearest, false);
    } else {
      plan.status = otherwise;
    }
  };

  while (!open.empty()) {
    std::pop_heap(open.begin(), open.end(), WorseEntry{});
    const OpenEntry top = open.back();
    open.pop_back();
    const int i = top.index;
    if (closed[i] == search) continue;  // a stale entry: the cell was closed at a lower cost
    closed[i] = search;
    ++plan.expansions;

    if (i == goal_index) {
      finish(i, true);
      return plan;
    }
    const int mx = i % nx;
    const int my = i / nx;
    const double distance_m = (costmap.MapToWorld(mx, my) - goal).norm();
    // Distances within kSameDistance_m are ties: rounding must not pick among equidistant cells.
    const bool nearer = distance_m < nearest_distance_m - kSameDistance_m;
    const bool tie = !nearer && distance_m <= nearest_distance_m + kSameDistance_m;
    if (nearer || (tie && (g(i) < g(nearest) || (g(i) == g(nearest) && i < nearest)))) {
      nearest_distance_m = distance_m;
      nearest = i;
    }
    if (plan.expansions >= params.max_expansions) {
      finish_within_tolerance(PlanStatus::kExpansionLimit);
      return plan;
    }

    for (const Move& move : moves) {
      const int cx = mx + move.dx;
      const int cy = my + move.dy;
      if (cx < 0 || cx >= nx || cy < 0 || cy >= ny) continue;
      const int j = cy * nx + cx;
      if (closed[j] == search || !traversable(j)) continue;
      const double weight = 1.0 + params.cost_travel_multiplier *
                                      (static_cast<double>(costs[j]) / kMaxNonInscribedCost);
      const double g_new = g(i) + resolution_m * move.step * weight;
      if (!(g_new < g(j))) continue;
      g_cells[j] = g_new;
      parent[j] = i;
      reached[j] = search;
      const double h = heuristic_m(cx, cy);
      push({g_new + h, h, j});
    }
  }
  finish_within_tolerance(PlanStatus::kNoPath);
  return plan;
}

GlobalPlan PlanThroughPoses(const GlobalPlannerParams& params, const Costmap2D& costmap,
                            const world::Vec2& start, const std::vector<world::Vec2>& goals,
                            PlannerScratch* scratch) {
  if (goals.empty()) return PlanGlobalPath(params, costmap, start, start, scratch);
  GlobalPlan joined;
  joined.status = PlanStatus::kOk;
  world::Vec2 from = start;
  for (const world::Vec2& goal : goals) {
    GlobalPlan leg = PlanGlobalPath(params, costmap, from, goal, scratch);
    joined.expansions += leg.expansions;
    if (!leg.ok()) {
      joined.status = leg.status;
      joined.path_m.clear();
      joined.cost = 0.0;
      joined.length_m = 0.0;
      joined.exact_goal = false;
      return joined;
    }
    const std::size_t skip = joined.path_m.empty() ? 0 : 1;  // the cell both legs share
    joined.path_m.insert(joined.path_m.end(), leg.path_m.begin() + static_cast<long>(skip),
                         leg.path_m.end());
    joined.cost += leg.cost;
    joined.length_m += leg.length_m;
    joined.exact_goal = leg.exact_goal;
    from = leg.path_m.back();
  }
  return joined;
}

}  // namespace autonomsim::stack
