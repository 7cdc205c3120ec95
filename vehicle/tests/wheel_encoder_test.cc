// The Hall wheel encoder: pulse timing and the quantised speed the real car computes from it.
#include "vehicle/wheel_encoder.h"

#include <gtest/gtest.h>

#include <cmath>

namespace autonomsim::vehicle {
namespace {

constexpr Duration kStep = std::chrono::milliseconds(2);

// Drives at constant speed for `duration` in physics steps of kStep.
void Drive(const WheelEncoderParams& params, double speed, Duration duration, Time* t,
           WheelEncoderState* state) {
  const Time end = *t + duration;
  while (*t < end) {
    *t += kStep;
    AdvanceWheelEncoder(params, *t, kStep, speed, state);
  }
}

TEST(WheelEncoderTest, DefaultsAreTheReferenceFigures) {
  const WheelEncoderParams params;
  EXPECT_NO_THROW(params.Validate());
  EXPECT_DOUBLE_EQ(params.metres_per_pulse(), 0.357 / 8.0);
  WheelEncoderParams bad;
  bad.pulses_per_revolution = 0;
  EXPECT_THROW(bad.Validate(), std::invalid_argument);
}

TEST(WheelEncoderTest, ReadsZeroUntilTwoPulsesHaveCome) {
  const WheelEncoderParams params;
  WheelEncoderState state;
  Time t{};
  EXPECT_EQ(WheelSpeedReading(params, state, t), 0.0);
  Drive(params, 0.25, std::chrono::milliseconds(100), &t, &state);  // 2.5 cm: no pulse yet
  EXPECT_EQ(state.pulses, 0u);
  EXPECT_EQ(WheelSpeedReading(params, state, t), 0.0);
  Drive(params, 0.25, std::chrono::milliseconds(200), &t, &state);  // 7.5 cm: one pulse
  EXPECT_EQ(state.pulses, 1u);
  EXPECT_EQ(WheelSpeedReading(params, state, t), 0.0);
}

TEST(WheelEncoderTest, ConstantSpeedReadsBackWithinTheCountersResolution) {
  const WheelEncoderParams params;
  WheelEncoderState state;
  Time t{};
  Drive(params, 0.25, std::chrono::seconds(2), &t, &state);
  // 2 s at 0.25 m/s is 0.5 m: 11 pulses of 44.625 mm
  EXPECT_EQ(state.pulses, 11u);
  const double reading = WheelSpeedReading(params, state, t);
  // the interval 0.1785 s is 17,850,000 counts of 10 ns; pulse times are interpolated to 1 ns
  EXPECT_NEAR(reading, 0.25, 0.25 * 1e-6);
  // the reading is quantised: (0.357 / 8) / (k · 10 ns) for a whole k
  const double k = params.metres_per_pulse() / reading * params.counter_clock_hz;
  EXPECT_NEAR(k, std::round(k), 1e-6);
}

TEST(WheelEncoderTest, TheReadingLagsByOnePulseInterval) {
  const WheelEncoderParams params;
  WheelEncoderState state;
  Time t{};
  Drive(params, 0.2, std::chrono::seconds(1), &t, &state);        // 4 pulses, 2.15 cm past the last
  Drive(params, 0.4, std::chrono::milliseconds(20), &t, &state);  // 0.8 cm more: no pulse yet
  EXPECT_NEAR(WheelSpeedReading(params, state, t), 0.2, 1e-3);
  Drive(params, 0.4, std::chrono::milliseconds(500), &t, &state);
  EXPECT_NEAR(WheelSpeedReading(params, state, t), 0.4, 1e-3);
}

TEST(WheelEncoderTest, AStoppedCarReadsZeroAfterTheTimeout) {
  const WheelEncoderParams params;
  WheelEncoderState state;
  Time t{};
  Drive(params, 0.3, std::chrono::seconds(1), &t, &state);  // the last pulse at 0.8925 s
  Drive(params, 0.0, std::chrono::milliseconds(300), &t, &state);
  EXPECT_GT(WheelSpeedReading(params, state, t), 0.29);  // stale, as the register holds it
  Drive(params, 0.0, std::chrono::milliseconds(200), &t, &state);  // 0.61 s without a pulse
  EXPECT_EQ(WheelSpeedReading(params, state, t), 0.0);
}

TEST(WheelEncoderTest, DirectionIsNotSensed) {
  const WheelEncoderParams params;
  WheelEncoderState forward, backward;
  Time t1{}, t2{};
  Drive(params, 0.3, std::chrono::seconds(1), &t1, &forward);
  Drive(params, -0.3, std::chrono::seconds(1), &t2, &backward);
  EXPECT_EQ(WheelSpeedReading(params, forward, t1), WheelSpeedReading(params, backward, t2));
}

TEST(WheelEncoderTest, PulseTimesDoNotDependOnTheStepSize) {
  const WheelEncoderParams params;
  WheelEncoderState coarse, fine;
  for (int i = 1; i <= 500; ++i) {
    AdvanceWheelEncoder(params, Time{i * kStep}, kStep, 0.37, &coarse);
    AdvanceWheelEncoder(params, Time{2 * i * kStep / 2 - kStep / 2}, kStep / 2, 0.37, &fine);
    AdvanceWheelEncoder(params, Time{i * kStep}, kStep / 2, 0.37, &fine);
  }
  EXPECT_EQ(coarse.pulses, fine.pulses);
  ASSERT_TRUE(coarse.last_pulse && fine.last_pulse);
  EXPECT_LE(std::abs((*coarse.last_pulse - *fine.last_pulse).count()), 2);
}

}  // namespace
}  // namespace autonomsim::vehicle
