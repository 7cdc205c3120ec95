#include "sim/loop/simulation.h"

#include <cmath>
#include <deque>
#include <map>
#include <numbers>
#include <stdexcept>

#include "sim/car/oracle_driver.h"
#include "sim/car/perception_nodes.h"
#include "sim/car/sensors.h"
#include "sim/car/stack_nodes.h"
#include "sim/core/kernel.h"
#include "sim/core/priorities.h"
#include "sim/core/random.h"
#include "sim/platform/node_graph.h"
#include "sim/v2i/mqtt_endpoint.h"
#include "sim/v2i/traffic_light_node.h"
#include "sim/v2i/v2i_link.h"
#include "stack/intersection_client.h"
#include "vehicle/physics_world.h"
#include "world/floor_raster.h"
#include "world/occupancy_map.h"

namespace autonomsim::sim {
namespace {

// An open route ends this far before its last point: the car parks there (its motor brakes it
// within ≈ v·τ ≈ 0.15 m).
constexpr double kArrivalMargin_m = 0.2;
// How far a car may move along its route between two physics steps, for the local projection.
constexpr double kTrackingWindow_m = 0.5;
// Lane detection is judged where its lane centre is this far ahead of the chassis centre (the
// lane tests' distance, issue 5).
constexpr double kLaneJudgeAhead_m = 0.5;
// ... and only where the route is straight (|κ| below this, checked every kLaneJudgeStep_m) from
// kLaneJudgeSettled_m behind the car to kLaneJudgeStraight_m ahead.
constexpr double kLaneJudgeSettled_m = 0.5;
constexpr double kLaneJudgeStraight_m = 0.9;  // the bird's-eye view ends ≈ 0.9 m ahead (§5)
constexpr double kLaneJudgeStep_m = 0.05;
constexpr double kStraightCurvature_per_m = 1e-3;
// Camera frames remembered per car for judging the perception's results (≈ 2 s at 30 fps).
constexpr std::size_t kRecentFrames = 64;
// The oracle looks this far ahead along its route for obstacles.
constexpr double kObstacleHorizon_m = 2.0;

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
  vehicle::ActuatorCommand command;
  bool waiting{false};  // the intersection client says: stop here until granted
  bool parked{false};   // done: laps driven or route ended
  std::vector<ObstacleOnRoute> obstacles_on_lane;
  std::optional<Time> wait_started;
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
};

Duration Phase(const RngStreams& streams, const std::string& name, Duration period) {
  // whole milliseconds, so that phases read well in traces
  Rng rng = streams.Stream(name);
  const auto period_ms = std::chrono::duration_cast<std::chrono::milliseconds>(period).count();
  if (period_ms <= 0) return kZeroTime;
  return std::chrono::milliseconds(
      static_cast<std::int64_t>(rng.Uniform01() * static_cast<double>(period_ms)));
}

// The traffic-light server: in process, or a tlserver behind a broker (v2i.link: mqtt).
std::unique_ptr<TrafficLightEndpoint> MakeServerEndpoint(const LoadedScenario& loaded) {
  std::vector<int> ids;
  for (const world::IntersectionSpec& i : loaded.track.spec().intersections) ids.push_back(i.id);
  const Scenario& scenario = loaded.scenario;
  if (scenario.v2i.link == "mqtt") {
    return MakeMqttEndpoint(scenario.v2i.mqtt, scenario.traffic_lights, std::move(ids));
  }
  return std::make_unique<EmbeddedTrafficLightEndpoint>(scenario.traffic_lights, std::move(ids));
}

}  // namespace

struct Simulation::Impl {
  explicit Impl(const LoadedScenario& loaded);

