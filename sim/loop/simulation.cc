#include "sim/loop/simulation.h"

#include <fmt/format.h>

#include <cmath>
#include <numbers>
#include <stdexcept>

#include "sim/loop/area_sensing.h"
#include "sim/loop/simulation_impl.h"

namespace autonomsim::sim {

namespace {

// The car's footprint where it stands now: its body's box at its pose.
world::OrientedBox FootprintOf(const detail::CarAgent& agent) {
  return world::OrientedBox{agent.car->pose(), agent.config->vehicle.length_m,
                            agent.config->vehicle.width_m};
}

}  // namespace
namespace {

using detail::CarAgent;
using detail::ObstacleOnRoute;

// The oracle looks this far ahead along its route for obstacles.
constexpr double kObstacleHorizon_m = 2.0;
// At the end of a real-time run, the longest we wait (wall time) for the broker to take the
// messages still on their way. Assumed: ample for a broker that is there, short if it is not.
constexpr std::chrono::seconds kRealTimeFlushTimeout{2};

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
  if (scenario.v2i.link == V2ILinkKind::kMqtt) {
    return MakeMqttEndpoint(scenario.v2i.mqtt, scenario.traffic_lights, std::move(ids));
  }
  return std::make_unique<EmbeddedTrafficLightEndpoint>(scenario.traffic_lights, std::move(ids));
}

}  // namespace

Simulation::Impl::Impl(const LoadedScenario& loaded_scenario, std::shared_ptr<RecordStore> store_)
    : loaded(loaded_scenario),
      scenario(loaded_scenario.scenario),
      end(loaded_scenario.scenario.duration),
      streams(loaded_scenario.scenario.seed),
      physics(loaded_scenario.scenario.physics),
      server(&kernel, MakeServerEndpoint(loaded_scenario),
             [this](Event event) { Emit(std::move(event)); }),
      emit_event([this](Event event) { Emit(std::move(event)); }),
      store(std::move(store_)) {
  // The closed loop. At each instant the kernel runs, in this order (sim/core/priorities.h):
  // obstacles appear or go · V2I messages arrive · the server's lease ticks · sensors sample the
  // world at t · nodes run on the boards (perception, stack → actuator commands) · oracle cars'
  // clients and drivers set their actuators · the trajectory is sampled · the world steps from t
  // to t + step under the held commands, and the monitors judge it (collisions, route, gaps).
  AddCars();              // the cars in the Box2D world, each on its route
  AddSensorsAndBoards();  // sensors → nodes → actuators, per car
  ConnectServer();        // the traffic-light server and the V2I link to it
  AddObstacles();         // appearing and disappearing on schedule
  ScheduleFaults();       // the scenario's faults, struck and lifted on schedule
  AddOracleDrivers();     // oracle cars: intersection client and driver → actuators
  ScheduleRecording();    // trajectory samples
  ScheduleWorldStep();    // world step → monitors
}

void Simulation::Impl::AddCars() {
  agents.reserve(scenario.cars.size());
  for (std::size_t i = 0; i < scenario.cars.size(); ++i) {
    const LoadedCar& loaded_car = loaded.cars[i];
    const CarConfig& config = *loaded_car.config;
    const world::Pose2& start = loaded_car.start_pose;
    CarAgent agent;
    agent.config = &config;
    agent.route = &loaded_car.route;
    agent.car = &physics.AddCar(config.id, config.vehicle, start);
    agent.route_monitor = RouteMonitor({.car_id = config.id,
                                        .route = &loaded_car.route,
                                        .track = &loaded.track,
                                        .laps = config.laps},
                                       loaded_car.start_s_m);
    agent.driver.rear_axle_s_m =
        agent.route->path
            .Project(start.position() - 0.5 * config.vehicle.wheelbase_m * start.heading())
            .s_m;
    agent.metrics.id = config.id;
    agent.metrics.route = agent.route->name;
    agent.metrics.route_length_m = agent.route->path.length_m();
    agent_index[config.id] = agents.size();
    agents.push_back(std::move(agent));
  }
}

