#include "sim/car/stack_config.h"

#include <stdexcept>

namespace autonomsim::sim {

void PoseFixConfig::Validate() const {
  if (!(rate_hz > 0.0 && rate_hz <= 1000.0))
    throw std::invalid_argument("rate_hz must be in (0, 1000]");
  if (!(position_stddev_m >= 0.0)) throw std::invalid_argument("position_stddev_m must be >= 0");
  if (!(yaw_stddev_rad >= 0.0)) throw std::invalid_argument("yaw_stddev_rad must be >= 0");
}

void ControllerSelectorConfig::Validate() const {
  if (!(zone_margin_m >= 0.0 && zone_margin_m <= 1.0)) {
    throw std::invalid_argument("zone_margin_m must be in [0, 1] m");
  }
}

void StackConfig::Validate() const {
  if (planner_period <= kZeroTime) throw std::invalid_argument("planner_period_s must be > 0");
  if (controller_period <= kZeroTime) {
    throw std::invalid_argument("controller_period_s must be > 0");
  }
}

}  // namespace autonomsim::sim
