// The whole closed loop (issue 19): BM_ClosedLoopDefault runs the default scenario,
// scenarios/lab_two_cars.yaml (two stack-driven cars, both cameras of both cars at 640×480 and
// 30 fps), cut to 30 s of simulated time, and reports simulated seconds per wall second
// (`sim_s_per_wall_s`, the real-time factor) on one thread. docs/performance.md#speed-today
// times `autonomsim run` on the whole 200 s (medians), which this tracks.
//
//     build/bin/bench_closed_loop --benchmark_filter=BM_ClosedLoopDefault
//     build/bin/bench_closed_loop --benchmark_filter=BM_ClosedLoopCars   # /2, /4, /10 cars
#include <benchmark/benchmark.h>

#include <string>
#include <vector>

#include "sim/loop/simulation.h"
#include "sim/scenario/scenario.h"

namespace autonomsim {
namespace {

void RunScenario(benchmark::State& state, const std::string& file, double seconds,
                 std::vector<std::string> overrides = {}) {
  overrides.push_back("duration_s=" + std::to_string(seconds));
  overrides.push_back("expect=[]");
  const sim::LoadedScenario loaded =
      sim::LoadScenario(std::string(AUTONOMSIM_SOURCE_DIR) + "/" + file, overrides);
  double simulated_s = 0.0;
  for (auto _ : state) {
    sim::Simulation simulation(loaded);
    simulation.Run();
    simulated_s += seconds;
    benchmark::DoNotOptimize(simulation.record().kernel_events);
  }
  state.counters["sim_s_per_wall_s"] = benchmark::Counter(simulated_s, benchmark::Counter::kIsRate);
}

void BM_ClosedLoopDefault(benchmark::State& state) {
  RunScenario(state, "scenarios/lab_two_cars.yaml", 30.0);
}
BENCHMARK(BM_ClosedLoopDefault)->Unit(benchmark::kSecond)->Iterations(2)->UseRealTime();

// Four stack-driven cars (scenarios/fleet_four_cars.yaml), 30 s.
void BM_ClosedLoopFourCars(benchmark::State& state) {
  RunScenario(state, "scenarios/fleet_four_cars.yaml", 30.0);
}
BENCHMARK(BM_ClosedLoopFourCars)->Unit(benchmark::kSecond)->Iterations(2)->UseRealTime();

// The fleet at scale (issue 38): the first N stack-driven cars of scenarios/fleet_ten_cars.yaml,
// 30 s. Peak memory per process: bench/scaling.sh (docs/performance.md#the-fleet-at-scale).
void BM_ClosedLoopCars(benchmark::State& state) {
  std::vector<std::string> drop;
  for (auto k = 9; k >= state.range(0); --k) drop.push_back("cars[" + std::to_string(k) + "]=null");
  RunScenario(state, "scenarios/fleet_ten_cars.yaml", 30.0, drop);
}
BENCHMARK(BM_ClosedLoopCars)
    ->Arg(2)
    ->Arg(4)
    ->Arg(10)
    ->Unit(benchmark::kSecond)
    ->Iterations(2)
    ->UseRealTime();

}  // namespace
}  // namespace autonomsim
