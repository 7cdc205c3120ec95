#include "vehicle/car.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <limits>
#include <memory>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

#include "vehicle/physics_world.h"

namespace autonomsim::vehicle {
namespace {

using ::testing::HasSubstr;

constexpr double kG_mps2 = 9.81;

// Steps the world for `seconds` of simulated time (a whole number of steps).
void RunFor(PhysicsWorld& world, double seconds) {
  const auto steps = static_cast<int>(std::llround(seconds / ToSeconds(world.step())));
  for (int i = 0; i < steps; ++i) world.Step();
}

// Sideways speed of the rear axle's centre, body y (zero while the rear tyres grip).
double RearSlipMps(const Car& car) {
  const world::Pose2 pose = car.pose();
  const world::Vec2 y_axis{-std::sin(pose.yaw_rad), std::cos(pose.yaw_rad)};
  return car.velocity_map_mps().dot(y_axis) -
         car.yaw_rate_rad_per_s() * car.params().wheelbase_m / 2.0;
}

world::Vec2 RearAxle(const Car& car) {
  const world::Pose2 pose = car.pose();
  return pose.position() - pose.heading() * (car.params().wheelbase_m / 2.0);
}

// Algebraic (Kåsa) least-squares circle through the points: x² + y² + D x + E y + F = 0.
double FitCircleRadius(const std::vector<world::Vec2>& points) {
  Eigen::MatrixXd a(points.size(), 3);
  Eigen::VectorXd b(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    const auto row = static_cast<Eigen::Index>(i);
    a(row, 0) = points[i].x();
    a(row, 1) = points[i].y();
    a(row, 2) = 1.0;
    b(row) = -points[i].squaredNorm();
  }
  const Eigen::Vector3d def = a.colPivHouseholderQr().solve(b);
  return std::sqrt(def(0) * def(0) / 4.0 + def(1) * def(1) / 4.0 - def(2));
}

struct Circle {
  double fit_radius_m;  // rear axle path, least-squares circle
  double v_over_w_m;    // forward speed / yaw rate at the end
  double speed_mps;
};

// Drives a car at `throttle` with curvature `kappa` for `settle_s`, then records the rear axle
// over `arc_rad` of heading change.
Circle DriveCircle(const CarParams& params, double throttle, double kappa, double settle_s,
                   double arc_rad) {
  PhysicsWorld world(PhysicsParams{});
  Car& car = world.AddCar(1, params, world::Pose2{});
  car.SetCommand({throttle, kappa});
  RunFor(world, settle_s);
  std::vector<world::Vec2> points;
  double turned_rad = 0.0;
  double last_yaw = car.pose().yaw_rad;
  constexpr std::size_t kMaxSteps = 1'000'000;
  while (turned_rad < arc_rad && points.size() < kMaxSteps) {
    world.Step();
    const double yaw = car.pose().yaw_rad;
    turned_rad += std::abs(world::WrapAngle(yaw - last_yaw));
    last_yaw = yaw;
    points.push_back(RearAxle(car));
  }
  EXPECT_GE(turned_rad, arc_rad) << "the car does not turn";
  return {FitCircleRadius(points), car.forward_speed_mps() / car.yaw_rate_rad_per_s(),
          car.forward_speed_mps()};
}

std::string InvalidArgumentMessage(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "(no std::invalid_argument thrown)";
}

TEST(CarParamsTest, DefaultsAreValidAndFromTheReference) {
  const CarParams params;
  EXPECT_NO_THROW(params.Validate());
  EXPECT_DOUBLE_EQ(params.length_m, 0.525);
  EXPECT_DOUBLE_EQ(params.width_m, 0.296);
  EXPECT_DOUBLE_EQ(params.mass_kg, 2.16);
  EXPECT_DOUBLE_EQ(params.wheelbase_m, 0.325);
  EXPECT_DOUBLE_EQ(params.max_curvature_per_m, 1.2);
}

TEST(CarParamsTest, RejectsNonsenseNamingTheKey) {
  struct Case {
    std::string key;
    std::function<void(CarParams&)> spoil;
  };
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::vector<Case> cases = {
      {"mass_kg", [](CarParams& p) { p.mass_kg = -1.0; }},
      {"mass_kg", [nan](CarParams& p) { p.mass_kg = nan; }},
      {"wheelbase_m", [](CarParams& p) { p.wheelbase_m = 0.0; }},
      {"wheelbase_m", [](CarParams& p) { p.wheelbase_m = 0.6; }},  // longer than the car
      {"length_m", [](CarParams& p) { p.length_m = 0.0; }},
      {"width_m", [](CarParams& p) { p.width_m = -0.3; }},
      {"height_m", [](CarParams& p) { p.height_m = 0.0; }},
      {"track_m", [](CarParams& p) { p.track_m = 0.4; }},  // wider than the car
      {"wheel_radius_m", [](CarParams& p) { p.wheel_radius_m = 0.0; }},
      {"max_curvature_per_m", [](CarParams& p) { p.max_curvature_per_m = 0.0; }},
      {"steering_rate_rad_per_s", [](CarParams& p) { p.steering_rate_rad_per_s = -1.0; }},
      {"top_speed_mps", [](CarParams& p) { p.top_speed_mps = 0.0; }},
      {"motor_time_constant_s", [](CarParams& p) { p.motor_time_constant_s = 0.0; }},
      {"tire_friction_coefficient", [](CarParams& p) { p.tire_friction_coefficient = 0.0; }},
      {"body_friction_coefficient", [](CarParams& p) { p.body_friction_coefficient = -0.1; }},
      {"body_restitution", [](CarParams& p) { p.body_restitution = 1.5; }},
  };
  for (const Case& c : cases) {
    CarParams params;
    c.spoil(params);
    EXPECT_THAT(InvalidArgumentMessage([&] { params.Validate(); }), HasSubstr(c.key)) << c.key;
  }
}

TEST(CarParamsTest, DescribeListsEveryKeyOnce) {
  CarParams params;
  std::vector<std::string> keys;
  auto visit = [&keys](const char* key, auto&, auto&&...) { keys.emplace_back(key); };
  params.Describe(visit);
  EXPECT_THAT(keys, ::testing::Contains("top_speed_mps"));
  EXPECT_THAT(keys, ::testing::Contains("motor_time_constant_s"));
  EXPECT_THAT(keys, ::testing::Contains("esc_neutral_band"));
  EXPECT_EQ(keys.size(), 15u);
}

// PhysicsWorld::Step solves its cars' tyres side by side (Car::SolveTires over all of them): three
// cars far apart in one world, turning, braking and driving straight, move bit for bit as each
// does alone in a world of its own (where its tyres are solved by themselves), step by step.
TEST(CarTest, TyresSolvedSideBySideAreBitIdenticalToOneAtATime) {
  const ActuatorCommand commands[] = {{1.0, 0.8}, {-1.0, -1.2}, {0.4, 0.0}};
  const auto start = [](int id) { return world::Pose2{30.0 * id, 0.0, 0.3 * id}; };
  PhysicsWorld together(PhysicsParams{});
  std::vector<std::unique_ptr<PhysicsWorld>> alone;
  for (int id = 0; id < 3; ++id) {
    together.AddCar(id, CarParams{}, start(id)).SetCommand(commands[id]);
    alone.push_back(std::make_unique<PhysicsWorld>(PhysicsParams{}));
    alone.back()->AddCar(id, CarParams{}, start(id)).SetCommand(commands[id]);
  }
  const auto bits = [](double x) { return std::bit_cast<std::uint64_t>(x); };
  for (int step = 0; step < 1000; ++step) {  // 2 s: the servos slew, the tyres slide
    together.Step();
    for (int id = 0; id < 3; ++id) {
      alone[static_cast<std::size_t>(id)]->Step();
      const Car& a = together.car(id);
      const Car& b = alone[static_cast<std::size_t>(id)]->car(id);
      ASSERT_EQ(bits(a.pose().x_m), bits(b.pose().x_m)) << id << " at step " << step;
      ASSERT_EQ(bits(a.pose().y_m), bits(b.pose().y_m)) << id << " at step " << step;
      ASSERT_EQ(bits(a.pose().yaw_rad), bits(b.pose().yaw_rad)) << id << " at step " << step;
      ASSERT_EQ(bits(a.yaw_rate_rad_per_s()), bits(b.yaw_rate_rad_per_s())) << id;
    }
  }
  EXPECT_GT(std::abs(together.car(0).yaw_rate_rad_per_s()), 0.1);  // the first car is turning
}

// A throttle inside the ESC's neutral band drives nothing; just outside it, the car drives off at
// u · top speed (2 s = 3.3 motor time constants: ≈ 96 % of 0.12 m/s).
TEST(CarTest, ThrottleInsideTheEscNeutralBandDrivesNothing) {
  PhysicsWorld world(PhysicsParams{});
  Car& car = world.AddCar(1, CarParams{}, {});
  car.SetCommand({0.049, 0.0});
  for (int i = 0; i < 1000; ++i) world.Step();  // 2 s
  EXPECT_EQ(car.forward_speed_mps(), 0.0);
  car.SetCommand({0.06, 0.0});
  for (int i = 0; i < 1000; ++i) world.Step();  // 2 s
  EXPECT_NEAR(car.forward_speed_mps(), 0.96 * 0.12, 0.01);
}

TEST(CarTest, ConstructorValidatesParams) {
  PhysicsWorld world(PhysicsParams{});
  CarParams params;
  params.mass_kg = -2.0;
  EXPECT_THAT(InvalidArgumentMessage([&] { world.AddCar(1, params, {}); }), HasSubstr("mass_kg"));
}

TEST(CarTest, CommandIsClampedLikeThePwmAndNanThrows) {
  PhysicsWorld world(PhysicsParams{});
  Car& car = world.AddCar(1, CarParams{}, {});
  car.SetCommand({3.0, -7.0});
  EXPECT_EQ(car.command().throttle, 1.0);
  EXPECT_EQ(car.command().curvature_per_m, -1.2);
  car.SetCommand({-std::numeric_limits<double>::infinity(), 0.5});
  EXPECT_EQ(car.command().throttle, -1.0);
  EXPECT_EQ(car.command().curvature_per_m, 0.5);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(car.SetCommand({nan, 0.0}), std::invalid_argument);
  EXPECT_THROW(car.SetCommand({0.0, nan}), std::invalid_argument);
  EXPECT_EQ(car.command().throttle, -1.0);  // a rejected command leaves the last one in force
}

TEST(CarTest, StartsAtItsPoseAtRest) {
  PhysicsWorld world(PhysicsParams{});
  const Car& car = world.AddCar(7, CarParams{}, {0.96, -2.18, 0.5});
  EXPECT_EQ(car.id(), 7);
  EXPECT_NEAR(car.pose().x_m, 0.96, 1e-6);
  EXPECT_NEAR(car.pose().y_m, -2.18, 1e-6);
  EXPECT_NEAR(car.pose().yaw_rad, 0.5, 1e-6);
  EXPECT_EQ(car.forward_speed_mps(), 0.0);
  EXPECT_EQ(car.steering_angle_rad(), 0.0);
}

TEST(CarTest, SteeringServoSlewsAtItsRateLimit) {
  PhysicsWorld world(PhysicsParams{});
  Car& car = world.AddCar(1, CarParams{}, {});
  const CarParams& p = car.params();
  const double dt = ToSeconds(world.step());
  const double full_lock = std::atan(p.wheelbase_m * p.max_curvature_per_m);
  EXPECT_NEAR(full_lock, 21.3 * std::numbers::pi / 180.0,
              0.1 * std::numbers::pi / 180.0);  // reference §2: ≈21°

  car.SetCommand({0.0, 1.2});
  for (int k = 1; k <= 10; ++k) {
    world.Step();
    EXPECT_NEAR(car.steering_angle_rad(), k * p.steering_rate_rad_per_s * dt, 1e-12) << k;
  }
  RunFor(world, 0.1);
  EXPECT_NEAR(car.steering_angle_rad(), full_lock, 1e-12);

  // full left to full right takes 2·full_lock / rate
  car.SetCommand({0.0, -1.2});
  const int steps_needed =
      static_cast<int>(std::ceil(2.0 * full_lock / (p.steering_rate_rad_per_s * dt)));
  for (int k = 1; k < steps_needed; ++k) world.Step();
  EXPECT_GT(car.steering_angle_rad(), -full_lock + 1e-9);
  world.Step();
  EXPECT_NEAR(car.steering_angle_rad(), -full_lock, 1e-12);
}

TEST(CarTest, SpeedFollowsTheFirstOrderMotor) {
  PhysicsWorld world(PhysicsParams{});
  Car& car = world.AddCar(1, CarParams{}, {});
  const CarParams& p = car.params();
  const double u = 0.3;
  const double target = u * p.top_speed_mps;
  car.SetCommand({u, 0.0});
  RunFor(world, p.motor_time_constant_s);
  EXPECT_NEAR(car.forward_speed_mps(), (1.0 - std::exp(-1.0)) * target, 0.01 * target);
  RunFor(world, 2.0 * p.motor_time_constant_s);
  EXPECT_NEAR(car.forward_speed_mps(), (1.0 - std::exp(-3.0)) * target, 0.01 * target);
  RunFor(world, 10.0 * p.motor_time_constant_s);
  EXPECT_NEAR(car.forward_speed_mps(), target, 1e-4);
  // straight ahead
  EXPECT_NEAR(car.pose().y_m, 0.0, 1e-6);
  EXPECT_NEAR(car.pose().yaw_rad, 0.0, 1e-6);
  EXPECT_GT(car.pose().x_m, 1.5);

  // reverse
  car.SetCommand({-0.5, 0.0});
  RunFor(world, 15.0 * p.motor_time_constant_s);
  EXPECT_NEAR(car.forward_speed_mps(), -0.5 * p.top_speed_mps, 1e-4);
}

TEST(CarTest, ZeroThrottleBrakesToAStop) {
  PhysicsWorld world(PhysicsParams{});
  Car& car = world.AddCar(1, CarParams{}, {});
  const double tau = car.params().motor_time_constant_s;
  car.SetCommand({0.5, 0.0});
  RunFor(world, 10.0 * tau);
  car.SetCommand({0.0, 0.0});
  const double v0 = car.forward_speed_mps();
  RunFor(world, tau);
  EXPECT_NEAR(car.forward_speed_mps(), v0 * std::exp(-1.0), 0.01 * v0);
  RunFor(world, 15.0 * tau);
  EXPECT_LT(std::abs(car.forward_speed_mps()), 1e-5);
  const double x = car.pose().x_m;
  RunFor(world, 2.0);
  EXPECT_NEAR(car.pose().x_m, x, 1e-4);  // stopped, not creeping
}

TEST(CarTest, FullThrottleLaunchWithinGripAndUnderSteeringDoesNotSpin) {
  PhysicsWorld world(PhysicsParams{});
  Car& car = world.AddCar(1, CarParams{}, {});
  const CarParams& p = car.params();
  ASSERT_LT(p.top_speed_mps / p.motor_time_constant_s, p.tire_friction_coefficient * kG_mps2 / 2.0);
  car.SetCommand({1.0, 1.2});
  const double full_lock = std::atan(p.wheelbase_m * p.max_curvature_per_m);
  int steps_at_full_lock = 0;
  for (int k = 0; k < 500; ++k) {  // 1 s
    world.Step();
    // the rear axle keeps to its path: yaw rate = κ·v once the servo is at full lock
    if (std::abs(car.steering_angle_rad() - full_lock) < 1e-12) {
      ++steps_at_full_lock;
      ASSERT_NEAR(car.yaw_rate_rad_per_s(), 1.2 * car.forward_speed_mps(), 0.01) << k;
    }
    // After a step the body has turned by ω·dt under a velocity the tyres set before it: a
    // residual sideways speed of v·ω·dt that the next step removes.
    const double step_lag_mps =
        std::abs(car.forward_speed_mps() * car.yaw_rate_rad_per_s()) * ToSeconds(world.step());
    ASSERT_LE(std::abs(RearSlipMps(car)), 1.5 * step_lag_mps + 1e-6) << k;
  }
  EXPECT_GT(steps_at_full_lock, 400);
}

TEST(CarTest, WheelspinLaunchIsLimitedByRearGripAndLosesSideGrip) {
  CarParams params;
  params.motor_time_constant_s = 0.2;  // asks 10 m/s², the rear tyres give 3.9
  PhysicsWorld world(PhysicsParams{});
  Car& car = world.AddCar(1, params, {});
  const double dt = ToSeconds(world.step());
  const double rear_grip_accel = params.tire_friction_coefficient * kG_mps2 / 2.0;
  car.SetCommand({1.0, 0.0});
  world.Step();
  EXPECT_NEAR(car.forward_speed_mps() / dt, rear_grip_accel, 1e-3 * rear_grip_accel);
  RunFor(world, 0.1);
  EXPECT_NEAR(car.forward_speed_mps(), 51 * dt * rear_grip_accel, 1e-3);
  EXPECT_NEAR(car.pose().yaw_rad, 0.0, 1e-6);

  // Steering while the rear wheels spin: the rear has no side grip left, slides out, and the car
  // yaws faster than its path curvature gives (power oversteer).
  car.SetCommand({1.0, 1.2});
  RunFor(world, 0.2);
  EXPECT_LT(RearSlipMps(car), -0.05);  // the tail swings out of the left turn
  EXPECT_GT(car.yaw_rate_rad_per_s(), 1.15 * 1.2 * car.forward_speed_mps());

  car.SetCommand({1.0, 0.0});
  RunFor(world, 5.0);
  EXPECT_NEAR(car.forward_speed_mps(), params.top_speed_mps, 1e-3);
}

TEST(CarTest, TurningRadiusIsOneOverCommandedCurvature) {
  const CarParams params;
  const double throttle = 0.15;  // ≈0.3 m/s with the default top speed
  for (double kappa : {0.3, 0.6, 1.0, 1.2}) {
    const Circle c = DriveCircle(params, throttle, kappa, 3.0, 1.5);
    const double r = 1.0 / kappa;
    std::printf(
        "kappa %.2f 1/m: speed %.4f m/s, fitted radius %.5f m (error %+.3f%%), v/w %.5f m "
        "(error %+.3f%%)\n",
        kappa, c.speed_mps, c.fit_radius_m, 100.0 * (c.fit_radius_m - r) / r, c.v_over_w_m,
        100.0 * (c.v_over_w_m - r) / r);
    EXPECT_NEAR(c.speed_mps, 0.3, 0.03) << kappa;
    EXPECT_NEAR(c.fit_radius_m, r, 0.05 * r) << kappa;
    EXPECT_NEAR(c.v_over_w_m, r, 0.05 * r) << kappa;
  }
}

TEST(CarTest, CurvatureBeyondTheActuatorLimitGivesTheLimitRadius) {
  const CarParams params;
  const Circle limit = DriveCircle(params, 0.15, 1.2, 3.0, 1.5);
  const Circle beyond = DriveCircle(params, 0.15, 2.5, 3.0, 1.5);
  EXPECT_NEAR(beyond.fit_radius_m, 1.0 / 1.2, 0.05 / 1.2);
  EXPECT_EQ(beyond.fit_radius_m, limit.fit_radius_m);
}

TEST(CarTest, NegativeCurvatureTurnsRight) {
  PhysicsWorld world(PhysicsParams{});
  Car& car = world.AddCar(1, CarParams{}, {});
  car.SetCommand({0.15, -0.6});
  RunFor(world, 3.0);
  EXPECT_LT(car.yaw_rate_rad_per_s(), 0.0);
  EXPECT_LT(car.pose().y_m, 0.0);
  EXPECT_NEAR(car.forward_speed_mps() / car.yaw_rate_rad_per_s(), -1.0 / 0.6, 0.05 / 0.6);
}

TEST(CarTest, HoldsTheCirclePathAtSpeedWithinGrip) {
  // 1 m/s at κ = 1.2 asks 1.2 m/s² sideways, well under μ·g: still on the kinematic radius.
  const Circle c = DriveCircle(CarParams{}, 0.5, 1.2, 3.0, 1.5);
  EXPECT_NEAR(c.fit_radius_m, 1.0 / 1.2, 0.05 / 1.2);
}

TEST(CarTest, SkidsWideBeyondTheGripLimit) {
  CarParams params;
  params.tire_friction_coefficient = 0.05;  // ice: at most 0.49 m/s² from all four tyres
  const double grip_accel = params.tire_friction_coefficient * kG_mps2;
  PhysicsWorld world(PhysicsParams{});
  Car& car = world.AddCar(1, params, {});
  car.SetCommand({0.5, 0.0});
  RunFor(world, 8.0);
  ASSERT_NEAR(car.forward_speed_mps(), 1.0, 0.01);

  // Full lock at 1 m/s asks 1.2 m/s² sideways: the tyres slide, the accelerations stay within
  // the grip, and the centre of mass runs wide of the commanded circle.
  car.SetCommand({0.5, 1.2});
  const double dt = ToSeconds(world.step());
  std::vector<world::Vec2> path;
  double max_accel = 0.0;
  for (int k = 0; k < 1000; ++k) {
    const world::Vec2 v0 = car.velocity_map_mps();
    world.Step();
    max_accel = std::max(max_accel, (car.velocity_map_mps() - v0).norm() / dt);
    path.push_back(car.pose().position());
  }
  EXPECT_LT(max_accel, grip_accel * 1.001);
  EXPECT_GT(max_accel, grip_accel * 0.9);  // it does use the grip it has
  EXPECT_GT(FitCircleRadius(path), 1.5);   // vs 0.85 m for the centre on the kinematic circle

  // With the default grip the same manoeuvre holds the circle.
  PhysicsWorld grippy(PhysicsParams{});
  Car& reference = grippy.AddCar(1, CarParams{}, {});
  reference.SetCommand({0.5, 0.0});
  RunFor(grippy, 3.0);
  reference.SetCommand({0.5, 1.2});
  RunFor(grippy, 1.0);
  EXPECT_NEAR(reference.forward_speed_mps() / reference.yaw_rate_rad_per_s(), 1.0 / 1.2,
              0.05 / 1.2);
}

TEST(CarTest, AccelerationEstimateSeesTheCentripetalAcceleration) {
  PhysicsWorld world(PhysicsParams{});
  Car& car = world.AddCar(1, CarParams{}, {});
  EXPECT_EQ(car.acceleration_body_mps2(), world::Vec2(0.0, 0.0));
  car.SetCommand({0.5, 1.0});
  RunFor(world, 4.0);
  world.Step();  // the estimate is for the step before the last ApplyForces
  // The chassis centre circles the turn centre, which sits beside the rear axle: in the body
  // frame the centripetal acceleration is ω²·(−wheelbase/2, R) with R·ω = v.
  const double w = car.yaw_rate_rad_per_s();
  const double expected_y = car.forward_speed_mps() * w;
  const double expected_x = -w * w * car.params().wheelbase_m / 2.0;
  EXPECT_NEAR(car.acceleration_body_mps2().y(), expected_y, 0.02 * expected_y);
  EXPECT_NEAR(car.acceleration_body_mps2().x(), expected_x, 0.02 * expected_y);
}

TEST(CarTest, ApplyForcesRejectsABadStep) {
  PhysicsWorld world(PhysicsParams{});
  Car& car = world.AddCar(1, CarParams{}, {});
  EXPECT_THROW(car.ApplyForces(0.0), std::invalid_argument);
  EXPECT_THROW(car.ApplyForces(std::numeric_limits<double>::quiet_NaN()), std::invalid_argument);
}

TEST(CarTest, ManyTurnsKeepTheYawWrapped) {
  PhysicsWorld world(PhysicsParams{});
  Car& car = world.AddCar(1, CarParams{}, {});
  car.SetCommand({1.0, 1.2});
  RunFor(world, 30.0);  // ≈ 11 turns at 2 m/s on a 0.83 m radius
  EXPECT_LE(std::abs(car.pose().yaw_rad), std::numbers::pi);
  EXPECT_NEAR(car.forward_speed_mps() / car.yaw_rate_rad_per_s(), 1.0 / 1.2, 0.05 / 1.2);
}

TEST(PwmTest, ReproducesTheReferenceMapping) {
  const PwmParams pwm;
  EXPECT_NO_THROW(pwm.Validate());
  EXPECT_EQ(pwm.period, std::chrono::milliseconds(10));
  EXPECT_EQ(ThrottlePulse(pwm, 0.0), 150000);
  EXPECT_EQ(ThrottlePulse(pwm, 1.0), 180000);
  EXPECT_EQ(ThrottlePulse(pwm, -1.0), 120000);
  EXPECT_EQ(ThrottlePulse(pwm, 0.5), 165000);
  EXPECT_EQ(ThrottlePulse(pwm, -0.25), 142500);
  EXPECT_EQ(ThrottlePulse(pwm, 1.7), 180000);
  EXPECT_EQ(ThrottlePulse(pwm, -4.0), 120000);
  EXPECT_EQ(ThrottlePulse(pwm, std::numeric_limits<double>::infinity()), 180000);

  EXPECT_EQ(SteeringPulse(pwm, 0.0), 150000);
  EXPECT_EQ(SteeringPulse(pwm, 1.2), 100000);   // full left
  EXPECT_EQ(SteeringPulse(pwm, -1.2), 200000);  // full right
  EXPECT_EQ(SteeringPulse(pwm, 0.6), 125000);
  EXPECT_EQ(SteeringPulse(pwm, -0.3), 162500);
  EXPECT_EQ(SteeringPulse(pwm, 3.0), 100000);
  EXPECT_EQ(SteeringPulse(pwm, -3.0), 200000);

  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(ThrottlePulse(pwm, nan), std::invalid_argument);
  EXPECT_THROW(SteeringPulse(pwm, nan), std::invalid_argument);
}

TEST(PwmTest, ParamsValidationNamesTheKey) {
  PwmParams pwm;
  pwm.throttle_max_counts = 140000;  // below neutral
  EXPECT_THAT(InvalidArgumentMessage([&] { pwm.Validate(); }), HasSubstr("throttle_max_counts"));
  pwm = PwmParams{};
  pwm.steering_full_curvature_per_m = 0.0;
  EXPECT_THAT(InvalidArgumentMessage([&] { pwm.Validate(); }),
              HasSubstr("steering_full_curvature_per_m"));
  pwm = PwmParams{};
  pwm.period = Duration::zero();
  EXPECT_THAT(InvalidArgumentMessage([&] { pwm.Validate(); }), HasSubstr("period_s"));
}

}  // namespace
}  // namespace autonomsim::vehicle
