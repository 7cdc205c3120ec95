#include "stack/global_planner.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>

#include "world/validation.h"

namespace autonomsim::stack {

void SmootherParams::Validate() const {
  Require(max_iterations > 0,
          [&] { return "smoother.max_iterations must be > 0, got " + Num(max_iterations); });
  Require(std::isfinite(w_smooth) && w_smooth >= 0.0,
          [&] { return "smoother.w_smooth must be >= 0, got " + Num(w_smooth); });
  Require(std::isfinite(w_data) && w_data >= 0.0,
          [&] { return "smoother.w_data must be >= 0, got " + Num(w_data); });
  Require(std::isfinite(tolerance) && tolerance > 0.0,
          [&] { return "smoother.tolerance must be > 0, got " + Num(tolerance); });
}

void GlobalPlannerParams::Validate() const {
  Require(std::isfinite(tolerance_m) && tolerance_m >= 0.0,
          [&] { return "tolerance_m must be >= 0, got " + Num(tolerance_m); });
  Require(std::isfinite(cost_travel_multiplier) && cost_travel_multiplier >= 0.0, [&] {
    return "cost_travel_multiplier must be >= 0, got " + Num(cost_travel_multiplier);
  });
  Require(max_expansions > 0,
          [&] { return "max_expansions must be > 0, got " + Num(max_expansions); });
  Require(max_on_approach_iterations > 0, [&] {
    return "max_on_approach_iterations must be > 0, got " + Num(max_on_approach_iterations);
  });
  smoother.Validate();
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
    case PlanStatus::kStartOccupied:
      return "start in lethal space";
    case PlanStatus::kNoPath:
      return "no valid path found";
    case PlanStatus::kExpansionLimit:
      return "expansion limit reached";
  }
  return "unknown";
}

// --- the smoother (Galactic smoother.hpp:71-188) -----------------------------------------------

namespace {

// Galactic's MAX_NON_OBSTACLE (nav2_smac_planner/constants.hpp): 252.
bool InCollision(const Costmap2D& costmap, const world::Vec2& p) {
  const std::optional<std::uint8_t> cost = costmap.CostAt(p);
  return !cost || *cost > kMaxNonInscribedCost;
}

// One smoothing pass over *path (the data it is pulled back to is *path as it came in);
// `refine`: a converged pass smooths its result once more (smoother.hpp:165-169).
SmoothResult SmoothPass(const SmootherParams& params, const Costmap2D& costmap, bool refine,
                        std::vector<world::Vec2>* path) {
  const std::vector<world::Vec2>& data = *path;
  const std::size_t n = data.size();
  std::vector<world::Vec2> next = data;
  std::vector<world::Vec2> last = data;
  SmoothResult result;
  double change = params.tolerance;
  int its = 0;
  while (change >= params.tolerance) {
    ++its;
    change = 0.0;
    if (its >= params.max_iterations) {
      *path = std::move(last);
      return result;
    }
    for (std::size_t i = 2; i != n - 2; ++i) {
      for (int j = 0; j != 2; ++j) {
        const double x_i = data[i][j];
        double y_i = next[i][j];
        const double y_org = y_i;
        const double y_m1 = next[i - 1][j];
        const double y_p1 = next[i + 1][j];
        if (i > 2) {
          const double y_m2 = next[i - 2][j];
          const double y_p2 = next[i + 2][j];
          y_i += params.w_data * (x_i - y_i) +
                 params.w_smooth * (y_m2 + y_p2 + y_p1 + y_m1 - 4.0 * y_i);
        } else {
          y_i += params.w_data * (x_i - y_i) + params.w_smooth * (y_p1 + y_m1 - 2.0 * y_i);
        }
        next[i][j] = y_i;
        change += std::abs(y_i - y_org);
      }
      if (InCollision(costmap, next[i])) {
        *path = std::move(last);
        return result;
      }
    }
    last = next;
    result.sweeps = its;
  }
  if (refine) SmoothPass(params, costmap, false, &next);
  *path = std::move(next);
  result.converged = true;
  return result;
}

}  // namespace

