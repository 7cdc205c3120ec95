// The closed loop's internals, shared by its two files: simulation.cc (construction, the loop's
// steps, the monitors) and car_boards.cc (a car's board: cameras, perception and stack nodes).
#pragma once

#include <deque>
#include <map>
#include <memory>
#include <optional>
#include <vector>

#include "sim/car/oracle_driver.h"
#include "sim/car/perception_nodes.h"
#include "sim/car/sensors.h"
#include "sim/car/stack_nodes.h"
#include "sim/core/kernel.h"
#include "sim/core/priorities.h"
#include "sim/core/random.h"
#include "sim/loop/lane_judge.h"
#include "sim/loop/simulation.h"
#include "sim/platform/node_graph.h"
#include "sim/v2i/mqtt_endpoint.h"
#include "sim/v2i/realtime_link.h"
#include "sim/v2i/realtime_pacing.h"
#include "sim/v2i/traffic_light_node.h"
#include "sim/v2i/v2i_link.h"
#include "stack/intersection_client.h"
#include "vehicle/physics_world.h"
#include "world/floor_raster.h"
#include "world/occupancy_map.h"

namespace autonomsim::sim {
namespace detail {

// Camera frames remembered per car for judging the perception's results (≈ 2 s at 30 fps).
constexpr std::size_t kRecentFrames = 64;

// A static obstacle as seen along one car's route (ground truth, for the oracle).
struct ObstacleOnRoute {
  std::size_t index{0};       // in the physics world
  double s_m{0.0};            // where its centre projects on the route
  double half_extent_m{0.0};  // half its diagonal: a conservative reach in every direction
};

// One car and everything that drives and watches it.
struct CarAgent {
  const CarConfig* config{nullptr};
  const world::Route* route{nullptr};
  vehicle::Car* car{nullptr};
  OracleDriverState driver;
  stack::IntersectionClientState client;
  std::vector<world::Response> inbox;  // responses for this car since the client's last step
  vehicle::ActuatorCommand command;    // what its driver commands
  bool stalled{false};                 // car_stall: the motor is dead (sim/loop/faults.h)
  StackControls stack_controls;        // driver: stack
  bool waiting{false};                 // the intersection client says: stop here until granted
  bool parked{false};                  // done: laps driven or route ended
  std::vector<ObstacleOnRoute> obstacles_on_lane;
  std::optional<Time> wait_started;
  int waiting_for{-1};  // the intersection of the current (or last) wait
  // the colour camera's recent frames (stamp, pose), to judge lane detection against ground truth
  std::deque<std::pair<Time, world::Pose2>> color_frames;
  double lane_error_sq_sum{0.0};  // over the judged lane detection results
  // ground-truth tracking of the chassis centre along the route
  double route_s_m{0.0};
  double progress_m{0.0};
  double lateral_error_m{0.0};
  double lateral_sq_sum{0.0};
  std::uint64_t lateral_samples{0};
  int area{-1};  // the intersection whose area holds the chassis centre, or -1
  // driver: stack
  stack::BehaviorMode behavior_mode{stack::BehaviorMode::kDrive};
  CarMetrics metrics;

  // What reaches the car: its driver's command, with no throttle while the motor is dead.
  vehicle::ActuatorCommand applied() const {
    return stalled ? vehicle::ActuatorCommand{0.0, command.curvature_per_m} : command;
  }
};

}  // namespace detail

struct Simulation::Impl {
  using CarAgent = detail::CarAgent;

  Impl(const LoadedScenario& loaded, std::shared_ptr<RecordStore> store);

  // construction
  void AddCars();
  void AddObstacles();
  void ConnectServer();
  void AddSensorsAndBoards();
  void AddOracleDrivers();
  void ScheduleFaults();  // sim/loop/faults.cc
  void ScheduleRecording();
  void ScheduleWorldStep();

  void Emit(Event event);
  void StepWorld();
  void RecordContacts(Time t);
  void Track(CarAgent* agent, Time t);
  void MeasureObstacleGaps();
  void StepDriver(CarAgent* agent);
  std::optional<double> ObstacleGap(const CarAgent& agent) const;
  bool StepClient(CarAgent* agent, const world::Vec2& p_map, bool navigation_failed = false);
  void AddStack(CarAgent* agent, SensorSuite* suite, const PerceptionTopics& perception,
                NodeGraph* graph);
  void Sample();
  void ReceiveAtCar(int car_id, const world::V2IMessage& message);
  std::unique_ptr<Board> MakeBoard(CarAgent* agent, const PlatformProfile& profile,
                                   SensorSuite* suite);
  void JudgeLanes(CarAgent* agent, const stack::LanePoints& lanes, Time stamp);
  void JudgeGrid(CarAgent* agent, const stack::Grid234& grid);
  void Finish();
  // v2i.link: realtime: runs to the end paced to the wall clock (sim/v2i/realtime_pacing.h).
  void RunRealTime();

  const LoadedScenario& loaded;
  const Scenario& scenario;
  const Time end;
  Kernel kernel;
  RngStreams streams;
  vehicle::PhysicsWorld physics;
  std::vector<CarAgent> agents;
  std::map<int, std::size_t> agent_index;  // car id -> agents index
  TrafficLightNode server;
  std::unique_ptr<EmbeddedV2ILink> link;
  // v2i.link: realtime: the cars' link to a server outside the run, instead of `link`
  std::unique_ptr<RealTimeV2ILink> realtime_link;
  V2ILink* to_server{nullptr};  // what the cars send on: `link` or `realtime_link`
  // the cars' sensors; camera frames are rendered only by whoever processes them
  world::FloorRaster floor;
  std::unique_ptr<SensorEnvironment> sensor_world;
  std::vector<std::unique_ptr<SensorSuite>> sensors;
  // driver: stack — the planners' static maps, by resolution (m); before the boards that use them
  std::map<double, std::unique_ptr<world::OccupancyMap>> static_maps;
  // per car (agents' order): its compute board, for the cars that run nodes on one
  std::vector<std::unique_ptr<Board>> boards;
  LaneJudgeParams lane_judge;
  std::shared_ptr<RecordStore> store;  // where samples and events go; null: into `record`
  RunRecord record;
};

}  // namespace autonomsim::sim
