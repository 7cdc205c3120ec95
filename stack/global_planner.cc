#include "stack/global_planner.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>

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

namespace {

// Smac's neighbour order (cardinal moves first), as (dx, dy, step in cells).
struct Move {
  int dx;
  int dy;
  double step;
};
constexpr double kDiagonal = std::numbers::sqrt2;
constexpr Move kMoves[8] = {{-1, 0, 1.0},       {1, 0, 1.0},         {0, -1, 1.0},
                            {0, 1, 1.0},        {-1, -1, kDiagonal}, {1, -1, kDiagonal},
                            {-1, 1, kDiagonal}, {1, 1, kDiagonal}};

// The search's memory, a PlannerScratch's: per cell g, parent and the stamps saying whether this
// search reached or closed it; the open list.
struct SearchMemory {
  double* g_cells;
  int* parent;
  std::uint32_t* reached;
  std::uint32_t* closed;
  std::uint32_t search;
  std::vector<OpenEntry>* open;
};

// One A* search from the start cell to the goal cell (Smac 2D's costs: a step's length times
// 1 + cost_travel_multiplier · cost / kMaxNonInscribedCost; Euclidean heuristic).
class AStarSearch {
 public:
  AStarSearch(const GlobalPlannerParams& params, const Costmap2D& costmap, CellIndex start,
              CellIndex goal, const world::Vec2& goal_m, SearchMemory memory)
      : params_(params),
        costmap_(costmap),
        costs_(costmap.costs()),
        nx_(costmap.size_x_cells()),
        ny_(costmap.size_y_cells()),
        resolution_m_(costmap.resolution_m()),
        start_(start),
        goal_(goal),
        goal_m_(goal_m),
        goal_index_(static_cast<int>(costmap.Index(goal.mx, goal.my))),
        escape_cells_sq_((params.start_escape_m / resolution_m_) *
                         (params.start_escape_m / resolution_m_)),
        m_(memory) {}

  // Expands cells until the goal, the expansion limit or an empty open list; the plan's status,
  // path, cost, length and expansions.
  void Run(GlobalPlan* plan) {
    const int start_index = static_cast<int>(costmap_.Index(start_.mx, start_.my));
    m_.g_cells[start_index] = 0.0;
    m_.parent[start_index] = -1;
    m_.reached[start_index] = m_.search;
    m_.open->clear();
    const double h_start = Heuristic_m(start_.mx, start_.my);
    Push({h_start, h_start, start_index});
    std::vector<OpenEntry>& open = *m_.open;
    while (!open.empty()) {
      std::pop_heap(open.begin(), open.end(), WorseEntry{});
      const OpenEntry top = open.back();
      open.pop_back();
      const int i = top.index;
      if (m_.closed[i] == m_.search) continue;  // a stale entry: closed at a lower cost
      m_.closed[i] = m_.search;
      ++plan->expansions;
      if (i == goal_index_) {
        Finish(i, true, plan);
        return;
      }
      const int mx = i % nx_;
      const int my = i / nx_;
      NoteIfNearest(i, mx, my);
      if (plan->expansions >= params_.max_expansions) {
        FinishWithinTolerance(PlanStatus::kExpansionLimit, plan);
        return;
      }
      ExpandNeighbours(i, mx, my);
    }
    FinishWithinTolerance(PlanStatus::kNoPath, plan);
  }

 private:
  bool NearStart(int i) const {
    const double dx = i % nx_ - static_cast<int>(start_.mx);
    const double dy = i / nx_ - static_cast<int>(start_.my);
    return dx * dx + dy * dy <= escape_cells_sq_;
  }
  bool Traversable(int i) const {
    const std::uint8_t c = costs_[i];
    if (c == kNoInformation) return params_.allow_unknown;
    return c < kInscribedInflatedObstacle ||
           (c == kInscribedInflatedObstacle && params_.start_escape_m > 0.0 && NearStart(i));
  }
  double Heuristic_m(int mx, int my) const {
    const double dx = mx - goal_.mx;
    const double dy = my - goal_.my;
    return resolution_m_ * std::sqrt(dx * dx + dy * dy);
  }
  // The cost so far of cell i: +inf until this search reaches it.
  double G(int i) const {
    return m_.reached[i] == m_.search ? m_.g_cells[i] : std::numeric_limits<double>::infinity();
  }
  void Push(const OpenEntry& entry) {
    m_.open->push_back(entry);
    std::push_heap(m_.open->begin(), m_.open->end(), WorseEntry{});
  }

