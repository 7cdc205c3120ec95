// Plain 2D geometry in the map frame: x right (east), y up (north), yaw counter-clockwise from +x,
// metres and radians (REP-103 in the plane).
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <vector>

namespace autonomsim::world {

using Vec2 = Eigen::Vector2d;

// Pose of a body in the map frame (X_map_body in Drake's notation).
struct Pose2 {
  double x_m{0.0};
  double y_m{0.0};
  double yaw_rad{0.0};

  Vec2 position() const { return {x_m, y_m}; }
  Vec2 heading() const { return {std::cos(yaw_rad), std::sin(yaw_rad)}; }
  friend bool operator==(const Pose2&, const Pose2&) = default;  // exactly, bit for bit
};

// Axis-aligned box in the map frame; used for the intersection areas and stop zones, which the
// real cars test with strict inequalities (reference §1).
struct Box {
  double x_min_m{0.0};
  double x_max_m{0.0};
  double y_min_m{0.0};
  double y_max_m{0.0};

  bool Contains(const Vec2& p) const {
    return p.x() > x_min_m && p.x() < x_max_m && p.y() > y_min_m && p.y() < y_max_m;
  }
  template <class V>
  void Describe(V& v) {
    v("x_min_m", x_min_m);
    v("x_max_m", x_max_m);
    v("y_min_m", y_min_m);
    v("y_max_m", y_max_m);
  }
  void Validate() const;
};

// Wraps an angle to (-pi, pi].
double WrapAngle(double a_rad);

// std::remainder(x, period) (x less the nearest multiple of period), without the library call
// where x already lies within half a period of 0: there the remainder is x itself, exactly (the
// nearest multiple is 0). Most calls are of that kind (an arc length's change over one step).
inline double Remainder(double x, double period) {
  return std::abs(x) < 0.5 * period ? x : std::remainder(x, period);
}

// Points of a frame F expressed in a body's frame, the body at X_F_body: p_body = R(-yaw) ·
// (p_F - p_F_body). The rotation's cos and sin are taken once, for as many points as are asked
// (a collision check maps thousands of cells under one pose); each point's arithmetic is
// c·dx + s·dy, -s·dx + c·dy in that order.
class PointsInFrame {
 public:
  explicit PointsInFrame(const Pose2& X_F_body);
  Vec2 operator()(const Vec2& p_F) const;

 private:
  Vec2 p_F_body_;
  double c_{1.0}, s_{0.0};
};

// A rectangle centred on a pose: the footprint of a car or an obstacle.
struct OrientedBox {
  Pose2 pose;
  double length_m{0.0};  // along the pose's x axis
  double width_m{0.0};

  std::vector<Vec2> Corners() const;  // counter-clockwise
  friend bool operator==(const OrientedBox&, const OrientedBox&) = default;
};

// The free distance between two rectangles: 0 when they touch or overlap.
double Distance(const OrientedBox& a, const OrientedBox& b);

}  // namespace autonomsim::world
