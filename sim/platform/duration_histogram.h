// A sample of durations kept in bounded memory with a bounded error, for percentiles over runs of
// any length (a node's turnaround, a topic's latency: one value per job or message; a 24 h run
// would keep millions of them).
//
// Durations are whole nanoseconds (the kernel's time). Below kExactBelow_ns every value is a
// bucket of its own; above it each power-of-two range [2^e, 2^(e+1)) is split into
// kSubBuckets equal buckets, so a bucket is at most 1/kSubBuckets (≈ 0.1 %) of the values in it
// wide. A bucket remembers its count and the least and greatest value it holds. At most
// 64 * kSubBuckets buckets exist (28 bytes each, about 1.8 MB); a node's turnaround occupies a few
// hundred.
//
// Percentiles are nearest-rank, as over the full sample: the value is exact when the rank falls on
// a bucket's least or greatest value or the bucket holds one distinct value, otherwise the middle
// of the bucket's least and greatest value (off by at most half a bucket: ≤ 0.05 %). Min, max, the
// mean and the count are exact. Equal inputs in equal order give equal results on every machine.
#pragma once

#include <cstdint>
#include <vector>

#include "world/time.h"

namespace autonomsim::sim {

// min / p50 / p95 / p99 / max and the mean of a sample, in milliseconds; all zero when empty.
struct Stats {
  std::size_t count{0};
  double min{0.0}, p50{0.0}, p95{0.0}, p99{0.0}, max{0.0};
  double mean{0.0};
};

class DurationHistogram {
 public:
  static constexpr int kSubBucketBits = 10;
  static constexpr std::int64_t kSubBuckets = std::int64_t{1} << kSubBucketBits;
  static constexpr std::int64_t kExactBelow_ns = 2 * kSubBuckets;

  // Throws std::invalid_argument for a negative duration (a job that ends before it starts).
  void Add(Duration d);

  std::uint64_t count() const { return count_; }
  std::size_t buckets() const { return keys_.size(); }
  Stats ComputeStats() const;
  // The nearest-rank value at quantile q in (0, 1], in nanoseconds (as described above).
  double Quantile_ns(double q) const;
  // Counts per bin of `edges_ms` (ascending): bin i holds [edge i, edge i+1); the first bin also
  // holds what is below the range, the last what is above it. A bucket counts in the bin of its
  // least value when it lies within one bin, else of its middle.
  std::vector<std::uint64_t> Counts(const std::vector<double>& edges_ms) const;

 private:
  struct Bucket {
    std::uint64_t count{0};
    std::int64_t min_ns{0};
    std::int64_t max_ns{0};
  };
  static std::uint32_t KeyOf(std::int64_t ns);

  // The buckets ordered by value: their keys (KeyOf), searched by bisection, and beside them
  // what they hold.
  std::vector<std::uint32_t> keys_;
  std::vector<Bucket> buckets_;
  std::size_t last_{0};  // the bucket Add last used (if any)
  std::uint64_t count_{0};
  std::int64_t sum_ns_{0};  // exact; overflows only past 292 years of summed durations
};

}  // namespace autonomsim::sim
