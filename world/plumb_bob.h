// The plumb_bob lens model of ROS CameraInfo and OpenCV (k1, k2, p1, p2, k3) on normalized image
// coordinates: the distortion and its inverse. The camera model that renders images (vehicle/)
// and the lane detection that looks through the same lens (stack/) share it.
#pragma once

#include <Eigen/Core>
#include <array>
#include <optional>
#include <span>

namespace autonomsim::world {

using PlumbBob = std::array<double, 5>;  // k1, k2, p1 (t1), p2 (t2), k3, in ROS/OpenCV order

// Undistorted → distorted normalized coordinates.
Eigen::Vector2d Distort(const PlumbBob& D, const Eigen::Vector2d& undistorted);

// Distorted → undistorted, by Newton's method from the distorted point (the distortion is mild
// near the axis); nullopt where it does not converge or crosses a fold of the model.
std::optional<Eigen::Vector2d> Undistort(const PlumbBob& D, const Eigen::Vector2d& distorted);

// Undistort of every point of `distorted` into `undistorted` (of the same size; else
// std::invalid_argument), bit for bit, several points at a time: each point's iterations are a
// chain of dependent square roots and divisions, and independent points side by side let the
// processor overlap them (a camera's ray table, 307 k points, in ~half the time: issue 38).
void UndistortAll(const PlumbBob& D, std::span<const Eigen::Vector2d> distorted,
                  std::span<std::optional<Eigen::Vector2d>> undistorted);

// Whether the radial factor r · (1 + k1 r² + k2 r⁴ + k3 r⁶) still grows at r² = r2: beyond the
// first radius where it stops, the model no longer describes a lens.
bool RadialGrowsAt(const PlumbBob& D, double r2);

}  // namespace autonomsim::world
