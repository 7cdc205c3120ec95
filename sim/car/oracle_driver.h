// The oracle driver: ground-truth lane following along a route (pure pursuit on the lane centre
// path), the reference driver for studies and the driver of the world's own tests. It sees the
// true pose, never a sensor.
#pragma once

#include <optional>

#include "vehicle/car.h"
#include "world/geometry.h"
#include "world/road_graph.h"
#include "world/time.h"

namespace autonomsim::sim {

struct OracleDriverParams {
  // Reference §2: the real car drives at 0.25 m/s (Nav2 desired_linear_vel), their Gazebo world at
  // 0.5 m/s; we take the middle of that range.
  double speed_mps{0.4};
  // Assumed: pure pursuit look-ahead from the rear axle. Short enough to hug the 0.9 m lane
  // corners (cutting them by ≈ L²/(8R) ≈ 2 cm), long enough to stay stable at 0.5 m/s.
  double lookahead_m{0.4};
  // Assumed: throttle per m/s of speed error on top of the feed-forward u = v / top_speed.
  double speed_gain_per_mps{1.0};
  // Assumed: with ideal perception the oracle stops for an obstacle on its lane when the gap from
  // its front to the obstacle closes to this (the motor then brakes it within ≈ v·τ ≈ 0.15 m).
  double obstacle_stop_gap_m{0.35};
  // Assumed: the oracle stands for ideal driving, so it steers at 50 Hz (the real controller
  // server runs at 20 Hz, reference §6).
  Duration period{std::chrono::milliseconds(20)};

  template <class V>
  void Describe(V& v) {
    v("period_s", period, "how often the oracle steers");
    v("speed_mps", speed_mps, "the speed it drives at");
    v("lookahead_m", lookahead_m, "pure pursuit look-ahead along the lane, from the rear axle");
    v("speed_gain_per_mps", speed_gain_per_mps,
      "throttle per m/s of speed error, on top of the feed-forward");
    v("obstacle_stop_gap_m", obstacle_stop_gap_m,
      "it stops when the gap from its front to an obstacle on its lane closes to this");
  }
  void Validate() const;
};

struct OracleDriverInput {
  world::Pose2 X_map_car;  // true chassis pose
  double speed_mps{0.0};   // true forward speed
  bool hold{false};        // stop and stay (waiting for a grant, or parked)
  // Ground truth: free distance from the car's front to the nearest obstacle on its lane ahead.
  std::optional<double> obstacle_gap_m;
};

struct OracleDriverState {
  double rear_axle_s_m{0.0};  // where the rear axle projects on the route, tracked step to step
};

vehicle::ActuatorCommand StepOracleDriver(const OracleDriverParams& params,
                                          const vehicle::CarParams& car, const world::Route& route,
                                          const OracleDriverInput& input, OracleDriverState* state);

}  // namespace autonomsim::sim
