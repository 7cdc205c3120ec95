#include "vehicle/physics_world.h"

#include <box2d/box2d.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <tuple>
#include <utility>

#include "world/validation.h"

namespace autonomsim::vehicle {
namespace {

// Longest step accepted: the tyre impulses act once per step on the velocities left by the last
// one, which stays accurate while the heading turns little per step.
constexpr Duration kMaxStep = std::chrono::milliseconds(20);

}  // namespace

namespace detail {

// Box2D calls BeginContact during b2World::Step when two fixtures start touching. Bodies say
// what they are through their user data: a dynamic body's is its Car, a static body's is its
// obstacle index + 1.
class ContactRecorder : public b2ContactListener {
 public:
  struct Raw {
    int car_id;
    bool with_car;
    int other_car_id;
    std::size_t obstacle_index;
  };

  void BeginContact(b2Contact* contact) override {
    b2Body* a = contact->GetFixtureA()->GetBody();
    b2Body* b = contact->GetFixtureB()->GetBody();
    if (a->GetType() != b2_dynamicBody) std::swap(a, b);
    if (a->GetType() != b2_dynamicBody) return;  // static–static never touch; kept for safety
    const int car_a = CarOf(a).id();
    if (b->GetType() == b2_dynamicBody) {
      const int car_b = CarOf(b).id();
      raw_.push_back({std::min(car_a, car_b), true, std::max(car_a, car_b), 0});
    } else {
      raw_.push_back({car_a, false, -1, static_cast<std::size_t>(b->GetUserData().pointer - 1)});
    }
  }

  std::vector<Raw> Take() { return std::exchange(raw_, {}); }

 private:
  static const Car& CarOf(b2Body* body) {
    return *reinterpret_cast<const Car*>(body->GetUserData().pointer);
  }

