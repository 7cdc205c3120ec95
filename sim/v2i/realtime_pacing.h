// The pacing of a real-time run (v2i.link: realtime, `autonomsim run --realtime`): the kernel runs
// in short slices, and after each one the run waits for the wall clock, so that simulated time t
// happens at wall time start + t. It lives beside the real-time link because that link is the only
// reason to pace a run: the kernel itself knows nothing of wall time. Apart from the CLI, this is
// the one piece of the simulator that reads the wall clock (ARCHITECTURE "Layers"), and it does so
// through WallClock, so that a test can put a clock of its own behind it.
//
// Slice k covers the simulated times (t_k, t_k + slice]. Its computation starts once the wall clock
// has reached start + t_k (the end of the previous slice), so the simulation runs at most one slice
// ahead of the wall clock, and a message a car sends at simulated time t goes out at a wall time in
// [start + t - slice, start + t] (or later, when behind). A slice's lag is the wall time at which
// its computation ended minus start + t_k + slice, 0 when it ended in time. A late slice is not
// made up by skipping simulated time: the next one starts at once, and the run catches up as soon
// as slices compute faster than real time again.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>

#include "sim/core/kernel.h"
#include "sim/scenario/run_record.h"

namespace autonomsim::sim {

// 10 ms: a tenth of the intersection client's 100 ms tick (reference §7), so what the pacing adds
// to a response's way to a car is small beside what the car's own polling adds; and long enough
// that the default scenario (≈ 20x faster than real time on one core) computes a slice well within
// it.
inline constexpr Duration kRealTimeSlice = std::chrono::milliseconds(10);

class WallClock {
 public:
  using TimePoint = std::chrono::steady_clock::time_point;
  virtual ~WallClock() = default;
  virtual TimePoint Now() = 0;
  // Returns at `t` or soon after; at once if `t` has passed.
  virtual void SleepUntil(TimePoint t) = 0;
};

// std::chrono::steady_clock, and std::this_thread::sleep_until.
class SteadyWallClock final : public WallClock {
 public:
  TimePoint Now() override;
  void SleepUntil(TimePoint t) override;
};

class Pacer {
 public:
  // `clock` must outlive the pacer. Throws std::invalid_argument unless slice > 0.
  Pacer(WallClock* clock, Duration slice = kRealTimeSlice);

  // Runs `kernel` from its Now() to `end` slice by slice (the last one may be shorter), the wall
  // clock's start being this call. `before_slice`, if given, runs before each slice, outside the
  // kernel with Now() at the slice's start: the real-time link hands the cars what arrived. A
  // kernel Stop() ends the slice early only: the pacing goes on to `end`.
  void Run(Kernel* kernel, Time end, const std::function<void()>& before_slice = {});

  // The figures so far: slice_s, slices, late_slices and the lags (the message counts are the
  // link's to fill in).
  RealTimeMetrics figures() const;

 private:
  WallClock* clock_;
  Duration slice_;
  std::uint64_t slices_{0};
  std::uint64_t late_slices_{0};
  std::chrono::nanoseconds max_lag_{0};
  std::chrono::nanoseconds lag_sum_{0};
};

}  // namespace autonomsim::sim
