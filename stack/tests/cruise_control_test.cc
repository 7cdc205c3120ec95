#include "stack/cruise_control.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

namespace autonomsim::stack {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;

constexpr double kTol = 1e-12;

Time At(double s) { return FromSeconds(s); }

// One cruise control, stepped by hand. Each Step delivers a fresh odometry unless told otherwise.
struct Cruise {
  CruiseControlParams params;
  CruiseControlState state;

  CruiseControlOutput Step(double t_s, std::optional<VelocityCommand> command,
                           std::optional<double> odometry_mps,
                           std::optional<bool> set_emergency = std::nullopt) {
    CruiseControlInput input;
    input.now = At(t_s);
    input.command = command;
    if (odometry_mps) input.odometry = OdometrySpeed{At(t_s), *odometry_mps};
    input.set_emergency = set_emergency;
    return StepCruiseControl(params, input, &state);
  }
};

VelocityCommand Cmd(double t_s, double v_mps, double w_rad_per_s = 0.0) {
  return VelocityCommand{At(t_s), v_mps, w_rad_per_s};
}

TEST(CruiseControlParamsTest, DefaultsKeysAndValidation) {
  CruiseControlParams params;
  EXPECT_EQ(params.p_gain, 0.4);
  EXPECT_EQ(params.i_gain_per_s, 0.2);
  EXPECT_EQ(params.d_gain_s, 0.0);
  EXPECT_EQ(params.i_clamp_min, 0.0);
  EXPECT_EQ(params.i_clamp_max, 10.0);
  EXPECT_EQ(params.period, Milliseconds(33));
  EXPECT_EQ(params.watchdog_timeout, std::chrono::seconds(1));
  EXPECT_NO_THROW(params.Validate());
  std::vector<std::string> keys;
  auto visit = [&](const std::string& key, auto&, auto&&...) { keys.push_back(key); };
  params.Describe(visit);
  EXPECT_THAT(keys, ElementsAre("p_gain", "i_gain_per_s", "d_gain_s", "i_clamp_min", "i_clamp_max",
                                "antiwindup", "throttle_limit", "watchdog_timeout_s", "period_s",
                                "max_curvature_per_m", "min_speed_for_curvature_mps",
                                "hold_steering_on_zero_command"));
  EXPECT_TRUE(params.hold_steering_on_zero_command);

  params.i_clamp_min = 11.0;
  try {
    params.Validate();
    FAIL() << "accepted i_clamp_min > i_clamp_max";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("i_clamp_min"));
    EXPECT_THAT(e.what(), HasSubstr("11"));
  }
  params = {};
  params.p_gain = -0.1;
  EXPECT_THROW(params.Validate(), std::invalid_argument);
  params = {};
  params.watchdog_timeout = Duration::zero();
  EXPECT_THROW(params.Validate(), std::invalid_argument);
}

TEST(CruiseControlTest, PidStepsByHand) {
  Cruise c;
  // First cycle: no elapsed time, P only: u = 0.4 · 0.25.
  CruiseControlOutput out = c.Step(0.0, Cmd(0.0, 0.25, 0.1), 0.0);
  EXPECT_EQ(out.stopped, CruiseStop::kNone);
  EXPECT_NEAR(out.error_mps, 0.25, kTol);
  EXPECT_NEAR(out.throttle, 0.1, kTol);
  EXPECT_NEAR(out.curvature_per_m, 0.4, kTol);  // κ = ω / v = 0.1 / 0.25
  // 33 ms later at 0.1 m/s: e = 0.15, ∫e = 0.00495, u = 0.06 + 0.2 · 0.00495.
  out = c.Step(0.033, std::nullopt, 0.1);
  EXPECT_NEAR(out.error_mps, 0.15, kTol);
  EXPECT_NEAR(out.integral_term, 0.00099, kTol);
  EXPECT_NEAR(out.throttle, 0.06099, kTol);
  // Overshoot to 0.3 m/s: e = -0.05, ∫e = 0.00495 - 0.00165 = 0.0033, u = -0.02 + 0.00066.
  out = c.Step(0.066, std::nullopt, 0.3);
  EXPECT_NEAR(out.integral_term, 0.00066, kTol);
  EXPECT_NEAR(out.throttle, -0.01934, kTol);
  // The measured speed's sign does not matter: |-0.3| = 0.3 gives the same error.
  Cruise mirrored;
  mirrored.Step(0.0, Cmd(0.0, 0.25, 0.1), 0.0);
  mirrored.Step(0.033, std::nullopt, -0.1);
  EXPECT_NEAR(mirrored.Step(0.066, std::nullopt, -0.3).throttle, -0.01934, kTol);
}

