// The model car as one Box2D body: a top-down rigid box driven by a first-order motor at the rear
// axle, steered by a rate-limited servo, held on its path by friction-limited lateral tyre
// impulses at both axles (the usual top-down car technique, e.g. iforce2d's). Its figures are the
// Traxxas Slash 2WD of reference §2; what the reference does not give is marked "assumed".
//
// Frames: pose() is the chassis centre in the map frame; the body frame is x forward, y left. The
// centre of mass is the chassis centre, midway between the axles. The commanded curvature is the
// curvature of the rear axle's path (the kinematic bicycle's reference point): at low speed the
// rear axle circles with radius 1/κ and the chassis centre with sqrt(1/κ² + (wheelbase/2)²).
//
// Collision shape: the chassis box length_m × width_m centred on the pose (the URDF body, reference
// §2; not the slightly different planner footprint). Box2D gives polygons a 1 cm skin, so the core
// box is shrunk by that skin: the outline touches where the chassis box does, with corners rounded
// by 1 cm. Contacts resolve with up to Box2D's linear slop (5 mm) of overlap.
#pragma once

#include <array>
#include <bit>
#include <chrono>
#include <cstdint>
#include <limits>
#include <span>

#include "world/geometry.h"
#include "world/time.h"

class b2World;
class b2Body;

namespace autonomsim::vehicle {

struct CarParams {
  double length_m{0.525};        // reference §2
  double width_m{0.296};         // reference §2
  double height_m{0.2};          // assumed: top of the Slash body shell; the sensor mast above it
                                 // is narrow (depth camera at 0.264 m, reference §2)
  double mass_kg{2.16};          // reference §2
  double wheelbase_m{0.325};     // reference §2
  double track_m{0.251};         // reference §2
  double wheel_radius_m{0.054};  // reference §2
  // reference §2: the real actuator saturates at |κ| = 1.2 1/m (≈21° of wheel angle).
  double max_curvature_per_m{1.2};
  // assumed: a 1:10 standard servo turns 60° in ≈0.17 s unloaded (6 rad/s); the steering linkage
  // is taken as 1:1, so full lock to full lock (2 × 21°) takes ≈0.12 s.
  double steering_rate_rad_per_s{6.0};
  // assumed: the reference gives no top speed (§2). The lab drives at 0.25 m/s (car) and 0.5 m/s
  // (their Gazebo world); 2 m/s puts those at u ≈ 0.12 and 0.25, leaving the speed controller
  // headroom while a full-throttle car stays on a 5 m track. The stock Slash is much faster.
  double top_speed_mps{2.0};
  // assumed: first-order motor and ESC, 95% of a speed step in 1.8 s. Chosen so that a
  // full-throttle launch (top_speed_mps / τ = 3.3 m/s²) stays within the rear tyres' grip
  // (μ·g/2 = 3.9 m/s²): a launch under steering does not spin the car. A shorter τ makes the
  // rear wheels spin and lose side grip (friction circle), which is modelled.
  double motor_time_constant_s{0.6};
  // assumed: a hobby ESC ignores throttle within its neutral band (typically a few % of full
  // throttle either side of the 1.5 ms neutral pulse): |u| below this drives nothing, so the motor
  // brakes the car (the lag above toward 0). 0: no band.
  double esc_neutral_band{0.05};
  // assumed: RC rubber tyres on a smooth lab floor; the grip limit per axle is μ·(m·g/2).
  double tire_friction_coefficient{0.8};
  // assumed: plastic shell on plastic or wood, for Box2D's contact friction (car–car,
  // car–obstacle).
  double body_friction_coefficient{0.3};
  // assumed: a soft plastic shell barely bounces; Box2D ignores restitution below 1 m/s anyway.
  double body_restitution{0.0};

  template <class V>
  void Describe(V& v) {
    v("length_m", length_m, "the body's length");
    v("width_m", width_m, "the body's width");
    v("height_m", height_m, "the body's height, for the cameras");
    v("mass_kg", mass_kg, "the car's mass");
    v("wheelbase_m", wheelbase_m, "front to rear axle");
    v("track_m", track_m, "left to right wheel");
    v("wheel_radius_m", wheel_radius_m, "the wheels' radius");
    v("max_curvature_per_m", max_curvature_per_m, "the tightest steering curvature");
    v("steering_rate_rad_per_s", steering_rate_rad_per_s, "how fast the steering turns");
    v("top_speed_mps", top_speed_mps, "the speed at full throttle");
    v("motor_time_constant_s", motor_time_constant_s, "the motor's lag to a throttle step");
    v("esc_neutral_band", esc_neutral_band, "throttle below this (0..1) drives nothing");
    v("tire_friction_coefficient", tire_friction_coefficient, "the tyres' grip on the floor");
    v("body_friction_coefficient", body_friction_coefficient, "friction of the body in a contact");
    v("body_restitution", body_restitution, "bounce of the body in a contact");
  }
  void Validate() const;  // throws std::invalid_argument naming the key and the bad value
};

// What the driving stack sends to the actuators, held until the next command (zero-order hold).
struct ActuatorCommand {
  double throttle{0.0};         // u, clamped to [-1, 1] like the real PWM mapping
  double curvature_per_m{0.0};  // κ > 0 turns left; clamped to ±max_curvature_per_m
};

class Car {
 public:
  // Creates the car's body in `world` (not owned; must outlive the car). Validates params.
  Car(b2World* world, const CarParams& params, int id, const world::Pose2& start);
  ~Car();  // destroys its body
  Car(const Car&) = delete;
  Car& operator=(const Car&) = delete;

