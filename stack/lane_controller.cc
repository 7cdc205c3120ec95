#include "stack/lane_controller.h"

#include <cmath>
#include <string>

#include "world/validation.h"

namespace autonomsim::stack {

void LaneControllerParams::Validate() const {
  pursuit.Validate();
  collision.Validate();
}

LaneControllerOutput StepLaneController(const LaneControllerParams& params,
                                        const LaneControllerInput& input) {
  Require(std::isfinite(input.speed_mps),
          [&] { return "lane controller: speed_mps must be finite, got " + Num(input.speed_mps); });
  Require(std::isfinite(input.X_F_base.x_m) && std::isfinite(input.X_F_base.y_m) &&
              std::isfinite(input.X_F_base.yaw_rad),
          "lane controller: the pose must be finite");
  LaneControllerOutput out;

  // carrot: the nearest point at range >= L (first of equals)
  const double lookahead_m = LookaheadDistance(params.pursuit, input.speed_mps);
  if (input.lanes_valid) {
    double best_m = 0.0;
    for (std::size_t i = 0; i < input.lane_points_base.size(); ++i) {
      const world::Vec2& p = input.lane_points_base[i];
      // a point that is not a number is no carrot: the lab's `hypot(x, y) >= L` is false for it
      // (lane_controller.cpp:349-351; the hardware fit's message can carry such points)
      if (!std::isfinite(p.x()) || !std::isfinite(p.y())) continue;
      const double range_m = p.norm();
      if (range_m >= lookahead_m && (!out.carrot_base || range_m < best_m)) {
        out.carrot_base = p;
        best_m = range_m;
      }
    }
  }
  if (!out.carrot_base) return out;

  // curvature, speed, and the collision check on the resulting arc
  out.curvature_per_m = PurePursuitCurvature(*out.carrot_base);
  const PursuitCommand command =
      RegulatedPursuitCommand(params.pursuit, params.collision, out.curvature_per_m, lookahead_m,
                              out.carrot_base->norm(), input.X_F_base, input.cell_cost);
  out.speed_mps = command.speed_mps;
  out.yaw_rate_rad_per_s = command.yaw_rate_rad_per_s;
  out.collision_ahead = command.collision_ahead;
  return out;
}

}  // namespace autonomsim::stack