TEST(CruiseControlTest, DerivativeTermUsesTheElapsedTime) {
  Cruise c;
  c.params.d_gain_s = 0.1;
  c.Step(0.0, Cmd(0.0, 0.25), 0.0);                                  // e = 0.25, no derivative
  const CruiseControlOutput out = c.Step(0.05, std::nullopt, 0.05);  // e = 0.2
  // 0.4 · 0.2 + 0.2 · (0.05 · 0.2) + 0.1 · (0.2 - 0.25) / 0.05
  EXPECT_NEAR(out.throttle, 0.08 + 0.002 - 0.1, kTol);
}

TEST(CruiseControlTest, IntegralTermClampedToZeroAndTenAndWindsUpUnderneath) {
  Cruise c;
  c.params.p_gain = 0.0;  // look at the integral term alone
  c.Step(0.0, Cmd(0.0, 10.0), 0.0);
  CruiseControlOutput out;
  // e = 10 for 6 s: ∫e = 60 m, i · ∫e = 12 is clamped to 10 (and u to 1).
  for (int k = 1; k <= 200; ++k) out = c.Step(0.03 * k, Cmd(0.03 * k, 10.0), 0.0);
  EXPECT_NEAR(c.state.integral_error_m, 60.0, 1e-9);
  EXPECT_EQ(out.integral_term, 10.0);
  EXPECT_EQ(out.throttle, 1.0);
  // Antiwindup off (the real node): the integral keeps its 60 m, so 1 s at e = -5 leaves
  // ∫e = 55 and the term still at its clamp.
  out = c.Step(7.0, Cmd(7.0, 0.0), 5.0);
  EXPECT_NEAR(c.state.integral_error_m, 55.0, 1e-9);
  EXPECT_EQ(out.integral_term, 10.0);

  // Antiwindup on: the integral itself stops at 10 / 0.2 = 50 m.
  Cruise a;
  a.params.p_gain = 0.0;
  a.params.antiwindup = true;
  a.Step(0.0, Cmd(0.0, 10.0), 0.0);
  for (int k = 1; k <= 200; ++k) a.Step(0.03 * k, Cmd(0.03 * k, 10.0), 0.0);
  EXPECT_NEAR(a.state.integral_error_m, 50.0, 1e-9);
  out = a.Step(7.0, Cmd(7.0, 0.0), 5.0);  // ∫e = 45 → term 9
  EXPECT_NEAR(out.integral_term, 9.0, 1e-9);

  // Lower clamp: too fast for a while gives a negative integral but a term of 0, u = p · e.
  Cruise b;
  b.Step(0.0, Cmd(0.0, 0.25), 0.5);
  out = b.Step(0.033, std::nullopt, 0.5);  // e = -0.25, ∫e = -0.00825
  EXPECT_NEAR(b.state.integral_error_m, -0.00825, kTol);
  EXPECT_EQ(out.integral_term, 0.0);
  EXPECT_NEAR(out.throttle, -0.1, kTol);
}

TEST(CruiseControlTest, ThrottleClampedToPlusMinusOne) {
  Cruise c;
  EXPECT_EQ(c.Step(0.0, Cmd(0.0, 5.0), 0.0).throttle, 1.0);  // 0.4 · 5 = 2
  Cruise d;
  EXPECT_EQ(d.Step(0.0, Cmd(0.0, -5.0), 0.0).throttle, -1.0);
}

TEST(CruiseControlTest, WatchdogTriggersAfterOneSecondAndNotBefore) {
  Cruise c;
  c.Step(0.0, Cmd(0.0, 0.25, 0.1), 0.0);
  // The command is exactly 1 s old: still running (the real test is `age > 1 s`).
  CruiseControlOutput out = c.Step(1.0, std::nullopt, 0.2);
  EXPECT_EQ(out.stopped, CruiseStop::kNone);
  EXPECT_NE(out.throttle, 0.0);
  // One nanosecond later: stale, zero throttle and zero curvature.
  CruiseControlInput input;
  input.now = At(1.0) + Duration{1};
  input.odometry = OdometrySpeed{input.now, 0.2};
  out = StepCruiseControl(c.params, input, &c.state);
  EXPECT_EQ(out.stopped, CruiseStop::kCommandStale);
  EXPECT_EQ(out.throttle, 0.0);
  EXPECT_EQ(out.curvature_per_m, 0.0);
  // A new command resumes with a fresh PID: no integral, P only.
  out = c.Step(1.5, Cmd(1.5, 0.25, 0.1), 0.2);
  EXPECT_EQ(out.stopped, CruiseStop::kNone);
  EXPECT_EQ(c.state.integral_error_m, 0.0);
  EXPECT_NEAR(out.throttle, 0.4 * 0.05, kTol);

  // Odometry age counts the same way.
  Cruise o;
  o.Step(0.0, Cmd(0.0, 0.25), 0.0);
  EXPECT_EQ(o.Step(1.0, Cmd(1.0, 0.25), std::nullopt).stopped, CruiseStop::kNone);
  EXPECT_EQ(o.Step(1.001, Cmd(1.001, 0.25), std::nullopt).stopped, CruiseStop::kOdometryStale);
}

