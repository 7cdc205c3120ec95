// The global planner (reference §6: Nav2 Galactic's Smac Planner 2D, nav2_car_params.yaml:256-276):
// 8-connected A* over the global costmap's cells, as Galactic's nav2_smac_planner reads it:
//   - a cell is traversable when its cost is below INSCRIBED (253); NO_INFORMATION (255) only when
//     allow_unknown (GridCollisionChecker::inCollision, collision_checker.hpp:174-185);
//   - moving into cell c costs 1 (a side step) or √2 (a diagonal step), in cells, PLUS
//     cost_travel_multiplier · cost(c) / 252 (Node2D::getTraversalCost, node_2d.cpp:64-79): the
//     cost term is added per step, not scaled by the step's length;
//   - the heuristic is the Manhattan distance to the goal cell in cells (Node2D::getHeuristicCost,
//     node_2d.cpp:81-90). On an 8-connected grid it overestimates (a diagonal step costs √2 but
//     lowers it by 2), so the search is greedier than optimal A*: plans need not be the cheapest;
//   - a diagonal move checks only the cell it enters (Node2D::getNeighbors, node_2d.cpp:118-156);
//   - a start cell of cost >= INSCRIBED fails the plan ("Starting point in lethal space",
//     a_star.cpp:201-204); a start and goal in the same cell give a one-pose plan at the start
//     unless that cell is LETHAL (smac_planner_2d.cpp:245-260);
//   - goal tolerance and the search's end (a_star.cpp:250-308, 405-418): the node with the least
//     heuristic of all nodes queued so far is kept; once it is within tolerance_m / resolution
//     (in Manhattan cells), the search returns the path to it after max_on_approach_iterations
//     more expansions unless it reaches the goal cell first. An emptied open list or
//     max_iterations expansions fail the plan even within tolerance;
//   - the path is the cell centres after the start cell up to the goal (or tolerance) cell: the
//     start cell is not in it (a_star.cpp:316-333, smac_planner_2d.cpp:289-294);
//   - a path of more than 6 poses is smoothed (smac_planner_2d.cpp:311-314) by Galactic's
//     Smoother (smoother.hpp:71-188): see SmoothPath below.
// Not modelled: max_planning_time (2 s, yaml:269) bounds only the smoother by wall time
// (smac_planner_2d.cpp:301-314); here the smoother always runs to its own end. The open list: ours
// orders by (f, h, cell index); Galactic's std::priority_queue orders by f only, its ties by the
// heap's internals (a_star.hpp:80-88), so among equal-f nodes the two may expand in another order.
// The costs are float, as Galactic's.
//
// Deterministic: the same costmap, start and goal give the same path on every run and machine.
// Failure is a status, never an exception.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "stack/costmap.h"
#include "world/geometry.h"

namespace autonomsim::stack {

// Galactic's Smoother (smoother.hpp): Gauss-Seidel sweeps over the poses 2 .. n-3 (the first
// and last two stay), each coordinate y_i += w_data (x_i - y_i) + w_smooth (y_{i-2} + y_{i+2} +
// y_{i-1} + y_{i+1} - 4 y_i) (3 points at i = 2), until the summed change of a sweep is below
// tolerance; a sweep that moves a pose onto a cell of cost > 252 (INSCRIBED or LETHAL) returns the
// path of the sweep before; reaching max_iterations returns the last sweep's path. A converged
// path is smoothed once more with itself as the data (do_refinement).
struct SmootherParams {
  int max_iterations{1000};  // nav2_car_params.yaml:273
  double w_smooth{0.3};      // yaml:274
  double w_data{0.2};        // yaml:275
  double tolerance{1e-10};   // yaml:276 (metres, summed over the path's coordinates)

