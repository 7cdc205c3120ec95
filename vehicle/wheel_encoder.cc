#include "vehicle/wheel_encoder.h"

#include <cmath>
#include <stdexcept>
#include <string>

#include "world/validation.h"

namespace autonomsim::vehicle {
namespace {}  // namespace

void WheelEncoderParams::Validate() const {
  Require(pulses_per_revolution > 0, [&] {
    return "pulses_per_revolution must be > 0, got " + std::to_string(pulses_per_revolution);
  });
  Require(std::isfinite(metres_per_revolution) && metres_per_revolution > 0.0,
          [&] { return "metres_per_revolution must be > 0, got " + Num(metres_per_revolution); });
  Require(std::isfinite(counter_clock_hz) && counter_clock_hz >= 1.0,
          [&] { return "counter_clock_hz must be >= 1, got " + Num(counter_clock_hz); });
  Require(standstill_timeout >= Duration::zero(), "standstill_timeout_s must be >= 0");
}

void AdvanceWheelEncoder(const WheelEncoderParams& params, Time t, Duration dt, double speed_mps,
                         WheelEncoderState* state) {
  const double speed = std::abs(speed_mps);
  if (!(speed > 0.0) || dt <= Duration::zero()) return;
  const double per_pulse = params.metres_per_pulse();
  const double travelled = speed * ToSeconds(dt);
  const Time start = t - dt;
  double covered = 0.0;  // within this interval, m
  while (state->distance_since_pulse_m + (travelled - covered) >= per_pulse) {
    covered += per_pulse - state->distance_since_pulse_m;
    state->distance_since_pulse_m = 0.0;
    const Time pulse =
        start + Duration{static_cast<std::int64_t>(std::llround(covered / speed * 1e9))};
    if (state->last_pulse) {
      const double interval_s = ToSeconds(pulse - *state->last_pulse);
      state->interval_counts =
          static_cast<std::int64_t>(std::floor(interval_s * params.counter_clock_hz));
    }
    state->last_pulse = pulse;
    ++state->pulses;
  }
  state->distance_since_pulse_m += travelled - covered;
}

double WheelSpeedReading(const WheelEncoderParams& params, const WheelEncoderState& state, Time t) {
  if (state.interval_counts <= 0 || !state.last_pulse) return 0.0;
  if (params.standstill_timeout > Duration::zero() &&
      t - *state.last_pulse > params.standstill_timeout) {
    return 0.0;
  }
  const double interval_s = static_cast<double>(state.interval_counts) / params.counter_clock_hz;
  return params.metres_per_pulse() / interval_s;
}

}  // namespace autonomsim::vehicle