  void Emit(Event event) { record.events.push_back(std::move(event)); }
  void StepPhysics();
  void Track(CarAgent* agent, Time t);
  void MeasureObstacleGaps();
  void StepDriver(CarAgent* agent);
  std::optional<double> ObstacleGap(const CarAgent& agent) const;
  bool StepClient(CarAgent* agent, const world::Vec2& p_map);
  void AddStack(CarAgent* agent, SensorSuite* suite, const PerceptionTopics& perception,
                NodeGraph* graph);
  void Sample();
  void ReceiveAtCar(int car_id, const world::V2IMessage& message);
  std::unique_ptr<Board> MakeBoard(CarAgent* agent, const PlatformProfile& profile,
                                   SensorSuite* suite);
  void JudgeLanes(CarAgent* agent, const stack::LanePoints& lanes, Time stamp);
  void JudgeGrid(CarAgent* agent, const stack::Grid234& grid);
  void Finish();

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
  // the cars' sensors; camera frames are rendered only by whoever processes them
  world::FloorRaster floor;
  std::unique_ptr<SensorEnvironment> sensor_world;
  std::vector<std::unique_ptr<SensorSuite>> sensors;
  // driver: stack — the planners' static maps, by resolution (m); before the boards that use them
  std::map<double, std::unique_ptr<world::OccupancyMap>> static_maps;
  // per car (agents' order): its compute board, for the cars that run nodes on one
  std::vector<std::unique_ptr<Board>> boards;
  RunRecord record;
};

Simulation::Impl::Impl(const LoadedScenario& loaded_scenario)
    : loaded(loaded_scenario),
      scenario(loaded_scenario.scenario),
      end(loaded_scenario.scenario.duration),
      streams(loaded_scenario.scenario.seed),
      physics(loaded_scenario.scenario.physics),
      server(&kernel, MakeServerEndpoint(loaded_scenario),
             [this](Event event) { Emit(std::move(event)); }) {
  // cars, each on its route
  std::vector<int> car_ids;
  agents.reserve(scenario.cars.size());
  for (std::size_t i = 0; i < scenario.cars.size(); ++i) {
    const CarConfig& config = scenario.cars[i];
    CarAgent agent;
    agent.config = &config;
    agent.route = &loaded.routes[i];
    agent.car = &physics.AddCar(config.id, config.vehicle, loaded.start_poses[i]);
    agent.route_s_m = loaded.start_s_m[i];
    const world::Vec2 heading = loaded.start_poses[i].heading();
    agent.driver.rear_axle_s_m =
        agent.route->path
            .Project(loaded.start_poses[i].position() - 0.5 * config.vehicle.wheelbase_m * heading)
            .s_m;
    agent.metrics.id = config.id;
    agent.metrics.route = agent.route->name;
    agent.metrics.route_length_m = agent.route->path.length_m();
    agent_index[config.id] = agents.size();
    agents.push_back(std::move(agent));
    car_ids.push_back(config.id);
  }

  // each car's sensors
  floor = world::RasterizeFloor(loaded.track);
  sensor_world = std::make_unique<SensorEnvironment>(&physics, floor, scenario.appearance);
  for (std::size_t i = 0; i < agents.size(); ++i) {
    const CarConfig& config = *agents[i].config;
    // On a board the cameras are the graph's source nodes, which capture the frames.
    const SensorSuiteOptions options{.camera_timers = !config.has_board()};
    sensors.push_back(std::make_unique<SensorSuite>(
        &kernel, sensor_world.get(), config.id, config.sensors, streams, physics.step(), options));
    boards.push_back(config.has_board()
                         ? MakeBoard(&agents[i], *loaded.profiles[i], sensors.back().get())
                         : nullptr);
  }

  // the V2I link between the cars and the server
  link = std::make_unique<EmbeddedV2ILink>(
      &kernel, scenario.v2i, streams, car_ids,
      [this](int car_id, const world::V2IMessage& m) { server.OnMessage(car_id, m); },
      [this](int car_id, const world::V2IMessage& m) { ReceiveAtCar(car_id, m); },
      [this](int car_id, const world::V2IMessage& m) {
        Emit(Event{.t = kernel.Now(),
                   .type = "v2i_lost",
                   .car = car_id,
                   .detail = m.topic + " '" + m.payload + "'"});
      });
  server.set_link(link.get());

  // obstacles, appearing and disappearing on schedule
  for (const ObstacleConfig& o : scenario.obstacles) {
    const vehicle::ObstacleBox box{o.name,
                                   world::Pose2{o.x_m, o.y_m, o.yaw_deg * std::numbers::pi / 180.0},
                                   o.length_m, o.width_m, o.height_m};
    const std::size_t index = physics.AddObstacle(box, false);
    auto set = [this, index, name = o.name](bool enabled) {
      physics.SetObstacleEnabled(index, enabled);
      Emit(Event{.t = kernel.Now(),
                 .type = enabled ? "obstacle_appear" : "obstacle_disappear",
                 .obstacle = name});
    };
    kernel.ScheduleAt(
        FromSeconds(o.appear_s), [set] { set(true); }, kPriorityWorldChange);
    if (o.disappear_s) {
      kernel.ScheduleAt(
          FromSeconds(*o.disappear_s), [set] { set(false); }, kPriorityWorldChange);
    }
  }

  // which obstacles stand on which car's lane
  for (CarAgent& agent : agents) {
    for (std::size_t o = 0; o < physics.obstacle_count(); ++o) {
      const vehicle::ObstacleBox& box = physics.obstacle(o);
      const double half_extent = 0.5 * std::hypot(box.length_m, box.width_m);
      const world::Polyline::Projection on = agent.route->path.Project(box.pose.position());
      if (std::abs(on.lateral_m) < half_extent + 0.5 * agent.config->vehicle.width_m) {
        agent.obstacles_on_lane.push_back(ObstacleOnRoute{o, on.s_m, half_extent});
      }
    }
  }

  // the periodic work: clients, drivers, recording, physics
  for (CarAgent& agent : agents) {
    const std::string car = "car" + std::to_string(agent.config->id);
    if (agent.config->drives_by_stack()) continue;  // its nodes do this on its board
    const Duration client_period = agent.config->intersection_client.tick_period;
    const Duration driver_period = agent.config->oracle.period;
    kernel.SchedulePeriodic(
        Phase(streams, car + "/client_phase", client_period), client_period,
        [this, a = &agent] { StepClient(a, a->car->pose().position()); }, kPriorityClient);
    kernel.SchedulePeriodic(
        Phase(streams, car + "/driver_phase", driver_period), driver_period,
        [this, a = &agent] { StepDriver(a); }, kPriorityDriver);
  }
  kernel.SchedulePeriodic(
      kZeroTime, scenario.output.trajectory_period, [this] { Sample(); }, kPriorityRecord);
  kernel.SchedulePeriodic(
      kZeroTime, physics.step(), [this] { StepPhysics(); }, kPriorityPhysics);
}

