#include "stack/path_follower.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "stack/costmap.h"
#include "world/validation.h"

namespace autonomsim::stack {
namespace {

// Nav2 RPP: a carrot nearer than this (squared, m²) gives no curvature.
constexpr double kMinCarrotDist2_m2 = 0.001;
// Tolerance on "elapsed time <= horizon" so that 5 steps of 0.2 s reach exactly 1.0 s.
constexpr double kHorizonEpsilon_s = 1e-9;

void RequireNonNegative(double x, const std::string& key) {
  Require(std::isfinite(x) && x >= 0.0, [&] { return key + " must be >= 0, got " + Num(x); });
}

bool Finite(const world::Vec2& p) { return std::isfinite(p.x()) && std::isfinite(p.y()); }

bool Finite(const world::Pose2& X) {
  return std::isfinite(X.x_m) && std::isfinite(X.y_m) && std::isfinite(X.yaw_rad);
}

double Distance(const world::Pose2& X, const world::Vec2& p) {
  return std::hypot(p.x() - X.x_m, p.y() - X.y_m);
}

double SquaredDistance(const world::Pose2& X, const world::Vec2& p) {
  const double dx = p.x() - X.x_m, dy = p.y() - X.y_m;
  return dx * dx + dy * dy;
}

// Where two distances' squares differ by more than this factor, their hypots (each within an ulp
// of the true distance, as is the square's rounding) compare the same way: a comparison of
// distances takes the hypots only where the squares are this close. That holds for squares in
// the normal range; below kSquaresDecideFrom (m²) a square's underflow can be larger than the
// margin, and the hypots decide.
constexpr double kSquaresApart = 1.0 + 1e-9;
constexpr double kSquaresDecideFrom = 0x1p-900;

// Whether the cell containing p_F collides under the model (the lab's inCollision for centre).
bool CellCollides(CollisionModel model, const CostQuery& cell_cost, const world::Vec2& p_F) {
  const std::optional<std::uint8_t> cost = cell_cost(p_F);
  if (!cost) return false;  // outside the costmap (Nav2: worldToMap fails, no collision)
  return model == CollisionModel::kCentre ? *cost >= kInscribedInflatedObstacle
                                          : *cost == kLethalObstacle;
}

// The footprint's sample grid: (nx + 1) × (ny + 1) points evenly spaced over the rectangle, edges
// included, at most footprint_sample_spacing_m apart.
struct FootprintGrid {
  int nx{0};
  int ny{0};
};

FootprintGrid FootprintGridOf(const CollisionCheckParams& params) {
  auto intervals = [&](double half) {
    return static_cast<int>(std::ceil(2.0 * half / params.footprint_sample_spacing_m));
  };
  return {intervals(params.footprint_half_length_m), intervals(params.footprint_half_width_m)};
}

// Whether the pose X_F_base collides under params.model.
bool PoseCollides(const CollisionCheckParams& params, const FootprintGrid& grid,
                  const world::Pose2& X_F_base, const CostQuery& cell_cost) {
  if (params.model == CollisionModel::kCentre) {
    return CellCollides(params.model, cell_cost, X_F_base.position());
  }
  const double c = std::cos(X_F_base.yaw_rad);
  const double s = std::sin(X_F_base.yaw_rad);
  const double hl = params.footprint_half_length_m;
  const double hw = params.footprint_half_width_m;
  for (int i = 0; i <= grid.nx; ++i) {
    const double x = -hl + 2.0 * hl * i / grid.nx;
    for (int j = 0; j <= grid.ny; ++j) {
      const double y = -hw + 2.0 * hw * j / grid.ny;
      const world::Vec2 p_F{X_F_base.x_m + c * x - s * y, X_F_base.y_m + s * x + c * y};
      if (CellCollides(params.model, cell_cost, p_F)) return true;
    }
  }
  return false;
}

}  // namespace

void RegulatedPurePursuitParams::Validate() const {
  RequirePositive(desired_speed_mps, "desired_speed_mps");
  RequirePositive(lookahead_dist_m, "lookahead_dist_m");
  RequirePositive(min_lookahead_dist_m, "min_lookahead_dist_m");
  RequirePositive(max_lookahead_dist_m, "max_lookahead_dist_m");
  Require(min_lookahead_dist_m <= max_lookahead_dist_m, [&] {
    return "min_lookahead_dist_m must be <= max_lookahead_dist_m, got " +
           Num(min_lookahead_dist_m) + " and " + Num(max_lookahead_dist_m);
  });
  RequirePositive(lookahead_time_s, "lookahead_time_s");
  RequirePositive(regulated_min_radius_m, "regulated_min_radius_m");
  RequireNonNegative(regulated_min_speed_mps, "regulated_min_speed_mps");
  RequireNonNegative(min_approach_speed_mps, "min_approach_speed_mps");
  RequireNonNegative(approach_min_dist_error_m, "approach_min_dist_error_m");
}

void CollisionCheckParams::Validate() const {
  RequireNonNegative(horizon_s, "horizon_s");
  RequirePositive(step_m, "step_m");
  RequirePositive(footprint_half_length_m, "footprint_half_length_m");
  RequirePositive(footprint_half_width_m, "footprint_half_width_m");
  RequirePositive(footprint_sample_spacing_m, "footprint_sample_spacing_m");
}

void PathFollowerParams::Validate() const {
  pursuit.Validate();
  collision.Validate();
  RequirePositive(goal_tolerance_m, "goal_tolerance_m");
  RequirePositive(yaw_goal_tolerance_rad, "yaw_goal_tolerance_rad");
  RequirePositive(max_robot_pose_search_dist_m, "max_robot_pose_search_dist_m");
  RequirePositive(max_costmap_extent_m, "max_costmap_extent_m");
}

double LookaheadDistance(const RegulatedPurePursuitParams& params, double speed_mps) {
  if (!params.use_velocity_scaled_lookahead) return params.lookahead_dist_m;
  return std::clamp(std::abs(speed_mps) * params.lookahead_time_s, params.min_lookahead_dist_m,
                    params.max_lookahead_dist_m);
}

double PurePursuitCurvature(const world::Vec2& p_base_carrot) {
  const double dist2 = p_base_carrot.squaredNorm();
  return dist2 > kMinCarrotDist2_m2 ? 2.0 * p_base_carrot.y() / dist2 : 0.0;
}

double RegulatedSpeed(const RegulatedPurePursuitParams& params, double curvature_per_m,
                      double lookahead_dist_m, double carrot_dist_m) {
  double speed = params.desired_speed_mps;
  if (params.use_regulated_speed_scaling && curvature_per_m != 0.0) {
    const double radius = 1.0 / std::abs(curvature_per_m);
    const double r_min = params.regulated_min_radius_m;
    if (radius < r_min) speed *= 1.0 - std::abs(radius - r_min) / r_min;
  }
  speed = std::max(speed, params.regulated_min_speed_mps);
  const double dist_error = std::abs(lookahead_dist_m - carrot_dist_m);
  if (params.use_approach_speed_scaling && dist_error > params.approach_min_dist_error_m) {
    const double scaling = 1.0 - dist_error / lookahead_dist_m;
    const double approach = params.desired_speed_mps * scaling < params.min_approach_speed_mps
                                ? params.min_approach_speed_mps
                                : params.desired_speed_mps * scaling;
    speed = std::min(speed, approach);
  }
  return std::clamp(speed, 0.0, params.desired_speed_mps);
}

bool IsCollisionImminent(const CollisionCheckParams& params, const world::Pose2& X_F_base,
                         double speed_mps, double yaw_rate_rad_per_s, const CostQuery& cell_cost) {
  const FootprintGrid grid = FootprintGridOf(params);
  if (PoseCollides(params, grid, X_F_base, cell_cost)) return true;
  if (speed_mps == 0.0) return false;
  const double dt_s = params.step_m / std::abs(speed_mps);
  world::Pose2 X = X_F_base;
  for (int i = 1; i * dt_s <= params.horizon_s + kHorizonEpsilon_s; ++i) {
    X.x_m += dt_s * speed_mps * std::cos(X.yaw_rad);
    X.y_m += dt_s * speed_mps * std::sin(X.yaw_rad);
    X.yaw_rad += dt_s * yaw_rate_rad_per_s;
    if (PoseCollides(params, grid, X, cell_cost)) return true;
  }
  return false;
}

namespace {

// The first of the points nearest X among those from `begin` within
// max_robot_pose_search_dist_m of path length.
std::size_t ClosestAhead(const PathFollowerParams& params, std::span<const world::Vec2> path,
                         const world::Pose2& X, std::size_t begin) {
  std::size_t search_end = path.size();
  double along_m = 0.0;
  for (std::size_t i = begin; i + 1 < path.size(); ++i) {
    along_m += (path[i + 1] - path[i]).norm();
    if (along_m > params.max_robot_pose_search_dist_m) {
      search_end = i + 1;
      break;
    }
  }
  std::size_t closest = begin;
  double closest_sq = SquaredDistance(X, path[closest]);
  double closest_m = Distance(X, path[closest]);
  for (std::size_t i = begin + 1; i < search_end; ++i) {
    const double sq = SquaredDistance(X, path[i]);
    // farther: Distance would say so too
    if (closest_sq >= kSquaresDecideFrom && sq > closest_sq * kSquaresApart) continue;
    const double distance_m = Distance(X, path[i]);
    if (distance_m < closest_m) {
      closest = i;
      closest_sq = sq;
      closest_m = distance_m;
    }
  }
  return closest;
}

// The end of the run of points from `closest` on within max_costmap_extent_m of X (Distance <= it),
// by their squares where those decide.
std::size_t WithinExtentEnd(const PathFollowerParams& params, std::span<const world::Vec2> path,
                            const world::Pose2& X, std::size_t closest) {
  const double extent_m = params.max_costmap_extent_m;
  const double extent_sq = extent_m * extent_m;
  const bool squares_decide = extent_sq >= kSquaresDecideFrom;
  const auto within_extent = [&](const world::Vec2& p) {
    const double sq = SquaredDistance(X, p);
    if (squares_decide && sq * kSquaresApart < extent_sq) return true;
    if (squares_decide && sq > extent_sq * kSquaresApart) return false;
    return Distance(X, p) <= extent_m;
  };
  std::size_t end = closest;
  while (end < path.size() && within_extent(path[end])) ++end;
  return end;
}

}  // namespace

PathFollowerOutput StepPathFollower(const PathFollowerParams& params,
                                    const PathFollowerInput& input, PathFollowerState* state) {
  Require(Finite(input.X_F_base), "path follower: the pose must be finite");
  Require(std::isfinite(input.speed_mps),
          [&] { return "path follower: speed_mps must be finite, got " + Num(input.speed_mps); });
  for (std::size_t i = 0; i < input.path.size(); ++i) {
    Require(Finite(input.path[i]),
            [&] { return "path follower: path point " + std::to_string(i) + " is not finite"; });
  }
  PathFollowerState& s = *state;
  PathFollowerOutput out;
  const std::span<const world::Vec2> path = input.path;
  if (path.empty()) {
    out.no_path = true;
    return out;
  }
  if (s.path_id != input.path_id || s.begin >= path.size()) {
    s.path_id = input.path_id;
    s.begin = 0;
  }

  // goal
  const world::Pose2& X = input.X_F_base;
  bool reached = Distance(X, path.back()) <= params.goal_tolerance_m;
  if (reached && input.goal_yaw_rad) {
    reached = std::abs(world::WrapAngle(*input.goal_yaw_rad - X.yaw_rad)) <=
              params.yaw_goal_tolerance_rad;
  }
  if (reached) {
    out.goal_reached = true;
    return out;
  }

  // prune: the closest point within the search distance (first of equals), never backwards; the
  // path kept out to the costmap's extent
  s.begin = ClosestAhead(params, path, X, s.begin);
  const std::size_t closest = s.begin;
  const std::size_t end = WithinExtentEnd(params, path, X, closest);
  if (end == closest) {  // even the closest point is beyond the local costmap
    out.no_path = true;
    return out;
  }

  // carrot and curvature
  const double lookahead_m = LookaheadDistance(params.pursuit, input.speed_mps);
  const world::PointsInFrame to_base(X);
  std::size_t carrot = end - 1;
  for (std::size_t i = closest; i < end; ++i) {
    if (to_base(path[i]).norm() >= lookahead_m) {
      carrot = i;
      break;
    }
  }
  const world::Vec2 p_base_carrot = to_base(path[carrot]);
  out.carrot = path[carrot];
  out.curvature_per_m = PurePursuitCurvature(p_base_carrot);

  // speed and the collision check on the resulting arc
  const PursuitCommand command =
      RegulatedPursuitCommand(params.pursuit, params.collision, out.curvature_per_m, lookahead_m,
                              p_base_carrot.norm(), X, input.cell_cost);
  out.speed_mps = command.speed_mps;
  out.yaw_rate_rad_per_s = command.yaw_rate_rad_per_s;
  out.collision_ahead = command.collision_ahead;
  return out;
}

PursuitCommand RegulatedPursuitCommand(const RegulatedPurePursuitParams& pursuit,
                                       const CollisionCheckParams& collision,
                                       double curvature_per_m, double lookahead_dist_m,
                                       double carrot_dist_m, const world::Pose2& X_F_base,
                                       const CostQuery& cell_cost) {
  const double speed = RegulatedSpeed(pursuit, curvature_per_m, lookahead_dist_m, carrot_dist_m);
  const double yaw_rate = speed * curvature_per_m;
  if (cell_cost && IsCollisionImminent(collision, X_F_base, speed, yaw_rate, cell_cost)) {
    return PursuitCommand{.collision_ahead = true};
  }
  return PursuitCommand{.speed_mps = speed, .yaw_rate_rad_per_s = yaw_rate};
}

}  // namespace autonomsim::stack