void Simulation::Impl::AddSensorsAndBoards() {
  floor = world::RasterizeFloor(loaded.track);
  try {  // the GL backend's context and each camera's renderer
    sensor_world = std::make_unique<SensorEnvironment>(&physics, floor, scenario.appearance,
                                                       scenario.camera_backend);
    for (const CarAgent& agent : agents) {
      const CarConfig& config = *agent.config;
      // On a board the cameras are the graph's source nodes, which capture the frames.
      const SensorSuiteOptions options{.camera_timers = !config.has_board()};
      sensors.push_back(std::make_unique<SensorSuite>(&kernel, sensor_world.get(), config.id,
                                                      config.sensors, streams, physics.step(),
                                                      options));
    }
  } catch (const vehicle::GlUnavailable& e) {
    throw ConfigError("camera_backend: gl: " + std::string(e.what()));
  }
  for (std::size_t i = 0; i < agents.size(); ++i) {
    boards.push_back(agents[i].config->has_board()
                         ? MakeBoard(&agents[i], *loaded.cars[i].profile, sensors[i].get())
                         : nullptr);
  }
}

void Simulation::Impl::ConnectServer() {
  std::vector<int> car_ids;
  for (const CarAgent& agent : agents) car_ids.push_back(agent.config->id);
  if (scenario.v2i.link == V2ILinkKind::kRealtime) {
    // the server is outside the run; the one in process is given no link and never answers
    realtime_link = ConnectRealTimeLink(
        scenario.v2i.mqtt, &kernel, car_ids,
        [this](int car_id, const world::V2IMessage& m) { ReceiveAtCar(car_id, m); });
    to_server = realtime_link.get();
    return;
  }
  link = std::make_unique<EmbeddedV2ILink>(
      &kernel, scenario.v2i, streams, car_ids,
      [this](int car_id, const world::V2IMessage& m) { server.OnMessage(car_id, m); },
      [this](int car_id, const world::V2IMessage& m) { ReceiveAtCar(car_id, m); },
      [this](int car_id, const world::V2IMessage& m, const std::string& cause) {
        Emit(Event{.t = kernel.Now(),
                   .type = EventKind::kV2iLost,
                   .car = car_id,
                   .detail = m.topic + " '" + m.payload + "'" +
                             (cause.empty() ? "" : " (" + cause + ")")});
      });
  server.set_link(link.get());
  to_server = link.get();
}

void Simulation::Impl::AddObstacles() {
  for (const ObstacleConfig& o : scenario.obstacles) {
    const vehicle::ObstacleBox box{o.name,
                                   world::Pose2{o.x_m, o.y_m, o.yaw_deg * std::numbers::pi / 180.0},
                                   o.length_m, o.width_m, o.height_m};
    const std::size_t index = physics.AddObstacle(box, false);
    auto set = [this, index, name = o.name](bool enabled) {
      physics.SetObstacleEnabled(index, enabled);
      Emit(Event{.t = kernel.Now(),
                 .type = enabled ? EventKind::kObstacleAppear : EventKind::kObstacleDisappear,
                 .obstacle = name});
    };
    kernel.ScheduleAt(
        FromSeconds(o.appear_s), [set] { set(true); }, kPriorityWorldChange);
    if (o.disappear_s) {
      kernel.ScheduleAt(
          FromSeconds(*o.disappear_s), [set] { set(false); }, kPriorityWorldChange);
    }
  }
  // which obstacles stand on which car's lane (for the oracle's ground-truth stop)
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
}

void Simulation::Impl::AddOracleDrivers() {
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
}

void Simulation::Impl::ScheduleRecording() {
  kernel.SchedulePeriodic(
      kZeroTime, scenario.output.trajectory_period, [this] { Sample(); }, kPriorityRecord);
}

