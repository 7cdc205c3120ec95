// Simulated time. Every module counts time as int64 nanoseconds (ARCHITECTURE: "Time is
// std::chrono::nanoseconds everywhere"); doubles in seconds appear only at the edges (config
// files, outputs) and are converted here, once.
#pragma once

#include <chrono>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>

#include "world/validation.h"

namespace autonomsim {

using Duration = std::chrono::nanoseconds;
using Time = std::chrono::nanoseconds;  // time since the start of a run

inline constexpr Duration kZeroTime{0};

// The largest magnitude a time in seconds may have: int64 nanoseconds reach 9.22e18 ns, about
// 292 years. The config reader refuses any `_s` key beyond it, at the key.
inline constexpr double kMaxTimeSeconds = 9.2e9;

// Seconds (finite, within ±kMaxTimeSeconds) to nanoseconds, rounded to the nearest nanosecond.
inline Duration FromSeconds(double s) {
  if (!std::isfinite(s) || std::abs(s) > kMaxTimeSeconds) {
    throw std::invalid_argument("time value out of range: " + Num(s) + " s");
  }
  return Duration{static_cast<std::int64_t>(std::llround(s * 1e9))};
}

// Division (not multiplication by 1e-9) is correctly rounded, so whole and decimal instants come
// out as the closest double (2.775 s, not 2.7750000000000004 s) and print as written.
inline constexpr double ToSeconds(Duration d) { return static_cast<double>(d.count()) / 1e9; }

inline constexpr Duration Milliseconds(std::int64_t ms) { return std::chrono::milliseconds{ms}; }

}  // namespace autonomsim
