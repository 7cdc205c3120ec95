#include "vehicle/physics_world.h"

#include <box2d/box2d.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <functional>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

namespace autonomsim::vehicle {
namespace {

using ::testing::HasSubstr;

void RunFor(PhysicsWorld& world, double seconds) {
  const auto steps = static_cast<int>(std::llround(seconds / ToSeconds(world.step())));
  for (int i = 0; i < steps; ++i) world.Step();
}

// Steps until `done` holds or `max_seconds` pass; returns whether it held.
bool StepUntil(PhysicsWorld& world, const std::function<bool()>& done, double max_seconds) {
  const auto max_steps = static_cast<int>(std::llround(max_seconds / ToSeconds(world.step())));
  for (int i = 0; i < max_steps && !done(); ++i) world.Step();
  return done();
}

std::string InvalidArgumentMessage(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "(no std::invalid_argument thrown)";
}

// A 0.4 m × 1 m wall whose near face is at x = face_x, across the x axis.
ObstacleBox WallAt(double face_x, const std::string& name = "wall") {
  return ObstacleBox{name, {face_x + 0.2, 0.0, 0.0}, 0.4, 1.0, 0.3};
}

bool BitIdentical(const world::Pose2& a, const world::Pose2& b) {
  return std::memcmp(&a.x_m, &b.x_m, sizeof(double)) == 0 &&
         std::memcmp(&a.y_m, &b.y_m, sizeof(double)) == 0 &&
         std::memcmp(&a.yaw_rad, &b.yaw_rad, sizeof(double)) == 0;
}

// Spins until `ms` milliseconds of wall-clock time have passed.
void SpinFor(double ms) {
  const auto start = std::chrono::steady_clock::now();
  while (
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count() <
      ms) {
  }
}

// physics_world.cc defines b2Timer as a clock that stands still (Box2D's step profile is never
// read, and reading the wall clock cost 4 % of a run): a timer made here reads 0 ms after 2 ms,
// and so does libbox2d's own step profile, though a contact callback inside the step spins 2 ms.
TEST(PhysicsWorldTest, Box2dProfileTimersReadNoWallClock) {
  const b2Timer timer;
  SpinFor(2.0);
  EXPECT_EQ(timer.GetMilliseconds(), 0.0f);

  struct Spinning : b2ContactListener {
    void BeginContact(b2Contact* /*contact*/) override {
      SpinFor(2.0);
      ++contacts;
    }
    int contacts{0};
  } listener;
  b2World world(b2Vec2(0.0f, 0.0f));
  world.SetContactListener(&listener);
  b2PolygonShape box;
  box.SetAsBox(0.5f, 0.5f);
  for (const float x : {0.0f, 0.5f}) {  // two overlapping boxes: a contact in the first step
    b2BodyDef def;
    def.type = b2_dynamicBody;
    def.position.Set(x, 0.0f);
    world.CreateBody(&def)->CreateFixture(&box, 1.0f);
  }
  world.Step(0.001f, 8, 3);
  ASSERT_EQ(listener.contacts, 1);
  EXPECT_EQ(world.GetProfile().collide, 0.0f);
  EXPECT_EQ(world.GetProfile().step, 0.0f);
}

TEST(PhysicsParamsTest, DefaultsAndValidation) {
  PhysicsParams params;
  EXPECT_NO_THROW(params.Validate());
  EXPECT_EQ(params.step, std::chrono::milliseconds(2));
  params.step = Duration::zero();
  EXPECT_THAT(InvalidArgumentMessage([&] { params.Validate(); }), HasSubstr("step_s"));
  params.step = std::chrono::milliseconds(50);
  EXPECT_THAT(InvalidArgumentMessage([&] { params.Validate(); }), HasSubstr("step_s"));
  params = PhysicsParams{};
  params.velocity_iterations = 0;
  EXPECT_THAT(InvalidArgumentMessage([&] { params.Validate(); }), HasSubstr("velocity_iterations"));
  params = PhysicsParams{};
  params.position_iterations = -1;
  EXPECT_THAT(InvalidArgumentMessage([&] { params.Validate(); }), HasSubstr("position_iterations"));
  params.step = Duration::zero();
  EXPECT_THROW(PhysicsWorld world(params), std::invalid_argument);
}

TEST(PhysicsWorldTest, CarIdsAreUnique) {
  PhysicsWorld world(PhysicsParams{});
  world.AddCar(2, CarParams{}, {0.0, 0.0, 0.0});
  world.AddCar(1, CarParams{}, {0.0, 1.0, 0.0});
  EXPECT_THAT(InvalidArgumentMessage([&] {
                world.AddCar(2, CarParams{}, {0.0, 2.0, 0.0});
              }),
              HasSubstr("2"));
  EXPECT_EQ(world.car_ids(), (std::vector<int>{1, 2}));
  EXPECT_EQ(world.car(1).id(), 1);
  EXPECT_THROW(world.car(3), std::out_of_range);
  const PhysicsWorld& const_world = world;
  EXPECT_EQ(const_world.car(2).id(), 2);
}

TEST(PhysicsWorldTest, ObstaclesAreValidatedAndNamedUniquely) {
  PhysicsWorld world(PhysicsParams{});
  EXPECT_EQ(world.AddObstacle(WallAt(1.0, "a"), true), 0u);
  EXPECT_EQ(world.AddObstacle(WallAt(3.0, "b"), false), 1u);
  EXPECT_EQ(world.obstacle_count(), 2u);
  EXPECT_EQ(world.obstacle(1).name, "b");
  EXPECT_TRUE(world.obstacle_enabled(0));
  EXPECT_FALSE(world.obstacle_enabled(1));
  EXPECT_THAT(InvalidArgumentMessage([&] { world.AddObstacle(WallAt(5.0, "a"), true); }),
              HasSubstr("'a'"));
  ObstacleBox bad = WallAt(5.0, "c");
  bad.width_m = 0.0;
  EXPECT_THAT(InvalidArgumentMessage([&] { world.AddObstacle(bad, true); }), HasSubstr("width_m"));
  bad = WallAt(5.0, "");
  EXPECT_THROW(world.AddObstacle(bad, true), std::invalid_argument);
  EXPECT_THROW(world.SetObstacleEnabled(2, true), std::out_of_range);
  EXPECT_EQ(world.obstacle_count(), 2u);
}

TEST(PhysicsWorldTest, CarDrivenIntoAWallMakesOneContactAndStops) {
  PhysicsWorld world(PhysicsParams{});
  Car& car = world.AddCar(4, CarParams{}, {0.0, 0.0, 0.0});
  world.AddObstacle(WallAt(1.5), true);
  car.SetCommand({0.3, 0.0});
  RunFor(world, 2.0);
  EXPECT_TRUE(world.TakeContacts().empty());  // not there yet
  RunFor(world, 4.0);                         // reaches the wall after ≈3 s and keeps pushing
  const std::vector<ContactEvent> events = world.TakeContacts();
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].car_id, 4);
  EXPECT_FALSE(events[0].with_car);
  EXPECT_EQ(events[0].obstacle_name, "wall");
  EXPECT_GT(events[0].time, Milliseconds(2000));
  EXPECT_LT(events[0].time, Milliseconds(6000));