  // The closed cell nearest the goal point (among equals the cheapest, then the lowest index),
  // for the tolerance.
  void NoteIfNearest(int i, int mx, int my) {
    const double distance_m = (costmap_.MapToWorld(mx, my) - goal_m_).norm();
    // Distances within kSameDistance_m are ties: rounding must not pick among equidistant cells.
    const bool nearer = distance_m < nearest_distance_m_ - kSameDistance_m;
    const bool tie = !nearer && distance_m <= nearest_distance_m_ + kSameDistance_m;
    if (nearer || (tie && (G(i) < G(nearest_) || (G(i) == G(nearest_) && i < nearest_)))) {
      nearest_distance_m_ = distance_m;
      nearest_ = i;
    }
  }

  void ExpandNeighbours(int i, int mx, int my) {
    for (const Move& move : kMoves) {
      const int cx = mx + move.dx;
      const int cy = my + move.dy;
      if (cx < 0 || cx >= nx_ || cy < 0 || cy >= ny_) continue;
      const int j = cy * nx_ + cx;
      if (m_.closed[j] == m_.search || !Traversable(j)) continue;
      const double weight = 1.0 + params_.cost_travel_multiplier *
                                      (static_cast<double>(costs_[j]) / kMaxNonInscribedCost);
      const double g_new = G(i) + resolution_m_ * move.step * weight;
      if (!(g_new < G(j))) continue;
      m_.g_cells[j] = g_new;
      m_.parent[j] = i;
      m_.reached[j] = m_.search;
      const double h = Heuristic_m(cx, cy);
      Push({g_new + h, h, j});
    }
  }

  void Finish(int end, bool exact, GlobalPlan* plan) const {
    plan->status = PlanStatus::kOk;
    plan->path_m = Backtrace(costmap_, m_.parent, end);
    plan->cost = G(end);
    plan->length_m = Length_m(plan->path_m);
    plan->exact_goal = exact;
  }
  void FinishWithinTolerance(PlanStatus otherwise, GlobalPlan* plan) const {
    if (nearest_ >= 0 && nearest_distance_m_ <= params_.tolerance_m) {
      Finish(nearest_, false, plan);
    } else {
      plan->status = otherwise;
    }
  }

  const GlobalPlannerParams& params_;
  const Costmap2D& costmap_;
  const std::vector<std::uint8_t>& costs_;
  const int nx_, ny_;
  const double resolution_m_;
  const CellIndex start_, goal_;
  const world::Vec2 goal_m_;
  const int goal_index_;
  const double escape_cells_sq_;
  SearchMemory m_;
  int nearest_{-1};
  double nearest_distance_m_{std::numeric_limits<double>::infinity()};
};

}  // namespace

GlobalPlan PlanGlobalPath(const GlobalPlannerParams& params, const Costmap2D& costmap,
                          const world::Vec2& start, const world::Vec2& goal,
                          PlannerScratch* scratch) {
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
  PlannerScratch local;
  PlannerScratch& memory = scratch != nullptr ? *scratch : local;
  const std::size_t n = costmap.costs().size();
  if (memory.g_.size() != n || ++memory.search_ == 0) {  // a new size, or the stamps wrapped
    memory.g_.assign(n, 0.0);
    memory.parent_.assign(n, -1);
    memory.reached_.assign(n, 0);
    memory.closed_.assign(n, 0);
    memory.search_ = 1;
  }
  AStarSearch search(params, costmap, *start_cell, *goal_cell, goal,
                     {memory.g_.data(), memory.parent_.data(), memory.reached_.data(),
                      memory.closed_.data(), memory.search_, &memory.open_});
  search.Run(&plan);
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
