// The car's cruise control (reference §6; code/ros_ws/src/carcontroller): every 33 ms a PID on
// speed turns the latest velocity command (cmd_vel: v, ω) and the latest odometry into a throttle
// u ∈ [-1, 1] and a steering curvature κ = ω / v. The PWM mapping of u and κ lives in vehicle/.
//
// Behaviour, following the real node:
// - error = v_cmd − |v_measured|; PID as control_toolbox's Pid with antiwindup off: the integral
//   of the error accumulates without bound, its term i·∫e is clamped to [i_clamp_min, i_clamp_max];
//   u = p·e + clamp(i·∫e) + d·ė, then clamped to ±1. dt is the time since the previous cycle.
// - A negative command is not special-cased: e = v_cmd − |v| < 0 gives u < 0 (the ESC reverses),
//   while the integral term stays >= i_clamp_min = 0; κ = ω / v_cmd keeps the geometric meaning
//   (a reversing car with ω > 0 and v < 0 steers right: κ < 0).
// - Watchdog: zero output (u = 0, κ = 0) while the latest command or odometry arrived more than
//   watchdog_timeout ago (strictly: exactly 1 s old still runs), none arrived yet, or the latched
//   emergency stop is set. The first normal cycle afterwards resets the PID (integral and
//   derivative memory) and has no elapsed time, so its output is p·e alone, as on the real car.
// - The real node sends its output every cycle. Here a stop's zero output is marked for sending
//   once (`publish`) and the following stopped cycles are silent until a normal cycle: the PWM
//   generator holds the last command, so the car does the same, and the end-to-end latency on the
//   command topic is measured only on commands derived from fresh input.
// - The real node divides ω / v_cmd unguarded (carcontroller.cpp:91): v = 0 with ω ≠ 0 gives
//   ±inf, which the steering clamp turns into full lock in ω's direction. 0/0, the zero twist
//   Nav2's controller server publishes when FollowPath is halted (a wait at an intersection;
//   nav2_controller.cpp:370, 530-542, galactic), gives NaN: rt_carcontrol's float `angle` is NaN,
//   passes both clamps (every comparison with NaN is false) and is written as (int)NaN, which on
//   the A53 (AArch64's fcvtzs) is 0 (rt_carcontrol.cpp:44-57): a zero pulse width, no pulse, so
//   the steering servo is not driven and stays where it was (assumed: what a hobby servo without
//   pulses does; the car's servo is not named). Here: |v_cmd| < min_speed_for_curvature_mps
//   gives full lock (±max_curvature_per_m) in ω's direction when ω ≠ 0, and when ω = 0 the last
//   κ (hold_steering_on_zero_command) or κ = 0; otherwise κ = ω / v_cmd clamped to
//   ±max_curvature_per_m (the same saturation the PWM mapping applies), so κ is always finite.
#pragma once

#include <optional>

#include "world/time.h"

namespace autonomsim::stack {

struct CruiseControlParams {
  // Reference §6 (carcontroller params in nav2_car_params.yaml). The package's own
  // params/params.yaml says p 2.0, i 0.0; the launch used on the car loads nav2_car_params.
  double p_gain{0.4};
  double i_gain_per_s{0.2};
  double d_gain_s{0.0};
  double i_clamp_min{0.0};   // reference §6: the integral term's range (throttle units)
  double i_clamp_max{10.0};  // reference §6
  // control_toolbox's Pid (ROS 2 Galactic): false clamps only the term and lets the integral wind
  // up (the carcontroller calls initPid(..., false)); true clamps the integral itself.
  bool antiwindup{false};
  double throttle_limit{1.0};  // reference §6: u clamped to ±1
  // Reference §6: 1 s watchdog on command and odometry age.
  Duration watchdog_timeout{std::chrono::seconds(1)};
  // Reference §6: the control loop's period (the node's timer; Step measures dt itself).
  Duration period{Milliseconds(33)};
  // Reference §2: the actuator saturates at |κ| = 1.2 1/m (rt_carcontrol clamps the pulse).
  double max_curvature_per_m{1.2};
  // Assumed: below this |v_cmd| the quotient ω / v is treated as the real car's ±inf (see above).
  // 1 mm/s is far below any speed the controllers command (0.05–0.25 m/s).
  double min_speed_for_curvature_mps{1e-3};
  // The zero twist (v = 0, ω = 0) keeps the steering where it was (true: the lab's NaN pulse,
  // above) or straightens it (false: κ = 0, what this model did before issue 33).
  bool hold_steering_on_zero_command{true};

