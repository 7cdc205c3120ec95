// What one V2I message costs in wall time over the mqtt link (lock-step with a real mosquitto and
// `tlserver --sim-clock`) against the embedded link (the server in-process): the scripted cars of
// sim/v2i/tests/scripted_cars.h, 300 s simulated, the same traffic on both links. Starting and
// stopping the broker and tlserver is outside the timing. per_message is the wall time of a run
// over the V2I messages delivered to the server (the server's lease ticks ride along); the mqtt
// link's own cost per message is the difference of the two.
//
//   build/bin/bench_mqtt --benchmark_min_time=0.1
#include <benchmark/benchmark.h>

#include <cstdint>
#include <exception>
#include <memory>
#include <vector>

#include "sim/mqtt/mqtt_link_config.h"
#include "sim/v2i/mqtt_endpoint.h"
#include "sim/v2i/tests/scripted_cars.h"
#include "sim/v2i/traffic_light_node.h"

namespace autonomsim::sim {
namespace {

using testing::kScriptSeed;
using testing::ScriptedCars;
using testing::ScriptedServerParams;

const Time kRunEnd = std::chrono::seconds(300);
const std::vector<int> kIntersections{0, 1};

void ReportPerMessage(benchmark::State& state, std::uint64_t messages) {
  state.SetItemsProcessed(static_cast<std::int64_t>(messages));
  state.counters["per_message"] = benchmark::Counter(
      static_cast<double>(messages), benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

void BM_EmbeddedLinkPerMessage(benchmark::State& state) {
  std::uint64_t messages = 0;
  for (auto _ : state) {
    ScriptedCars cars(
        std::make_unique<EmbeddedTrafficLightEndpoint>(ScriptedServerParams(), kIntersections),
        kScriptSeed);
    cars.Run(kRunEnd);
    messages += cars.messages();
  }
  ReportPerMessage(state, messages);
}
BENCHMARK(BM_EmbeddedLinkPerMessage)->UseRealTime()->Unit(benchmark::kMillisecond);

void BM_MqttLinkPerMessage(benchmark::State& state) {
  std::uint64_t messages = 0;
  for (auto _ : state) {
    state.PauseTiming();
    try {
      // broker "": a private mosquitto and tlserver, as a run with v2i.link: mqtt starts them
      ScriptedCars cars(MakeMqttEndpoint(MqttLinkConfig{}, ScriptedServerParams(), kIntersections),
                        kScriptSeed);
      state.ResumeTiming();
      cars.Run(kRunEnd);
      state.PauseTiming();
      messages += cars.messages();
    } catch (const std::exception& e) {  // no mosquitto, or the broker or tlserver failed
      state.SkipWithError(e.what());
      break;
    }
    state.ResumeTiming();  // the broker and tlserver stopped with `cars`, untimed
  }
  ReportPerMessage(state, messages);
}
BENCHMARK(BM_MqttLinkPerMessage)->UseRealTime()->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace autonomsim::sim