  EXPECT_NEAR(car.forward_speed_mps(), 0.0, 1e-3);
  const double front_x = car.pose().x_m + car.params().length_m / 2.0;
  EXPECT_NEAR(front_x, 1.5, 0.01);  // touching, within Box2D's slop
  EXPECT_NEAR(car.pose().y_m, 0.0, 1e-3);

  RunFor(world, 1.0);  // still pressed against it: no new contact
  EXPECT_TRUE(world.TakeContacts().empty());
}

TEST(PhysicsWorldTest, DisabledObstacleIsPassedThroughAndCanAppear) {
  PhysicsWorld world(PhysicsParams{});
  Car& car = world.AddCar(1, CarParams{}, {0.0, 0.0, 0.0});
  const std::size_t ghost = world.AddObstacle(WallAt(1.0, "ghost"), false);
  const std::size_t late = world.AddObstacle(WallAt(3.0, "late"), false);
  car.SetCommand({0.5, 0.0});
  ASSERT_TRUE(StepUntil(
      world, [&] { return car.pose().x_m > 2.0; }, 10.0));  // through "ghost"
  EXPECT_TRUE(world.TakeContacts().empty());
  EXPECT_GT(car.forward_speed_mps(), 0.5);

  world.SetObstacleEnabled(late, true);
  EXPECT_TRUE(world.obstacle_enabled(late));
  RunFor(world, 5.0);
  const std::vector<ContactEvent> events = world.TakeContacts();
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].obstacle_name, "late");
  EXPECT_NEAR(car.forward_speed_mps(), 0.0, 1e-3);

  // back out through where "ghost" stands disabled, enable it, and drive into it
  world.SetObstacleEnabled(late, false);
  car.SetCommand({-0.5, 0.0});
  ASSERT_TRUE(StepUntil(
      world, [&] { return car.pose().x_m < 0.3; }, 10.0));
  world.SetObstacleEnabled(ghost, true);
  car.SetCommand({0.0, 0.0});
  RunFor(world, 5.0);
  EXPECT_TRUE(world.TakeContacts().empty());
  car.SetCommand({0.5, 0.0});
  RunFor(world, 5.0);
  const std::vector<ContactEvent> again = world.TakeContacts();
  ASSERT_EQ(again.size(), 1u);
  EXPECT_EQ(again[0].obstacle_name, "ghost");
  EXPECT_NEAR(car.pose().x_m + car.params().length_m / 2.0, 1.0, 0.01);
}