TEST(CruiseControlTest, AStopsZeroOutputIsPublishedOnce) {
  Cruise c;
  // Nothing received yet: the first stopped cycle's zero goes out, the next ones do not.
  CruiseControlOutput out = c.Step(0.0, std::nullopt, std::nullopt);
  EXPECT_EQ(out.stopped, CruiseStop::kNoCommand);
  EXPECT_TRUE(out.publish);
  EXPECT_FALSE(c.Step(0.033, std::nullopt, std::nullopt).publish);
  // Driving: every cycle is published.
  EXPECT_TRUE(c.Step(0.066, Cmd(0.066, 0.25), 0.0).publish);
  EXPECT_TRUE(c.Step(0.1, Cmd(0.1, 0.25), 0.1).publish);
  // The command goes stale (1.1 s > 1 s): one zero output, then silence while stale, even when
  // the reason changes (emergency on top).
  out = c.Step(1.2, std::nullopt, 0.1);
  EXPECT_EQ(out.stopped, CruiseStop::kCommandStale);
  EXPECT_TRUE(out.publish);
  EXPECT_FALSE(c.Step(1.233, std::nullopt, 0.1).publish);
  EXPECT_FALSE(c.Step(1.266, std::nullopt, 0.1, true).publish);
  // Released and driving again, then a new stop: its zero goes out once more.
  out = c.Step(1.3, Cmd(1.3, 0.25), 0.1, false);
  EXPECT_EQ(out.stopped, CruiseStop::kNone);
  EXPECT_TRUE(out.publish);
  out = c.Step(1.333, Cmd(1.333, 0.25), 0.1, true);
  EXPECT_EQ(out.stopped, CruiseStop::kEmergency);
  EXPECT_TRUE(out.publish);
  EXPECT_FALSE(c.Step(1.366, Cmd(1.366, 0.25), 0.1).publish);
}

TEST(CruiseControlTest, NothingReceivedYetIsAStop) {
  Cruise c;
  EXPECT_EQ(c.Step(0.0, std::nullopt, std::nullopt).stopped, CruiseStop::kNoCommand);
  EXPECT_EQ(c.Step(0.1, Cmd(0.1, 0.25), std::nullopt).stopped, CruiseStop::kNoOdometry);
  EXPECT_EQ(c.Step(0.2, std::nullopt, 0.0).stopped, CruiseStop::kNone);
}

TEST(CruiseControlTest, EmergencyStopLatchesUntilCleared) {
  Cruise c;
  c.Step(0.0, Cmd(0.0, 0.25, 0.1), 0.0);
  c.Step(0.033, Cmd(0.033, 0.25, 0.1), 0.1);
  CruiseControlOutput out = c.Step(0.066, Cmd(0.066, 0.25, 0.1), 0.1, true);
  EXPECT_EQ(out.stopped, CruiseStop::kEmergency);
  EXPECT_EQ(out.throttle, 0.0);
  EXPECT_EQ(out.curvature_per_m, 0.0);
  EXPECT_EQ(c.Step(0.1, Cmd(0.1, 0.25, 0.1), 0.1).stopped, CruiseStop::kEmergency);
  out = c.Step(0.133, Cmd(0.133, 0.25, 0.1), 0.1, false);
  EXPECT_EQ(out.stopped, CruiseStop::kNone);
  EXPECT_NEAR(out.throttle, 0.4 * 0.15, kTol);  // fresh PID
}

TEST(CruiseControlTest, CurvatureIsYawRateOverSpeed) {
  const CruiseControlParams params;
  EXPECT_NEAR(CommandCurvature(params, 0.25, 0.1), 0.4, kTol);
  EXPECT_NEAR(CommandCurvature(params, 0.5, -0.25), -0.5, kTol);
  // Reversing with ω > 0 is a right-hand arc.
  EXPECT_NEAR(CommandCurvature(params, -0.2, 0.1), -0.5, kTol);
  // Saturation like the real steering clamp.
  EXPECT_EQ(CommandCurvature(params, 0.25, 1.0), 1.2);
  EXPECT_EQ(CommandCurvature(params, 0.25, -1.0), -1.2);
  // v ≈ 0: the real car's ±inf is full lock in ω's direction; never a NaN (0/0: see below).
  EXPECT_EQ(CommandCurvature(params, 0.0, 0.1), 1.2);
  EXPECT_EQ(CommandCurvature(params, 0.0, -0.1), -1.2);
  EXPECT_EQ(CommandCurvature(params, 0.0, 0.0), 0.0);
  EXPECT_EQ(CommandCurvature(params, -0.0005, 0.1), 1.2);
}

