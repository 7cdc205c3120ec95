#include "sim/v2i/realtime_pacing.h"

#include <algorithm>
#include <stdexcept>
#include <thread>

namespace autonomsim::sim {

WallClock::TimePoint SteadyWallClock::Now() { return std::chrono::steady_clock::now(); }

void SteadyWallClock::SleepUntil(TimePoint t) { std::this_thread::sleep_until(t); }

Pacer::Pacer(WallClock* clock, Duration slice) : clock_(clock), slice_(slice) {
  if (clock_ == nullptr) throw std::invalid_argument("Pacer: no wall clock");
  if (slice_ <= Duration::zero()) {
    throw std::invalid_argument("Pacer: the slice must be > 0, got " +
                                std::to_string(slice_.count()) + " ns");
  }
}

void Pacer::Run(Kernel* kernel, Time end, const std::function<void()>& before_slice) {
  const Time first = kernel->Now();
  const WallClock::TimePoint start = clock_->Now();
  for (Time t = first; t < end;) {
    const Time next = std::min(end, t + slice_);
    if (before_slice) before_slice();
    kernel->RunUntil(next);
    // when its last instant was due on the wall clock
    const WallClock::TimePoint due = start + (next - first);
    const WallClock::TimePoint done = clock_->Now();
    const std::chrono::nanoseconds lag =
        std::max<std::chrono::nanoseconds>(done - due, std::chrono::nanoseconds::zero());
    ++slices_;
    if (lag > std::chrono::nanoseconds::zero()) ++late_slices_;
    max_lag_ = std::max(max_lag_, lag);
    lag_sum_ += lag;
    clock_->SleepUntil(due);
    t = next;
  }
}

RealTimeMetrics Pacer::figures() const {
  RealTimeMetrics m;
  m.slice_s = ToSeconds(slice_);
  m.slices = slices_;
  m.late_slices = late_slices_;
  m.pacing_max_lag_s = ToSeconds(max_lag_);
  m.pacing_mean_lag_s = slices_ == 0 ? 0.0 : ToSeconds(lag_sum_) / static_cast<double>(slices_);
  return m;
}

}  // namespace autonomsim::sim
