#include "sim/car/stack_nodes.h"

#include <algorithm>
#include <memory>
#include <optional>
#include <stdexcept>
#include <utility>

#include "sim/car/stack_messages.h"
#include "stack/controller_server.h"

namespace autonomsim::sim {
namespace {

// ---- The messages between the stack's nodes ----

// CostmapMessage, PathMessage, IntersectionFree: sim/car/stack_messages.h.
struct EmergencyCall {  // /emergency (the carcontroller's SetBool service, as a topic)
  bool stop{false};
};
// /cmd_vel carries stack::Twist, /controller/status stack::ControllerStatus.

// Message types and sizes (CDR, 4-byte encapsulation header included). Assumed from the ROS 2
// message definitions: a std_msgs/Header with frame id "map"/"odom" is 16 B; a PoseStamped 72 B.
MessageType OdometryType() { return {"nav_msgs/Odometry", 720, false}; }  // 2 frame ids, 2×36 cov
MessageType PathType(std::size_t poses) {
  return {"nav_msgs/Path", 24 + 72 * static_cast<std::int64_t>(poses), false};
}
MessageType GoalsType(std::size_t poses) {  // the behaviour's goals and state
  return {"autonomsim/Behavior", 32 + 72 * static_cast<std::int64_t>(poses), false};
}
MessageType CostmapType(const stack::LocalCostmapParams& p) {  // nav2_msgs/Costmap: 100×100 + meta
  const auto cells = static_cast<std::int64_t>(std::lround(p.width_m / p.resolution_m) *
                                               std::lround(p.height_m / p.resolution_m));
  // fixed-size: the rolling window never changes its shape (shared in the controller's process)
  return {"nav2_msgs/Costmap", 96 + cells, true};
}
MessageType TwistType() { return {"geometry_msgs/Twist", 52, true}; }
MessageType BoolType(const char* name) { return {name, 8, true}; }
MessageType CarCommandType() { return {"autonomsim/CarCommand", 20, true}; }
// assumed: sized as the Hall sensor's TwistWithCovarianceStamped (344 B, sim/car/sensors.h): the
// same header and 6×6 covariance (a pose carries one double more, 8 B, which the model ignores)
MessageType PoseFixType() { return {"geometry_msgs/PoseWithCovarianceStamped", 344, false}; }
// The fix's covariance never reaches zero (the EKF inverts it): at least (1 mm)² and (1 mrad)².
constexpr double kMinFixVariance = 1e-6;

Transport DefaultTransport(const MessageType& type) {
  return type.fixed_size ? Transport::kZeroCopy : Transport::kDds;
}

template <class T>
TopicId<T> Topic(NodeGraph& graph, const std::string& name, const MessageType& type) {
  return graph.AddTopic<T>({.name = name, .type = type, .transport = DefaultTransport(type)});
}

MessageType SensorTopicType(const SensorStream& stream) {
  return {stream.type.name, stream.type.bytes, false};
}

NodeSpec SoftwareNode(const char* name) {
  return NodeSpec{.name = name, .mapping = NodeMappingConfig{.target = Target::kSw}};
}

// The stack's topics, made once. The members are initialised in this order, which is the order
// the topics are added to the graph in (the graph's topic ids follow it).
struct StackTopics {
  TopicId<vehicle::ImuReading> imu;
  TopicId<WheelSpeedMessage> wheel_speed;
  TopicId<stack::LocalizationEkfOutput> odometry;
  TopicId<CostmapMessage> costmap;
  TopicId<stack::BehaviorOutput> behavior;
  TopicId<PathMessage> plan;
  TopicId<stack::ControllerStatus> status;
  TopicId<IntersectionFree> intersection_free;
  TopicId<stack::Twist> cmd_vel;
  TopicId<vehicle::ActuatorCommand> command;
  PerceptionTopics perception;  // made by AddPerceptionNodes
};

StackTopics AddStackTopics(NodeGraph& graph, const StackConfig& config, const SensorSuite& sensors,
                           const PerceptionTopics& perception) {
  const auto goals = static_cast<std::size_t>(config.behavior.waypoint_horizon_m /
                                              config.behavior.waypoint_spacing_m);
  return StackTopics{
      .imu = Topic<vehicle::ImuReading>(graph, sensors.imu_stream().topic,
                                        SensorTopicType(sensors.imu_stream())),
      .wheel_speed = Topic<WheelSpeedMessage>(graph, sensors.wheel_speed_stream().topic,
                                              SensorTopicType(sensors.wheel_speed_stream())),
      .odometry = Topic<stack::LocalizationEkfOutput>(graph, "/odometry/filtered", OdometryType()),
      .costmap = Topic<CostmapMessage>(graph, "/local_costmap/costmap_raw",
                                       CostmapType(config.local_costmap)),
      .behavior = Topic<stack::BehaviorOutput>(graph, "/behavior", GoalsType(goals)),
      .plan = Topic<PathMessage>(graph, "/plan", PathType(0)),
      .status = Topic<stack::ControllerStatus>(graph, "/controller/status",
                                               BoolType("autonomsim/ControllerStatus")),
      .intersection_free =
          Topic<IntersectionFree>(graph, "/intersection_free", BoolType("std_msgs/Bool")),
      .cmd_vel = Topic<stack::Twist>(graph, "/cmd_vel", TwistType()),
      .command = Topic<vehicle::ActuatorCommand>(graph, kCarCommandTopic, CarCommandType()),
      .perception = perception};
}

// Subscriptions that only keep their message for the node's timer, at the subscription_cache
// cost: Keep stores it as `store` says; KeepLatest into `owner->*slot`.
class Cache {
 public:
  explicit Cache(NodeGraph& graph)
      : graph_(graph),
        options_{.loaned = true,
                 .cost = graph.platform().profile().Component("subscription_cache").sw} {}