SmoothResult SmoothPath(const SmootherParams& params, const Costmap2D& costmap,
                        std::vector<world::Vec2>* path) {
  if (path->size() < 5) return {};  // no pose between the two fixed ones at each end
  return SmoothPass(params, costmap, true, path);
}

// --- the search (Galactic a_star.cpp, node_2d.cpp) ---------------------------------------------

std::size_t PlannerScratch::bytes() const {
  return window_.capacity() * sizeof(WindowCell) + slots_.capacity() * sizeof(Slot) +
         open_.capacity() * sizeof(OpenEntry);
}

void PlannerScratch::Begin(int nx, int cx, int cy) {
  constexpr std::size_t kInitialSlots = std::size_t{1} << 12;  // assumed: beyond the window, rare
  if (slots_.empty()) slots_.assign(kInitialSlots, Slot{0, -1, {}});
  if (window_.empty()) window_.assign(std::size_t{kWindowCells} * kWindowCells, WindowCell{0, {}});
  nx_ = nx;
  window_x0_ = cx - kWindowCells / 2;
  window_y0_ = cy - kWindowCells / 2;
  used_ = 0;
  open_.clear();
  if (++search_ == 0) {  // the stamps wrapped: clear them once
    for (Slot& slot : slots_) slot.stamp = 0;
    for (WindowCell& cell : window_) cell.stamp = 0;
    search_ = 1;
  }
}

PlannerScratch::WindowCell* PlannerScratch::WindowCellAt(int mx, int my) {
  const auto lx = static_cast<unsigned>(mx - window_x0_);
  const auto ly = static_cast<unsigned>(my - window_y0_);
  if (lx >= unsigned{kWindowCells} || ly >= unsigned{kWindowCells}) return nullptr;
  return &window_[ly * kWindowCells + lx];
}

PlannerScratch::Node* PlannerScratch::Find(int key, int mx, int my) {
  if (WindowCell* cell = WindowCellAt(mx, my)) {
    return cell->stamp == search_ ? &cell->node : nullptr;
  }
  return FindHashed(key);
}

PlannerScratch::Node& PlannerScratch::Emplace(int key, int mx, int my, const Node& fresh,
                                              bool* added) {
  if (WindowCell* cell = WindowCellAt(mx, my)) {
    *added = cell->stamp != search_;
    if (*added) *cell = WindowCell{search_, fresh};
    return cell->node;
  }
  return EmplaceHashed(key, fresh, added);
}

std::size_t PlannerScratch::SlotOf(int key) const {
  // Fibonacci hashing onto the power-of-two table.
  return (static_cast<std::uint32_t>(key) * 2654435769u) & (slots_.size() - 1);
}

PlannerScratch::Node* PlannerScratch::FindHashed(int key) {
  for (std::size_t i = SlotOf(key);; i = (i + 1) & (slots_.size() - 1)) {
    Slot& slot = slots_[i];
    if (slot.stamp != search_) return nullptr;
    if (slot.key == key) return &slot.node;
  }
}

PlannerScratch::Node& PlannerScratch::EmplaceHashed(int key, const Node& fresh, bool* added) {
  if (2 * (used_ + 1) > slots_.size()) Grow();
  for (std::size_t i = SlotOf(key);; i = (i + 1) & (slots_.size() - 1)) {
    Slot& slot = slots_[i];
    if (slot.stamp != search_) {
      slot = Slot{search_, key, fresh};
      ++used_;
      *added = true;
      return slot.node;
    }
    if (slot.key == key) {
      *added = false;
      return slot.node;
    }
  }
}

void PlannerScratch::Grow() {
  std::vector<Slot> old = std::move(slots_);
  slots_.assign(2 * old.size(), Slot{0, -1, {}});
  used_ = 0;
  bool added = false;
  for (const Slot& slot : old) {
    if (slot.stamp == search_) EmplaceHashed(slot.key, slot.node, &added);
  }
}

