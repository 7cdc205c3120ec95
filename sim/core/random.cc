#include "sim/core/random.h"

#include <cmath>
#include <stdexcept>
#include <string>

#include "world/validation.h"

namespace autonomsim::sim {
namespace {

constexpr std::uint64_t kSplitMixIncrement = 0x9e3779b97f4a7c15ULL;

// The SplitMix64 output function (Steele, Lea & Flood 2014): a bijection with full avalanche.
constexpr std::uint64_t SplitMix64Mix(std::uint64_t z) {
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

// FNV-1a, 64 bit: stable across platforms and releases, unlike std::hash.
constexpr std::uint64_t Fnv1a64(std::string_view s) {
  std::uint64_t h = 0xcbf29ce484222325ULL;
  for (const char c : s) {
    h ^= static_cast<unsigned char>(c);
    h *= 0x100000001b3ULL;
  }
  return h;
}

constexpr std::uint64_t Rotl(std::uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }

}  // namespace

Rng::Rng(std::uint64_t seed) {
  // Four consecutive SplitMix64 outputs are distinct, so the state is never all zero.
  std::uint64_t x = seed;
  for (std::uint64_t& word : s_) {
    x += kSplitMixIncrement;
    word = SplitMix64Mix(x);
  }
}

std::uint64_t Rng::NextU64() {
  const std::uint64_t result = Rotl(s_[0] + s_[3], 23) + s_[0];
  const std::uint64_t t = s_[1] << 17;
  s_[2] ^= s_[0];
  s_[3] ^= s_[1];
  s_[1] ^= s_[2];
  s_[0] ^= s_[3];
  s_[2] ^= t;
  s_[3] = Rotl(s_[3], 45);
  return result;
}

double Rng::Uniform01() { return static_cast<double>(NextU64() >> 11) * 0x1.0p-53; }

double Rng::Uniform(double lo, double hi) {
  if (!std::isfinite(lo) || !std::isfinite(hi) || !(lo <= hi) || !std::isfinite(hi - lo)) {
    throw std::invalid_argument("Rng::Uniform: need finite lo <= hi with finite hi - lo, got lo=" +
                                Num(lo) + " hi=" + Num(hi));
  }
  const double x = lo + (hi - lo) * Uniform01();
  // Rounding of lo + (hi - lo) * u can reach hi when u is just below 1; keep the interval
  // half-open.
  return x < hi ? x : lo;
}

double Rng::Normal(double mean, double stddev) {
  if (!std::isfinite(mean) || !std::isfinite(stddev) || !(stddev >= 0.0)) {
    throw std::invalid_argument("Rng::Normal: need finite mean and stddev >= 0, got mean=" +
                                Num(mean) + " stddev=" + Num(stddev));
  }
  if (has_spare_normal_) {
    has_spare_normal_ = false;
    return mean + stddev * spare_normal_;
  }
  double u = 0.0;
  double v = 0.0;
  double s = 0.0;
  do {
    u = 2.0 * Uniform01() - 1.0;
    v = 2.0 * Uniform01() - 1.0;
    s = u * u + v * v;
  } while (s >= 1.0 || s == 0.0);
  const double scale = std::sqrt(-2.0 * std::log(s) / s);
  spare_normal_ = v * scale;
  has_spare_normal_ = true;
  return mean + stddev * (u * scale);
}

double Rng::Exponential(double mean) {
  if (!std::isfinite(mean) || !(mean > 0.0)) {
    throw std::invalid_argument("Rng::Exponential: need finite mean > 0, got mean=" + Num(mean));
  }
  // A uniform draw on (0, 1] (the 2^-53 grid shifted up by one step), so the log is finite.
  const double u = static_cast<double>((NextU64() >> 11) + 1) * 0x1.0p-53;
  // -0.0 when u == 1 (probability 2^-53); fixing the sign would lengthen the kernel benchmark's
  // critical path by an add.
  return -mean * std::log(u);
}

bool Rng::Bernoulli(double p) {
  if (!(p >= 0.0 && p <= 1.0)) {
    throw std::invalid_argument("Rng::Bernoulli: need p in [0, 1], got p=" + Num(p));
  }
  return Uniform01() < p;
}

Rng RngStreams::Stream(std::string_view name) const {
  // Mixing the seed first keeps nearby seeds (1, 2, 3...) from giving related streams for the same
  // name; the outer mix spreads FNV's weak high bits before Rng's own SplitMix64 seeding.
  return Rng(SplitMix64Mix(SplitMix64Mix(seed_) ^ Fnv1a64(name)));
}

}  // namespace autonomsim::sim
