#include "sim/platform/duration_histogram.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

namespace autonomsim::sim {
namespace {

constexpr double kNsPerMs = 1e6;

// The bin of `edges_ms` that holds `ms`, clamped to the outer bins.
std::size_t BinOf(const std::vector<double>& edges_ms, double ms) {
  const auto it = std::upper_bound(edges_ms.begin(), edges_ms.end(), ms);
  const std::ptrdiff_t bin = std::clamp<std::ptrdiff_t>(
      (it - edges_ms.begin()) - 1, 0, static_cast<std::ptrdiff_t>(edges_ms.size()) - 2);
  return static_cast<std::size_t>(bin);
}

}  // namespace

std::uint32_t DurationHistogram::KeyOf(std::int64_t ns) {
  if (ns < kExactBelow_ns) return static_cast<std::uint32_t>(ns);
  // ns in [2^b, 2^(b+1)) with b >= kSubBucketBits + 1: shift so that kSubBucketBits + 1 bits remain
  const int shift = std::bit_width(static_cast<std::uint64_t>(ns)) - 1 - kSubBucketBits;
  const std::int64_t sub = (ns >> shift) - kSubBuckets;  // in [0, kSubBuckets)
  return static_cast<std::uint32_t>(kExactBelow_ns + (shift - 1) * kSubBuckets + sub);
}

void DurationHistogram::Add(Duration d) {
  const std::int64_t ns = d.count();
  if (ns < 0) {
    throw std::invalid_argument("DurationHistogram: negative duration " + std::to_string(ns) +
                                " ns");
  }
  // jobs of one node tend to last alike: the last bucket first, then a bisection; a new bucket is
  // rare after the first jobs (a node's turnaround occupies a few hundred)
  const std::uint32_t key = KeyOf(ns);
  if (last_ >= keys_.size() || keys_[last_] != key) {
    const auto at = std::lower_bound(keys_.begin(), keys_.end(), key);
    last_ = static_cast<std::size_t>(at - keys_.begin());
    if (at == keys_.end() || *at != key) {
      keys_.insert(at, key);
      buckets_.insert(buckets_.begin() + static_cast<std::ptrdiff_t>(last_), Bucket{});
    }
  }
  Bucket& b = buckets_[last_];
  if (b.count == 0) {
    b.min_ns = ns;
    b.max_ns = ns;
  } else {
    b.min_ns = std::min(b.min_ns, ns);
    b.max_ns = std::max(b.max_ns, ns);
  }
  ++b.count;
  ++count_;
  sum_ns_ += ns;
}

double DurationHistogram::Quantile_ns(double q) const {
  if (count_ == 0) return 0.0;
  // nearest rank: the smallest value with at least q of the sample at or below it
  const double r = std::ceil(q * static_cast<double>(count_));
  const std::uint64_t rank =
      std::clamp<std::uint64_t>(r < 1.0 ? 1 : static_cast<std::uint64_t>(r), 1, count_);
  std::uint64_t before = 0;
  for (const Bucket& b : buckets_) {
    if (before + b.count >= rank) {
      if (rank == before + 1) return static_cast<double>(b.min_ns);
      if (rank == before + b.count) return static_cast<double>(b.max_ns);
      return 0.5 * (static_cast<double>(b.min_ns) + static_cast<double>(b.max_ns));
    }
    before += b.count;
  }
  return static_cast<double>(buckets_.back().max_ns);
}

Stats DurationHistogram::ComputeStats() const {
  Stats s;
  s.count = count_;
  if (count_ == 0) return s;
  s.min = static_cast<double>(buckets_.front().min_ns) / kNsPerMs;
  s.max = static_cast<double>(buckets_.back().max_ns) / kNsPerMs;
  s.p50 = Quantile_ns(0.50) / kNsPerMs;
  s.p95 = Quantile_ns(0.95) / kNsPerMs;
  s.p99 = Quantile_ns(0.99) / kNsPerMs;
  s.mean = static_cast<double>(sum_ns_) / static_cast<double>(count_) / kNsPerMs;
  return s;
}

std::vector<std::uint64_t> DurationHistogram::Counts(const std::vector<double>& edges_ms) const {
  if (edges_ms.size() < 2) throw std::invalid_argument("DurationHistogram::Counts: < 2 edges");
  std::vector<std::uint64_t> counts(edges_ms.size() - 1, 0);
  for (const Bucket& b : buckets_) {
    const std::size_t low = BinOf(edges_ms, static_cast<double>(b.min_ns) / kNsPerMs);
    const std::size_t high = BinOf(edges_ms, static_cast<double>(b.max_ns) / kNsPerMs);
    const double middle_ms =
        0.5 * (static_cast<double>(b.min_ns) + static_cast<double>(b.max_ns)) / kNsPerMs;
    counts[low == high ? low : BinOf(edges_ms, middle_ms)] += b.count;
  }
  return counts;
}

}  // namespace autonomsim::sim
