#include "stack/emergency_stop.h"

#include <cmath>
#include <stdexcept>

namespace autonomsim::stack {

void EmergencyStopParams::Validate() const {
  if (!(stop_distance_m > 0.0)) throw std::invalid_argument("stop_distance_m must be > 0");
  if (!(release_distance_m > stop_distance_m && release_distance_m <= 4.0)) {
    throw std::invalid_argument(
        "release_distance_m must be > stop_distance_m and <= 4 m (the ranger's maximum)");
  }
}

std::optional<bool> StepEmergencyStop(const EmergencyStopParams& params, double range_m,
                                      EmergencyStopState* state) {
  if (std::isnan(range_m)) return std::nullopt;
  const bool stop =
      state->stopped ? range_m <= params.release_distance_m : range_m < params.stop_distance_m;
  if (stop == state->stopped) return std::nullopt;
  state->stopped = stop;
  return stop;
}

}  // namespace autonomsim::stack
