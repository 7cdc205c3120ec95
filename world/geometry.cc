#include "world/geometry.h"

#include <numbers>
#include <stdexcept>
#include <string>

namespace autonomsim::world {

void Box::Validate() const {
  if (!(x_min_m < x_max_m) || !(y_min_m < y_max_m)) {
    throw std::invalid_argument("box must have x_min_m < x_max_m and y_min_m < y_max_m, got x [" +
                                std::to_string(x_min_m) + ", " + std::to_string(x_max_m) +
                                "], y [" + std::to_string(y_min_m) + ", " +
                                std::to_string(y_max_m) + "]");
  }
}

double WrapAngle(double a_rad) {
  constexpr double kPi = std::numbers::pi;
  double r = std::remainder(a_rad, 2.0 * kPi);
  if (r <= -kPi) r += 2.0 * kPi;
  return r;
}

}  // namespace autonomsim::world