TEST(PhysicsWorldTest, TwoCarsCollidingMakeOneCarCarEvent) {
  PhysicsWorld world(PhysicsParams{});
  Car& east = world.AddCar(9, CarParams{}, {1.5, 0.0, std::numbers::pi});
  Car& west = world.AddCar(3, CarParams{}, {-1.5, 0.0, 0.0});
  east.SetCommand({0.3, 0.0});
  west.SetCommand({0.3, 0.0});
  RunFor(world, 6.0);
  const std::vector<ContactEvent> events = world.TakeContacts();
  ASSERT_EQ(events.size(), 1u);
  EXPECT_TRUE(events[0].with_car);
  EXPECT_EQ(events[0].car_id, 3);
  EXPECT_EQ(events[0].other_car_id, 9);
  EXPECT_TRUE(events[0].obstacle_name.empty());
  // head on with equal pushes: both stand still, nose to nose
  EXPECT_NEAR(east.forward_speed_mps(), 0.0, 1e-3);
  EXPECT_NEAR(west.forward_speed_mps(), 0.0, 1e-3);
  EXPECT_NEAR(east.pose().x_m - west.pose().x_m, CarParams{}.length_m, 0.02);
}

TEST(PhysicsWorldTest, ContactsWithinOneStepAreOrderedByKey) {
  PhysicsWorld world(PhysicsParams{});
  // Two cars side by side overlap each other and a wall each by 4 mm: three contacts begin in the
  // first step. Added in this order, Box2D reports them in the reverse of the key order.
  const double y = CarParams{}.width_m / 2.0 - 0.002;
  world.AddObstacle(ObstacleBox{"a_wall", {0.0, -2.0 * y - 0.15 + 0.002, 0.0}, 1.0, 0.3, 0.3},
                    true);
  world.AddCar(1, CarParams{}, {0.0, -y, 0.0});
  world.AddCar(2, CarParams{}, {0.0, y, 0.0});
  world.AddObstacle(ObstacleBox{"z_wall", {0.0, 2.0 * y + 0.15 - 0.002, 0.0}, 1.0, 0.3, 0.3}, true);
  world.Step();
  const std::vector<ContactEvent> events = world.TakeContacts();
  ASSERT_EQ(events.size(), 3u);
  EXPECT_EQ(events[0].car_id, 1);
  EXPECT_FALSE(events[0].with_car);
  EXPECT_EQ(events[0].obstacle_name, "a_wall");
  EXPECT_EQ(events[1].car_id, 1);
  EXPECT_TRUE(events[1].with_car);
  EXPECT_EQ(events[1].other_car_id, 2);
  EXPECT_EQ(events[2].car_id, 2);
  EXPECT_EQ(events[2].obstacle_name, "z_wall");
  for (const ContactEvent& e : events) EXPECT_EQ(e.time, world.step());
  EXPECT_TRUE(world.TakeContacts().empty());
}

