#include "sim/platform/duration_histogram.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

namespace autonomsim::sim {
namespace {

using std::chrono::milliseconds;
using std::chrono::nanoseconds;

// Nearest rank over the full sample: the reference the histogram approximates.
double ExactQuantile(std::vector<std::int64_t> sorted, double q) {
  const double r = std::ceil(q * static_cast<double>(sorted.size()));
  const std::size_t i = r < 1.0 ? 0 : static_cast<std::size_t>(r) - 1;
  return static_cast<double>(sorted[std::min(i, sorted.size() - 1)]);
}

TEST(DurationHistogram, SmallSamplesGiveTheExactNearestRankPercentiles) {
  DurationHistogram h;
  for (int ms : {5, 1, 4, 2, 3, 10, 9, 8, 7, 6}) h.Add(milliseconds(ms));
  const Stats s = h.ComputeStats();
  EXPECT_EQ(s.count, 10u);
  EXPECT_EQ(s.min, 1.0);
  EXPECT_EQ(s.p50, 5.0);   // rank 5
  EXPECT_EQ(s.p95, 10.0);  // rank 10
  EXPECT_EQ(s.p99, 10.0);
  EXPECT_EQ(s.max, 10.0);
  EXPECT_EQ(s.mean, 5.5);
  EXPECT_EQ(DurationHistogram().ComputeStats().count, 0u);
  EXPECT_EQ(DurationHistogram().ComputeStats().p50, 0.0);
}

TEST(DurationHistogram, ValuesBelowTheExactLimitAreExact) {
  DurationHistogram h;
  for (std::int64_t ns = 0; ns < DurationHistogram::kExactBelow_ns; ++ns) h.Add(nanoseconds(ns));
  EXPECT_EQ(h.buckets(), static_cast<std::size_t>(DurationHistogram::kExactBelow_ns));
  EXPECT_EQ(h.Quantile_ns(0.5), 1023.0);  // rank 1024 of 0..2047
}

// 200,000 durations from 1 µs to 10 s (log-uniform): every percentile within half a bucket
// (1/2048 of the value) of the full sample's, while the memory stays a few thousand buckets.
TEST(DurationHistogram, PercentilesStayWithinHalfABucketOfTheFullSample) {
  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> log10_ns(3.0, 10.0);
  DurationHistogram h;
  std::vector<std::int64_t> all;
  for (int i = 0; i < 200000; ++i) {
    const auto ns = static_cast<std::int64_t>(std::pow(10.0, log10_ns(rng)));
    h.Add(nanoseconds(ns));
    all.push_back(ns);
  }
  std::sort(all.begin(), all.end());
  for (double q : {0.001, 0.01, 0.25, 0.5, 0.75, 0.95, 0.99, 0.999, 1.0}) {
    const double exact = ExactQuantile(all, q);
    EXPECT_NEAR(h.Quantile_ns(q), exact, exact / 2048.0) << "q=" << q;
  }
  const Stats s = h.ComputeStats();
  EXPECT_EQ(s.min, static_cast<double>(all.front()) / 1e6);
  EXPECT_EQ(s.max, static_cast<double>(all.back()) / 1e6);
  EXPECT_LE(h.buckets(), 7u * 4u * static_cast<std::size_t>(DurationHistogram::kSubBuckets));
}

TEST(DurationHistogram, MemoryIsBoundedHoweverManyValues) {
  DurationHistogram h;
  std::mt19937_64 rng(1);
  std::uniform_int_distribution<std::int64_t> ns(5'000'000, 6'000'000);  // 5–6 ms
  for (int i = 0; i < 1'000'000; ++i) h.Add(nanoseconds(ns(rng)));
  // [5, 6] ms spans two power-of-two ranges, each kSubBuckets buckets at most
  EXPECT_LE(h.buckets(), 2u * static_cast<std::size_t>(DurationHistogram::kSubBuckets));
  EXPECT_EQ(h.count(), 1'000'000u);
}

TEST(DurationHistogram, CountsFallInTheBinsOfTheirValues) {
  DurationHistogram h;
  for (double ms : {0.05, 0.5, 0.5, 2.0, 20.0, 20000.0}) {
    h.Add(nanoseconds(static_cast<std::int64_t>(ms * 1e6)));
  }
  const std::vector<std::uint64_t> counts = h.Counts({0.1, 1.0, 10.0, 100.0});
  // below the range in the first bin, above it in the last
  EXPECT_EQ(counts, (std::vector<std::uint64_t>{3, 1, 2}));
}

TEST(DurationHistogram, CopiesAndMovesAreIndependentHistogramsOfTheSameSample) {
  // Add remembers its last bucket; a copy or a move must not write into the other's buckets.
  DurationHistogram a;
  for (int k = 0; k < 5; ++k) a.Add(milliseconds(3));
  DurationHistogram copy = a;
  copy.Add(milliseconds(3));
  a.Add(milliseconds(7));
  EXPECT_EQ(a.count(), 6u);
  EXPECT_EQ(copy.count(), 6u);
  EXPECT_EQ(copy.Quantile_ns(1.0), 3e6);
  EXPECT_EQ(a.Quantile_ns(1.0), 7e6);
  std::vector<DurationHistogram> many;
  for (int k = 0; k < 9; ++k) {  // reallocations move them
    many.push_back(a);
    many.back().Add(milliseconds(k + 1));
  }
  for (int k = 0; k < 9; ++k) {
    many[static_cast<std::size_t>(k)].Add(milliseconds(3));
    EXPECT_EQ(many[static_cast<std::size_t>(k)].count(), 8u) << k;
  }
  DurationHistogram moved = std::move(copy);
  moved.Add(milliseconds(3));
  EXPECT_EQ(moved.count(), 7u);
  copy = a;  // a moved-from histogram takes a new value
  copy.Add(milliseconds(7));
  EXPECT_EQ(copy.Quantile_ns(0.5), 3e6);
  EXPECT_EQ(copy.count(), 7u);
}

TEST(DurationHistogram, ANegativeDurationIsAnError) {
  DurationHistogram h;
  EXPECT_THROW(h.Add(nanoseconds(-1)), std::invalid_argument);
}

}  // namespace
}  // namespace autonomsim::sim