  template <class V>
  void Describe(V& v) {
    v("p_gain", p_gain, "the speed PID's proportional gain (throttle per m/s)");
    v("i_gain_per_s", i_gain_per_s, "its integral gain");
    v("d_gain_s", d_gain_s, "its derivative gain");
    v("i_clamp_min", i_clamp_min, "the integral term's lower bound (throttle units)");
    v("i_clamp_max", i_clamp_max, "the integral term's upper bound");
    v("antiwindup", antiwindup, "clamp the integral itself (false: only its term, as the lab's)");
    v("throttle_limit", throttle_limit, "the throttle's bound, ±");
    v("watchdog_timeout_s", watchdog_timeout, "no command or odometry for this long stops the car");
    v("period_s", period, "how often the control loop runs");
    v("max_curvature_per_m", max_curvature_per_m, "the steering curvature's bound");
    v("min_speed_for_curvature_mps", min_speed_for_curvature_mps,
      "below this commanded speed a turn command is full lock, as the real car's ω / 0");
    v("hold_steering_on_zero_command", hold_steering_on_zero_command,
      "a zero command keeps the steering where it was, as the lab's car does (false: straightens "
      "it)");
  }
  void Validate() const;
};

// geometry_msgs/Twist on cmd_vel, as received.
struct VelocityCommand {
  Time received{kZeroTime};
  double speed_mps{0.0};           // linear.x; negative = reverse
  double yaw_rate_rad_per_s{0.0};  // angular.z
};

// The EKF's odometry (odometry/filtered), as received: the node uses the twist's magnitude.
struct OdometrySpeed {
  Time received{kZeroTime};
  double speed_mps{0.0};
};

struct CruiseControlInput {
  Time now{kZeroTime};
  std::optional<VelocityCommand> command;  // a cmd_vel that arrived since the last step
  std::optional<OdometrySpeed> odometry;   // an odometry that arrived since the last step
  std::optional<bool> set_emergency;       // a call of the /emergency SetBool service
};

enum class CruiseStop { kNone, kNoCommand, kCommandStale, kNoOdometry, kOdometryStale, kEmergency };

struct CruiseControlOutput {
  double throttle{0.0};         // u ∈ [-throttle_limit, throttle_limit]
  double curvature_per_m{0.0};  // κ > 0 turns left, finite, |κ| <= max_curvature_per_m
  CruiseStop stopped{CruiseStop::kNone};
  bool publish{true};     // false: a stopped cycle after the stop's zero output already went out
  double error_mps{0.0};  // v_cmd − |v_measured| in a normal cycle, else 0
  double integral_term{0.0};  // the clamped i·∫e that went into u
};

struct CruiseControlState {
  std::optional<VelocityCommand> command;  // the latest ones received
  std::optional<OdometrySpeed> odometry;
  bool emergency{false};
  Time last_step{kZeroTime};
  bool stop_published{false};  // the current stop's zero output went out
  // PID memory; `pid_fresh` means the next normal cycle (re)starts it with dt = 0.
  bool pid_fresh{true};
  Time last_cycle{kZeroTime};    // the previous normal (PID) cycle
  double integral_error_m{0.0};  // ∫e dt, m (unbounded unless antiwindup)
  double curvature_per_m{0.0};   // the steering's last output (a stop's is 0)
  double last_error_mps{0.0};
};

// Throws std::invalid_argument on non-finite input values, a message received after `now`, or
// `now` before the previous step.
CruiseControlOutput StepCruiseControl(const CruiseControlParams& params,
                                      const CruiseControlInput& input, CruiseControlState* state);

// κ = ω / v as described above (exposed for the node layer's diagnostics and tests).
double CommandCurvature(const CruiseControlParams& params, double speed_mps,
                        double yaw_rate_rad_per_s);

}  // namespace autonomsim::stack