namespace {

using OpenEntry = PlannerScratch::OpenEntry;
using Node = PlannerScratch::Node;

// The open list is a heap with the least (f, h, index) on top.
struct WorseEntry {
  bool operator()(const OpenEntry& a, const OpenEntry& b) const {
    if (a.f != b.f) return a.f > b.f;
    if (a.h != b.h) return a.h > b.h;
    return a.index > b.index;
  }
};

// Galactic's Moore neighbourhood in its order (node_2d.cpp:107-110): as (dx, dy).
constexpr int kMoves[8][2] = {{-1, 0}, {1, 0}, {0, -1}, {0, 1}, {-1, -1}, {1, -1}, {-1, 1}, {1, 1}};

double Length_m(const std::vector<world::Vec2>& path) {
  double length = 0.0;
  for (std::size_t i = 1; i < path.size(); ++i) length += (path[i] - path[i - 1]).norm();
  return length;
}

// Each cell cost over MAX_NON_OBSTACLE (252), in float (Node2D::getTraversalCost, node_2d.cpp:
// 64-79): a constant table, so that a step costs no division.
const std::array<float, 256>& NormalizedCosts() {
  static const std::array<float, 256> table = [] {
    std::array<float, 256> t{};
    for (std::size_t c = 0; c < t.size(); ++c) {
      t[c] = static_cast<float>(static_cast<double>(c) / double{kMaxNonInscribedCost});
    }
    return t;
  }();
  return table;
}

}  // namespace

// One search (AStarAlgorithm<Node2D>::createPath) on a costmap, in the scratch's memory.
class AStarSearch {
 public:
  AStarSearch(const GlobalPlannerParams& params, const Costmap2D& costmap, CellIndex start,
              CellIndex goal, PlannerScratch* memory)
      : params_(params),
        costs_(costmap.costs()),
        nx_(costmap.size_x_cells()),
        ny_(costmap.size_y_cells()),
        start_(start),
        goal_(goal),
        goal_index_(goal.my * nx_ + goal.mx),
        tolerance_cells_(static_cast<float>(params.tolerance_m) /
                         static_cast<float>(costmap.resolution_m())),
        multiplier_(static_cast<float>(params.cost_travel_multiplier)),
        escape_cells_sq_((params.start_escape_m / costmap.resolution_m()) *
                         (params.start_escape_m / costmap.resolution_m())),
        memory_(*memory),
        open_(memory->open_) {
    memory_.Begin(nx_, start.mx, start.my);
  }

  bool Valid(int i) const {
    const std::uint8_t c = costs_[i];
    if (c == kNoInformation && params_.allow_unknown) return true;
    return c < kInscribedInflatedObstacle ||
           (c == kInscribedInflatedObstacle && params_.start_escape_m > 0.0 && NearStart(i));
  }

  // Expands until the goal, the approach limit, max_expansions or an empty open list (a_star.cpp:
  // 250-308). The cell the path ends in, or -1 with the failure in *plan.
  int Run(GlobalPlan* plan) {
    const int start_index = start_.my * nx_ + start_.mx;
    bool added = false;
    memory_.Emplace(start_index, start_.mx, start_.my, Node{0.0F, -1, false}, &added);
    Push({0.0F, 0.0F, start_index});  // addNode(0.0, start): no heuristic for the start
    int approach = 0;
    while (plan->expansions < params_.max_expansions && !open_.empty()) {
      std::pop_heap(open_.begin(), open_.end(), WorseEntry{});
      const int i = open_.back().index;
      open_.pop_back();
      const int mx = i % nx_;
      const int my = i / nx_;
      Node* node = memory_.Find(i, mx, my);
      if (node->closed) continue;  // queued again at a lower cost and already expanded
      ++plan->expansions;
      node->closed = true;
      if (i == goal_index_) return i;
      if (best_h_ < tolerance_cells_ && ++approach >= params_.max_on_approach_iterations) {
        return best_index_;
      }
      ExpandNeighbours(i, mx, my, node->g);
    }
    plan->status = plan->expansions < params_.max_expansions ? PlanStatus::kNoPath
                                                             : PlanStatus::kExpansionLimit;
    return -1;
  }