std::unique_ptr<Board> Simulation::Impl::MakeBoard(CarAgent* agent, const PlatformProfile& profile,
                                                   SensorSuite* suite) {
  const CarConfig& config = *agent->config;
  const std::string name = "car" + std::to_string(config.id);
  auto board = std::make_unique<Board>(kernel, name, config.platform, profile, &streams);
  NodeGraph& graph = board->graph();
  // The camera drivers: each publishes its frames, captured at its stream's instants.
  const auto camera_topic = [&](const SensorStream& stream) {
    return graph.AddTopic<CameraFrame>(
        {.name = stream.topic, .type = MessageType{stream.type.name, stream.type.bytes, true}});
  };
  const NodeMappingConfig camera_cost{.cost = "camera_publisher"};
  const SensorStream& color = suite->color_stream();
  const SensorStream& depth = suite->depth_stream();
  const TopicId<CameraFrame> image = camera_topic(color);
  const TopicId<CameraFrame> depth_image = camera_topic(depth);
  AddSourceNode(
      graph, NodeSpec{.name = suite->color_camera().params().camera.name, .mapping = camera_cost},
      image, color.first, color.period, [suite, agent](Time) {
        CameraFrame frame = suite->CaptureColorFrame();
        agent->color_frames.emplace_back(frame.stamp, frame.X_map_car);
        if (agent->color_frames.size() > kRecentFrames) agent->color_frames.pop_front();
        return frame;
      });
  AddSourceNode(
      graph, NodeSpec{.name = suite->depth_camera().params().camera.name, .mapping = camera_cost},
      depth_image, depth.first, depth.period, [suite](Time) { return suite->CaptureDepthFrame(); });

  if (config.perception.enabled) {
    agent->metrics.perception.emplace();
    PerceptionHooks hooks{
        .on_grid = [this, agent](const stack::Grid234& grid, Time) { JudgeGrid(agent, grid); },
        .on_lanes = [this, agent](const stack::LanePoints& lanes,
                                  Time stamp) { JudgeLanes(agent, lanes, stamp); }};
    const PerceptionTopics topics =
        AddPerceptionNodes(graph, config.perception, config.platform.mapping, *suite, image,
                           depth_image, std::move(hooks));
    if (config.drives_by_stack()) AddStack(agent, suite, topics, &graph);
  }
  board->Finish(kZeroTime);
  return board;
}