  std::vector<Raw> raw_;
};

}  // namespace detail

void PhysicsParams::Validate() const {
  Require(step > Duration::zero() && step <= kMaxStep, [&] {
    return "step_s must be in (0, " + Num(ToSeconds(kMaxStep)) + "] s, got " + Num(ToSeconds(step));
  });
  Require(velocity_iterations >= 1, [&] {
    return "velocity_iterations must be >= 1, got " + std::to_string(velocity_iterations);
  });
  Require(position_iterations >= 1, [&] {
    return "position_iterations must be >= 1, got " + std::to_string(position_iterations);
  });
}

void ObstacleBox::Validate() const {
  Require(!name.empty(), "obstacle needs a name");
  Require(std::isfinite(pose.x_m) && std::isfinite(pose.y_m) && std::isfinite(pose.yaw_rad),
          [&] { return "obstacle '" + name + "': pose must be finite"; });
  auto positive = [this](double value, const char* key) {
    Require(std::isfinite(value) && value > 0.0, [&] {
      return "obstacle '" + name + "': " + key + " must be finite and > 0, got " + Num(value);
    });
  };
  positive(length_m, "length_m");
  positive(width_m, "width_m");
  positive(height_m, "height_m");
}

PhysicsWorld::PhysicsWorld(const PhysicsParams& params)
    : params_(params), recorder_(std::make_unique<detail::ContactRecorder>()) {
  params_.Validate();
  world_ = std::make_unique<b2World>(b2Vec2(0.0f, 0.0f));
  world_->SetContactListener(recorder_.get());
}

PhysicsWorld::~PhysicsWorld() {
  cars_.clear();  // their destructors destroy their bodies in the still living world
}

Car& PhysicsWorld::AddCar(int id, const CarParams& params, const world::Pose2& start) {
  Require(!cars_.contains(id),
          [&] { return "car id " + std::to_string(id) + " is already in the world"; });
  auto car = std::make_unique<Car>(world_.get(), params, id, start);
  Car& ref = *car;
  cars_.emplace(id, std::move(car));
  return ref;
}

Car& PhysicsWorld::car(int id) {
  const auto it = cars_.find(id);
  if (it == cars_.end()) throw std::out_of_range("no car with id " + std::to_string(id));
  return *it->second;
}

const Car& PhysicsWorld::car(int id) const { return const_cast<PhysicsWorld*>(this)->car(id); }

std::vector<int> PhysicsWorld::car_ids() const {
  std::vector<int> ids;
  ids.reserve(cars_.size());
  for (const auto& entry : cars_) ids.push_back(entry.first);
  return ids;
}

std::size_t PhysicsWorld::AddObstacle(const ObstacleBox& box, bool enabled) {
  box.Validate();
  for (const Obstacle& other : obstacles_) {
    Require(other.box.name != box.name,
            [&] { return "obstacle name '" + box.name + "' is already in the world"; });
  }
  const std::size_t index = obstacles_.size();

  b2BodyDef body_def;
  body_def.type = b2_staticBody;
  body_def.position.Set(static_cast<float>(box.pose.x_m), static_cast<float>(box.pose.y_m));
  body_def.angle = static_cast<float>(world::WrapAngle(box.pose.yaw_rad));
  body_def.enabled = enabled;
  body_def.userData.pointer = static_cast<std::uintptr_t>(index + 1);
  b2Body* body = world_->CreateBody(&body_def);

  // The core is shrunk by Box2D's skin so that the outline is the box (see car.h).
  const float half_length = static_cast<float>(box.length_m / 2.0) - b2_polygonRadius;
  const float half_width = static_cast<float>(box.width_m / 2.0) - b2_polygonRadius;
  b2PolygonShape shape;
  shape.SetAsBox(std::max(half_length, b2_linearSlop), std::max(half_width, b2_linearSlop));
  body->CreateFixture(&shape, 0.0f);

  obstacles_.push_back({box, body, enabled});
  return index;
}

void PhysicsWorld::SetObstacleEnabled(std::size_t index, bool enabled) {
  if (index >= obstacles_.size()) {
    throw std::out_of_range("no obstacle with index " + std::to_string(index));
  }
  obstacles_[index].body->SetEnabled(enabled);
  obstacles_[index].enabled = enabled;
}

const ObstacleBox& PhysicsWorld::obstacle(std::size_t index) const {
  if (index >= obstacles_.size()) {
    throw std::out_of_range("no obstacle with index " + std::to_string(index));
  }
  return obstacles_[index].box;
}

bool PhysicsWorld::obstacle_enabled(std::size_t index) const {
  if (index >= obstacles_.size()) {
    throw std::out_of_range("no obstacle with index " + std::to_string(index));
  }
  return obstacles_[index].enabled;
}

void PhysicsWorld::Step() {
  const double dt_s = ToSeconds(params_.step);
  // every car's forces, their tyres solved side by side (Car::SolveTires)
  tire_solves_.clear();
  for (auto& entry : cars_) tire_solves_.push_back(entry.second->BeginForces(dt_s));
  Car::SolveTires(tire_solves_);
  std::size_t k = 0;
  for (auto& entry : cars_) entry.second->EndForces(tire_solves_[k++]);
  world_->Step(static_cast<float>(dt_s), params_.velocity_iterations, params_.position_iterations);
  time_ += params_.step;

  std::vector<detail::ContactRecorder::Raw> raw = recorder_->Take();
  std::vector<ContactEvent> events;
  events.reserve(raw.size());
  for (const auto& contact : raw) {
    ContactEvent event;
    event.time = time_;
    event.car_id = contact.car_id;
    event.with_car = contact.with_car;
    if (event.with_car) {
      event.other_car_id = contact.other_car_id;
    } else {
      event.obstacle_name = obstacles_.at(contact.obstacle_index).box.name;
    }
    events.push_back(std::move(event));
  }
  std::sort(events.begin(), events.end(), [](const ContactEvent& a, const ContactEvent& b) {
    return std::tie(a.car_id, a.with_car, a.other_car_id, a.obstacle_name) <
           std::tie(b.car_id, b.with_car, b.other_car_id, b.obstacle_name);
  });
  pending_.insert(pending_.end(), std::make_move_iterator(events.begin()),
                  std::make_move_iterator(events.end()));
}

std::vector<ContactEvent> PhysicsWorld::TakeContacts() { return std::exchange(pending_, {}); }

}  // namespace autonomsim::vehicle

// Box2D's step profile (b2World::GetProfile) times each phase of every b2World::Step with
// b2Timer, which reads the wall clock (gettimeofday) about 20 times a step: 4 % of the default
// scenario's run. Nothing here reads that profile, and a simulation step has no business reading
// the wall clock, so b2Timer is defined here as a clock that stands still. On Linux (ELF) libbox2d
// calls its timer through its procedure linkage table, so a program that links this file (every
// one that uses PhysicsWorld) supplies these definitions to the library too: its profile then
// reads 0 ms for every phase. Where the library's own definitions win instead (a library built
// with -Bsymbolic or LTO, or another platform's linking) only the speed is lost, and
// PhysicsWorldTest.Box2dProfileTimersReadNoWallClock fails to say so.
b2Timer::b2Timer() = default;
void b2Timer::Reset() {}
float b2Timer::GetMilliseconds() const { return 0.0f; }
