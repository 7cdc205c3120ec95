#include "world/plumb_bob.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <string>

namespace autonomsim::world {
namespace {

constexpr int kUndistortIterations = 50;
constexpr double kUndistortTolerance = 1e-13;
// How many points UndistortAll iterates side by side.
constexpr int kUndistortLanes = 4;

enum class NewtonStatus { kConverged, kFailed, kGoingOn };

// One iteration of Undistort's Newton's method at *x: kConverged when Distort(D, *x) is within the
// tolerance of `target` (*x unchanged), kFailed beyond a fold of the model or where *x turns
// infinite, else *x moved by one step. The step in scalars, with the operations of Eigen's 2×2
// determinant, inverse and product in their order, so that it gives the bits of the Eigen form it
// replaced (x -= J.inverse() * residual).
NewtonStatus NewtonStep(const PlumbBob& D, const Eigen::Vector2d& target, Eigen::Vector2d* x) {
  const double k1 = D[0];
  const double k2 = D[1];
  const double p1 = D[2];
  const double p2 = D[3];
  const double k3 = D[4];
  const Eigen::Vector2d residual = Distort(D, *x) - target;
  if (residual.norm() < kUndistortTolerance) return NewtonStatus::kConverged;
  const double eu = residual.x();
  const double ev = residual.y();
  const double u = x->x();
  const double v = x->y();
  const double r2 = u * u + v * v;
  const double radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
  const double g = k1 + r2 * (2.0 * k2 + 3.0 * k3 * r2);  // d(radial)/d(r²)
  const double j00 = radial + 2.0 * g * u * u + 2.0 * p1 * v + 6.0 * p2 * u;
  const double j01 = 2.0 * g * u * v + 2.0 * p1 * u + 2.0 * p2 * v;  // = j10
  const double j11 = radial + 2.0 * g * v * v + 6.0 * p1 * v + 2.0 * p2 * u;
  const double det = j00 * j11 - j01 * j01;
  if (!(det > 0.0)) return NewtonStatus::kFailed;  // beyond a fold of the model
  const double inv_det = 1.0 / det;
  *x = Eigen::Vector2d(u - (j11 * inv_det * eu + -j01 * inv_det * ev),
                       v - (-j01 * inv_det * eu + j00 * inv_det * ev));
  return x->allFinite() ? NewtonStatus::kGoingOn : NewtonStatus::kFailed;
}

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
  Eigen::Vector2d x = target;
  for (int i = 0; i < kUndistortIterations; ++i) {
    switch (NewtonStep(D, target, &x)) {
      case NewtonStatus::kConverged:
        return x;
      case NewtonStatus::kFailed:
        return std::nullopt;
      case NewtonStatus::kGoingOn:
        break;
    }
  }
  return std::nullopt;
}

void UndistortAll(const PlumbBob& D, std::span<const Eigen::Vector2d> distorted,
                  std::span<std::optional<Eigen::Vector2d>> undistorted) {
  if (distorted.size() != undistorted.size()) {
    throw std::invalid_argument("UndistortAll: " + std::to_string(distorted.size()) +
                                " points in, room for " + std::to_string(undistorted.size()));
  }
  for (std::size_t first = 0; first < distorted.size(); first += kUndistortLanes) {
    const int lanes =
        static_cast<int>(std::min<std::size_t>(kUndistortLanes, distorted.size() - first));
    const Eigen::Vector2d* target = distorted.data() + first;
    std::optional<Eigen::Vector2d>* out = undistorted.data() + first;
    std::array<Eigen::Vector2d, kUndistortLanes> x;
    std::array<bool, kUndistortLanes> going{};
    for (int l = 0; l < lanes; ++l) {
      x[l] = target[l];
      going[l] = true;
      out[l].reset();
    }
    // Each lane takes the steps Undistort would, and stops where Undistort would return.
    int left = lanes;
    for (int i = 0; i < kUndistortIterations && left > 0; ++i) {
      for (int l = 0; l < lanes; ++l) {
        if (!going[l]) continue;
        const NewtonStatus status = NewtonStep(D, target[l], &x[l]);
        if (status == NewtonStatus::kGoingOn) continue;
        if (status == NewtonStatus::kConverged) out[l] = x[l];
        going[l] = false;
        --left;
      }
    }
  }
}

bool RadialGrowsAt(const PlumbBob& D, double r2) {
  return 1.0 + r2 * (3.0 * D[0] + r2 * (5.0 * D[1] + r2 * 7.0 * D[4])) > 0.0;
}

}  // namespace autonomsim::world
