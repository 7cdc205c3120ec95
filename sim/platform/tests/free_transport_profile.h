// A platform profile for tests whose transports cost nothing and take no time, so that a job's
// turnaround is its own work and can be computed by hand. It has one component, "source" (free);
// each test adds the components it measures.
#pragma once

#include "sim/platform/platform_profile.h"

namespace autonomsim::sim::testing {

inline PlatformProfile FreeTransportProfile(int cores) {
  PlatformProfile p;
  p.name = "test";
  p.cpu.cores = cores;
  p.cpu.memcpy_bytes_per_s = 1e9;
  p.fpga.slots = 2;
  p.fpga.memif_bytes_per_s = 1e9;
  p.zero_copy.mempools = {{.chunk_bytes = 1024, .chunks = 64}};
  p.components["source"] = ComponentCost{.sw = SwCost{}};
  return p;
}

}  // namespace autonomsim::sim::testing