// Nav2's zero twist when FollowPath is halted mid-curve (nav2_controller.cpp:370, 530-542): the
// lab's carcontroller divides 0/0 (carcontroller.cpp:91), rt_carcontrol writes (int)NaN = 0 as
// the pulse width (rt_carcontrol.cpp:44-57): no pulse, and the steering stays where it was while
// the car brakes. With hold_steering_on_zero_command false it straightens (this model before).
// A watchdog stop's explicit zeros are a neutral pulse: straight, in both.
TEST(CruiseControlTest, TheZeroTwistLeavesTheSteeringWhereItWas) {
  for (const bool hold : {true, false}) {
    CruiseControlParams params;
    params.hold_steering_on_zero_command = hold;
    Cruise c{params};
    c.Step(0.0, Cmd(0.0, 0.25, -0.3), 0.25);
    EXPECT_NEAR(c.Step(0.033, Cmd(0.033, 0.25, -0.3), 0.25).curvature_per_m, -1.2, kTol);
    const CruiseControlOutput halted = c.Step(0.066, Cmd(0.066, 0.0, 0.0), 0.25);
    EXPECT_EQ(halted.stopped, CruiseStop::kNone);
    EXPECT_LT(halted.throttle, 0.0 + kTol);  // it brakes
    EXPECT_EQ(halted.curvature_per_m, hold ? -1.2 : 0.0) << hold;
    EXPECT_EQ(c.Step(0.1, Cmd(0.1, 0.0, 0.0), 0.2).curvature_per_m, hold ? -1.2 : 0.0);
    // the next real command steers again
    EXPECT_NEAR(c.Step(0.133, Cmd(0.133, 0.25, 0.1), 0.2).curvature_per_m, 0.4, kTol);
  }
  // a watchdog stop sends explicit zeros: straight wheels, and a zero twist after it holds those
  Cruise c;
  c.Step(0.0, Cmd(0.0, 0.25, -0.3), 0.25);
  c.Step(0.033, Cmd(0.033, 0.25, -0.3), 0.25);
  EXPECT_EQ(c.Step(1.5, std::nullopt, 0.25).curvature_per_m, 0.0);  // the command is 1.5 s old
  EXPECT_EQ(c.Step(1.533, Cmd(1.533, 0.0, 0.0), 0.0).curvature_per_m, 0.0);
}

TEST(CruiseControlTest, NegativeCommandReversesWithTheIntegralHeldAtZero) {
  Cruise c;
  CruiseControlOutput out = c.Step(0.0, Cmd(0.0, -0.2, 0.1), 0.0);
  EXPECT_NEAR(out.throttle, -0.08, kTol);        // 0.4 · (-0.2 - 0)
  EXPECT_NEAR(out.curvature_per_m, -0.5, kTol);  // 0.1 / -0.2
  // The Hall sensor and the EKF report |v|, the error uses |v| anyway: e = -0.2 - 0.1.
  out = c.Step(0.033, std::nullopt, -0.1);
  EXPECT_NEAR(out.error_mps, -0.3, kTol);
  EXPECT_EQ(out.integral_term, 0.0);
  EXPECT_NEAR(out.throttle, -0.12, kTol);
}

TEST(CruiseControlTest, RejectsNonFiniteInputAndTimeGoingBack) {
  Cruise c;
  EXPECT_THROW(c.Step(0.0, Cmd(0.0, std::numeric_limits<double>::quiet_NaN()), 0.0),
               std::invalid_argument);
  EXPECT_THROW(c.Step(0.0, Cmd(0.0, 0.25), std::numeric_limits<double>::infinity()),
               std::invalid_argument);
  c.Step(1.0, Cmd(1.0, 0.25), 0.0);
  try {
    c.Step(0.5, std::nullopt, 0.0);
    FAIL() << "accepted time going back";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("before the previous step"));
  }
  EXPECT_THROW(c.Step(2.0, Cmd(3.0, 0.25), 0.0), std::invalid_argument);  // received in future
}

TEST(CruiseControlTest, Deterministic) {
  auto run = [] {
    Cruise c;
    std::vector<double> u;
    for (int k = 0; k < 100; ++k) {
      const double t = 0.033 * k;
      u.push_back(c.Step(t, Cmd(t, 0.25, 0.05), 0.002 * k).throttle);
    }
    return u;
  };
  EXPECT_EQ(run(), run());
}

}  // namespace
}  // namespace autonomsim::stack
