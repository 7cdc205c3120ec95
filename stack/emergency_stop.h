// An emergency stop from the front ultrasonic ranger: a safety addition beyond the lab's stack.
// The real car carries the sensor (reference §2: 10 Hz, 0.05-4 m) and its carcontroller offers
// an /emergency service (reference §6: zero output on an emergency stop), but nothing in the lab's
// stack connects the two. The depth camera cannot see what is right in front of the bumper (its
// blind range), and a recovery clears the costmap of what it saw before: a car restarting after a
// recovery may drive into a car standing 0.6 m ahead. This core latches the stop while something
// is nearer than stop_distance_m and releases it once the range exceeds release_distance_m
// (hysteresis, so that echo noise on the threshold does not toggle it).
//
// Reading follows REP-117 as the sensor model publishes it: -inf is an echo nearer than the
// sensor's minimum range (stop), +inf nothing within its maximum range (clear).
#pragma once

#include <optional>

namespace autonomsim::stack {

struct EmergencyStopParams {
  // Off in the lab's stack (stack.preset: lab); on with stack.preset: safe.
  bool enabled{false};
  // assumed: at the lab's 0.25 m/s a car covers 0.025 m per 10 Hz reading and stops within a few
  // centimetres once its throttle is cut; 0.3 m from the bumper leaves room for both.
  double stop_distance_m{0.3};
  // assumed: 0.15 m above the stop distance, thirty times the echo noise (3 mm)
  double release_distance_m{0.45};

  template <class V>
  void Describe(V& v) {
    v("enabled", enabled, "the ultrasonic ranger stops the car (lab: false)");
    v("stop_distance_m", stop_distance_m, "stop when an echo is nearer than this");
    v("release_distance_m", release_distance_m,
      "drive on when the echo is farther than this again");
  }
  void Validate() const;  // 0 < stop < release <= 4 m
};

struct EmergencyStopState {
  bool stopped{false};
};

// One range reading (m). Returns the /emergency call to make when the latch changes (true: stop,
// false: release), nothing otherwise. NaN readings are ignored (the latch holds).
std::optional<bool> StepEmergencyStop(const EmergencyStopParams& params, double range_m,
                                      EmergencyStopState* state);

}  // namespace autonomsim::stack