void Simulation::Impl::ScheduleWorldStep() {
  kernel.SchedulePeriodic(
      kZeroTime, physics.step(), [this] { StepWorld(); }, kPriorityPhysics);
}

std::optional<bool> Simulation::Impl::StepClient(CarAgent* agent, const world::Vec2& p_map,
                                                 bool navigation_failed) {
  const int id = agent->config->id;
  stack::IntersectionClientInput input;
  input.now = kernel.Now();
  input.p_map = p_map;
  input.navigation_failed = navigation_failed;
  if (agent->config->intersection_client.enter_only_if_clear) {
    input.occupied_areas = OccupiedAreasSeenBy(*agent);
  }
  input.responses = std::move(agent->inbox);
  agent->inbox.clear();
  const stack::IntersectionClientOutput out =
      stack::StepIntersectionClient(agent->config->intersection_client, id,
                                    loaded.track.spec().intersections, input, &agent->client);
  // the server's records of what it received and did are the run's request/free/grant/denied
  // events (TrafficLightNode); a message the link lost is a v2i_lost event
  for (const world::Request& request : out.requests) {
    to_server->SendToServer(id, world::ToMessage(request));
  }
  for (const world::Free& free : out.frees) to_server->SendToServer(id, world::ToMessage(free));
  agent->waits.Observe(kernel.Now(), !out.may_proceed, out.waiting_for.value_or(-1), id, emit_event,
                       &agent->metrics);
  if (out.stuck) return std::nullopt;
  return out.may_proceed;
}

std::vector<int> Simulation::Impl::OccupiedAreasSeenBy(const CarAgent& agent) const {
  std::vector<world::OrientedBox> others;
  for (const CarAgent& other : agents) {
    if (&other != &agent) others.push_back(FootprintOf(other));
  }
  return OccupiedAreasSeen(WedgeOf(agent.car->pose(), agent.config->sensors.depth_camera.camera),
                           loaded.track.spec().intersections, others);
}

void Simulation::Impl::ReceiveAtCar(int car_id, const world::V2IMessage& message) {
  const world::Decoded<world::V2IPayload> decoded = world::Decode(message);
  if (!decoded || !std::holds_alternative<world::Response>(decoded.value())) return;
  const world::Response response = std::get<world::Response>(decoded.value());
  if (response.car != car_id) return;  // a broadcast for another car
  agents[agent_index.at(car_id)].inbox.push_back(response);
}

void Simulation::Impl::StepDriver(CarAgent* agent) {
  OracleDriverInput input;
  input.X_map_car = agent->car->pose();
  input.speed_mps = agent->car->forward_speed_mps();
  input.hold = agent->waits.waiting() || agent->route_monitor.parked();
  input.obstacle_gap_m = ObstacleGap(*agent);
  agent->command = StepOracleDriver(agent->config->oracle, agent->config->vehicle, *agent->route,
                                    input, &agent->driver);
  agent->car->SetCommand(agent->applied());
}

std::optional<double> Simulation::Impl::ObstacleGap(const CarAgent& agent) const {
  const world::Polyline& path = agent.route->path;
  const double front_s = agent.route_monitor.route_s_m() + 0.5 * agent.config->vehicle.length_m;
  std::optional<double> nearest;
  for (const ObstacleOnRoute& o : agent.obstacles_on_lane) {
    if (!physics.obstacle_enabled(o.index)) continue;
    double ahead = o.s_m - front_s;
    if (path.cyclic()) ahead = world::Remainder(ahead, path.length_m());
    const double gap = ahead - o.half_extent_m;
    if (ahead < -o.half_extent_m || gap > kObstacleHorizon_m) continue;
    if (!nearest || gap < *nearest) nearest = gap;
  }
  return nearest;
}

