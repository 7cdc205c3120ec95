#include "vehicle/ultrasonic.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "world/validation.h"

namespace autonomsim::vehicle {
namespace {

constexpr double kRadPerDeg = std::numbers::pi / 180.0;

double Cross(const world::Vec2& a, const world::Vec2& b) { return a.x() * b.y() - a.y() * b.x(); }

// Keeps the part of a convex polygon where Cross(u, p - apex) >= 0 (Sutherland–Hodgman).
std::vector<world::Vec2> ClipLeftOf(const std::vector<world::Vec2>& polygon,
                                    const world::Vec2& apex, const world::Vec2& u) {
  std::vector<world::Vec2> out;
  const std::size_t n = polygon.size();
  for (std::size_t i = 0; i < n; ++i) {
    const world::Vec2& a = polygon[i];
    const world::Vec2& b = polygon[(i + 1) % n];
    const double da = Cross(u, a - apex);
    const double db = Cross(u, b - apex);
    if (da >= 0.0) out.push_back(a);
    if ((da >= 0.0) != (db >= 0.0)) out.push_back(a + (da / (da - db)) * (b - a));
  }
  return out;
}

double DistanceToSegment(const world::Vec2& p, const world::Vec2& a, const world::Vec2& b) {
  const world::Vec2 ab = b - a;
  const double length_sq = ab.squaredNorm();
  const double t = length_sq > 0.0 ? std::clamp((p - a).dot(ab) / length_sq, 0.0, 1.0) : 0.0;
  return (a + t * ab - p).norm();
}

}  // namespace

void UltrasonicParams::Validate() const {
  Require(std::isfinite(mount_x_m) && std::isfinite(mount_y_m) && std::isfinite(mount_yaw_deg),
          "mount_x_m, mount_y_m and mount_yaw_deg must be finite");
  Require(field_of_view_deg > 0.0 && field_of_view_deg < 180.0,
          [&] { return "field_of_view_deg must be in (0, 180), got " + Num(field_of_view_deg); });
  Require(std::isfinite(min_range_m) && min_range_m >= 0.0,
          [&] { return "min_range_m must be >= 0, got " + Num(min_range_m); });
  Require(std::isfinite(max_range_m) && max_range_m > min_range_m,
          [&] { return "max_range_m must be > min_range_m, got " + Num(max_range_m); });
  Require(std::isfinite(noise_stddev_m) && noise_stddev_m >= 0.0,
          [&] { return "noise_stddev_m must be finite and >= 0, got " + Num(noise_stddev_m); });
}

double NearestInCone(const UltrasonicParams& params, const world::Pose2& X_map_car,
                     std::span<const Prism> prisms) {
  const double c = std::cos(X_map_car.yaw_rad);
  const double s = std::sin(X_map_car.yaw_rad);
  const world::Vec2 apex(X_map_car.x_m + c * params.mount_x_m - s * params.mount_y_m,
                         X_map_car.y_m + s * params.mount_x_m + c * params.mount_y_m);
  const double heading = X_map_car.yaw_rad + params.mount_yaw_deg * kRadPerDeg;
  const double half = 0.5 * params.field_of_view_deg * kRadPerDeg;
  const world::Vec2 right(std::cos(heading - half), std::sin(heading - half));
  const world::Vec2 left(std::cos(heading + half), std::sin(heading + half));

  double nearest = std::numeric_limits<double>::infinity();
  for (const Prism& prism : prisms) {
    // inside the cone: left of its right edge and right of its left edge
    std::vector<world::Vec2> polygon = prism.footprint.Corners();
    polygon = ClipLeftOf(polygon, apex, right);
    polygon = ClipLeftOf(polygon, apex, -left);
    if (polygon.empty()) continue;
    bool inside = true;  // the apex within the clipped (convex, counter-clockwise) polygon
    for (std::size_t i = 0; i < polygon.size(); ++i) {
      const world::Vec2& a = polygon[i];
      const world::Vec2& b = polygon[(i + 1) % polygon.size()];
      nearest = std::min(nearest, DistanceToSegment(apex, a, b));
      inside = inside && Cross(b - a, apex - a) >= 0.0;
    }
    if (inside && polygon.size() >= 3) nearest = 0.0;
  }
  return nearest;
}

double UltrasonicRange(const UltrasonicParams& params, const world::Pose2& X_map_car,
                       std::span<const Prism> prisms, double noise_draw) {
  const double nearest = NearestInCone(params, X_map_car, prisms);
  if (!(nearest <= params.max_range_m)) return std::numeric_limits<double>::infinity();
  const double range = nearest + params.noise_stddev_m * noise_draw;
  if (range < params.min_range_m) return -std::numeric_limits<double>::infinity();
  if (range > params.max_range_m) return std::numeric_limits<double>::infinity();
  return range;
}

}  // namespace autonomsim::vehicle
