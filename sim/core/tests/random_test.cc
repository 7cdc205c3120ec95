#include "sim/core/random.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

namespace autonomsim::sim {
namespace {

std::vector<std::uint64_t> Draw(Rng rng, int n) {
  std::vector<std::uint64_t> out;
  for (int i = 0; i < n; ++i) out.push_back(rng.NextU64());
  return out;
}

// xoshiro256++ transcribed from the reference (prng.di.unimi.it/xoshiro256plusplus.c), checked
// below against the published vector, to pin Rng to the published algorithm bit for bit.
struct ReferenceXoshiro {
  std::array<std::uint64_t, 4> s;
  static std::uint64_t Rotl(std::uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }
  std::uint64_t Next() {
    const std::uint64_t result = Rotl(s[0] + s[3], 23) + s[0];
    const std::uint64_t t = s[1] << 17;
    s[2] ^= s[0];
    s[3] ^= s[1];
    s[1] ^= s[2];
    s[0] ^= s[3];
    s[2] ^= t;
    s[3] = Rotl(s[3], 45);
    return result;
  }
};

TEST(RngTest, MatchesPublishedXoshiro256PlusPlusWithSplitMix64Seeding) {
  // The vector every port checks: state {1, 2, 3, 4} (rand_xoshiro's reference test).
  ReferenceXoshiro published{{1, 2, 3, 4}};
  const std::array<std::uint64_t, 6> expected = {41943041ULL,
                                                 58720359ULL,
                                                 3588806011781223ULL,
                                                 3591011842654386ULL,
                                                 9228616714210784205ULL,
                                                 9973669472204895162ULL};
  for (const std::uint64_t e : expected) ASSERT_EQ(published.Next(), e);

  // Seed 0: the state is the first four SplitMix64 outputs from 0 (published values).
  ReferenceXoshiro reference{
      {0xe220a8397b1dcdafULL, 0x6e789e6aa1b965f4ULL, 0x06c45d188009454fULL, 0xf88bb8a8724c81ecULL}};
  Rng rng(0);
  for (int i = 0; i < 1000; ++i) ASSERT_EQ(rng.NextU64(), reference.Next()) << i;
}

TEST(RngTest, SameSeedGivesIdenticalSequence) {
  EXPECT_EQ(Draw(Rng(123), 1000), Draw(Rng(123), 1000));
  Rng a(99);
  a.NextU64();
  Rng copy = a;  // a copy continues the same sequence
  EXPECT_EQ(Draw(a, 100), Draw(copy, 100));
}

TEST(RngTest, DifferentSeedsDiffer) {
  std::set<std::uint64_t> firsts;
  for (std::uint64_t seed = 0; seed < 1000; ++seed) firsts.insert(Rng(seed).NextU64());
  EXPECT_EQ(firsts.size(), 1000u);
  EXPECT_NE(Draw(Rng(1), 100), Draw(Rng(2), 100));
}

TEST(RngTest, Uniform01IsInUnitIntervalOnThe53BitGrid) {
  Rng rng(5);
  for (int i = 0; i < 100000; ++i) {
    const double u = rng.Uniform01();
    ASSERT_GE(u, 0.0);
    ASSERT_LT(u, 1.0);
    ASSERT_EQ(std::ldexp(u, 53), std::floor(std::ldexp(u, 53)));
  }
}

TEST(RngTest, UniformStaysInHalfOpenRange) {
  Rng rng(6);
  for (int i = 0; i < 100000; ++i) {
    const double x = rng.Uniform(-2.5, 7.0);
    ASSERT_GE(x, -2.5);
    ASSERT_LT(x, 7.0);
  }
  EXPECT_EQ(rng.Uniform(3.0, 3.0), 3.0);
}

TEST(RngTest, BernoulliExtremes) {
  Rng rng(7);
  for (int i = 0; i < 10000; ++i) {
    ASSERT_FALSE(rng.Bernoulli(0.0));
    ASSERT_TRUE(rng.Bernoulli(1.0));
  }
}

TEST(RngTest, NormalWithZeroStddevIsTheMean) {
  Rng rng(8);
  for (int i = 0; i < 100; ++i) ASSERT_EQ(rng.Normal(2.5, 0.0), 2.5);
}

// Sample mean and variance over a fixed seed: deterministic, so a pass is a pass forever. With
// 1e6 samples the 1% bounds are >= 3.5 standard errors wide for every statistic checked.
struct Moments {
  double mean{0.0};
  double variance{0.0};
};

template <class Draw>
Moments Sample(Draw draw) {
  constexpr int kSamples = 1'000'000;
  double sum = 0.0;
  double sum_sq = 0.0;
  for (int i = 0; i < kSamples; ++i) {
    const double x = draw();
    sum += x;
    sum_sq += x * x;
  }
  const double mean = sum / kSamples;
  return {mean, sum_sq / kSamples - mean * mean};
}

TEST(RngTest, UniformMoments) {
  Rng rng(11);
  const Moments m = Sample([&] { return rng.Uniform(2.0, 6.0); });
  EXPECT_NEAR(m.mean, 4.0, 0.01 * 4.0);
  EXPECT_NEAR(m.variance, 16.0 / 12.0, 0.01 * 16.0 / 12.0);
}

TEST(RngTest, NormalMoments) {
  Rng rng(12);
  const Moments m = Sample([&] { return rng.Normal(10.0, 2.0); });
  EXPECT_NEAR(m.mean, 10.0, 0.01 * 10.0);
  EXPECT_NEAR(m.variance, 4.0, 0.01 * 4.0);
  // Symmetry and tails: about 68.3% within one sigma.
  Rng rng2(13);
  int within = 0;
  for (int i = 0; i < 100000; ++i) within += std::abs(rng2.Normal(0.0, 1.0)) < 1.0;
  EXPECT_NEAR(within / 100000.0, 0.6827, 0.01);
}

TEST(RngTest, ExponentialMoments) {
  Rng rng(14);
  const Moments m = Sample([&] {
    const double x = rng.Exponential(3.0);
    EXPECT_TRUE(x >= 0.0 && std::isfinite(x)) << x;
    return x;
  });
  EXPECT_NEAR(m.mean, 3.0, 0.01 * 3.0);
  EXPECT_NEAR(m.variance, 9.0, 0.01 * 9.0);
}

TEST(RngTest, BernoulliFrequency) {
  Rng rng(15);
  const Moments m = Sample([&] { return rng.Bernoulli(0.3) ? 1.0 : 0.0; });
  EXPECT_NEAR(m.mean, 0.3, 0.01 * 0.3);
}

TEST(RngTest, InvalidArgumentsThrow) {
  Rng rng(16);
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  constexpr double kInf = std::numeric_limits<double>::infinity();
  EXPECT_THROW(rng.Normal(0.0, -1.0), std::invalid_argument);
  EXPECT_THROW(rng.Normal(0.0, kNaN), std::invalid_argument);
  EXPECT_THROW(rng.Normal(kInf, 1.0), std::invalid_argument);
  EXPECT_THROW(rng.Exponential(0.0), std::invalid_argument);
  EXPECT_THROW(rng.Exponential(-1.0), std::invalid_argument);
  EXPECT_THROW(rng.Exponential(kInf), std::invalid_argument);
  EXPECT_THROW(rng.Exponential(kNaN), std::invalid_argument);
  EXPECT_THROW(rng.Bernoulli(-0.01), std::invalid_argument);
  EXPECT_THROW(rng.Bernoulli(1.01), std::invalid_argument);
  EXPECT_THROW(rng.Bernoulli(kNaN), std::invalid_argument);
  EXPECT_THROW(rng.Uniform(1.0, 0.0), std::invalid_argument);
  EXPECT_THROW(rng.Uniform(kNaN, 1.0), std::invalid_argument);
  EXPECT_THROW(rng.Uniform(0.0, kInf), std::invalid_argument);
  EXPECT_THROW(rng.Uniform(-1e308, 1e308), std::invalid_argument);  // hi - lo overflows
  try {
    rng.Exponential(-2.0);
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("-2"), std::string::npos) << e.what();
  }
  // A rejected call draws nothing: the stream continues as if it had not been made.
  Rng fresh(16);
  EXPECT_EQ(rng.NextU64(), fresh.NextU64());
}

TEST(RngStreamsTest, SameSeedAndNameGiveIdenticalSequence) {
  const RngStreams a(42);
  const RngStreams b(42);
  EXPECT_EQ(Draw(a.Stream("car0/depth_noise"), 1000), Draw(b.Stream("car0/depth_noise"), 1000));
  EXPECT_EQ(a.seed(), 42u);
}

TEST(RngStreamsTest, DifferentNamesOrSeedsDiffer) {
  const RngStreams streams(42);
  std::set<std::uint64_t> firsts;
  const std::vector<std::string> names = {"car0/depth_noise",
                                          "car1/depth_noise",
                                          "car0/depth",
                                          "car0/depth_noise ",
                                          "",
                                          "a",
                                          "b",
                                          "ab",
                                          "ba"};
  for (const std::string& name : names) firsts.insert(streams.Stream(name).NextU64());
  EXPECT_EQ(firsts.size(), names.size());
  for (std::uint64_t seed = 1000; seed < 2000; ++seed) {  // 42 is above
    firsts.insert(RngStreams(seed).Stream("car0/depth_noise").NextU64());
  }
  EXPECT_EQ(firsts.size(), names.size() + 1000);
}

TEST(RngStreamsTest, StreamDoesNotDependOnOtherStreamsOrCreationOrder) {
  const RngStreams first(7);
  const std::vector<std::uint64_t> alone = Draw(first.Stream("car1/steering_noise"), 100);

  const RngStreams second(7);
  Rng other = second.Stream("car0/depth_noise");
  for (int i = 0; i < 50; ++i) other.NextU64();
  second.Stream("world/obstacles");
  EXPECT_EQ(Draw(second.Stream("car1/steering_noise"), 100), alone);
}

TEST(RngStreamsTest, PinnedValuesGuardScenarioReproducibility) {
  // Changing the generator, the seeding or the name hash would silently change every scenario's
  // results; if that is intended, update these values in the same change and say so.
  EXPECT_EQ(Rng(42).NextU64(), 15021278609987233951ULL);  // also an independent port's value
  EXPECT_EQ(RngStreams(42).Stream("car0/depth_noise").NextU64(), 9833120425733787024ULL);
}

}  // namespace
}  // namespace autonomsim::sim