// A scene with two cars, a wall and a changing script of commands.
void BuildScene(PhysicsWorld& world) {
  world.AddCar(1, CarParams{}, {-1.0, -0.2, 0.1});
  world.AddCar(2, CarParams{}, {1.0, 0.3, std::numbers::pi});
  world.AddObstacle(ObstacleBox{"box", {0.0, 1.2, 0.3}, 0.5, 0.5, 0.3}, true);
}

void ScriptStep(PhysicsWorld& world, int k, double gain) {
  if (k % 50 == 0) {
    const double phase = 0.013 * k;
    world.car(1).SetCommand({gain * (0.6 + 0.4 * std::sin(phase)), 1.2 * std::sin(0.7 * phase)});
    world.car(2).SetCommand({gain * 0.7, -0.8 * std::cos(phase)});
  }
  world.Step();
}

TEST(PhysicsWorldTest, IdenticalWorldsGiveBitIdenticalResultsAndDoNotInterfere) {
  PhysicsWorld a(PhysicsParams{});
  PhysicsWorld b(PhysicsParams{});
  PhysicsWorld other(PhysicsParams{});
  BuildScene(a);
  BuildScene(b);
  BuildScene(other);
  std::vector<ContactEvent> events_a;
  std::vector<ContactEvent> events_b;
  int other_events = 0;
  constexpr int kSteps = 10000;  // 20 s: the cars meet each other and the box
  for (int k = 0; k < kSteps; ++k) {
    ScriptStep(a, k, 1.0);
    ScriptStep(other, k, 0.5);  // a different run in between must not matter
    if (k % 3 == 0) ScriptStep(other, k, 0.5);
    ScriptStep(b, k, 1.0);
    for (ContactEvent& e : a.TakeContacts()) events_a.push_back(e);
    for (ContactEvent& e : b.TakeContacts()) events_b.push_back(e);
    other_events += static_cast<int>(other.TakeContacts().size());
    for (int id : {1, 2}) {
      ASSERT_TRUE(BitIdentical(a.car(id).pose(), b.car(id).pose()))
          << "step " << k << " car " << id;
    }
  }
  ASSERT_EQ(events_a.size(), events_b.size());
  EXPECT_FALSE(events_a.empty()) << "the scene should exercise contacts";
  for (std::size_t i = 0; i < events_a.size(); ++i) {
    EXPECT_EQ(events_a[i].time, events_b[i].time);
    EXPECT_EQ(events_a[i].car_id, events_b[i].car_id);
    EXPECT_EQ(events_a[i].with_car, events_b[i].with_car);
    EXPECT_EQ(events_a[i].other_car_id, events_b[i].other_car_id);
    EXPECT_EQ(events_a[i].obstacle_name, events_b[i].obstacle_name);
  }
  EXPECT_FALSE(BitIdentical(a.car(1).pose(), other.car(1).pose()));
  EXPECT_EQ(a.time(), kSteps * a.step());
}

}  // namespace
}  // namespace autonomsim::vehicle
