// Event-kernel throughput in the classic hold model (Jones, CACM 1986; ns-3's bench-scheduler works
// the same way): N events pending; each, when run, schedules one successor at now + Exp(mean 1 us)
// drawn from an Rng. The queue size stays N, so items_per_second is the steady-state rate of
// events, each one pop, one push, one callback and one exponential draw.
#include <benchmark/benchmark.h>

#include <cstdint>

#include "sim/core/kernel.h"
#include "sim/core/random.h"

namespace autonomsim::sim {
namespace {

constexpr double kHoldMeanDelay_ns = 1000.0;  // mean successor delay, 1 us
constexpr std::uint64_t kSeed = 42;
constexpr int kStepsPerIteration = 1024;  // amortizes the benchmark loop's own overhead

// The callback: 16 trivially copyable bytes, stored inline in the Callback (no allocation).
struct HoldEvent {
  Kernel* kernel;
  Rng* rng;
  void operator()() const {
    const auto delay_ns = static_cast<std::int64_t>(rng->Exponential(kHoldMeanDelay_ns));
    kernel->ScheduleIn(Duration{delay_ns}, HoldEvent{kernel, rng});
  }
};

void BM_Hold(benchmark::State& state) {
  const auto n = static_cast<std::int64_t>(state.range(0));
  Kernel kernel;
  Rng rng(kSeed);
  for (std::int64_t i = 0; i < n; ++i) {
    const auto at_ns = static_cast<std::int64_t>(rng.Exponential(kHoldMeanDelay_ns));
    kernel.ScheduleAt(Time{at_ns}, HoldEvent{&kernel, &rng});
  }
  // Untimed warm-up: let the queue's time distribution settle into its steady state.
  for (std::int64_t i = 0; i < 4 * n; ++i) kernel.Step();

  const std::uint64_t executed_before = kernel.executed();
  for (auto _ : state) {
    for (int i = 0; i < kStepsPerIteration; ++i) kernel.Step();
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(kernel.executed() - executed_before));
  if (kernel.pending() != static_cast<std::size_t>(n)) state.SkipWithError("queue size drifted");
}
BENCHMARK(BM_Hold)->Arg(1000)->Arg(100000);

}  // namespace
}  // namespace autonomsim::sim
