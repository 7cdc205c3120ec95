// The front ultrasonic range sensor (reference §2: 10 Hz, field of view 0.366 rad, 0.05–4 m;
// configured on the real car but not used by its stack). Modelled in the plane: the range is the
// distance from the sensor to the nearest point of any prism (obstacle box or other car) within
// its cone. The track's outer boundary is paint, not a wall, and the lab's walls are not
// described, so nothing else echoes; nor does the floor (the real sensor may see it at short
// range, which the reference does not say).
//
// The reading follows REP-117 (sensor_msgs/Range): +inf when nothing is within max range, -inf
// when the echo is nearer than min range. (The real code publishes the raw echo time × 170 m/s.)
#pragma once

#include <numbers>
#include <span>

#include "vehicle/ray_caster.h"
#include "world/geometry.h"
#include "world/time.h"

namespace autonomsim::vehicle {

struct UltrasonicParams {
  // assumed: at the middle of the front bumper (half the car's length, reference §2), facing
  // forward; the reference gives no mount.
  double mount_x_m{0.2625};
  double mount_y_m{0.0};
  double mount_yaw_deg{0.0};
  double field_of_view_deg{0.366 * 180.0 / std::numbers::pi};  // reference §2: 0.366 rad, full
  double min_range_m{0.05};                                    // reference §2
  double max_range_m{4.0};                                     // reference §2
  // assumed: a hobby ultrasonic ranger resolves ~3 mm; its echo timing jitters by about as much.
  double noise_stddev_m{0.003};

  template <class V>
  void Describe(V& v) {
    v("mount_x_m", mount_x_m, "forward of base_link");
    v("mount_y_m", mount_y_m, "left of base_link");
    v("mount_yaw_deg", mount_yaw_deg, "its heading, positive left");
    v("field_of_view_deg", field_of_view_deg, "the cone's full angle");
    v("min_range_m", min_range_m, "nearer echoes read -inf");
    v("max_range_m", max_range_m, "with nothing nearer than this it reads +inf");
    v("noise_stddev_m", noise_stddev_m, "the range's noise");
  }
  void Validate() const;  // 0 < field of view < 180°, 0 <= min < max, finite mount, noise >= 0
};

// The distance (m) from the sensor to the nearest part of a prism within its cone, or +inf if none
// is; exact for the prisms' footprints (a convex polygon clipped to the cone).
double NearestInCone(const UltrasonicParams& params, const world::Pose2& X_map_car,
                     std::span<const Prism> prisms);

// The published range: NearestInCone + noise_stddev_m · noise_draw (a standard normal draw),
// then REP-117's ±inf outside [min_range_m, max_range_m].
double UltrasonicRange(const UltrasonicParams& params, const world::Pose2& X_map_car,
                       std::span<const Prism> prisms, double noise_draw);

}  // namespace autonomsim::vehicle
