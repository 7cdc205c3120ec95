#include "world/geometry.h"

#include <algorithm>
#include <numbers>
#include <stdexcept>
#include <string>

#include "world/validation.h"

namespace autonomsim::world {

void Box::Validate() const {
  if (!(x_min_m < x_max_m) || !(y_min_m < y_max_m)) {
    throw std::invalid_argument("box must have x_min_m < x_max_m and y_min_m < y_max_m, got x [" +
                                Num(x_min_m) + ", " + Num(x_max_m) + "], y [" + Num(y_min_m) +
                                ", " + Num(y_max_m) + "]");
  }
}

double WrapAngle(double a_rad) {
  constexpr double kPi = std::numbers::pi;
  double r = Remainder(a_rad, 2.0 * kPi);
  if (r <= -kPi) r += 2.0 * kPi;
  return r;
}

PointsInFrame::PointsInFrame(const Pose2& X_F_body)
    : p_F_body_(X_F_body.position()),
      c_(std::cos(X_F_body.yaw_rad)),
      s_(std::sin(X_F_body.yaw_rad)) {}

Vec2 PointsInFrame::operator()(const Vec2& p_F) const {
  const double dx = p_F.x() - p_F_body_.x();
  const double dy = p_F.y() - p_F_body_.y();
  return {c_ * dx + s_ * dy, -s_ * dx + c_ * dy};
}

std::vector<Vec2> OrientedBox::Corners() const {
  const Vec2 c = pose.position();
  const Vec2 x = 0.5 * length_m * pose.heading();
  const Vec2 y = 0.5 * width_m * Vec2(-std::sin(pose.yaw_rad), std::cos(pose.yaw_rad));
  return {c - x - y, c + x - y, c + x + y, c - x + y};
}

namespace {

double PointSegmentDistance(const Vec2& p, const Vec2& a, const Vec2& b) {
  const Vec2 ab = b - a;
  const double t = std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
  return (a + t * ab - p).norm();
}

// Separating-axis test on the four edge normals of two rectangles.
bool Overlap(const std::vector<Vec2>& a, const std::vector<Vec2>& b) {
  for (const std::vector<Vec2>* poly : {&a, &b}) {
    for (std::size_t i = 0; i < 2; ++i) {
      const Vec2 edge = (*poly)[i + 1] - (*poly)[i];
      const Vec2 axis(-edge.y(), edge.x());
      double a_min = 1e300, a_max = -1e300, b_min = 1e300, b_max = -1e300;
      for (const Vec2& p : a) {
        a_min = std::min(a_min, p.dot(axis));
        a_max = std::max(a_max, p.dot(axis));
      }
      for (const Vec2& p : b) {
        b_min = std::min(b_min, p.dot(axis));
        b_max = std::max(b_max, p.dot(axis));
      }
      if (a_max < b_min || b_max < a_min) return false;
    }
  }
  return true;
}

}  // namespace

double Distance(const OrientedBox& a, const OrientedBox& b) {
  const std::vector<Vec2> pa = a.Corners();
  const std::vector<Vec2> pb = b.Corners();
  if (Overlap(pa, pb)) return 0.0;
  double d = 1e300;
  for (std::size_t i = 0; i < 4; ++i) {
    for (std::size_t j = 0; j < 4; ++j) {
      d = std::min(d, PointSegmentDistance(pa[i], pb[j], pb[(j + 1) % 4]));
      d = std::min(d, PointSegmentDistance(pb[j], pa[i], pa[(i + 1) % 4]));
    }
  }
  return d;
}

}  // namespace autonomsim::world
