#include "sim/platform/transport_run.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "sim/core/config.h"
#include "sim/core/kernel.h"
#include "sim/core/priorities.h"
#include "sim/platform/platform.h"
#include "world/validation.h"

namespace autonomsim::sim {
namespace {

// The q-quantile of sorted `v` (nearest rank), in ms; 0 for an empty v.
double QuantileMs(const std::vector<Duration>& v, double q) {
  if (v.empty()) return 0.0;
  const auto rank = static_cast<std::size_t>(std::ceil(q * static_cast<double>(v.size())));
  return ToSeconds(v[std::min(v.size(), std::max<std::size_t>(rank, 1)) - 1]) * 1000.0;
}

}  // namespace

void TransportRunOptions::Validate() const {
  const auto require = [](bool ok, const std::string& message) {
    if (!ok) throw ConfigError(message);
  };
  require(bytes >= 1 && bytes <= (std::int64_t{1} << 31),
          "--bytes must be between 1 and 2147483648, got " + std::to_string(bytes));
  require(std::isfinite(rate_hz) && rate_hz > 0.0 && rate_hz <= 10000.0,
          "--rate-hz must be > 0 and <= 10000, got " + Num(rate_hz));
  require(warmup >= Duration{0} && duration > warmup && duration <= std::chrono::hours(1),
          "--seconds must exceed the warm-up (" + Num(ToSeconds(warmup)) +
              " s) and be at most "
              "3600, got " +
              Num(ToSeconds(duration)));
  require(background_cores >= 0 && background_cores <= 1024,
          "--background-load must be between 0 and 1024 cores, got " +
              std::to_string(background_cores));
  require(depth >= 1, "--depth must be >= 1, got " + std::to_string(depth));
}

TransportRunResult RunTransport(const PlatformProfile& profile,
                                const TransportRunOptions& options) {
  options.Validate();
  TransportRunResult result;
  result.params = DdsLinkParamsFor(profile, TopicTransportConfig{}, options.depth);
  result.cores = profile.cpu.cores;

  Kernel kernel;
  Cpu cpu(kernel, profile.cpu.cores, nullptr);
  // a busy loop: one core's worth of demand, never done within the run
  const double forever_core_s = 2.0 * ToSeconds(options.duration) + 1.0;
  for (int i = 0; i < options.background_cores; ++i) cpu.Start(-1, forever_core_s, 1.0, {});
  DdsSocket socket(kernel, cpu, -1, result.params.SocketCapacityBytes(), result.params.sched_slice);
  std::vector<Time> written_at;  // by sequence number
  std::vector<Duration> latencies;
  const Time measure_from = kZeroTime + options.warmup;
  DdsLink link(kernel, cpu, result.params, -1, socket, [&](std::int64_t seq) {
    const Time now = kernel.Now();
    if (now < measure_from) return;
    ++result.delivered;
    latencies.push_back(now - written_at[static_cast<std::size_t>(seq)]);
  });
  const Duration period = FromSeconds(1.0 / options.rate_hz);
  // One publishing thread: a tick that finds its write call still running is skipped (a ROS 2
  // timer's missed tick; ddsperf catches up instead, to the same rate once the link saturates).
  bool writing = false;
  kernel.SchedulePeriodic(
      kZeroTime, period,
      [&] {
        ++result.offered;
        if (writing) return;
        writing = true;
        written_at.push_back(kernel.Now());  // the link numbers its writes 0, 1, ...
        link.Write(options.bytes, [&](bool) { writing = false; });
      },
      kPriorityPlatform);
  const Time end = kZeroTime + options.duration;
  kernel.RunUntil(end);

  std::sort(latencies.begin(), latencies.end());
  result.delivered_hz =
      static_cast<double>(result.delivered) / ToSeconds(options.duration - options.warmup);
  result.latency_p50_ms = QuantileMs(latencies, 0.50);
  result.latency_p95_ms = QuantileMs(latencies, 0.95);
  result.stats = link.stats();
  return result;
}

}  // namespace autonomsim::sim
