// Seeded random streams. The standard library's distributions are not specified bit for bit
// (libstdc++ and libc++ give different normals from the same engine), so a scenario seed would not
// reproduce across toolchains; the generator and the distributions here are our own and fully
// specified. What remains platform-dependent: Normal and Exponential call std::log (std::sqrt is
// exact by IEEE 754), whose last bit may differ between C libraries; we build on glibc. A portable
// fdlibm log was tried and cost 15% of the kernel benchmark's throughput (bench/bench_kernel.cc),
// so it waits until another C library matters.
#pragma once

#include <cstdint>
#include <string_view>

namespace autonomsim::sim {

// xoshiro256++ (Blackman & Vigna, 2019), state seeded from the 64-bit seed through SplitMix64.
// Cheap to copy; a copy continues the same sequence independently.
class Rng {
 public:
  explicit Rng(std::uint64_t seed);

  std::uint64_t NextU64();
  // [0, 1) on the 2^-53 grid: every representable value equally likely.
  double Uniform01();
  // [lo, hi); lo <= hi and hi - lo finite (lo == hi returns lo). Else std::invalid_argument.
  double Uniform(double lo, double hi);
  // Marsaglia's polar method; the second variate of each pair is kept for the next call, so a
  // stream's draws depend only on its own call history. stddev >= 0 and finite; mean finite.
  double Normal(double mean, double stddev);
  // Inverse transform, -mean * ln(U) with U uniform on (0, 1] (2^-53 grid); mean > 0 and finite.
  double Exponential(double mean);
  // One draw: Uniform01() < p; p in [0, 1].
  bool Bernoulli(double p);

 private:
  std::uint64_t s_[4];
  double spare_normal_{0.0};
  bool has_spare_normal_{false};
};

// Named streams derived from a scenario seed. Stream(name) depends only on (seed, name): adding,
// removing or reordering other streams never shifts it. Names are free-form; use the component
// path, e.g. "car0/depth_noise".
class RngStreams {
 public:
  explicit RngStreams(std::uint64_t seed) : seed_(seed) {}

  Rng Stream(std::string_view name) const;
  std::uint64_t seed() const { return seed_; }

 private:
  std::uint64_t seed_;
};

}  // namespace autonomsim::sim
