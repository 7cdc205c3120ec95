// The rear wheel's Hall sensor and the speed the car computes from it (reference §2: 8 pulses per
// revolution, 0.357 m per revolution, speed published at 10 Hz). The real car measures the
// interval between the last two pulses with a counter on the FPGA's 100 MHz clock and publishes
// speed = (0.357 m / 8) / interval (code/reconros_ws/carcontrol/src/rt_hallsensor), so the reading
// is quantised the same way here: it is one pulse interval old, changes only when a pulse comes,
// and takes values 0.0446 m / (k · 10 ns). A Hall sensor does not sense direction: speed >= 0.
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>

#include "world/time.h"

namespace autonomsim::vehicle {

struct WheelEncoderParams {
  int pulses_per_revolution{8};         // reference §2
  double metres_per_revolution{0.357};  // reference §2 (the code's constant; 2π · 0.054 = 0.339)
  // reference §8: the fabric's system clock, 100 MHz; the real code divides the interval count
  // by 1e8.
  double counter_clock_hz{1e8};
  // assumed: the FPGA's behaviour when no pulse comes is not documented. A counter that never
  // saw the car stop would report the last speed for ever; we take the interval register to
  // clear after this long without a pulse, so a stopped car reads 0 (at 0.1 m/s pulses come
  // every 0.45 s). Zero: never clear.
  Duration standstill_timeout{std::chrono::milliseconds(500)};

  template <class V>
  void Describe(V& v) {
    v("pulses_per_revolution", pulses_per_revolution, "Hall pulses per wheel turn");
    v("metres_per_revolution", metres_per_revolution,
      "distance per wheel turn, as the car's code takes it (m)");
    v("counter_clock_hz", counter_clock_hz, "the clock that times the pulse intervals");
    v("standstill_timeout_s", standstill_timeout,
      "without a pulse for this long the speed reads 0 (0: never)");
  }
  void Validate() const;

  double metres_per_pulse() const { return metres_per_revolution / pulses_per_revolution; }
};

struct WheelEncoderState {
  double distance_since_pulse_m{0.0};
  std::optional<Time> last_pulse;
  std::int64_t interval_counts{0};  // the latched interval register; 0 before two pulses
  std::uint64_t pulses{0};
};

// The wheel rolled at |speed_mps| through (t - dt, t]: emits the pulses in that interval (timed by
// linear interpolation) and latches their intervals.
void AdvanceWheelEncoder(const WheelEncoderParams& params, Time t, Duration dt, double speed_mps,
                         WheelEncoderState* state);

// What the speed topic carries at time t (m/s, >= 0).
double WheelSpeedReading(const WheelEncoderParams& params, const WheelEncoderState& state, Time t);

}  // namespace autonomsim::vehicle