  template <class V>
  void Describe(V& v) {
    v("max_iterations", max_iterations, "the smoother's sweeps at most");
    v("w_smooth", w_smooth, "weight of smoothness");
    v("w_data", w_data, "weight of staying on the planned path");
    v("tolerance", tolerance,
      "a sweep changing the path by less than this (m, summed) ends the smoothing");
  }
  void Validate() const;
  bool operator==(const SmootherParams&) const = default;
};

struct SmoothResult {
  bool converged{false};  // Galactic's return value: false after a collision or the cap
  int sweeps{0};          // sweeps of the first pass that were kept
};

// Smooths `path` in place on `costmap` (poses outside it count as a collision).
SmoothResult SmoothPath(const SmootherParams& params, const Costmap2D& costmap,
                        std::vector<world::Vec2>* path);

struct GlobalPlannerParams {
  double tolerance_m{0.125};             // nav2_car_params.yaml:263
  double cost_travel_multiplier{2.0};    // yaml:270
  bool allow_unknown{true};              // yaml:266; the lab's map has no unknown cells
  int max_expansions{1000000};           // yaml:267 (max_iterations)
  int max_on_approach_iterations{1000};  // yaml:268
  SmootherParams smoother{};             // yaml:272-276
  // Beyond Smac (0: Smac, the lab's): cells within this distance of the start may be INSCRIBED
  // (not LETHAL), so a car whose centre came within its inscribed radius of a painted line can
  // plan its way out instead of failing until the navigation gives up. stack.preset: safe sets
  // 0.3 m (assumed: two car half-widths).
  double start_escape_m{0.0};

  template <class V>
  void Describe(V& v) {
    v("tolerance_m", tolerance_m, "a goal in an obstacle may be reached this close instead");
    v("cost_travel_multiplier", cost_travel_multiplier, "how strongly A* avoids costly cells");
    v("allow_unknown", allow_unknown, "plan through unknown cells");
    v("max_expansions", max_expansions, "A* expansions before it gives up");
    v("max_on_approach_iterations", max_on_approach_iterations,
      "expansions once within the tolerance of the goal");
    v("smoother", smoother, "the smoother run on the plan");
    v("start_escape_m", start_escape_m,
      "cells this close to the start may be near a line, so a car that came near one can plan away "
      "(lab: 0)");
  }
  void Validate() const;
  bool operator==(const GlobalPlannerParams&) const = default;
};

enum class PlanStatus {
  kOk,               // path reaches the goal cell, or a cell within tolerance of the goal
  kStartOutsideMap,  // (Galactic does not check: worldToMap's result is ignored)
  kGoalOutsideMap,
  kStartOccupied,   // Smac: "Starting point in lethal space"
  kNoPath,          // the open list emptied first (Smac: "no valid path found")
  kExpansionLimit,  // max_expansions reached first (Smac: "exceeded maximum iterations")
};
std::string ToString(PlanStatus status);

struct GlobalPlan {
  PlanStatus status{PlanStatus::kNoPath};
  std::vector<world::Vec2> path_m;  // see the header comment; empty unless kOk
  double cost{0.0};        // the search's accumulated cost to the last cell, times the resolution
  double length_m{0.0};    // the path's geometric length (from its first pose)
  bool exact_goal{false};  // ends in the goal's own cell (false: a cell within tolerance)
  int expansions{0};       // cells expanded (closed)

  bool ok() const { return status == PlanStatus::kOk; }
};

// The search's memory, for a caller that plans again and again (a planner node): the nodes this
// search touched, by cell index, in an open-addressing hash table whose slots are stamped with the
// search they belong to (so a new search starts without clearing them; Galactic keeps an
// unordered_map: memory grows with the search, not with the 1934² map), and the open list. The
// plans are the same with or without it.
class PlannerScratch {
 public:
  struct Node {
    float g;     // accumulated cost, cells
    int parent;  // cell index, -1 for the start
    bool closed;
  };
  // An entry of the open list.
  struct OpenEntry {
    float f;  // g + h, cells
    float h;  // heuristic: among equal f, the one nearer the goal first
    int index;
  };
  // Bytes the scratch holds now (its window's, table's and open list's storage).
  std::size_t bytes() const;

