// Sweep throughput (issue 8): runs per minute of a small fixed grid at --jobs 1 and --jobs 2.
// Parallel efficiency = (runs/min at jobs:2) / (2 * runs/min at jobs:1); runs are independent and
// single-threaded, so it is bounded by the machine (cores free, memory bandwidth), not the sweep.
//
//   build/bin/bench_sweep --benchmark_filter=BM_SweepThroughput
//
// The grid: the default scenario (both cars on the full stack) for 10 s simulated, lane planner
// latency scaled 1, 2, 4 and 8 times: four runs, so two workers get two each.
#include <benchmark/benchmark.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <string>

#include "sim/study/sweep.h"

namespace autonomsim::sim {
namespace {

namespace fs = std::filesystem;

void BM_SweepThroughput(benchmark::State& state) {
  SweepSpec spec;
  spec.scenario = fs::path(AUTONOMSIM_SOURCE_DIR) / "scenarios/lab_two_cars.yaml";
  spec.overrides = {"duration_s=10", "expect=[]"};
  spec.axes = {ParseVary("cars[0].platform.cost_scale.lane_planner=1,2,4,8")};
  const fs::path dir =
      fs::temp_directory_path() / ("autonomsim_bench_sweep_" + std::to_string(::getpid()));
  std::size_t runs = 0;
  const auto start = std::chrono::steady_clock::now();  // a benchmark may read the wall clock
  for (auto _ : state) {
    fs::remove_all(dir);  // every iteration runs the whole grid (nothing to resume)
    const SweepSummary summary =
        RunSweep(spec, SweepOptions{.out_dir = dir,
                                    .jobs = static_cast<int>(state.range(0)),
                                    .shard = {},
                                    .plots = false,
                                    .progress = {}});
    if (!summary.failures.empty()) state.SkipWithError(summary.failures.front().c_str());
    runs += summary.ran;
  }
  const double wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  fs::remove_all(dir);
  state.counters["runs_per_min"] = static_cast<double>(runs) * 60.0 / wall_s;
}
BENCHMARK(BM_SweepThroughput)
    ->ArgName("jobs")
    ->Arg(1)
    ->Arg(2)
    ->Iterations(2)
    ->UseRealTime()
    ->Unit(benchmark::kSecond);

}  // namespace
}  // namespace autonomsim::sim