  float G(int i) const { return memory_.Find(i, i % nx_, i / nx_)->g; }
  int Parent(int i) const { return memory_.Find(i, i % nx_, i / nx_)->parent; }

 private:
  bool NearStart(int i) const {
    const double dx = i % nx_ - start_.mx;
    const double dy = i / nx_ - start_.my;
    return dx * dx + dy * dy <= escape_cells_sq_;
  }
  void Push(const OpenEntry& entry) {
    open_.push_back(entry);
    std::push_heap(open_.begin(), open_.end(), WorseEntry{});
  }
  // Node2D::getTraversalCost (node_2d.cpp:64-79), in float as Galactic's.
  float TraversalCost(int j, bool diagonal) const {
    static const float kSqrt2 = std::sqrt(2.0F);
    return (diagonal ? kSqrt2 : 1.0F) + multiplier_ * normalized_[costs_[j]];
  }
  // Node2D::getHeuristicCost (node_2d.cpp:81-90): Manhattan, in cells.
  float Heuristic(int mx, int my) const {
    return std::fabs(static_cast<float>(goal_.mx - mx)) +
           std::fabs(static_cast<float>(goal_.my - my));
  }

  void ExpandNeighbours(int i, int mx, int my, float g_i) {
    for (const auto& move : kMoves) {
      const int cx = mx + move[0];
      const int cy = my + move[1];
      if (cx < 0 || cx >= nx_ || cy < 0 || cy >= ny_) continue;
      const int j = cy * nx_ + cx;
      if (!Valid(j)) continue;
      bool added = false;
      Node& neighbour =
          memory_.Emplace(j, cx, cy, Node{std::numeric_limits<float>::max(), -1, false}, &added);
      if (neighbour.closed) continue;
      const float g = g_i + TraversalCost(j, move[0] != 0 && move[1] != 0);
      if (!(g < neighbour.g)) continue;
      neighbour.g = g;
      neighbour.parent = i;
      const float h = Heuristic(cx, cy);
      if (h < best_h_) {  // AStarAlgorithm::getHeuristicCost (a_star.cpp:405-418)
        best_h_ = h;
        best_index_ = j;
      }
      Push({g + h, h, j});
    }
  }

  const GlobalPlannerParams& params_;
  const std::vector<std::uint8_t>& costs_;
  const int nx_, ny_;
  const CellIndex start_, goal_;
  const int goal_index_;
  const float tolerance_cells_;
  const float multiplier_;
  const std::array<float, 256>& normalized_{NormalizedCosts()};
  const double escape_cells_sq_;
  PlannerScratch& memory_;
  std::vector<OpenEntry>& open_;
  float best_h_{std::numeric_limits<float>::max()};
  int best_index_{0};
};

