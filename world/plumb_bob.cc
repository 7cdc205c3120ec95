#include "world/plumb_bob.h"

#include <Eigen/LU>

namespace autonomsim::world {
namespace {

constexpr int kUndistortIterations = 50;
constexpr double kUndistortTolerance = 1e-13;

}  // namespace

Eigen::Vector2d Distort(const PlumbBob& D, const Eigen::Vector2d& p) {
  const double k1 = D[0];
  const double k2 = D[1];
  const double p1 = D[2];
  const double p2 = D[3];
  const double k3 = D[4];
  const double x = p.x();
  const double y = p.y();
  const double r2 = x * x + y * y;
  const double radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
  return {x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x),
          y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y};
}

std::optional<Eigen::Vector2d> Undistort(const PlumbBob& D, const Eigen::Vector2d& target) {
  const double k1 = D[0];
  const double k2 = D[1];
  const double p1 = D[2];
  const double p2 = D[3];
  const double k3 = D[4];
  Eigen::Vector2d x = target;
  for (int i = 0; i < kUndistortIterations; ++i) {
    const Eigen::Vector2d residual = Distort(D, x) - target;
    if (residual.norm() < kUndistortTolerance) return x;
    const double r2 = x.squaredNorm();
    const double radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
    const double g = k1 + r2 * (2.0 * k2 + 3.0 * k3 * r2);  // d(radial)/d(r²)
    Eigen::Matrix2d J;
    J(0, 0) = radial + 2.0 * g * x.x() * x.x() + 2.0 * p1 * x.y() + 6.0 * p2 * x.x();
    J(0, 1) = 2.0 * g * x.x() * x.y() + 2.0 * p1 * x.x() + 2.0 * p2 * x.y();
    J(1, 0) = J(0, 1);
    J(1, 1) = radial + 2.0 * g * x.y() * x.y() + 6.0 * p1 * x.y() + 2.0 * p2 * x.x();
    if (!(J.determinant() > 0.0)) return std::nullopt;  // beyond a fold of the model
    x -= J.inverse() * residual;
    if (!x.allFinite()) return std::nullopt;
  }
  return std::nullopt;
}

bool RadialGrowsAt(const PlumbBob& D, double r2) {
  return 1.0 + r2 * (3.0 * D[0] + r2 * (5.0 * D[1] + r2 * 7.0 * D[4])) > 0.0;
}

}  // namespace autonomsim::world
