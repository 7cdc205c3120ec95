// One Box2D world (zero gravity, top down) holding the cars and the static obstacles of a run,
// stepped at a fixed period. An instance owns everything it uses, the contact listener included:
// two PhysicsWorlds in one process are independent, and the same calls give bit-identical results.
//
// Box2D keeps positions and velocities in float: poses resolve to about 2.4e-7 m on the 5 m
// track. Cars are the only dynamic bodies, so the contacts are car–car and car–obstacle.
#pragma once

#include <chrono>
#include <cstddef>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "vehicle/car.h"
#include "world/geometry.h"
#include "world/time.h"

class b2Body;
class b2World;

namespace autonomsim::vehicle {

struct PhysicsParams {
  // assumed: 2 ms resolves the 10 ms actuator PWM period (reference §2) five times over and keeps a
  // car at top speed under 5 mm of travel per step (Box2D's linear slop). Valid: (0, 20 ms].
  Duration step{std::chrono::milliseconds(2)};
  int velocity_iterations{8};  // Box2D's recommended values
  int position_iterations{3};

  template <class V>
  void Describe(V& v) {
    v("step_s", step, "Box2D advances the cars this often (valid: (0, 0.02] s)");
    v("velocity_iterations", velocity_iterations, "Box2D's velocity solver iterations per step");
    v("position_iterations", position_iterations, "Box2D's position solver iterations per step");
  }
  void Validate() const;
};

// A static box (a parked obstacle, a wall). Its collision outline is the box, like the car's
// (car.h); boxes thinner than 3 cm collide as 3 cm (Box2D's smallest polygon with its skin).
struct ObstacleBox {
  std::string name;      // unique within a world; names the obstacle in contact events
  world::Pose2 pose;     // box centre, map frame
  double length_m{0.0};  // along the pose's x axis
  double width_m{0.0};
  double height_m{0.0};  // for sensors only

  void Validate() const;
};

// A contact that began during a step. A car–car contact is reported once, with car_id the smaller
// id; a car–obstacle contact names the obstacle. A contact that persists is not reported again.
struct ContactEvent {
  Time time{};  // end of the step in which it began, counted from the world's creation
  int car_id{0};
  bool with_car{false};
  int other_car_id{-1};       // with_car only
  std::string obstacle_name;  // !with_car only
};

namespace detail {
class ContactRecorder;
}

class PhysicsWorld {
 public:
  explicit PhysicsWorld(const PhysicsParams& params);  // validates params
  ~PhysicsWorld();
  PhysicsWorld(const PhysicsWorld&) = delete;
  PhysicsWorld& operator=(const PhysicsWorld&) = delete;

  // Ids must be unique (std::invalid_argument otherwise). The reference stays valid for the
  // world's life.
  Car& AddCar(int id, const CarParams& params, const world::Pose2& start);
  Car& car(int id);  // std::out_of_range for an unknown id
  const Car& car(int id) const;
  std::vector<int> car_ids() const;  // ascending

  // A static body; returns its index (0, 1, ... in the order added). A disabled obstacle is out of
  // the world: cars pass through it. Enabling one that overlaps a car reports a contact at the next
  // step, and Box2D pushes the car out over a few steps.
  std::size_t AddObstacle(const ObstacleBox& box, bool enabled);
  void SetObstacleEnabled(std::size_t index, bool enabled);  // std::out_of_range for a bad index
  std::size_t obstacle_count() const { return obstacles_.size(); }
  const ObstacleBox& obstacle(std::size_t index) const;
  bool obstacle_enabled(std::size_t index) const;

  // Every car's forces (ascending id; Car::BeginForces, then the tyres of all cars solved side by
  // side, then Car::EndForces: the same as ApplyForces on each), then one b2World::Step of step().
  void Step();
  // Contacts begun since the last call: by step, and within a step ordered by (car_id, with_car,
  // other_car_id, obstacle_name), so the order never depends on Box2D's internal lists.
  std::vector<ContactEvent> TakeContacts();

  Duration step() const { return params_.step; }
  Time time() const { return time_; }  // steps taken × step()

 private:
  struct Obstacle {
    ObstacleBox box;
    b2Body* body{nullptr};  // owned by world_
    bool enabled{false};
  };

  PhysicsParams params_;
  Time time_{kZeroTime};
  // Destroyed in reverse order: the cars (their destructors remove their bodies from the live
  // b2World), then the b2World, then the listener it points to.
  std::unique_ptr<detail::ContactRecorder> recorder_;
  std::unique_ptr<b2World> world_;
  std::vector<Obstacle> obstacles_;
  std::map<int, std::unique_ptr<Car>> cars_;
  std::vector<Car::TireSolve> tire_solves_;  // Step's scratch, one per car
  std::vector<ContactEvent> pending_;
};

}  // namespace autonomsim::vehicle
