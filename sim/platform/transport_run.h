// One publisher -> one subscriber over the modelled DDS transport alone (sim/platform/dds_link.h)
// on a profile's cores: what `autonomsim transport` runs, and bench/dds_vs_cyclone.sh sets beside
// Cyclone DDS's ddsperf. Optional busy loops stand for the rest of the machine's load.
#pragma once

#include <cstdint>

#include "sim/platform/dds_link.h"
#include "sim/platform/platform_profile.h"
#include "world/time.h"

namespace autonomsim::sim {

struct TransportRunOptions {
  std::int64_t bytes{4915200};  // one sample
  double rate_hz{30.0};  // writes offered (a tick that finds the last write running is skipped)
  Duration duration{std::chrono::seconds(10)};
  Duration warmup{std::chrono::seconds(1)};  // not measured
  int background_cores{0};  // busy loops beside the pair, each one core's worth of demand
  int depth{3};             // the topic's keep-last history (reference §8: depth 3)
  void Validate() const;    // ConfigError for a value out of range
};

struct TransportRunResult {
  DdsLinkParams params;  // what the link ran with
  int cores{0};
  double delivered_hz{0.0};    // samples delivered after the warm-up, per second
  double latency_p50_ms{0.0};  // write call to delivery (0 when nothing was delivered)
  double latency_p95_ms{0.0};
  std::int64_t offered{0};    // ticks of the publisher, skipped ones included
  std::int64_t delivered{0};  // after the warm-up
  DdsLinkStats stats;         // the whole run
};

TransportRunResult RunTransport(const PlatformProfile& profile, const TransportRunOptions& options);

}  // namespace autonomsim::sim