  // Clamps like the real PWM mapping (reference §2); a NaN throws std::invalid_argument.
  void SetCommand(const ActuatorCommand& command);
  const ActuatorCommand& command() const { return command_; }

  // Steering servo, motor and tyre impulses for the next step of dt_s; called before each
  // b2World::Step. Sets the body's velocities directly.
  void ApplyForces(double dt_s);

  // ApplyForces in three steps, so that a world solves its cars' tyres side by side: each car's
  // arithmetic is the same, in the same order (the same bits as ApplyForces), and the cars'
  // chains of dependent steps overlap. BeginForces: the servo, the motor and the tyres' problem;
  // SolveTires: sequential impulses at both axles, clamped to their grip (friction circle at the
  // rear), on each problem; EndForces: the solved velocities into the body.
  struct TireAxle {           // a point of the body that gets impulses along a fixed direction
    world::Vec2 r{0.0, 0.0};  // from the centre of mass, map frame, m
    world::Vec2 n{0.0, 0.0};  // unit lateral direction of the wheel, map frame
    double limit_Ns{0.0};     // the grip: the accumulated impulse stays within ±this
    double accumulated_Ns{0.0};
    double rn{0.0};                 // r × n, m
    double effective_mass_kg{0.0};  // of the body along n at r
  };
  struct TireSolve {
    std::array<TireAxle, 2> axles;  // rear, front
    world::Vec2 v{0.0, 0.0};        // the body's velocity, map frame, m/s
    double w{0.0};                  // its yaw rate, rad/s
    double m{0.0};                  // kg
    double inertia{0.0};            // about the centre of mass, kg m²
  };
  TireSolve BeginForces(double dt_s);
  static void SolveTires(std::span<TireSolve> solves);
  void EndForces(const TireSolve& solve);

  world::Pose2 pose() const;             // chassis centre, map frame, yaw wrapped to (-pi, pi]
  world::Vec2 velocity_map_mps() const;  // of the chassis centre
  double forward_speed_mps() const;      // signed, along body x (the same along the whole axis)
  double yaw_rate_rad_per_s() const;
  double steering_angle_rad() const { return steering_angle_rad_; }  // front wheel, after servo
  // Acceleration of the chassis centre over the last completed step, in the body frame at the
  // start of the next (x forward, y left); zero before two ApplyForces calls. No gravity.
  world::Vec2 acceleration_body_mps2() const { return acceleration_body_mps2_; }

  int id() const { return id_; }
  const CarParams& params() const { return params_; }

 private:
  CarParams params_;
  int id_;
  b2World* world_;
  b2Body* body_{nullptr};
  ActuatorCommand command_;
  double steering_angle_rad_{0.0};
  bool have_previous_velocity_{false};
  world::Vec2 previous_velocity_map_mps_{0.0, 0.0};
  world::Vec2 acceleration_body_mps2_{0.0, 0.0};

  // f(x) as last computed, for the functions ApplyForces takes of inputs that change less often
  // than every step (dt, the command, the servo at rest): the same x gives the same bits, so the
  // value is computed again only when x changes.
  template <class Y>
  struct LastValue {
    // the last input's bits, once there is one
    std::uint64_t x_bits{0};
    bool known{false};
    Y y{};
    template <class F>
    const Y& Of(double input, F f) {
      // by bits, so that -0 and +0 (whose functions differ) are different inputs
      const auto bits = std::bit_cast<std::uint64_t>(input);
      if (!known || bits != x_bits) {
        x_bits = bits;
        known = true;
        y = f(input);
      }
      return y;
    }
  };
  LastValue<double> motor_lag_;           // 1 - exp(-dt/τ), by dt_s
  LastValue<double> steer_target_;        // atan(wheelbase · κ), by the commanded κ
  LastValue<world::Vec2> steer_cos_sin_;  // (cos, sin) of the steering angle
};

// The real PWM mapping (reference §2), in timer counts within a 10 ms period (150000 counts is the
// usual 1.5 ms servo neutral, so presumably a 100 MHz timer; nothing here depends on that).
struct PwmParams {
  Duration period{std::chrono::milliseconds(10)};  // reference §2
  int neutral_counts{150000};                      // reference §2: throttle and steering neutral
  int throttle_counts_per_unit{30000};             // reference §2: pulse = neutral + u·30000
  int throttle_min_counts{120000};                 // reference §2
  int throttle_max_counts{180000};                 // reference §2
  // reference §2: steering pulse = neutral − (κ / 1.2)·50000; full left is the minimum.
  double steering_full_curvature_per_m{1.2};
  int steering_counts_at_full{50000};
  int steering_min_counts{100000};  // reference §2: full left
  int steering_max_counts{200000};  // reference §2: full right

  template <class V>
  void Describe(V& v) {
    v("period_s", period);
    v("neutral_counts", neutral_counts);
    v("throttle_counts_per_unit", throttle_counts_per_unit);
    v("throttle_min_counts", throttle_min_counts);
    v("throttle_max_counts", throttle_max_counts);
    v("steering_full_curvature_per_m", steering_full_curvature_per_m);
    v("steering_counts_at_full", steering_counts_at_full);
    v("steering_min_counts", steering_min_counts);
    v("steering_max_counts", steering_max_counts);
  }
  void Validate() const;
};

// Pulse widths in timer counts, rounded to the nearest count and clamped; NaN throws.
int ThrottlePulse(const PwmParams& params, double u);
int SteeringPulse(const PwmParams& params, double kappa_per_m);

}  // namespace autonomsim::vehicle