  template <class T>
  void Keep(NodeId node, TopicId<T> topic, std::function<void(const T&, Time stamp)> store) {
    graph_.AddSubscription<T>(
        node, topic,
        [store = std::move(store)](const T& v, Time stamp, Outbox&) { store(v, stamp); }, options_);
  }
  template <class T, class Owner>
  void KeepLatest(NodeId node, TopicId<T> topic, std::shared_ptr<Owner> owner,
                  std::optional<T> Owner::*slot) {
    Keep<T>(node, topic,
            [owner = std::move(owner), slot](const T& v, Time) { (*owner).*slot = v; });
  }

 private:
  NodeGraph& graph_;
  SubscriptionOptions options_;
};

// ---- The nodes, in the order they are added (node ids follow it) ----

// imu_driver, hall_sensor: publish each reading the suite samples (same instants, after it). The
// suite samples on the sensor's own clock (kPrioritySensor), not in the driver's tick as the
// cameras are (sim/loop/car_boards.cc): a tick's handler runs when the node's job starts, which is
// later than the tick while the node is hung or overrun, and a reading taken then (and the noise
// draws, one per tick) would differ from the sensor's.
void AddSensorDrivers(NodeGraph& graph, SensorSuite& sensors, const StackTopics& topics) {
  auto imu_latest = std::make_shared<vehicle::ImuReading>();
  sensors.OnImu([imu_latest](const vehicle::ImuReading& r) { *imu_latest = r; });
  AddSourceNode(graph, SoftwareNode("imu_driver"), topics.imu, sensors.imu_stream().first,
                sensors.imu_stream().period, [imu_latest](Time) { return *imu_latest; });
  auto speed_latest = std::make_shared<WheelSpeedMessage>();
  sensors.OnWheelSpeed([speed_latest](const WheelSpeedMessage& m) { *speed_latest = m; });
  AddSourceNode(graph, SoftwareNode("hall_sensor"), topics.wheel_speed,
                sensors.wheel_speed_stream().first, sensors.wheel_speed_stream().period,
                [speed_latest](Time) { return *speed_latest; });
}

// pose_fix (use_pose_fix only): the true pose with noise at rate_hz on /pose_fix.
TopicId<stack::PoseFix> AddPoseFixSource(NodeGraph& graph, const PoseFixConfig& fix,
                                         const StackContext& context) {
  if (!context.true_pose || !context.pose_fix_noise) {
    throw std::invalid_argument("AddStackNodes: the pose fix needs true_pose and its noise");
  }
  const auto topic = Topic<stack::PoseFix>(graph, "/pose_fix", PoseFixType());
  const Duration period = FromSeconds(1.0 / fix.rate_hz);
  AddSourceNode(
      graph, SoftwareNode("pose_fix"), topic, period, period,
      [fix, true_pose = context.true_pose, rng = std::make_shared<Rng>(*context.pose_fix_noise)](
          Time now) { return DrawPoseFix(fix, true_pose(), now, rng.get()); });
  return topic;
}

// ekf_filter_node: the EKF at 20 Hz on everything received since its last step.
// Returns the estimate's jump (StackControls::jump_localization).
std::function<void(double, double, double)> AddLocalizationNode(
    NodeGraph& graph, Cache& cache, const StackTopics& topics, const StackConfig& config,
    const StackContext& context,
    std::function<void(const stack::LocalizationEkfOutput&)> on_estimate) {
  struct State {
    stack::LocalizationEkfState ekf;
    stack::LocalizationEkfInput pending;
  };
  auto state = std::make_shared<State>();
  state->ekf =
      stack::InitialLocalizationEkfState(config.localization, kZeroTime, context.X_map_odom);
  const NodeId node = graph.AddNode(SoftwareNode("ekf_filter_node"));
  cache.Keep<vehicle::ImuReading>(node, topics.imu, [state](const vehicle::ImuReading& r, Time) {
    state->pending.imu.push_back({r.stamp, r.yaw_rad, r.yaw_rate_rad_per_s});
  });
  cache.Keep<WheelSpeedMessage>(node, topics.wheel_speed,
                                [state](const WheelSpeedMessage& m, Time) {
                                  state->pending.wheel_speed.push_back({m.stamp, m.speed_mps});
                                });
  if (config.localization.use_pose_fix) {
    const auto fix_topic = AddPoseFixSource(graph, config.pose_fix, context);
    cache.Keep<stack::PoseFix>(node, fix_topic, [state](const stack::PoseFix& f, Time) {
      state->pending.pose_fixes.push_back(f);
    });
  }
  const auto out = graph.AddPublisher(node, topics.odometry);
  graph.AddTimer(node, config.localization.period, config.localization.period,
                 [state, out, params = config.localization, on_estimate = std::move(on_estimate)](
                     Time now, Outbox& outbox) {
                   state->pending.now = now;
                   stack::LocalizationEkfOutput estimate =
                       stack::StepLocalizationEkf(params, state->pending, &state->ekf);
                   state->pending = {};
                   if (on_estimate) on_estimate(estimate);
                   const Time stamp = estimate.stamp;
                   outbox.Publish(out, std::move(estimate), stamp);
                 });
  return [state](double dx_m, double dy_m, double dyaw_rad) {
    stack::JumpLocalizationEstimate(dx_m, dy_m, dyaw_rad, &state->ekf);
  };
}

// vehicle_communication: the intersection client every 100 ms on the estimated position (and,
// with the client's release_on_failure, on whether the behaviour reported a failed navigation).
// The lab's blocking client (intersection_client.blocking) stuck in its wait publishes nothing:
// its timer callback has not returned (stack/intersection_client.h).
void AddVehicleCommunicationNode(
    NodeGraph& graph, Cache& cache, const StackTopics& topics, const StackContext& context,
    std::function<std::optional<bool>(const world::Vec2&, bool)> intersection_client) {
  struct State {
    std::optional<stack::LocalizationEkfOutput> odom;
    bool navigation_failed{false};
  };
  auto state = std::make_shared<State>();
  const NodeId node = graph.AddNode(SoftwareNode("vehicle_communication"));
  cache.KeepLatest(node, topics.odometry, state, &State::odom);
  if (context.intersection_client_watches_navigation) {
    cache.Keep<stack::BehaviorOutput>(node, topics.behavior,
                                      [state](const stack::BehaviorOutput& o, Time) {
                                        if (o.mode == stack::BehaviorMode::kFailed) {
                                          state->navigation_failed = true;
                                        }
                                      });
  }
  const auto out = graph.AddPublisher(node, topics.intersection_free);
  const Duration period = context.intersection_client_period;
  graph.AddTimer(node, period, period,
                 [state, out, client = std::move(intersection_client)](Time, Outbox& outbox) {
                   if (!state->odom) return;
                   const std::optional<bool> may_proceed =
                       client(state->odom->X_map_base.position(), state->navigation_failed);
                   if (!may_proceed) return;  // stuck in the blocking wait
                   outbox.Publish(out, IntersectionFree{*may_proceed}, state->odom->stamp);
                 });
}

// bt_navigator: the gate, the goals, recovery, ticked every 10 ms (stack/behavior.h). It
// publishes on the tick its hold, mode, attempt or recovery changes, and its goals at least every
// goals_period (the tree's blackboard is in-process in Nav2; here a topic).
void AddBehaviorNode(NodeGraph& graph, Cache& cache, const StackTopics& topics,
                     const stack::BehaviorParams& params, const StackContext& context,
                     const StackHooks& hooks) {
  struct State {
    stack::BehaviorState behavior;
    std::optional<stack::LocalizationEkfOutput> odom;
    bool intersection_free{true};
    std::optional<Time> intersection_free_stamp;
    std::optional<stack::FollowPathFailure> follow_path_failure;
    std::optional<bool> plan_failed;  // the newest /plan reply since the last tick
    // what the last publish said, as far as it decides the next (the goals go out on a period)
    struct Published {
      bool hold;
      stack::BehaviorMode mode;
      std::uint64_t attempt;
      Time at;
    };
    std::optional<Published> published;
  };
  auto state = std::make_shared<State>();
  const NodeId node = graph.AddNode(SoftwareNode("bt_navigator"));
  cache.KeepLatest(node, topics.odometry, state, &State::odom);
  cache.Keep<IntersectionFree>(node, topics.intersection_free,
                               [state](const IntersectionFree& f, Time stamp) {
                                 state->intersection_free = f.free;
                                 state->intersection_free_stamp = stamp;
                               });
  cache.Keep<stack::ControllerStatus>(
      node, topics.status, [state](const stack::ControllerStatus& s, Time) {
        if (s.failed) state->follow_path_failure = {s.attempt, s.collision_ahead};
      });
  cache.Keep<PathMessage>(node, topics.plan,
                          [state](const PathMessage& p, Time) { state->plan_failed = !p.ok; });
  const auto out = graph.AddPublisher(node, topics.behavior);
  graph.AddTimer(
      node, params.tick_period, params.tick_period,
      [state, out, params, route = context.route, intersections = context.intersections,
       mission_done = hooks.mission_done,
       on_behavior = hooks.on_behavior](Time now, Outbox& outbox) {
        if (!state->odom) return;
        const world::Vec2 p = state->odom->X_map_base.position();
        const stack::BehaviorInput input{
            .now = now,
            .p_map = p,
            .intersection_free = state->intersection_free,
            .intersection_free_stamp = state->intersection_free_stamp,
            .follow_path_failure = state->follow_path_failure,
            .plan_failed = state->plan_failed,
            .mission_done = mission_done && mission_done(),
            .near_intersection = params.patient_in_queue &&
                                 stack::UseFollowPath(*intersections, p, params.queue_margin_m),
            .in_stop_zone = params.intersection_free_timeout > kZeroTime &&
                            stack::InStopZone(*intersections, p)};
        state->plan_failed.reset();
        stack::BehaviorOutput result = stack::StepBehavior(params, *route, input, &state->behavior);
        if (on_behavior) on_behavior(result);
        const std::optional<State::Published>& last = state->published;
        const bool changed = !last || last->hold != result.hold || last->mode != result.mode ||
                             last->attempt != result.attempt ||
                             result.recovery != stack::RecoveryAction::kNone;
        if (!changed && now - last->at < params.goals_period) return;
        state->published = State::Published{result.hold, result.mode, result.attempt, now};
        outbox.Publish(out, std::move(result), state->odom->stamp);
      });
}

// planner_server: a plan through the behaviour's goals, at 1 Hz.
void AddPlannerNode(NodeGraph& graph, Cache& cache, const StackTopics& topics,
                    const StackConfig& config, const stack::GlobalCostmap& global_costmap) {
  struct State {
    const stack::Costmap2D* costmap{nullptr};
    std::optional<stack::LocalizationEkfOutput> odom;
    std::vector<world::Vec2> goals;
    std::uint64_t plans{0};
    stack::PlannerScratch search;
    stack::PlanLegMemo legs;  // the costmap is static: a leg between the same two goals is kept
  };
  config.planner.Validate();  // once here: PlanThroughPoses takes them as validated
  auto state = std::make_shared<State>();
  state->costmap = &global_costmap.costmap();
  const NodeId node = graph.AddNode(SoftwareNode("planner_server"));
  cache.KeepLatest(node, topics.odometry, state, &State::odom);
  cache.Keep<stack::BehaviorOutput>(
      node, topics.behavior,
      [state](const stack::BehaviorOutput& o, Time) { state->goals = o.goals; });
  const auto out = graph.AddPublisher(node, topics.plan);
  graph.AddTimer(
      node, config.planner_period, config.planner_period,
      [state, out, params = config.planner](Time, Outbox& outbox) {
        if (!state->odom || state->goals.empty()) return;
        stack::GlobalPlan plan =
            stack::PlanThroughPoses(params, *state->costmap, state->odom->X_map_base.position(),
                                    state->goals, &state->search, &state->legs);
        PathMessage message{
            .path = std::make_shared<const std::vector<world::Vec2>>(std::move(plan.path_m)),
            .id = ++state->plans,
            .ok = plan.ok()};
        const std::size_t poses = message.path->size();
        outbox.Publish(out, std::move(message), state->odom->stamp, PathType(poses).bytes);
      });
}

// What the local costmap's node and its transform listener share.
struct LocalCostmapState {
  std::unique_ptr<stack::LocalCostmap> costmap;
  // The obstacle layer's obstacles_: the newest grid's marks, written into the layer at every
  // update until the next grid replaces them (obstacle_layer.cpp:45-62, 75-87); empty after a
  // grid whose transform never came. A costmap clear keeps them (the layer's reset() only resets
  // its grid, obstacle_layer.cpp:98-101).
  std::vector<stack::CostmapMark> obstacles;
  // The listener's two newest odom→base_link transforms (the newest also centres the window).
  std::optional<stack::LocalizationEkfOutput> odom;
  std::optional<stack::StampedPose> before;
  struct WaitingGrid {
    stack::Grid234 grid;
    Time now{kZeroTime};  // when its callback ran: the time it is placed at
  };
  std::optional<WaitingGrid> waiting;  // a grid callback blocked in canTransform
};

// Places `grid` with the transform at `now` if the listener has it (stack::TransformAt).
bool PlaceGrid(LocalCostmapState* s, const stack::ObstacleLayerParams& layer,
               const stack::ObstacleGridParams& grid_params, const stack::Grid234& grid, Time now) {
  if (!s->odom) return false;
  const std::optional<world::Pose2> X_odom_base =
      stack::TransformAt(s->before, {s->odom->stamp, s->odom->X_odom_base}, now);
  if (!X_odom_base) return false;
  s->obstacles = stack::StepObstacleLayer(layer, grid_params, grid, *X_odom_base);
  return true;
}

// local_costmap's TF listener (the lab's tf2_ros::TransformListener spins a node and thread of its
// own, so the transforms arrive while the costmap's executor waits): keeps the transforms and ends
// a grid callback's wait once the transform at its time has come.
void AddLocalCostmapListener(NodeGraph& graph, Cache& cache, const StackTopics& topics,
                             const StackConfig& config,
                             const stack::ObstacleGridParams& grid_params, NodeId costmap_node,
                             std::shared_ptr<LocalCostmapState> state) {
  NodeSpec spec = SoftwareNode("local_costmap_tf");
  spec.cost = graph.platform().profile().Component("subscription_cache");
  const NodeId node = graph.AddNode(std::move(spec));
  cache.Keep<stack::LocalizationEkfOutput>(
      node, topics.odometry,
      [state, &graph, costmap_node, layer = config.obstacle_layer, grid_params](
          const stack::LocalizationEkfOutput& o, Time) {
        LocalCostmapState& s = *state;
        if (s.odom) s.before = stack::StampedPose{s.odom->stamp, s.odom->X_odom_base};
        s.odom = o;
        if (s.waiting && PlaceGrid(&s, layer, grid_params, s.waiting->grid, s.waiting->now)) {
          s.waiting.reset();
          graph.ReleaseJob(costmap_node);
        }
      });
}

// local_costmap: the obstacle layer from the grid + inflation, rolling, 5 Hz. A grid's callback
// clears the layer's obstacles and waits, holding the node (the lab's costmap executor blocks in
// canTransform and its update blocks on the layer's mutex), until the transform at the time it
// ran arrives (stack::TransformAt) or transform_timeout passes, when the grid is dropped
// (obstacle_layer.cpp:40-65).
void AddLocalCostmapNode(NodeGraph& graph, Cache& cache, const StackTopics& topics,
                         const StackConfig& config, const stack::ObstacleGridParams& grid_params,
                         const Kernel& kernel) {
  // once here: StepObstacleLayer takes them as validated
  config.obstacle_layer.Validate();
  grid_params.Validate();
  auto state = std::make_shared<LocalCostmapState>();
  state->costmap = std::make_unique<stack::LocalCostmap>(config.local_costmap);
  const NodeId node = graph.AddNode(SoftwareNode("local_costmap"));
  cache.Keep<stack::Grid234>(node, topics.perception.obstacles,
                             [state, &graph, &kernel, node, layer = config.obstacle_layer,
                              grid_params](const stack::Grid234& grid, Time) {
                               const Time now = kernel.Now();
                               state->obstacles.clear();
                               if (PlaceGrid(state.get(), layer, grid_params, grid, now)) return;
                               state->waiting = LocalCostmapState::WaitingGrid{grid, now};
                               graph.HoldJob(node, layer.transform_timeout,
                                             [state] { state->waiting.reset(); });
                             });
  cache.Keep<stack::BehaviorOutput>(
      node, topics.behavior,
      [state, params = config.local_costmap](const stack::BehaviorOutput& o, Time) {
        if (stack::ClearsLocalCostmap(o.recovery))
          state->costmap = std::make_unique<stack::LocalCostmap>(params);
      });
  const auto out = graph.AddPublisher(node, topics.costmap);
  const Duration period = FromSeconds(1.0 / config.local_costmap.update_rate_hz);
  graph.AddTimer(node, period, period, [state, out](Time, Outbox& outbox) {
    if (!state->odom) return;
    const stack::Costmap2D& grid = state->costmap->Step(
        {.p_robot = state->odom->X_odom_base.position(), .marks = state->obstacles});
    outbox.Publish(out, CostmapMessage{std::make_shared<const stack::Costmap2D>(grid)},
                   state->odom->stamp);
  });
  AddLocalCostmapListener(graph, cache, topics, config, grid_params, node, std::move(state));
}

// What the controller server's node keeps of its messages for the next cycle.
struct ControllerNodeState {
  struct Lanes {                           // the newest LanePoints, decoded to base_link
    std::vector<world::Vec2> points_base;  // empty unless valid
    bool valid{false};
    Time stamp{kZeroTime};
  };
  std::optional<stack::LocalizationEkfOutput> odom;
  std::optional<Lanes> lanes;
  std::optional<PathMessage> path;  // the newest successful plan
  std::shared_ptr<const stack::Costmap2D> costmap;
  bool costmap_can_collide{false};  // stack::CanCollide(*costmap), once per costmap
  bool hold{true};                  // nothing to do before the behaviour's first goals
  std::uint64_t attempt{0};         // the behaviour's FollowPath action
  stack::ControllerServerState server;
};

ControllerNodeState::Lanes DecodeLanes(const stack::LanePoints& lanes, Time stamp) {
  ControllerNodeState::Lanes decoded{.valid = lanes.valid != 0, .stamp = stamp};
  if (decoded.valid) {
    decoded.points_base.reserve(lanes.points.size());
    for (const stack::LanePoint& p : lanes.points) decoded.points_base.emplace_back(p.x_m, p.y_m);
  }
  return decoded;
}

// The cycle's input from what the node keeps (odom must be set).
stack::ControllerServerInput ControllerInput(const ControllerNodeState& s, Time now,
                                             const world::Pose2& X_map_odom) {
  stack::ControllerServerInput input{.now = now,
                                     .hold = s.hold,
                                     .attempt = s.attempt,
                                     .odometry_stamp = s.odom->stamp,
                                     .X_map_base = s.odom->X_map_base,
                                     .speed_mps = s.odom->speed_mps};
  if (s.lanes) {
    input.lanes = stack::ControllerLanes{
        .points_base = s.lanes->points_base, .valid = s.lanes->valid, .stamp = s.lanes->stamp};
  }
  if (s.path) input.path = stack::ControllerPath{.points_map = *s.path->path, .id = s.path->id};
  // (a costmap no pose can collide on is left out: the check's answer is the same, and it costs
  // a cost look-up per footprint sample and step of the horizon)
  if (s.costmap && s.costmap_can_collide) {
    input.cell_cost = stack::LocalCostmapCost(s.costmap, X_map_odom);
  }
  return input;
}

// controller_server: LaneController or FollowPath by zone, 20 Hz (stack/controller_server.h).
void AddControllerNode(NodeGraph& graph, Cache& cache, const StackTopics& topics,
                       const StackConfig& config, const StackContext& context,
                       std::function<void(bool, bool)> on_control) {
  using State = ControllerNodeState;
  auto state = std::make_shared<State>();
  const NodeId node = graph.AddNode(SoftwareNode("controller_server"));
  cache.KeepLatest(node, topics.odometry, state, &State::odom);
  cache.Keep<stack::LanePoints>(
      node, topics.perception.lanes,
      [state](const stack::LanePoints& l, Time stamp) { state->lanes = DecodeLanes(l, stamp); });
  cache.Keep<PathMessage>(node, topics.plan, [state](const PathMessage& p, Time) {
    if (p.ok) state->path = p;
  });
  cache.Keep<CostmapMessage>(node, topics.costmap, [state](const CostmapMessage& c, Time) {
    state->costmap = c.costmap;
    state->costmap_can_collide = c.costmap && stack::CanCollide(*c.costmap);
  });
  cache.Keep<stack::BehaviorOutput>(node, topics.behavior,
                                    [state](const stack::BehaviorOutput& o, Time) {
                                      state->hold = o.hold;
                                      state->attempt = o.attempt;
                                    });
  const auto out = graph.AddPublisher(node, topics.cmd_vel);
  const auto status_out = graph.AddPublisher(node, topics.status);
  const stack::ControllerServerParams params{
      .lane_controller = config.lane_controller,
      .follow_path = config.follow_path,
      .zone_margin_m = config.controller_selector.zone_margin_m,
      .follow_path_without_line = config.controller_selector.follow_path_without_line,
      .progress_checker = config.progress_checker};
  graph.AddTimer(node, config.controller_period, config.controller_period,
                 [state, out, status_out, params, intersections = context.intersections,
                  X_map_odom = context.X_map_odom,
                  on_control = std::move(on_control)](Time now, Outbox& outbox) {
                   if (!state->odom) return;
                   const stack::ControllerServerOutput r = stack::StepControllerServer(
                       params, *intersections, ControllerInput(*state, now, X_map_odom),
                       &state->server);
                   if (on_control && r.controller != stack::ActiveController::kNone) {
                     on_control(r.controller == stack::ActiveController::kFollowPath,
                                r.status.collision_ahead);
                   }
                   if (r.cmd_vel) outbox.Publish(out, *r.cmd_vel, r.cmd_vel_stamp);
                   outbox.Publish(status_out, r.status, r.status_stamp);
                 });
}

// carcontroller: the PID on speed, 30 Hz, with its watchdog (stack/cruise_control.h).
void AddCruiseControlNode(NodeGraph& graph, Cache& cache, const StackTopics& topics,
                          const stack::CruiseControlParams& params, const Kernel& kernel,
                          std::optional<TopicId<EmergencyCall>> emergency) {
  struct State {
    stack::CruiseControlState cruise;
    std::optional<stack::VelocityCommand> command;
    std::optional<stack::OdometrySpeed> odometry;
    std::optional<bool> set_emergency;
    Time command_stamp{kZeroTime};
  };
  auto state = std::make_shared<State>();
  const NodeId node = graph.AddNode(SoftwareNode("carcontroller"));
  cache.Keep<stack::Twist>(
      node, topics.cmd_vel, [state, &kernel](const stack::Twist& t, Time stamp) {
        state->command = stack::VelocityCommand{kernel.Now(), t.speed_mps, t.yaw_rate_rad_per_s};
        state->command_stamp = stamp;
      });
  cache.Keep<stack::LocalizationEkfOutput>(
      node, topics.odometry, [state, &kernel](const stack::LocalizationEkfOutput& o, Time) {
        state->odometry = stack::OdometrySpeed{kernel.Now(), o.speed_mps};
      });
  if (emergency) {
    cache.Keep<EmergencyCall>(node, *emergency, [state](const EmergencyCall& call, Time) {
      state->set_emergency = call.stop;
    });
  }
  const auto out = graph.AddPublisher(node, topics.command);
  graph.AddTimer(node, params.period, params.period,
                 [state, out, params](Time now, Outbox& outbox) {
                   const stack::CruiseControlOutput r =
                       stack::StepCruiseControl(params,
                                                {.now = now,
                                                 .command = state->command,
                                                 .odometry = state->odometry,
                                                 .set_emergency = state->set_emergency},
                                                &state->cruise);
                   state->command.reset();
                   state->odometry.reset();
                   state->set_emergency.reset();
                   if (!r.publish) return;  // a stop's zero output goes out once
                   outbox.Publish(out, vehicle::ActuatorCommand{r.throttle, r.curvature_per_m},
                                  state->command_stamp);
                 });
}

// rt_carcontrol: the PWM generator takes the command.
void AddActuatorNode(NodeGraph& graph, const StackTopics& topics,
                     std::function<void(const vehicle::ActuatorCommand&)> actuate) {
  const NodeId node = graph.AddNode(SoftwareNode("rt_carcontrol"));
  graph.AddSubscription<vehicle::ActuatorCommand>(
      node, topics.command,
      [actuate = std::move(actuate)](const vehicle::ActuatorCommand& c, Time, Outbox&) {
        if (actuate) actuate(c);
      });
}

// ultrasonic_driver + emergency_stop (stack.emergency_stop.enabled only): each range reading on
// /ultrasonic; the stop's latch changes go to the carcontroller's /emergency.
void AddEmergencyStopNodes(NodeGraph& graph, SensorSuite& sensors,
                           const stack::EmergencyStopParams& params, TopicId<RangeMessage> range,
                           TopicId<EmergencyCall> emergency) {
  auto latest = std::make_shared<RangeMessage>();
  sensors.OnRange([latest](const RangeMessage& m) { *latest = m; });
  AddSourceNode(graph, SoftwareNode("ultrasonic_driver"), range, sensors.range_stream().first,
                sensors.range_stream().period, [latest](Time) { return *latest; });
  const NodeId node = graph.AddNode(SoftwareNode("emergency_stop"));
  const auto out = graph.AddPublisher(node, emergency);
  graph.AddSubscription<RangeMessage>(
      node, range,
      [params, out, state = std::make_shared<stack::EmergencyStopState>()](
          const RangeMessage& m, Time stamp, Outbox& outbox) {
        if (const std::optional<bool> call =
                stack::StepEmergencyStop(params, m.range_m, state.get())) {
          outbox.Publish(out, EmergencyCall{*call}, stamp);
        }
      });
}

}  // namespace

stack::PoseFix DrawPoseFix(const PoseFixConfig& config, const world::Pose2& X_map_base_true,
                           Time now, Rng* noise) {
  // x, y, then yaw: the draws' order is part of the run's reproducibility
  const double x_m = X_map_base_true.x_m + noise->Normal(0.0, config.position_stddev_m);
  const double y_m = X_map_base_true.y_m + noise->Normal(0.0, config.position_stddev_m);
  const double yaw_rad =
      world::WrapAngle(X_map_base_true.yaw_rad + noise->Normal(0.0, config.yaw_stddev_rad));
  const double var_p =
      std::max(config.position_stddev_m * config.position_stddev_m, kMinFixVariance);
  const double var_y = std::max(config.yaw_stddev_rad * config.yaw_stddev_rad, kMinFixVariance);
  stack::PoseFix fix;
  fix.stamp = now;
  fix.X_map_base = world::Pose2{x_m, y_m, yaw_rad};
  fix.covariance = Eigen::Vector3d(var_p, var_p, var_y).asDiagonal();
  return fix;
}

StackControls AddStackNodes(NodeGraph& graph, const Kernel& kernel, const StackConfig& config,
                            SensorSuite& sensors, const PerceptionTopics& perception,
                            const StackContext& context, StackHooks hooks) {
  if (!context.route || !context.intersections || !context.global_costmap ||
      !context.obstacle_grid) {
    throw std::invalid_argument("AddStackNodes: incomplete context");
  }
  const StackTopics topics = AddStackTopics(graph, config, sensors, perception);
  Cache cache(graph);
  AddSensorDrivers(graph, sensors, topics);
  StackControls controls;
  controls.jump_localization =
      AddLocalizationNode(graph, cache, topics, config, context, std::move(hooks.on_estimate));
  // the emergency stop's topics come after the stack's, its nodes after the stack's nodes: a car
  // without it has the same graph as before it existed
  std::optional<TopicId<RangeMessage>> range;
  std::optional<TopicId<EmergencyCall>> emergency;
  if (config.emergency_stop.enabled) {
    range = Topic<RangeMessage>(graph, sensors.range_stream().topic,
                                SensorTopicType(sensors.range_stream()));
    emergency = Topic<EmergencyCall>(graph, "/emergency", BoolType("std_msgs/Bool"));
  }
  AddVehicleCommunicationNode(graph, cache, topics, context, std::move(hooks.intersection_client));
  AddBehaviorNode(graph, cache, topics, config.behavior, context, hooks);
  AddPlannerNode(graph, cache, topics, config, *context.global_costmap);
  AddLocalCostmapNode(graph, cache, topics, config, *context.obstacle_grid, kernel);
  AddControllerNode(graph, cache, topics, config, context, std::move(hooks.on_control));
  AddCruiseControlNode(graph, cache, topics, config.cruise_control, kernel, emergency);
  AddActuatorNode(graph, topics, std::move(hooks.actuate));
  if (config.emergency_stop.enabled) {
    AddEmergencyStopNodes(graph, sensors, config.emergency_stop, *range, *emergency);
  }
  return controls;
}

}  // namespace autonomsim::sim