void Simulation::Impl::StepWorld() {
  if (kernel.Now() >= end) return;  // the world is complete at `end`
  // world step: t → t + step under the held actuator commands
  physics.Step();
  const Time t = kernel.Now() + physics.step();
  // monitors: contacts, each car along its route, gaps to obstacles
  RecordContacts(t);
  for (CarAgent& agent : agents) Track(&agent, t);
  MeasureObstacleGaps();
}

void Simulation::Impl::RecordContacts(Time t) {
  for (const vehicle::ContactEvent& contact : physics.TakeContacts()) {
    Event event{.t = t, .type = EventKind::kCollision, .car = contact.car_id};
    ++agents[agent_index.at(contact.car_id)].metrics.collisions;
    if (contact.with_car) {
      event.other_car = contact.other_car_id;
      ++agents[agent_index.at(contact.other_car_id)].metrics.collisions;
    } else {
      event.obstacle = contact.obstacle_name;
    }
    Emit(std::move(event));
  }
}

void Simulation::Impl::MeasureObstacleGaps() {
  for (CarAgent& agent : agents) {
    const vehicle::CarParams& car = agent.config->vehicle;
    const world::OrientedBox footprint = FootprintOf(agent);
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
  // granted: the server holds the intersection for the car; in real time the server is outside
  // the run, and what counts is what the car was told (its client holds it). Two pointers: the
  // std::function holds them without allocating, once per car and physics step.
  const auto holds = [this, agent](int area) {
    if (realtime_link) {
      return agent->client.phase == stack::IntersectionClientState::Phase::kHolding &&
             agent->client.intersection == area;
    }
    const std::optional<int> holder = server.Holder(area);
    return holder.has_value() && *holder == agent->config->id;
  };
  agent->route_monitor.Observe(t, agent->car->pose(), agent->car->forward_speed_mps(),
                               physics.step(), holds, emit_event, &agent->metrics);
}

void Simulation::Impl::Emit(Event event) {
  for (RunObserver* observer : observers) observer->OnEvent(event);
  if (store) {
    store->Append(event);
  } else {
    record.events.push_back(std::move(event));
  }
}

void Simulation::Impl::Sample() {
  for (const CarAgent& agent : agents) {
    const world::Pose2 pose = agent.car->pose();
    const TrajectorySample sample{
        .t = kernel.Now(),
        .car = agent.config->id,
        .x_m = pose.x_m,
        .y_m = pose.y_m,
        .yaw_rad = pose.yaw_rad,
        .speed_mps = agent.car->forward_speed_mps(),
        .steering_rad = agent.car->steering_angle_rad(),
        .throttle = agent.command.throttle,
        .curvature_cmd_per_m = agent.command.curvature_per_m,
        .lateral_error_m = agent.route_monitor.lateral_error_m(),
        .route_progress_m = agent.route_monitor.progress_m(),
    };
    for (RunObserver* observer : observers) observer->OnSample(sample);
    if (store) {
      store->Append(sample);
    } else {
      record.trajectory.push_back(sample);
    }
  }
}

void Simulation::Impl::Finish() {
  record.sim_duration = end;
  record.kernel_events = kernel.executed();
  for (CarAgent& agent : agents) {
    agent.route_monitor.Finish(&agent.metrics);
    agent.metrics.mean_speed_mps = agent.metrics.distance_m / ToSeconds(end);
    if (agent.metrics.perception) agent.lanes.Finish(&*agent.metrics.perception);
    record.cars.push_back(agent.metrics);
  }
  const world::TrafficLightServer::Counters c = server.counters();
  record.server = {c.requests, c.grants, c.denials, c.frees, c.lease_expiries, server.malformed()};
  if (realtime_link) {  // what went out to the broker and what came back; nothing is lost
    record.v2i = {realtime_link->sent(), realtime_link->received(), 0};
  } else {
    record.v2i = {link->sent(), link->delivered(), link->lost()};
  }
  std::vector<BoardMetrics> traced;
  for (std::size_t i = 0; i < boards.size(); ++i) {
    if (!boards[i]) continue;
    record.boards.push_back(boards[i]->Report(end));
    if (agents[i].config->platform.trace) {
      traced.push_back({boards[i]->name(), &boards[i]->metrics()});
    }
  }
  if (!traced.empty()) {
    if (std::ostream* out = store ? store->OpenTrace() : nullptr) {
      WriteTraceJson(traced, *out);  // straight to the folder, never whole in memory
    } else {
      record.trace_json = TraceJson(traced);
    }
  }
  if (store) {
    store->Close();
    record.store = store;
  }
}

Simulation::Simulation(const LoadedScenario& scenario, std::shared_ptr<RecordStore> store)
    : impl_(std::make_unique<Impl>(scenario, std::move(store))) {}

Simulation::~Simulation() = default;

namespace {

// The V2I link with observers: tells them of each message as it is sent, then sends it.
class TappedV2ILink final : public V2ILink {
 public:
  TappedV2ILink(V2ILink* link, const Kernel* kernel, const std::vector<RunObserver*>* observers)
      : link_(link), kernel_(kernel), observers_(observers) {}
  void SendToServer(int car_id, const world::V2IMessage& message) override {
    for (RunObserver* o : *observers_) o->OnV2iPublished(kernel_->Now(), car_id, message);
    link_->SendToServer(car_id, message);
  }
  void Broadcast(const world::V2IMessage& message) override {
    for (RunObserver* o : *observers_) o->OnV2iPublished(kernel_->Now(), std::nullopt, message);
    link_->Broadcast(message);
  }

 private:
  V2ILink* link_;
  const Kernel* kernel_;
  const std::vector<RunObserver*>* observers_;
};

}  // namespace

void Simulation::Impl::AddObserver(RunObserver* observer) {
  if (advanced_to != kZeroTime || kernel.executed() != 0 || finished) {
    throw std::logic_error("Simulation::AddObserver: the run has started");
  }
  observers.push_back(observer);
  if (!tapped_link) {
    tapped_link = std::make_unique<TappedV2ILink>(to_server, &kernel, &observers);
    to_server = tapped_link.get();
    if (link) server.set_link(tapped_link.get());
  }
  for (std::size_t i = 0; i < agents.size(); ++i) {
    if (boards[i]) observer->OnBoard(agents[i].config->id, *boards[i], *sensors[i]);
  }
}

void Simulation::AddObserver(RunObserver* observer) { impl_->AddObserver(observer); }

void Simulation::Run(const std::function<void(Time)>& progress, Duration progress_period) {
  if (impl_->finished) throw std::logic_error("Simulation::Run: the run is over");
  if (progress) {
    impl_->kernel.SchedulePeriodic(
        progress_period, progress_period, [this, &progress] { progress(impl_->kernel.Now()); },
        kPriorityRecord);
  }
  Finish();
}

void Simulation::AdvanceTo(Time t) {
  if (impl_->finished) throw std::logic_error("Simulation::AdvanceTo: the run is over");
  if (impl_->realtime_link) {
    throw std::logic_error(
        "Simulation::AdvanceTo: a real-time run (v2i.link: realtime) paces "
        "itself; Run it");
  }
  if (t < impl_->advanced_to || t > impl_->end) {
    throw std::logic_error(fmt::format("Simulation::AdvanceTo: {} s is outside [{} s, {} s]",
                                       ToSeconds(t), ToSeconds(impl_->advanced_to),
                                       ToSeconds(impl_->end)));
  }
  if (t == impl_->advanced_to) return;
  impl_->kernel.RunUntil(t - Duration{1});  // every event before t; those at t come next
  impl_->advanced_to = t;
}

Time Simulation::now() const { return impl_->advanced_to; }
Time Simulation::end() const { return impl_->end; }
bool Simulation::finished() const { return impl_->finished; }

void Simulation::Finish() {
  if (impl_->finished) throw std::logic_error("Simulation::Finish: the run is over");
  if (impl_->realtime_link) {
    impl_->RunRealTime();
  } else {
    impl_->kernel.RunUntil(impl_->end);
  }
  impl_->Finish();
  impl_->finished = true;
  impl_->advanced_to = impl_->end;
}

void Simulation::Inject(FaultClause fault) {
  if (impl_->finished) throw std::logic_error("Simulation::Inject: the run is over");
  if (impl_->realtime_link) {  // its faults are checked against the link at load
    throw std::logic_error("Simulation::Inject: not into a real-time run (v2i.link: realtime)");
  }
  const std::optional<int> car = FaultCar(fault);
  if (car && !impl_->agent_index.contains(*car)) {
    throw ConfigError(
        fmt::format("{}.car: the scenario has no car {}", ToName(KindOf(fault)), *car));
  }
  std::visit([this](auto& f) { f.at_s = ToSeconds(impl_->advanced_to); }, fault);
  // kept for the life of the run: the fault's actions may refer to it
  impl_->injected_faults.push_back(std::make_unique<FaultClause>(std::move(fault)));
  impl_->ScheduleFault(*impl_->injected_faults.back());
}

std::vector<Simulation::CarState> Simulation::Cars() const {
  std::vector<CarState> cars;
  for (const CarAgent& agent : impl_->agents) {
    CarState car{.id = agent.config->id,
                 .pose = agent.car->pose(),
                 .speed_mps = agent.car->forward_speed_mps(),
                 .steering_rad = agent.car->steering_angle_rad(),
                 .lateral_error_m = agent.route_monitor.lateral_error_m(),
                 .route_progress_m = agent.route_monitor.progress_m(),
                 .laps = agent.metrics.laps,
                 .estimate = agent.estimate};
    if (agent.config->drives_by_stack()) car.behavior_mode = stack::ToString(agent.behavior_mode);
    cars.push_back(std::move(car));
  }
  return cars;
}

std::vector<Simulation::IntersectionState> Simulation::Server() const {
  const auto* embedded =
      dynamic_cast<const EmbeddedTrafficLightEndpoint*>(&impl_->server.endpoint());
  std::vector<IntersectionState> areas;
  for (const world::IntersectionSpec& spec : impl_->loaded.track.spec().intersections) {
    IntersectionState area{.id = spec.id, .holder = impl_->server.Holder(spec.id).value_or(-1)};
    if (embedded) area.queue = embedded->server().Queue(spec.id);  // mqtt: another process's
    areas.push_back(std::move(area));
  }
  return areas;
}

std::vector<Simulation::BoardState> Simulation::Boards() const {
  std::vector<BoardState> boards;
  for (std::size_t i = 0; i < impl_->boards.size(); ++i) {
    const std::unique_ptr<Board>& board = impl_->boards[i];
    if (!board) continue;
    boards.push_back({.car = impl_->agents[i].config->id,
                      .name = board->name(),
                      .busy_cores = board->platform().cpu().busy_cores(),
                      .report = ReportJson(board->Report(impl_->advanced_to).report)});
  }
  return boards;
}

void Simulation::Impl::RunRealTime() {
  SteadyWallClock clock;
  Pacer pacer(&clock);
  pacer.Run(&kernel, end, [this] { realtime_link->DeliverReceived(); });
  // the cars' last frees should reach the server before the run lets go of the broker
  realtime_link->Flush(kRealTimeFlushTimeout);
  record.realtime = pacer.figures();
  record.realtime->messages_sent = realtime_link->sent();
  record.realtime->messages_received = realtime_link->received();
}

const RunRecord& Simulation::record() const { return impl_->record; }

RunRecord RunScenario(const LoadedScenario& scenario) {
  Simulation simulation(scenario);
  simulation.Run();
  return simulation.record();
}

}  // namespace autonomsim::sim
