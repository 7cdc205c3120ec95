// The global planner (reference §6: Nav2 Smac Planner 2D, tolerance 0.125 m, cost multiplier 2.0):
// 8-connected A* over the global costmap's cells, as nav2_smac_planner's Node2D:
//   - a cell is traversable when its cost is below INSCRIBED (253); NO_INFORMATION (255) only when
//     allow_unknown (GridCollisionChecker::inCollision, Node2D::isNodeValid);
//   - moving into cell c costs step · (1 + cost_travel_multiplier · cost(c) / 252), step = 1 or √2
//     cells (Node2D::getTraversalCost in nav2_smac_planner/src/node_2d.cpp), here in metres;
//   - the heuristic is the straight-line distance to the goal cell (Node2D::getHeuristicCost),
//     admissible because every step costs at least its length;
//   - a diagonal move checks only the cell it enters, as Node2D::getNeighbors; on an inflated
//     costmap every LETHAL cell has an INSCRIBED halo, so no move can slip between two obstacles;
//   - the start cell is not checked (Smac: "the start is cleared" by the costmap's footprint
//     clearing), only that it lies on the map;
//   - goal tolerance: if the goal cell cannot be reached, the reachable cell whose centre is
//     nearest the goal point (ties: cheaper path, then lower index) is used when it lies within
//     tolerance_m. Smac keeps a best-heuristic node and stops max_on_approach_iterations after
//     first coming within tolerance; here the search runs until the open list is empty, so the
//     cell is the nearest of all reachable ones (a whole-map search: 100 × 100 cells on the lab).
// The path is the cell centres from the start cell to the goal cell, unsmoothed, as Smac 2D returns
// them (assumed: the reference does not say whether the car's planner smoothed its paths).
//
// Deterministic: the open list orders by (f, h, cell index), a cell's parent changes only on a
// strictly cheaper cost, and neighbours are expanded in a fixed order, so the same costmap, start
// and goal give the same path on every run and machine. Failure is a status, never an exception.
#pragma once

#include <string>
#include <vector>

#include "stack/costmap.h"
#include "world/geometry.h"

namespace autonomsim::stack {

struct GlobalPlannerParams {
  double tolerance_m{0.125};           // reference §6: Smac 2D tolerance 0.125 m
  double cost_travel_multiplier{2.0};  // reference §6: cost multiplier 2.0
  // assumed: Smac 2D's default (allow_unknown: true); the lab's static map has no unknown cells.
  bool allow_unknown{true};
  // assumed: a bound on expanded cells like Smac's max_iterations (default 1000000); the lab's
  // 100 × 100 costmap never comes near it.
  int max_expansions{1000000};
  // Beyond Smac (0: Smac, the lab's): cells within this distance of the start may be INSCRIBED
  // (not LETHAL), so a car whose centre came within its inscribed radius of a painted island (a
  // filled obstacle of the static map) can plan its way out instead of failing until the
  // navigation gives up. stack.preset: safe sets 0.3 m (assumed: two car half-widths).
  double start_escape_m{0.0};

  template <class V>
  void Describe(V& v) {
    v("tolerance_m", tolerance_m);
    v("cost_travel_multiplier", cost_travel_multiplier);
    v("allow_unknown", allow_unknown);
    v("max_expansions", max_expansions);
    v("start_escape_m", start_escape_m);
  }
  void Validate() const;
};

enum class PlanStatus {
  kOk,               // path reaches the goal cell, or a cell within tolerance of the goal
  kStartOutsideMap,  // Smac: StartOutsideMapBounds
  kGoalOutsideMap,   // Smac: GoalOutsideMapBounds
  kNoPath,           // nothing reachable within tolerance of the goal
  kExpansionLimit,   // max_expansions reached first (Smac: PlannerTimedOut)
};
std::string ToString(PlanStatus status);

struct GlobalPlan {
  PlanStatus status{PlanStatus::kNoPath};
  std::vector<world::Vec2> path_m;  // cell centres, start cell first; empty unless kOk
  double cost{0.0};        // accumulated traversal cost of the path (metres, cost-weighted)
  double length_m{0.0};    // its geometric length
  bool exact_goal{false};  // ends in the goal's own cell (false: a cell within tolerance)
  int expansions{0};       // cells expanded (closed)

  bool ok() const { return status == PlanStatus::kOk; }
};

// The search's memory, for a caller that plans again and again (a planner node): per cell, the
// cost so far and the parent, valid only where stamped by the current search, so a new search
// starts without clearing them; and the open list. The plans are the same with or without it.
class PlannerScratch {
 public:
  // An entry of the open list.
  struct OpenEntry {
    double f;  // g + h, metres
    double h;  // heuristic, metres: among equal f, the one nearer the goal first
    int index;
  };

 private:
  friend GlobalPlan PlanGlobalPath(const GlobalPlannerParams&, const Costmap2D&, const world::Vec2&,
                                   const world::Vec2&, PlannerScratch*);
  std::vector<double> g_;
  std::vector<int> parent_;
  std::vector<std::uint32_t> reached_;  // == search_: g_ and parent_ hold this search's values
  std::vector<std::uint32_t> closed_;   // == search_: closed in this search
  std::uint32_t search_{0};
  std::vector<OpenEntry> open_;
};

// Plans from start to goal (both in the costmap's frame) on `costmap`, with params as their
// Validate accepts them (the planner's node validates them once, when it is built). A start
// and goal in the same cell give a one-point path. `scratch` (optional) is the search's memory.
GlobalPlan PlanGlobalPath(const GlobalPlannerParams& params, const Costmap2D& costmap,
                          const world::Vec2& start, const world::Vec2& goal,
                          PlannerScratch* scratch = nullptr);

// Nav2's ComputePathThroughPoses: one plan per leg (start → goals[0] → goals[1] → ...), each leg
// from the previous leg's last cell, joined without repeating the shared cell. The status is the
// first failing leg's (and the path empty, as for any failed plan); expansions, cost and length
// add up; exact_goal is the last leg's. No goals: a one-point plan at start.
GlobalPlan PlanThroughPoses(const GlobalPlannerParams& params, const Costmap2D& costmap,
                            const world::Vec2& start, const std::vector<world::Vec2>& goals,
                            PlannerScratch* scratch = nullptr);

}  // namespace autonomsim::stack
