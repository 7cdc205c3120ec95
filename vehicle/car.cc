#include "vehicle/car.h"

#include <box2d/box2d.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>

#include "world/validation.h"

namespace autonomsim::vehicle {
namespace {

constexpr double kGravity_mps2 = 9.81;
// Gauss–Seidel passes over the two axles' lateral constraints. They couple only weakly (for a
// uniform box of the car's proportions the normalized coupling is ≈0.07), so a few passes solve
// them to rounding; more are cheap.
constexpr int kTireIterations = 8;

double Cross(const world::Vec2& a, const world::Vec2& b) { return a.x() * b.y() - a.y() * b.x(); }

// ω × r for a scalar ω about z.
world::Vec2 CrossScalar(double w, const world::Vec2& r) { return {-w * r.y(), w * r.x()}; }

world::Vec2 ToVec2(const b2Vec2& v) { return {static_cast<double>(v.x), static_cast<double>(v.y)}; }

}  // namespace

void CarParams::Validate() const {
  RequirePositive(length_m, "length_m");
  RequirePositive(width_m, "width_m");
  RequirePositive(height_m, "height_m");
  RequirePositive(mass_kg, "mass_kg");
  RequirePositive(wheelbase_m, "wheelbase_m");
  RequirePositive(track_m, "track_m");
  RequirePositive(wheel_radius_m, "wheel_radius_m");
  RequirePositive(max_curvature_per_m, "max_curvature_per_m");
  RequirePositive(steering_rate_rad_per_s, "steering_rate_rad_per_s");
  RequirePositive(top_speed_mps, "top_speed_mps");
  RequirePositive(motor_time_constant_s, "motor_time_constant_s");
  RequirePositive(tire_friction_coefficient, "tire_friction_coefficient");
  Require(wheelbase_m < length_m, [&] {
    return "wheelbase_m must be < length_m (" + Num(length_m) + "), got " + Num(wheelbase_m);
  });
  Require(track_m <= width_m,
          [&] { return "track_m must be <= width_m (" + Num(width_m) + "), got " + Num(track_m); });
  Require(std::isfinite(body_friction_coefficient) && body_friction_coefficient >= 0.0, [&] {
    return "body_friction_coefficient must be finite and >= 0, got " +
           Num(body_friction_coefficient);
  });
  Require(esc_neutral_band >= 0.0 && esc_neutral_band < 1.0,
          [&] { return "esc_neutral_band must be in [0, 1), got " + Num(esc_neutral_band); });
  Require(body_restitution >= 0.0 && body_restitution <= 1.0,
          [&] { return "body_restitution must be in [0, 1], got " + Num(body_restitution); });
}

Car::Car(b2World* world, const CarParams& params, int id, const world::Pose2& start)
    : params_(params), id_(id), world_(world) {
  params_.Validate();
  Require(world_ != nullptr, "Car needs a b2World");
  Require(std::isfinite(start.x_m) && std::isfinite(start.y_m) && std::isfinite(start.yaw_rad),
          [&] { return "car " + std::to_string(id) + ": start pose must be finite"; });

  b2BodyDef body_def;
  body_def.type = b2_dynamicBody;
  body_def.position.Set(static_cast<float>(start.x_m), static_cast<float>(start.y_m));
  body_def.angle = static_cast<float>(world::WrapAngle(start.yaw_rad));
  // A parked car must still answer a new command at once; sleeping would also make its state
  // depend on how long it was idle.
  body_def.allowSleep = false;
  body_def.userData.pointer = reinterpret_cast<std::uintptr_t>(this);
  body_ = world_->CreateBody(&body_def);

  // Shrink the core by Box2D's skin so that the rounded outline is the chassis box.
  const float half_length = static_cast<float>(params_.length_m / 2.0) - b2_polygonRadius;
  const float half_width = static_cast<float>(params_.width_m / 2.0) - b2_polygonRadius;
  b2PolygonShape shape;
  shape.SetAsBox(std::max(half_length, b2_linearSlop), std::max(half_width, b2_linearSlop));
  b2FixtureDef fixture_def;
  fixture_def.shape = &shape;
  fixture_def.density = static_cast<float>(params_.mass_kg / (params_.length_m * params_.width_m));
  fixture_def.friction = static_cast<float>(params_.body_friction_coefficient);
  fixture_def.restitution = static_cast<float>(params_.body_restitution);
  body_->CreateFixture(&fixture_def);

  // assumed: a uniform box, centre of mass at the chassis centre.
  b2MassData mass_data;
  mass_data.mass = static_cast<float>(params_.mass_kg);
  mass_data.center.SetZero();
  mass_data.I = static_cast<float>(
      params_.mass_kg * (params_.length_m * params_.length_m + params_.width_m * params_.width_m) /
      12.0);
  body_->SetMassData(&mass_data);
}

Car::~Car() { world_->DestroyBody(body_); }

void Car::SetCommand(const ActuatorCommand& command) {
  Require(!std::isnan(command.throttle) && !std::isnan(command.curvature_per_m),
          [&] { return "car " + std::to_string(id_) + ": actuator command must not be NaN"; });
  command_.throttle = std::clamp(command.throttle, -1.0, 1.0);
  command_.curvature_per_m = std::clamp(command.curvature_per_m, -params_.max_curvature_per_m,
                                        params_.max_curvature_per_m);
}

void Car::ApplyForces(double dt_s) {
  TireSolve solve = BeginForces(dt_s);
  SolveTires(std::span<TireSolve>(&solve, 1));
  EndForces(solve);
}

void Car::SolveTires(std::span<TireSolve> solves) {
  for (TireSolve& s : solves) {
    for (TireAxle& axle : s.axles) {  // (fixed over the passes)
      axle.rn = Cross(axle.r, axle.n);
      axle.effective_mass_kg = 1.0 / (1.0 / s.m + axle.rn * axle.rn / s.inertia);
    }
  }
  // the cars' passes side by side: each car's chain of dependent steps is its own
  for (int pass = 0; pass < kTireIterations; ++pass) {
    for (std::size_t a = 0; a < 2; ++a) {
      for (TireSolve& s : solves) {
        TireAxle& axle = s.axles[a];
        const double slip_mps = (s.v + CrossScalar(s.w, axle.r)).dot(axle.n);
        const double accumulated = std::clamp(
            axle.accumulated_Ns - slip_mps * axle.effective_mass_kg, -axle.limit_Ns, axle.limit_Ns);
        const double impulse_Ns = accumulated - axle.accumulated_Ns;
        axle.accumulated_Ns = accumulated;
        s.v += axle.n * (impulse_Ns / s.m);
        s.w += axle.rn * impulse_Ns / s.inertia;
      }
    }
  }
}

void Car::EndForces(const TireSolve& solve) {
  body_->SetLinearVelocity(
      b2Vec2(static_cast<float>(solve.v.x()), static_cast<float>(solve.v.y())));
  body_->SetAngularVelocity(static_cast<float>(solve.w));
}

Car::TireSolve Car::BeginForces(double dt_s) {
  Require(std::isfinite(dt_s) && dt_s > 0.0,
          [&] { return "ApplyForces: dt_s must be finite and > 0, got " + Num(dt_s); });

  // keep Box2D's (float) angle small so its resolution does not decay over many turns
  const float angle = body_->GetAngle();
  if (std::abs(angle) > b2_pi) {
    body_->SetTransform(body_->GetPosition(),
                        static_cast<float>(world::WrapAngle(static_cast<double>(angle))));
  }

  const double yaw_rad = static_cast<double>(body_->GetAngle());
  const world::Vec2 x_axis{std::cos(yaw_rad), std::sin(yaw_rad)};
  const world::Vec2 y_axis{-x_axis.y(), x_axis.x()};
  world::Vec2 v = ToVec2(body_->GetLinearVelocity());
  double w = static_cast<double>(body_->GetAngularVelocity());

  // acceleration over the step just completed
  if (have_previous_velocity_) {
    const world::Vec2 a_map = (v - previous_velocity_map_mps_) / dt_s;
    acceleration_body_mps2_ = {a_map.dot(x_axis), a_map.dot(y_axis)};
  }
  previous_velocity_map_mps_ = v;
  have_previous_velocity_ = true;

  // steering servo: slews toward the commanded wheel angle at a limited rate
  const double target_angle_rad = steer_target_.Of(
      command_.curvature_per_m, [&](double k) { return std::atan(params_.wheelbase_m * k); });
  const double max_slew_rad = params_.steering_rate_rad_per_s * dt_s;
  steering_angle_rad_ +=
      std::clamp(target_angle_rad - steering_angle_rad_, -max_slew_rad, max_slew_rad);

  const double m = params_.mass_kg;
  const double inertia = static_cast<double>(body_->GetInertia());
  const double axle_load_N = m * kGravity_mps2 / 2.0;
  const double axle_grip_Ns = params_.tire_friction_coefficient * axle_load_N * dt_s;

  // motor: first-order lag toward u·top_speed, discretized exactly over the step; the rear
  // (driven) tyres pass at most their grip
  const double forward_mps = v.dot(x_axis);
  const double drive_u =
      std::abs(command_.throttle) < params_.esc_neutral_band ? 0.0 : command_.throttle;
  const double target_mps = drive_u * params_.top_speed_mps;
  const double lag = motor_lag_.Of(
      dt_s, [&](double dt) { return 1.0 - std::exp(-dt / params_.motor_time_constant_s); });
  const double wanted_dv_mps = (target_mps - forward_mps) * lag;
  const double drive_Ns = std::clamp(m * wanted_dv_mps, -axle_grip_Ns, axle_grip_Ns);
  v += x_axis * (drive_Ns / m);  // at the rear axle, on the body's x axis: no torque

  // tyres: lateral impulses at both axles cancel the sideways slip up to the grip left over by
  // the drive (friction circle at the rear)
  const double half_wheelbase_m = params_.wheelbase_m / 2.0;
  const world::Vec2& steer = steer_cos_sin_.Of(
      steering_angle_rad_, [](double a) { return world::Vec2(std::cos(a), std::sin(a)); });
  const double cos_steer = steer.x();
  const double sin_steer = steer.y();
  TireSolve solve{.v = v, .w = w, .m = m, .inertia = inertia};
  solve.axles[0].r = -half_wheelbase_m * x_axis;
  solve.axles[0].n = y_axis;
  solve.axles[0].limit_Ns =
      std::sqrt(std::max(0.0, axle_grip_Ns * axle_grip_Ns - drive_Ns * drive_Ns));
  solve.axles[1].r = half_wheelbase_m * x_axis;
  solve.axles[1].n = y_axis * cos_steer - x_axis * sin_steer;
  solve.axles[1].limit_Ns = axle_grip_Ns;
  return solve;
}

world::Pose2 Car::pose() const {
  const b2Vec2& p = body_->GetPosition();
  return {static_cast<double>(p.x), static_cast<double>(p.y),
          world::WrapAngle(static_cast<double>(body_->GetAngle()))};
}

world::Vec2 Car::velocity_map_mps() const { return ToVec2(body_->GetLinearVelocity()); }

double Car::forward_speed_mps() const {
  const double yaw_rad = static_cast<double>(body_->GetAngle());
  return velocity_map_mps().dot(world::Vec2{std::cos(yaw_rad), std::sin(yaw_rad)});
}

double Car::yaw_rate_rad_per_s() const { return static_cast<double>(body_->GetAngularVelocity()); }

void PwmParams::Validate() const {
  Require(period > Duration::zero(), "period_s must be > 0");
  Require(throttle_counts_per_unit > 0, [&] {
    return "throttle_counts_per_unit must be > 0, got " + std::to_string(throttle_counts_per_unit);
  });
  Require(throttle_min_counts <= neutral_counts && neutral_counts <= throttle_max_counts, [&] {
    return "throttle_min_counts <= neutral_counts <= throttle_max_counts must hold, got " +
           std::to_string(throttle_min_counts) + ", " + std::to_string(neutral_counts) + ", " +
           std::to_string(throttle_max_counts);
  });
  Require(std::isfinite(steering_full_curvature_per_m) && steering_full_curvature_per_m > 0.0, [&] {
    return "steering_full_curvature_per_m must be finite and > 0, got " +
           Num(steering_full_curvature_per_m);
  });
  Require(steering_counts_at_full > 0, [&] {
    return "steering_counts_at_full must be > 0, got " + std::to_string(steering_counts_at_full);
  });
  Require(steering_min_counts <= neutral_counts && neutral_counts <= steering_max_counts, [&] {
    return "steering_min_counts <= neutral_counts <= steering_max_counts must hold, got " +
           std::to_string(steering_min_counts) + ", " + std::to_string(neutral_counts) + ", " +
           std::to_string(steering_max_counts);
  });
}

int ThrottlePulse(const PwmParams& params, double u) {
  Require(!std::isnan(u), "throttle must not be NaN");
  const double counts = params.neutral_counts + u * params.throttle_counts_per_unit;
  return static_cast<int>(
      std::llround(std::clamp(counts, static_cast<double>(params.throttle_min_counts),
                              static_cast<double>(params.throttle_max_counts))));
}

int SteeringPulse(const PwmParams& params, double kappa_per_m) {
  Require(!std::isnan(kappa_per_m), "curvature must not be NaN");
  const double counts = params.neutral_counts - kappa_per_m / params.steering_full_curvature_per_m *
                                                    params.steering_counts_at_full;
  return static_cast<int>(
      std::llround(std::clamp(counts, static_cast<double>(params.steering_min_counts),
                              static_cast<double>(params.steering_max_counts))));
}

}  // namespace autonomsim::vehicle
