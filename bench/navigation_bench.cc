// Issue 6: the costmaps and the global planner on the lab track (scenarios/tracks/lab.yaml; run
// from the repository root).
//   BM_GlobalPlanLab       A* from the real car's start (outer south lane) to the outer north lane
//                          on the inflated 1934 × 1934 global costmap at the map's 0.00517 m
//                          (reference §1, §6), smoothed.
//   BM_GlobalPlanLabScratch  the same with the search's memory kept from plan to plan.
//   BM_PlanThroughPosesLab the planner node's plan (1 Hz per car): ten goals 0.25 m apart along
//                          the outer south lane, one Smac 2D leg each.
//   BM_PlanThroughPosesLabMemo  the node's plans as the car drives: every plan 0.4 m further
//                          along the lane through the stations ahead, the legs between two
//                          stations the last plan shared kept (PlanLegMemo); per plan.
//   BM_InflateGlobal       static layer + inflation rebuild of the global costmap.
//   BM_LocalCostmapUpdate  one 5 × 5 m rolling local costmap update with the 234 marks of the
//                          obstacle grid (reference §4), the car moving along the lane.
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstddef>
#include <vector>

#include "sim/core/track_loader.h"
#include "stack/costmap.h"
#include "stack/global_planner.h"
#include "world/occupancy_map.h"

namespace {

using autonomsim::stack::CostmapMark;
using autonomsim::world::Vec2;

const autonomsim::world::OccupancyMap& LabMap() {
  static const autonomsim::world::OccupancyMap map =
      autonomsim::world::BuildStaticMap(autonomsim::sim::LoadTrack("scenarios/tracks/lab.yaml"),
                                        autonomsim::world::kLabMapResolution_m);
  return map;
}

void BM_GlobalPlanLab(benchmark::State& state) {
  const autonomsim::stack::GlobalCostmap global({}, LabMap());
  const autonomsim::stack::GlobalPlannerParams params;
  int expansions = 0;
  double length_m = 0.0;
  for (auto _ : state) {
    const auto plan =
        PlanGlobalPath(params, global.costmap(), Vec2(0.96, -2.18), Vec2(-0.96, 2.17));
    if (!plan.ok()) state.SkipWithError("no plan");
    expansions = plan.expansions;
    length_m = plan.length_m;
    benchmark::DoNotOptimize(plan.path_m.data());
  }
  state.counters["expansions"] = expansions;
  state.counters["length_m"] = length_m;
}
BENCHMARK(BM_GlobalPlanLab)->Unit(benchmark::kMicrosecond);

// The same plan as the planner node makes it, with one PlannerScratch for plan after plan.
void BM_GlobalPlanLabScratch(benchmark::State& state) {
  const autonomsim::stack::GlobalCostmap global({}, LabMap());
  const autonomsim::stack::GlobalPlannerParams params;
  autonomsim::stack::PlannerScratch scratch;
  for (auto _ : state) {
    const auto plan =
        PlanGlobalPath(params, global.costmap(), Vec2(0.96, -2.18), Vec2(-0.96, 2.17), &scratch);
    if (!plan.ok()) state.SkipWithError("no plan");
    benchmark::DoNotOptimize(plan.path_m.data());
  }
}
BENCHMARK(BM_GlobalPlanLabScratch)->Unit(benchmark::kMicrosecond);

void BM_PlanThroughPosesLab(benchmark::State& state) {
  const autonomsim::stack::GlobalCostmap global({}, LabMap());
  const autonomsim::stack::GlobalPlannerParams params;
  autonomsim::stack::PlannerScratch scratch;
  std::vector<Vec2> goals;
  for (int k = 1; k <= 10; ++k) goals.emplace_back(-1.5 + 0.25 * k, -2.17);
  int expansions = 0;
  for (auto _ : state) {
    const auto plan =
        PlanThroughPoses(params, global.costmap(), Vec2(-1.5, -2.17), goals, &scratch);
    if (!plan.ok()) state.SkipWithError("no plan");
    expansions = plan.expansions;
    benchmark::DoNotOptimize(plan.path_m.data());
  }
  state.counters["expansions"] = expansions;
  state.counters["scratch_bytes"] = static_cast<double>(scratch.bytes());
  state.counters["costmap_bytes"] = static_cast<double>(global.bytes());
}
BENCHMARK(BM_PlanThroughPosesLab)->Unit(benchmark::kMicrosecond);

void BM_PlanThroughPosesLabMemo(benchmark::State& state) {
  const autonomsim::stack::GlobalCostmap global({}, LabMap());
  const autonomsim::stack::GlobalPlannerParams params;
  autonomsim::stack::PlannerScratch scratch;
  autonomsim::stack::PlanLegMemo memo;
  double x_m = -2.0;  // along the outer south lane (y = -2.17), back again after 3.6 m
  for (auto _ : state) {
    x_m = x_m > 1.6 ? -2.0 : x_m + 0.4;
    std::vector<Vec2> goals;
    for (int n = static_cast<int>(std::floor(x_m / 0.25)) + 1; n * 0.25 <= x_m + 2.5; ++n) {
      goals.emplace_back(n * 0.25, -2.17);
    }
    const auto plan =
        PlanThroughPoses(params, global.costmap(), Vec2(x_m, -2.17), goals, &scratch, &memo);
    if (!plan.ok()) state.SkipWithError("no plan");
    benchmark::DoNotOptimize(plan.path_m.data());
  }
  state.counters["legs_reused"] =
      static_cast<double>(memo.reused()) / static_cast<double>(memo.reused() + memo.planned());
}
BENCHMARK(BM_PlanThroughPosesLabMemo)->Unit(benchmark::kMicrosecond);

void BM_InflateGlobal(benchmark::State& state) {
  autonomsim::stack::GlobalCostmap global({}, LabMap());
  for (auto _ : state) {
    benchmark::DoNotOptimize(global.Update().costs().data());
  }
}
BENCHMARK(BM_InflateGlobal)->Unit(benchmark::kMicrosecond);

// The obstacle grid's 18 × 13 cells (reference §4), centres at (gx·0.05 + 0.3, gy·0.05 − 0.325)
// in base_link, for a car at (x, y) heading +x; a 2 × 3-cell obstacle straight ahead.
std::vector<CostmapMark> GridMarks(double x_m, double y_m) {
  std::vector<CostmapMark> marks;
  marks.reserve(18 * 13);
  for (int gx = 0; gx < 18; ++gx) {
    for (int gy = 0; gy < 13; ++gy) {
      const bool lethal = (gx == 10 || gx == 11) && gy >= 5 && gy <= 7;
      marks.push_back({Vec2(x_m + gx * 0.05 + 0.3, y_m + gy * 0.05 - 0.325), lethal});
    }
  }
  return marks;
}

void BM_LocalCostmapUpdate(benchmark::State& state) {
  autonomsim::stack::LocalCostmap local({});
  // Along the outer south lane at 0.25 m/s, updated at 5 Hz (reference §6): 0.05 m, one cell,
  // per update, so every update rolls the window.
  std::vector<autonomsim::stack::LocalCostmapInput> inputs;
  for (int k = 0; k <= 80; ++k) {
    const double x_m = -2.0 + 0.05 * k;
    inputs.push_back({.p_robot = Vec2(x_m, -2.17), .marks = GridMarks(x_m, -2.17)});
  }
  std::size_t k = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(local.Step(inputs[k]).costs().data());
    k = (k + 1) % inputs.size();
  }
  state.counters["marks"] = 18 * 13;
}
BENCHMARK(BM_LocalCostmapUpdate)->Unit(benchmark::kMicrosecond);

}  // namespace