void Simulation::Impl::AddStack(CarAgent* agent, SensorSuite* suite,
                                const PerceptionTopics& perception, NodeGraph* graph) {
  const CarConfig& config = *agent->config;
  const int id = config.id;
  agent->metrics.stack.emplace();
  // the map the car is given (its planner's), built once per resolution for all cars
  std::unique_ptr<world::OccupancyMap>& static_map =
      static_maps[config.stack.global_costmap.resolution_m];
  if (!static_map) {
    static_map = std::make_unique<world::OccupancyMap>(
        world::BuildStaticMap(loaded.track, config.stack.global_costmap.resolution_m));
  }
  const StackContext context{
      .route = &agent->route->path,
      .intersections = &loaded.track.spec().intersections,
      .static_map = static_map.get(),
      .obstacle_grid = &config.perception.obstacle_grid,
      .X_map_odom = agent->car->pose(),  // the start pose
      .intersection_client_period = config.intersection_client.tick_period,
      .true_pose = [agent] { return agent->car->pose(); },
      .pose_fix_noise = streams.Stream("car" + std::to_string(id) + "/pose_fix/noise")};
  StackHooks hooks{
      .intersection_client = [this, agent](const world::Vec2& p) { return StepClient(agent, p); },
      .actuate =
          [agent](const vehicle::ActuatorCommand& command) {
            agent->command = command;
            agent->car->SetCommand(command);
          },
      .mission_done = [agent] { return agent->parked; },
      .on_behavior =
          [this, agent, id](const stack::BehaviorOutput& out) {
            StackMetrics& m = *agent->metrics.stack;
            if (out.clear_costmaps) ++m.recoveries;
            if (out.mode == stack::BehaviorMode::kFailed) m.navigation_failed = true;
            if (out.mode != agent->behavior_mode) {
              agent->behavior_mode = out.mode;
              Emit(Event{.t = kernel.Now(),
                         .type = "behavior",
                         .car = id,
                         .detail = std::string(stack::ToString(out.mode)) +
                                   (out.mode == stack::BehaviorMode::kRecovery
                                        ? " (retry " + std::to_string(out.retries) + ")"
                                        : "")});
            }
          },
      .on_estimate =
          [agent](const stack::LocalizationEkfOutput& estimate) {
            StackMetrics& m = *agent->metrics.stack;
            const double error =
                (estimate.X_map_base.position() - agent->car->pose().position()).norm();
            m.max_localization_error_m = std::max(m.max_localization_error_m, error);
            m.final_localization_error_m = error;
          },
      .on_control =
          [agent](bool follow_path, bool collision) {
            StackMetrics& m = *agent->metrics.stack;
            ++m.control_cycles;
            if (follow_path) ++m.follow_path_cycles;
            if (collision) ++m.collision_cycles;
          }};
  AddStackNodes(*graph, kernel, config.stack, *suite, perception, context, std::move(hooks));
}

void Simulation::Impl::JudgeGrid(CarAgent* agent, const stack::Grid234& grid) {
  PerceptionMetrics& m = *agent->metrics.perception;
  ++m.grid_frames;
  const int lethal_above = stack::ObstacleLayerParams{}.lethal_above_count;
  for (int i = 0; i < stack::Grid234::kCells; ++i) {
    if (grid.data[static_cast<std::size_t>(i)] > lethal_above) {
      ++m.grid_obstacle_frames;
      break;
    }
  }
}

