#include "stack/cruise_control.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "world/validation.h"

namespace autonomsim::stack {
namespace {

void RequireFinite(double x, const char* what) {
  Require(std::isfinite(x), [&] {
    return std::string("cruise control: ") + what + " must be finite, got " + Num(x);
  });
}

// The real node's test: strictly older than the timeout.
bool Stale(const CruiseControlParams& params, Time now, Time received) {
  return now - received > params.watchdog_timeout;
}

}  // namespace

void CruiseControlParams::Validate() const {
  Require(std::isfinite(p_gain) && p_gain >= 0.0,
          [&] { return "p_gain must be >= 0, got " + Num(p_gain); });
  Require(std::isfinite(i_gain_per_s) && i_gain_per_s >= 0.0,
          [&] { return "i_gain_per_s must be >= 0, got " + Num(i_gain_per_s); });
  Require(std::isfinite(d_gain_s) && d_gain_s >= 0.0,
          [&] { return "d_gain_s must be >= 0, got " + Num(d_gain_s); });
  Require(std::isfinite(i_clamp_min) && std::isfinite(i_clamp_max) && i_clamp_min <= i_clamp_max,
          [&] {
            return "i_clamp_min must be <= i_clamp_max, got " + Num(i_clamp_min) + " and " +
                   Num(i_clamp_max);
          });
  Require(std::isfinite(throttle_limit) && throttle_limit > 0.0 && throttle_limit <= 1.0,
          [&] { return "throttle_limit must be in (0, 1], got " + Num(throttle_limit); });
  Require(watchdog_timeout > Duration::zero(), [&] {
    return "watchdog_timeout_s must be > 0, got " + Num(ToSeconds(watchdog_timeout));
  });
  Require(period > Duration::zero(),
          [&] { return "period_s must be > 0, got " + Num(ToSeconds(period)); });
  Require(std::isfinite(max_curvature_per_m) && max_curvature_per_m > 0.0,
          [&] { return "max_curvature_per_m must be > 0, got " + Num(max_curvature_per_m); });
  Require(std::isfinite(min_speed_for_curvature_mps) && min_speed_for_curvature_mps > 0.0, [&] {
    return "min_speed_for_curvature_mps must be > 0, got " + Num(min_speed_for_curvature_mps);
  });
}

double CommandCurvature(const CruiseControlParams& params, double speed_mps,
                        double yaw_rate_rad_per_s) {
  const double k_max = params.max_curvature_per_m;
  if (std::abs(speed_mps) < params.min_speed_for_curvature_mps) {
    if (yaw_rate_rad_per_s == 0.0) return 0.0;
    return yaw_rate_rad_per_s > 0.0 ? k_max : -k_max;
  }
  return std::clamp(yaw_rate_rad_per_s / speed_mps, -k_max, k_max);
}

namespace {

// The steering of a normal cycle: κ from the latest command, except that the zero twist (0/0: no
// pulse) leaves it where it was when hold_steering_on_zero_command.
double SteeringCurvature(const CruiseControlParams& params, const CruiseControlState& s) {
  const bool zero_twist = std::abs(s.command->speed_mps) < params.min_speed_for_curvature_mps &&
                          s.command->yaw_rate_rad_per_s == 0.0;
  if (zero_twist && params.hold_steering_on_zero_command) return s.curvature_per_m;
  return CommandCurvature(params, s.command->speed_mps, s.command->yaw_rate_rad_per_s);
}

}  // namespace

CruiseControlOutput StepCruiseControl(const CruiseControlParams& params,
                                      const CruiseControlInput& input, CruiseControlState* state) {
  CruiseControlState& s = *state;
  Require(input.now >= s.last_step, [&] {
    return "cruise control: now (" + Num(ToSeconds(input.now)) +
           " s) is before the previous step (" + Num(ToSeconds(s.last_step)) + " s)";
  });
  s.last_step = input.now;

  // messages
  if (input.command) {
    RequireFinite(input.command->speed_mps, "command speed_mps");
    RequireFinite(input.command->yaw_rate_rad_per_s, "command yaw_rate_rad_per_s");
    Require(input.command->received <= input.now, "cruise control: command received after now");
    s.command = input.command;
  }
  if (input.odometry) {
    RequireFinite(input.odometry->speed_mps, "odometry speed_mps");
    Require(input.odometry->received <= input.now, "cruise control: odometry received after now");
    s.odometry = input.odometry;
  }
  if (input.set_emergency) s.emergency = *input.set_emergency;

  // watchdog and emergency stop
  CruiseControlOutput out;
  if (!s.command) {
    out.stopped = CruiseStop::kNoCommand;
  } else if (Stale(params, input.now, s.command->received)) {
    out.stopped = CruiseStop::kCommandStale;
  } else if (!s.odometry) {
    out.stopped = CruiseStop::kNoOdometry;
  } else if (Stale(params, input.now, s.odometry->received)) {
    out.stopped = CruiseStop::kOdometryStale;
  } else if (s.emergency) {
    out.stopped = CruiseStop::kEmergency;
  }
  if (out.stopped != CruiseStop::kNone) {
    s.pid_fresh = true;
    s.curvature_per_m = 0.0;  // the stop's zero twist: a neutral pulse, straight wheels
    out.publish = !s.stop_published;
    s.stop_published = true;
    return out;
  }
  s.stop_published = false;

  // PID on speed
  const double error = s.command->speed_mps - std::abs(s.odometry->speed_mps);
  double dt_s = 0.0;
  if (s.pid_fresh) {
    s.integral_error_m = 0.0;
    s.last_error_mps = error;
  } else {
    dt_s = ToSeconds(input.now - s.last_cycle);
  }
  s.last_cycle = input.now;
  out.error_mps = error;
  out.curvature_per_m = SteeringCurvature(params, s);
  s.curvature_per_m = out.curvature_per_m;
  if (!s.pid_fresh && dt_s == 0.0) return out;  // control_toolbox answers a zero dt with 0
  s.pid_fresh = false;

  s.integral_error_m += dt_s * error;
  if (params.antiwindup && params.i_gain_per_s > 0.0) {
    s.integral_error_m = std::clamp(s.integral_error_m, params.i_clamp_min / params.i_gain_per_s,
                                    params.i_clamp_max / params.i_gain_per_s);
  }
  const double i_term =
      std::clamp(params.i_gain_per_s * s.integral_error_m, params.i_clamp_min, params.i_clamp_max);
  out.integral_term = i_term;
  const double d_term = dt_s > 0.0 ? params.d_gain_s * (error - s.last_error_mps) / dt_s : 0.0;
  s.last_error_mps = error;
  const double u = params.p_gain * error + i_term + d_term;
  out.throttle = std::clamp(u, -params.throttle_limit, params.throttle_limit);
  return out;
}

}  // namespace autonomsim::stack
