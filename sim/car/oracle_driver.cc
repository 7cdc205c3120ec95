#include "sim/car/oracle_driver.h"

#include <algorithm>
#include <stdexcept>
#include <string>

#include "world/validation.h"

namespace autonomsim::sim {

void OracleDriverParams::Validate() const {
  if (period <= kZeroTime) throw std::invalid_argument("period_s must be > 0");
  if (!(speed_mps > 0.0 && speed_mps <= 5.0)) {
    throw std::invalid_argument("speed_mps must be in (0, 5] m/s, got " + Num(speed_mps));
  }
  if (!(lookahead_m >= 0.05 && lookahead_m <= 5.0)) {
    throw std::invalid_argument("lookahead_m must be in [0.05, 5] m, got " + Num(lookahead_m));
  }
  if (!(obstacle_stop_gap_m >= 0.0)) {
    throw std::invalid_argument("obstacle_stop_gap_m must be >= 0, got " +
                                Num(obstacle_stop_gap_m));
  }
  if (!(speed_gain_per_mps >= 0.0)) {
    throw std::invalid_argument("speed_gain_per_mps must be >= 0, got " + Num(speed_gain_per_mps));
  }
}

vehicle::ActuatorCommand StepOracleDriver(const OracleDriverParams& params,
                                          const vehicle::CarParams& car, const world::Route& route,
                                          const OracleDriverInput& input,
                                          OracleDriverState* state) {
  // steer: pure pursuit from the rear axle to the point lookahead_m further along the route
  const world::Vec2 heading = input.X_map_car.heading();
  const world::Vec2 p_rear = input.X_map_car.position() - 0.5 * car.wheelbase_m * heading;
  const world::Polyline& path = route.path;
  const double window_m = 1.0;
  state->rear_axle_s_m = path.ProjectNear(p_rear, state->rear_axle_s_m, window_m).s_m;
  const world::Vec2 p_target = path.PointAt(state->rear_axle_s_m + params.lookahead_m);
  const world::Vec2 d_map = p_target - p_rear;
  const double forward = d_map.dot(heading);
  const double left = heading.x() * d_map.y() - heading.y() * d_map.x();
  const double distance_sq = std::max(forward * forward + left * left, 1e-6);

  vehicle::ActuatorCommand command;
  command.curvature_per_m = 2.0 * left / distance_sq;

  // speed: feed-forward through the motor's top speed plus proportional feedback; holding means
  // no drive at all, so the motor brakes the car to a stop
  const bool blocked = input.obstacle_gap_m && *input.obstacle_gap_m <= params.obstacle_stop_gap_m;
  if (input.hold || blocked) {
    command.throttle = 0.0;
  } else {
    const double u = params.speed_mps / car.top_speed_mps +
                     params.speed_gain_per_mps * (params.speed_mps - input.speed_mps);
    command.throttle = std::clamp(u, -1.0, 1.0);
  }
  return command;
}

}  // namespace autonomsim::sim