void Simulation::Impl::JudgeLanes(CarAgent* agent, const stack::LanePoints& lanes, Time stamp) {
  PerceptionMetrics& m = *agent->metrics.perception;
  ++m.lane_frames;
  if (lanes.valid == 0) return;
  ++m.lane_valid_frames;
  // the car's pose when the frame was taken
  const auto frame = std::find_if(agent->color_frames.rbegin(), agent->color_frames.rend(),
                                  [stamp](const auto& f) { return f.first == stamp; });
  if (frame == agent->color_frames.rend()) return;
  const world::Pose2& X_map_car = frame->second;
  // Judged where the real car steers by it (reference §6: outside the intersection areas and stop
  // boxes, where FollowPath takes over) and where the route is the painted lane's centre: on a
  // straight from behind the car (so that the car has settled on it) to beyond the judged point.
  // In corners the route's 0.9 m arcs are not the painted centre (the car cannot turn tighter).
  if (loaded.track.IntersectionAt(X_map_car.position()) != nullptr ||
      loaded.track.StopZoneAt(X_map_car.position())) {
    return;
  }
  const world::Polyline& path = agent->route->path;
  const double s_car = path.Project(X_map_car.position()).s_m;
  for (double ds = -kLaneJudgeSettled_m; ds <= kLaneJudgeStraight_m; ds += kLaneJudgeStep_m) {
    if (std::abs(path.CurvatureAt(path.NormalizeS(s_car + ds))) > kStraightCurvature_per_m) return;
  }
  // the detected lane centre where it is kLaneJudgeAhead_m ahead (the points run far to near)
  for (std::size_t i = 0; i + 1 < lanes.points.size(); ++i) {
    const stack::LanePoint& far = lanes.points[i];
    const stack::LanePoint& near = lanes.points[i + 1];
    if (!(far.x_m >= kLaneJudgeAhead_m && near.x_m <= kLaneJudgeAhead_m) || far.x_m == near.x_m) {
      continue;
    }
    const double w = (kLaneJudgeAhead_m - near.x_m) / (far.x_m - near.x_m);
    const double y_car = near.y_m + w * (far.y_m - near.y_m);
    const world::Vec2 left(-std::sin(X_map_car.yaw_rad), std::cos(X_map_car.yaw_rad));
    const world::Vec2 p_map =
        X_map_car.position() + kLaneJudgeAhead_m * X_map_car.heading() + y_car * left;
    const double error = std::abs(path.Project(p_map).lateral_m);
    m.lane_error_max_m = std::max(m.lane_error_max_m, error);
    agent->lane_error_sq_sum += error * error;
    ++m.lane_error_samples;
    return;
  }
}

bool Simulation::Impl::StepClient(CarAgent* agent, const world::Vec2& p_map) {
  const int id = agent->config->id;
  stack::IntersectionClientInput input;
  input.now = kernel.Now();
  input.p_map = p_map;
  input.responses = std::move(agent->inbox);
  agent->inbox.clear();
  const stack::IntersectionClientOutput out =
      stack::StepIntersectionClient(agent->config->intersection_client, id,
                                    loaded.track.spec().intersections, input, &agent->client);
  for (const world::Request& request : out.requests) {
    Emit(Event{
        .t = kernel.Now(), .type = "request", .car = id, .intersection = request.intersection});
    link->SendToServer(id, world::ToMessage(request));
  }
  for (const world::Free& free : out.frees) {
    Emit(Event{.t = kernel.Now(), .type = "free", .car = id});
    link->SendToServer(id, world::ToMessage(free));
  }
  const bool was_waiting = agent->waiting;
  agent->waiting = !out.may_proceed;
  if (!was_waiting && agent->waiting) agent->wait_started = kernel.Now();
  if (was_waiting && !agent->waiting && agent->wait_started) {
    const double wait_s = ToSeconds(kernel.Now() - *agent->wait_started);
    agent->metrics.total_wait_s += wait_s;
    agent->metrics.max_wait_s = std::max(agent->metrics.max_wait_s, wait_s);
    ++agent->metrics.waits;
    agent->wait_started.reset();
  }
  return out.may_proceed;
}

void Simulation::Impl::ReceiveAtCar(int car_id, const world::V2IMessage& message) {
  const world::Decoded<world::V2IPayload> decoded = world::Decode(message);
  if (!decoded || !std::holds_alternative<world::Response>(decoded.value())) return;
  const world::Response response = std::get<world::Response>(decoded.value());
  if (response.car != car_id) return;  // a broadcast for another car
  CarAgent& agent = agents[agent_index.at(car_id)];
  Emit(Event{.t = kernel.Now(), .type = response.granted ? "grant" : "denied", .car = car_id});
  agent.inbox.push_back(response);
}