namespace {

// The cell centres from the one after the start to `end` (a_star.cpp:316-333).
std::vector<world::Vec2> Backtrace(const Costmap2D& costmap, const AStarSearch& search, int end) {
  std::vector<world::Vec2> path;
  for (int i = end; search.Parent(i) >= 0; i = search.Parent(i)) {
    const CellIndex cell = costmap.Cell(static_cast<std::size_t>(i));
    path.push_back(costmap.MapToWorld(cell.mx, cell.my));
  }
  return {path.rbegin(), path.rend()};
}

// SmacPlanner2D::createPlan (smac_planner_2d.cpp:205-340) between two cells of the costmap.
void PlanBetweenCells(const GlobalPlannerParams& params, const Costmap2D& costmap,
                      const world::Vec2& start, CellIndex start_cell, CellIndex goal_cell,
                      PlannerScratch* scratch, GlobalPlan* plan) {
  if (start_cell == goal_cell) {  // smac_planner_2d.cpp:245-260
    if (costmap.Cost(start_cell.mx, start_cell.my) == kLethalObstacle) {
      plan->status = PlanStatus::kStartOccupied;
      return;
    }
    plan->status = PlanStatus::kOk;
    plan->path_m = {start};
    plan->exact_goal = true;
    return;
  }
  AStarSearch search(params, costmap, start_cell, goal_cell, scratch);
  const int goal_index = static_cast<int>(costmap.Index(goal_cell.mx, goal_cell.my));
  if (params.tolerance_m < 0.001 && !search.Valid(goal_index)) {  // a_star.cpp:194-199
    plan->status = PlanStatus::kNoPath;
    return;
  }
  if (!search.Valid(static_cast<int>(costmap.Index(start_cell.mx, start_cell.my)))) {
    plan->status = PlanStatus::kStartOccupied;  // a_star.cpp:201-204
    return;
  }
  const int end = search.Run(plan);
  if (end < 0) return;
  plan->status = PlanStatus::kOk;
  plan->path_m = Backtrace(costmap, search, end);
  plan->cost = search.G(end) * costmap.resolution_m();
  plan->exact_goal = end == goal_index;
  if (plan->path_m.size() > 6) SmoothPath(params.smoother, costmap, &plan->path_m);
}

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
  PlanBetweenCells(params, costmap, start, *start_cell, *goal_cell,
                   scratch != nullptr ? scratch : &local, &plan);
  plan.length_m = Length_m(plan.path_m);
  return plan;
}

const GlobalPlan* PlanLegMemo::Find(const world::Vec2& from, const world::Vec2& to) const {
  for (const Leg& leg : last_) {
    if (leg.from.x() == from.x() && leg.from.y() == from.y() && leg.to.x() == to.x() &&
        leg.to.y() == to.y()) {
      return &leg.plan;
    }
  }
  return nullptr;
}

GlobalPlan PlanThroughPoses(const GlobalPlannerParams& params, const Costmap2D& costmap,
                            const world::Vec2& start, const std::vector<world::Vec2>& goals,
                            PlannerScratch* scratch, PlanLegMemo* memo) {
  if (goals.empty()) return PlanGlobalPath(params, costmap, start, start, scratch);
  if (memo != nullptr && (memo->costmap_ != &costmap || !(memo->params_ == params))) {
    memo->costmap_ = &costmap;
    memo->params_ = params;
    memo->last_.clear();
  }
  if (memo != nullptr) memo->current_.clear();
  GlobalPlan joined;
  joined.status = PlanStatus::kOk;
  for (std::size_t i = 0; i < goals.size(); ++i) {
    const world::Vec2& from = i == 0 ? start : goals[i - 1];
    const GlobalPlan* known = memo != nullptr ? memo->Find(from, goals[i]) : nullptr;
    GlobalPlan leg =
        known != nullptr ? *known : PlanGlobalPath(params, costmap, from, goals[i], scratch);
    if (memo != nullptr) {
      ++(known != nullptr ? memo->reused_ : memo->planned_);
      memo->current_.push_back({from, goals[i], leg});
    }
    joined.expansions += leg.expansions;
    if (!leg.ok()) {
      joined.status = leg.status;
      joined.path_m.clear();
      joined.cost = 0.0;
      joined.length_m = 0.0;
      joined.exact_goal = false;
      break;
    }
    joined.path_m.insert(joined.path_m.end(), leg.path_m.begin(), leg.path_m.end());
    joined.cost += leg.cost;
    joined.exact_goal = leg.exact_goal;
  }
  if (memo != nullptr) std::swap(memo->last_, memo->current_);
  if (joined.ok()) joined.length_m = Length_m(joined.path_m);
  return joined;
}

}  // namespace autonomsim::stack
