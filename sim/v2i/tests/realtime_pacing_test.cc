// The pacing of a real-time run on a clock of the test's own: where it sleeps, how it measures a
// slice that computed too long, and that it makes up for it without skipping simulated time.
#include "sim/v2i/realtime_pacing.h"

#include <gtest/gtest.h>

#include <vector>

namespace autonomsim::sim {
namespace {

using std::chrono::milliseconds;

// A wall clock that stands still until told: sleeping moves it to the wake-up time, and a test
// event "computes" by advancing it.
class ScriptedWallClock final : public WallClock {
 public:
  TimePoint Now() override { return now_; }
  void SleepUntil(TimePoint t) override {
    sleeps.push_back(t - TimePoint{});
    if (t > now_) now_ = t;
  }
  void Spend(Duration d) { now_ += d; }

  std::vector<std::chrono::nanoseconds> sleeps;  // the wake-up times asked for, since the epoch

 private:
  TimePoint now_{};
};

TEST(RealTimePacing, SlicesEndOnTheWallClockAtTheirSimulatedTime) {
  ScriptedWallClock clock;
  Kernel kernel;
  Pacer pacer(&clock, milliseconds(10));
  std::vector<Time> slice_starts;
  pacer.Run(&kernel, milliseconds(35), [&] { slice_starts.push_back(kernel.Now()); });
  // the last slice is the 5 ms that remain
  EXPECT_EQ(slice_starts, (std::vector<Time>{milliseconds(0), milliseconds(10), milliseconds(20),
                                             milliseconds(30)}));
  EXPECT_EQ(clock.sleeps,
            (std::vector<std::chrono::nanoseconds>{milliseconds(10), milliseconds(20),
                                                   milliseconds(30), milliseconds(35)}));
  EXPECT_EQ(kernel.Now(), milliseconds(35));
  const RealTimeMetrics m = pacer.figures();
  EXPECT_EQ(m.slice_s, 0.01);
  EXPECT_EQ(m.slices, 4u);
  EXPECT_EQ(m.late_slices, 0u);
  EXPECT_EQ(m.pacing_max_lag_s, 0.0);
  EXPECT_EQ(m.pacing_mean_lag_s, 0.0);
}

TEST(RealTimePacing, ASlowSliceIsLateAndTheRunCatchesUpWithoutSkippingTime) {
  ScriptedWallClock clock;
  Kernel kernel;
  // an event at 25 ms takes 30 ms of wall time: slice (20, 30] starts at wall 20 ms and ends at
  // wall 50 ms, 20 ms late; (30, 40] follows at once and ends at 50 ms, 10 ms late; (40, 50]
  // ends at 50 ms, in time
  kernel.ScheduleAt(milliseconds(25), [&] { clock.Spend(milliseconds(30)); });
  std::vector<Time> ran;
  kernel.SchedulePeriodic(milliseconds(0), milliseconds(10), [&] { ran.push_back(kernel.Now()); });
  Pacer pacer(&clock, milliseconds(10));
  pacer.Run(&kernel, milliseconds(100));
  // every instant ran, none skipped
  ASSERT_EQ(ran.size(), 11u);
  for (std::size_t i = 0; i < ran.size(); ++i) EXPECT_EQ(ran[i], milliseconds(10 * i));
  const RealTimeMetrics m = pacer.figures();
  EXPECT_EQ(m.slices, 10u);
  EXPECT_EQ(m.late_slices, 2u);
  EXPECT_DOUBLE_EQ(m.pacing_max_lag_s, 0.020);
  EXPECT_DOUBLE_EQ(m.pacing_mean_lag_s, 0.030 / 10);
  // the schedule stays start + t: the wake-up times are those of the slices' ends
  ASSERT_EQ(clock.sleeps.size(), 10u);
  for (std::size_t i = 0; i < clock.sleeps.size(); ++i) {
    EXPECT_EQ(clock.sleeps[i], milliseconds(10 * (i + 1)));
  }
}

TEST(RealTimePacing, StartsFromTheKernelsTimeAndTheClocksTime) {
  ScriptedWallClock clock;
  clock.Spend(std::chrono::seconds(100));
  Kernel kernel;
  kernel.RunUntil(std::chrono::seconds(2));
  Pacer pacer(&clock, milliseconds(500));
  pacer.Run(&kernel, std::chrono::seconds(3));
  EXPECT_EQ(clock.sleeps,
            (std::vector<std::chrono::nanoseconds>{milliseconds(100500), milliseconds(101000)}));
  EXPECT_EQ(pacer.figures().slices, 2u);
}

TEST(RealTimePacing, ASliceMustBeLongerThanZero) {
  ScriptedWallClock clock;
  EXPECT_THROW(Pacer(&clock, Duration::zero()), std::invalid_argument);
  EXPECT_THROW(Pacer(nullptr, milliseconds(10)), std::invalid_argument);
  EXPECT_EQ(Pacer(&clock).figures().slice_s, ToSeconds(kRealTimeSlice));
}

}  // namespace
}  // namespace autonomsim::sim
