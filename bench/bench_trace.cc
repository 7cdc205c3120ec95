// trace.json's writer (TraceJson): a board's trace of 200 k events (one board's part of the
// default scenario's 200 s) of eight nodes' executor and receive spans, slot spans and the CPU
// counter at every change (the receive spans and the unsampled counter asked for: a mix of every
// kind of event).
#include <benchmark/benchmark.h>

#include <string>

#include "sim/platform/node_metrics.h"

namespace autonomsim::sim {
namespace {

constexpr int kNodes = 8;
constexpr int kEventsPerRound = 4;  // an executor span, a receive span, a slot span, a counter

RunMetrics RecordedTrace(std::size_t events) {
  RunMetrics metrics(MetricsOptions{
      .trace_max_events = events, .trace_receive = true, .trace_busy_period = Duration::zero()});
  metrics.SetCores(4);
  for (int i = 0; i < kNodes; ++i) metrics.AddNode("node_" + std::to_string(i), "sw");
  const std::string slot_job = "slot job";
  for (std::size_t k = 0; k < events / kEventsPerRound; ++k) {
    const int node = static_cast<int>(k % kNodes);
    // microsecond times with odd nanoseconds, as the platform's job ends are
    const Time t0{static_cast<std::int64_t>(k) * 1'000'123};
    const Time t1 = t0 + Duration{456'789};
    metrics.Span(TraceLane::kExecutor, node, metrics.nodes()[node].name, t0, t1);
    metrics.Span(TraceLane::kReceive, node, metrics.nodes()[node].name, t0, t0 + Duration{12'345});
    metrics.Span(TraceLane::kSlot, node % 3, slot_job, t0, t1);
    metrics.BusyChanged(t1, 0.25 * static_cast<double>(node % 5));
  }
  return metrics;
}

void BM_TraceJson(benchmark::State& state) {
  const RunMetrics metrics = RecordedTrace(static_cast<std::size_t>(state.range(0)));
  std::size_t bytes = 0;
  for (auto _ : state) {
    const std::string trace = TraceJson({{"car0", &metrics}});
    bytes = trace.size();
    benchmark::DoNotOptimize(trace.data());
  }
  state.counters["bytes"] = static_cast<double>(bytes);
  state.SetItemsProcessed(state.iterations() *
                          static_cast<std::int64_t>(metrics.trace_events().size()));
}
BENCHMARK(BM_TraceJson)->Arg(200000)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace autonomsim::sim