void Simulation::Impl::StepDriver(CarAgent* agent) {
  OracleDriverInput input;
  input.X_map_car = agent->car->pose();
  input.speed_mps = agent->car->forward_speed_mps();
  input.hold = agent->waiting || agent->parked;
  input.obstacle_gap_m = ObstacleGap(*agent);
  agent->command = StepOracleDriver(agent->config->oracle, agent->config->vehicle, *agent->route,
                                    input, &agent->driver);
  agent->car->SetCommand(agent->command);
}

std::optional<double> Simulation::Impl::ObstacleGap(const CarAgent& agent) const {
  const world::Polyline& path = agent.route->path;
  const double front_s = agent.route_s_m + 0.5 * agent.config->vehicle.length_m;
  std::optional<double> nearest;
  for (const ObstacleOnRoute& o : agent.obstacles_on_lane) {
    if (!physics.obstacle_enabled(o.index)) continue;
    double ahead = o.s_m - front_s;
    if (path.cyclic()) ahead = std::remainder(ahead, path.length_m());
    const double gap = ahead - o.half_extent_m;
    if (ahead < -o.half_extent_m || gap > kObstacleHorizon_m) continue;
    if (!nearest || gap < *nearest) nearest = gap;
  }
  return nearest;
}

void Simulation::Impl::StepPhysics() {
  if (kernel.Now() >= end) return;  // the world is complete at `end`
  physics.Step();
  const Time t = kernel.Now() + physics.step();
  for (const vehicle::ContactEvent& contact : physics.TakeContacts()) {
    Event event{.t = t, .type = "collision", .car = contact.car_id};
    ++agents[agent_index.at(contact.car_id)].metrics.collisions;
    if (contact.with_car) {
      event.other_car = contact.other_car_id;
      ++agents[agent_index.at(contact.other_car_id)].metrics.collisions;
    } else {
      event.obstacle = contact.obstacle_name;
    }
    Emit(std::move(event));
  }
  for (CarAgent& agent : agents) Track(&agent, t);
  MeasureObstacleGaps();
}

void Simulation::Impl::MeasureObstacleGaps() {
  for (CarAgent& agent : agents) {
    const vehicle::CarParams& car = agent.config->vehicle;
    const world::OrientedBox footprint{agent.car->pose(), car.length_m, car.width_m};
    for (std::size_t o = 0; o < physics.obstacle_count(); ++o) {
      if (!physics.obstacle_enabled(o)) continue;
      const vehicle::ObstacleBox& box = physics.obstacle(o);
      const double reach =
          0.5 * (std::hypot(car.length_m, car.width_m) + std::hypot(box.length_m, box.width_m));
      if ((footprint.pose.position() - box.pose.position()).norm() - reach >
          kObstacleGapHorizon_m) {
        continue;  // too far for the exact distance to matter
      }
      const double gap =
          world::Distance(footprint, world::OrientedBox{box.pose, box.length_m, box.width_m});
      if (gap > kObstacleGapHorizon_m) continue;
      std::optional<double>& least = agent.metrics.min_obstacle_gap_m;
      if (!least || gap < *least) least = gap;
    }
  }
}