 private:
  friend class AStarSearch;
  struct Slot {
    std::uint32_t stamp;  // == search_: in use by this search
    int key;              // cell index
    Node node;
  };
  struct WindowCell {
    std::uint32_t stamp;  // == search_: in use by this search
    Node node;
  };
  // The cells of a search are kept in a dense window of kWindowCells² cells centred on its start
  // (a leg of a plan through poses stays inside it) and in a hash table beyond it.
  static constexpr int kWindowCells = 256;
  // A new search: every cell free, the window centred on (cx, cy) in a grid nx cells wide.
  void Begin(int nx, int cx, int cy);
  Node* Find(int key, int mx, int my);  // nullptr if this search has no node for the cell
  Node& Emplace(int key, int mx, int my, const Node& fresh, bool* added);  // may move hashed nodes
  WindowCell* WindowCellAt(int mx, int my);  // nullptr outside the window
  Node* FindHashed(int key);
  Node& EmplaceHashed(int key, const Node& fresh, bool* added);
  std::size_t SlotOf(int key) const;
  void Grow();
  std::vector<WindowCell> window_;
  int window_x0_{0}, window_y0_{0};
  int nx_{0};
  std::vector<Slot> slots_;
  std::size_t used_{0};
  std::uint32_t search_{0};
  std::vector<OpenEntry> open_;
};

// Plans from start to goal (both in the costmap's frame) on `costmap`, with params as their
// Validate accepts them (the planner's node validates them once, when it is built). `scratch`
// (optional) is the search's memory.
GlobalPlan PlanGlobalPath(const GlobalPlannerParams& params, const Costmap2D& costmap,
                          const world::Vec2& start, const world::Vec2& goal,
                          PlannerScratch* scratch = nullptr);

// The legs of the last PlanThroughPoses, for a caller that plans through overlapping goals again
// and again on one costmap whose costs do not change while it keeps the memo (the planner node:
// the static global costmap, and the behaviour's goals at fixed route stations). A leg is a pure
// function of its two ends, the costmap and the params, so a leg planned by the last call between
// the same two points (bit for bit) is taken as it was instead of searched again: the plan is the
// same, its expansions included; only the wall time differs. A call with another costmap or other
// params forgets the legs first.
class PlanLegMemo {
 public:
  std::uint64_t reused() const { return reused_; }    // legs taken from the memo, all calls
  std::uint64_t planned() const { return planned_; }  // legs searched, all calls

 private:
  friend GlobalPlan PlanThroughPoses(const GlobalPlannerParams&, const Costmap2D&,
                                     const world::Vec2&, const std::vector<world::Vec2>&,
                                     PlannerScratch*, PlanLegMemo*);
  struct Leg {
    world::Vec2 from, to;
    GlobalPlan plan;
  };
  // The last call's leg from `from` to `to`, or nullptr.
  const GlobalPlan* Find(const world::Vec2& from, const world::Vec2& to) const;
  const Costmap2D* costmap_{nullptr};
  GlobalPlannerParams params_{};
  std::vector<Leg> last_, current_;
  std::uint64_t reused_{0}, planned_{0};
};

// Galactic's ComputePathThroughPoses (nav2_planner/src/planner_server.cpp:355-381): one plan per
// leg, the first from start, each next one from the previous GOAL (not from where the previous
// leg's path ended), each smoothed on its own, joined as they are. The status is the first
// failing leg's (and the path empty); expansions and cost add up; the length is the joined
// path's; exact_goal is the last leg's. No goals: a one-point plan at start. `memo` (optional):
// the legs of the last call, see PlanLegMemo.
GlobalPlan PlanThroughPoses(const GlobalPlannerParams& params, const Costmap2D& costmap,
                            const world::Vec2& start, const std::vector<world::Vec2>& goals,
                            PlannerScratch* scratch = nullptr, PlanLegMemo* memo = nullptr);

}  // namespace autonomsim::stack
