// The closed loop's internals, shared by its two files: simulation.cc (construction, the loop's
// steps, the monitors) and car_boards.cc (a car's board: cameras, perception and stack nodes).
#pragma once

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
#include "sim/loop/car_monitors.h"
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

// A static obstacle as seen along one car's route (ground truth, for the oracle).
struct ObstacleOnRoute {
  std::size_t index{0};       // in the physics world
  double s_m{0.0};            // where its centre projects on the route
  double half_extent_m{0.0};  // half its diagonal: a conservative reach in every direction
};

// One car: what drives it (the Box2D car and its actuator command, its oracle driver or its
// stack, its intersection client), and the loop's monitors that watch it (car_monitors.h).
struct CarAgent {
  const CarConfig* config{nullptr};
  const world::Route* route{nullptr};
  // actuation
  vehicle::Car* car{nullptr};
  vehicle::ActuatorCommand command;  // what its driver commands
  bool stalled{false};               // car_stall: the motor is dead (sim/loop/faults.h)
  // driver: oracle
  OracleDriverState driver;
  std::vector<ObstacleOnRoute> obstacles_on_lane;
  // driver: stack
  StackControls stack_controls;
  stack::BehaviorMode behavior_mode{stack::BehaviorMode::kDrive};
  std::optional<world::Pose2> estimate;  // the EKF's last estimate (Simulation::Cars)
  // the intersection client, and the responses for this car since its last step
  stack::IntersectionClientState client;
  std::vector<world::Response> inbox;
  // monitors (ground truth), and what they measured
  RouteMonitor route_monitor;
  WaitMonitor waits;
  LaneMonitor lanes;
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
  void ScheduleFault(const FaultClause& fault);
  void ScheduleRecording();
  void ScheduleWorldStep();

  void Emit(Event event);
  void AddObserver(RunObserver* observer);
  void StepWorld();
  void RecordContacts(Time t);
  void Track(CarAgent* agent, Time t);
  void MeasureObstacleGaps();
  void StepDriver(CarAgent* agent);
  std::optional<double> ObstacleGap(const CarAgent& agent) const;
  // may_proceed, or nothing while a blocking client is stuck in its wait.
  // The intersections whose area the agent's depth camera sees another car in (area_sensing.h).
  std::vector<int> OccupiedAreasSeenBy(const CarAgent& agent) const;
  std::optional<bool> StepClient(CarAgent* agent, const world::Vec2& p_map,
                                 bool navigation_failed = false);
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
  EmitEvent emit_event;  // Emit, for the monitors
  std::unique_ptr<EmbeddedV2ILink> link;
  // v2i.link: realtime: the cars' link to a server outside the run, instead of `link`
  std::unique_ptr<RealTimeV2ILink> realtime_link;
  V2ILink* to_server{
      nullptr};  // what the cars send on: `link` or `realtime_link`, or `tapped_link`
  // with observers: the link the cars and the server send on, which tells the observers
  std::unique_ptr<V2ILink> tapped_link;
  std::vector<RunObserver*> observers;
  // the cars' sensors; camera frames are rendered only by whoever processes them
  world::FloorRaster floor;
  std::unique_ptr<SensorEnvironment> sensor_world;
  std::vector<std::unique_ptr<SensorSuite>> sensors;
  // driver: stack — the planners' static maps, by resolution (m); before the boards that use them
  std::map<double, std::unique_ptr<world::OccupancyMap>> static_maps;
  // ... and their global costmaps, one per distinct global_costmap parameters (the planners only
  // read them: the lab's global costmap has no obstacle layer)
  std::vector<std::unique_ptr<stack::GlobalCostmap>> global_costmaps;
  // driver: perception — the nodes' tables, one per distinct parameters and camera
  PerceptionTablesCache perception_tables;
  // per car (agents' order): its compute board, for the cars that run nodes on one
  std::vector<std::unique_ptr<Board>> boards;
  LaneJudgeParams lane_judge;
  std::shared_ptr<RecordStore> store;  // where samples and events go; null: into `record`
  RunRecord record;
  // stepping (Simulation::AdvanceTo): every event before `advanced_to` has run
  Time advanced_to{kZeroTime};
  bool finished{false};
  std::vector<std::unique_ptr<FaultClause>> injected_faults;  // Simulation::Inject's
};

}  // namespace autonomsim::sim