void Simulation::Impl::Track(CarAgent* agent, Time t) {
  const int id = agent->config->id;
  const world::Pose2 pose = agent->car->pose();
  const world::Polyline& path = agent->route->path;
  const double length = path.length_m();

  // progress and lateral error along the route
  const world::Polyline::Projection on =
      path.ProjectNear(pose.position(), agent->route_s_m, kTrackingWindow_m);
  double ds = on.s_m - agent->route_s_m;
  if (path.cyclic()) ds = std::remainder(ds, length);
  agent->route_s_m = on.s_m;
  agent->progress_m += ds;
  agent->lateral_error_m = on.lateral_m;
  agent->metrics.max_lateral_error_m =
      std::max(agent->metrics.max_lateral_error_m, std::abs(on.lateral_m));
  agent->lateral_sq_sum += on.lateral_m * on.lateral_m;
  ++agent->lateral_samples;
  agent->metrics.distance_m +=
      std::abs(agent->car->forward_speed_mps()) * ToSeconds(physics.step());

  // laps, and the end of the drive
  if (path.cyclic()) {
    while (agent->progress_m >= (agent->metrics.laps + 1) * length) {
      ++agent->metrics.laps;
      agent->metrics.lap_times_s.push_back(ToSeconds(t));
      Emit(Event{.t = t, .type = "lap", .car = id, .lap = agent->metrics.laps});
      if (!agent->parked && agent->config->laps && agent->metrics.laps >= *agent->config->laps) {
        agent->parked = true;
        Emit(Event{.t = t, .type = "parked", .car = id, .detail = "laps done"});
      }
    }
  } else if (!agent->parked && agent->route_s_m >= length - kArrivalMargin_m) {
    agent->parked = true;
    Emit(Event{.t = t, .type = "parked", .car = id, .detail = "route end"});
  }

  // ground truth: entering and leaving intersection areas
  const world::IntersectionSpec* inside = loaded.track.IntersectionAt(pose.position());
  const int area = inside ? inside->id : -1;
  if (area != agent->area) {
    if (agent->area >= 0) {
      Emit(Event{.t = t, .type = "exit", .car = id, .intersection = agent->area});
    }
    if (area >= 0) {
      const std::optional<int> holder = server.Holder(area);
      Emit(Event{.t = t,
                 .type = "enter",
                 .car = id,
                 .intersection = area,
                 .granted = holder.has_value() && *holder == id});
      ++agent->metrics.intersection_entries;
    }
    agent->area = area;
  }
}

void Simulation::Impl::Sample() {
  for (const CarAgent& agent : agents) {
    const world::Pose2 pose = agent.car->pose();
    record.trajectory.push_back(TrajectorySample{
        .t = kernel.Now(),
        .car = agent.config->id,
        .x_m = pose.x_m,
        .y_m = pose.y_m,
        .yaw_rad = pose.yaw_rad,
        .speed_mps = agent.car->forward_speed_mps(),
        .steering_rad = agent.car->steering_angle_rad(),
        .throttle = agent.command.throttle,
        .curvature_cmd_per_m = agent.command.curvature_per_m,
        .lateral_error_m = agent.lateral_error_m,
        .route_progress_m = agent.progress_m,
    });
  }
}

void Simulation::Impl::Finish() {
  record.sim_duration = end;
  record.kernel_events = kernel.executed();
  for (CarAgent& agent : agents) {
    if (agent.lateral_samples > 0) {
      agent.metrics.rms_lateral_error_m =
          std::sqrt(agent.lateral_sq_sum / static_cast<double>(agent.lateral_samples));
    }
    agent.metrics.mean_speed_mps = agent.metrics.distance_m / ToSeconds(end);
    if (agent.metrics.perception && agent.metrics.perception->lane_error_samples > 0) {
      PerceptionMetrics& m = *agent.metrics.perception;
      m.lane_error_rms_m =
          std::sqrt(agent.lane_error_sq_sum / static_cast<double>(m.lane_error_samples));
    }
    record.cars.push_back(agent.metrics);
  }
  const world::TrafficLightServer::Counters c = server.counters();
  record.server = {c.requests, c.grants, c.denials, c.frees, c.lease_expiries, server.malformed()};
  record.v2i = {link->sent(), link->delivered(), link->lost()};
  std::vector<BoardMetrics> traced;
  for (std::size_t i = 0; i < boards.size(); ++i) {
    if (!boards[i]) continue;
    record.boards.push_back(boards[i]->Report(end));
    if (agents[i].config->platform.trace) {
      traced.push_back({boards[i]->name(), &boards[i]->metrics()});
    }
  }
  if (!traced.empty()) record.trace_json = TraceJson(traced);
}

Simulation::Simulation(const LoadedScenario& scenario) : impl_(std::make_unique<Impl>(scenario)) {}

Simulation::~Simulation() = default;

void Simulation::Run(const std::function<void(Time)>& progress, Duration progress_period) {
  if (progress) {
    impl_->kernel.SchedulePeriodic(
        progress_period, progress_period, [this, &progress] { progress(impl_->kernel.Now()); },
        kPriorityRecord);
  }
  impl_->kernel.RunUntil(impl_->end);
  impl_->Finish();
}

const RunRecord& Simulation::record() const { return impl_->record; }

RunRecord RunScenario(const LoadedScenario& scenario) {
  Simulation simulation(scenario);
  simulation.Run();
  return simulation.record();
}

}  // namespace autonomsim::sim
