#include "sim/car/stack_nodes.h"

#include <memory>
#include <optional>
#include <stdexcept>
#include <utility>

namespace autonomsim::sim {

namespace {

// ---- The messages between the stack's nodes ----

struct CostmapMessage {  // /local_costmap/costmap_raw, in the odom frame
  std::shared_ptr<const stack::Costmap2D> costmap;
};
struct PathMessage {  // /plan, in the map frame
  std::shared_ptr<const std::vector<world::Vec2>> path;
  std::uint64_t id{0};
  bool ok{false};
};
struct ControllerStatus {  // /controller/status
  bool collision_ahead{false};
  bool follow_path{false};
};
struct IntersectionFree {  // /intersection_free
  bool free{true};
};
struct Twist {  // /cmd_vel
  double speed_mps{0.0};
  double yaw_rate_rad_per_s{0.0};
};

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

// Subscriptions that only keep their message for the node's timer, at the subscription_cache
// cost: Keep stores it as `store` says; KeepLatest into `owner->*slot`.
class Builder {
 public:
  explicit Builder(NodeGraph& graph)
      : graph_(graph),
        cache_{.loaned = true,
               .cost = graph.platform().profile().Component("subscription_cache").sw} {}

  template <class T>
  void Keep(NodeId node, TopicId<T> topic, std::function<void(const T&, Time stamp)> store) {
    graph_.AddSubscription<T>(
        node, topic,
        [store = std::move(store)](const T& v, Time stamp, Outbox&) { store(v, stamp); }, cache_);
  }
  template <class T, class Owner>
  void KeepLatest(NodeId node, TopicId<T> topic, std::shared_ptr<Owner> owner,
                  std::optional<T> Owner::*slot) {
    Keep<T>(node, topic,
            [owner = std::move(owner), slot](const T& v, Time) { (*owner).*slot = v; });
  }

 private:
  NodeGraph& graph_;
  SubscriptionOptions cache_;
};

template <class T>
struct Stamped {
  T value;
  Time stamp{kZeroTime};
};

}  // namespace

void AddStackNodes(NodeGraph& graph, const Kernel& kernel, const StackConfig& config,
                   SensorSuite& sensors, const PerceptionTopics& perception,
                   const StackContext& context, StackHooks hooks) {
  if (!context.route || !context.intersections || !context.static_map || !context.obstacle_grid) {
    throw std::invalid_argument("AddStackNodes: incomplete context");
  }
  Builder b(graph);
  const auto sw = [](const char* name) {
    return NodeSpec{.name = name, .mapping = NodeMappingConfig{.target = "sw"}};
  };

  // ---- topics ----
  const auto imu_topic = Topic<vehicle::ImuReading>(
      graph, sensors.imu_stream().topic,
      {sensors.imu_stream().type.name, sensors.imu_stream().type.bytes, false});
  const auto speed_topic = Topic<WheelSpeedMessage>(
      graph, sensors.wheel_speed_stream().topic,
      {sensors.wheel_speed_stream().type.name, sensors.wheel_speed_stream().type.bytes, false});
  const auto odometry =
      Topic<stack::LocalizationEkfOutput>(graph, "/odometry/filtered", OdometryType());
  const auto costmap_topic =
      Topic<CostmapMessage>(graph, "/local_costmap/costmap_raw", CostmapType(config.local_costmap));
  const auto behavior_topic = Topic<stack::BehaviorOutput>(
      graph, "/behavior",
      GoalsType(static_cast<std::size_t>(config.behavior.waypoint_horizon_m /
                                         config.behavior.waypoint_spacing_m)));
  const auto plan_topic = Topic<PathMessage>(graph, "/plan", PathType(0));
  const auto status_topic =
      Topic<ControllerStatus>(graph, "/controller/status", BoolType("autonomsim/ControllerStatus"));
  const auto free_topic =
      Topic<IntersectionFree>(graph, "/intersection_free", BoolType("std_msgs/Bool"));
  const auto cmd_vel = Topic<Twist>(graph, "/cmd_vel", TwistType());
  const auto command_topic =
      Topic<vehicle::ActuatorCommand>(graph, kCarCommandTopic, CarCommandType());

  // ---- sensor drivers: publish each reading the suite samples (same instants, after it) ----
  auto imu_latest = std::make_shared<vehicle::ImuReading>();
  sensors.OnImu([imu_latest](const vehicle::ImuReading& r) { *imu_latest = r; });
  AddSourceNode(graph, sw("imu_driver"), imu_topic, sensors.imu_stream().first,
                sensors.imu_stream().period, [imu_latest](Time) { return *imu_latest; });
  auto speed_latest = std::make_shared<WheelSpeedMessage>();
  sensors.OnWheelSpeed([speed_latest](const WheelSpeedMessage& m) { *speed_latest = m; });
  AddSourceNode(graph, sw("hall_sensor"), speed_topic, sensors.wheel_speed_stream().first,
                sensors.wheel_speed_stream().period,
                [speed_latest](Time) { return *speed_latest; });

  // ---- localization: EKF at 20 Hz on everything received since its last step ----
  {
    struct State {
      stack::LocalizationEkfState ekf;
      stack::LocalizationEkfInput pending;
    };
    auto state = std::make_shared<State>();
    state->ekf =
        stack::InitialLocalizationEkfState(config.localization, kZeroTime, context.X_map_odom);
    const NodeId node = graph.AddNode(sw("ekf_filter_node"));
    b.Keep<vehicle::ImuReading>(node, imu_topic, [state](const vehicle::ImuReading& r, Time) {
      state->pending.imu.push_back({r.stamp, r.yaw_rad, r.yaw_rate_rad_per_s});
    });
    b.Keep<WheelSpeedMessage>(node, speed_topic, [state](const WheelSpeedMessage& m, Time) {
      state->pending.wheel_speed.push_back({m.stamp, m.speed_mps});
    });
    if (config.localization.use_pose_fix) {
      if (!context.true_pose || !context.pose_fix_noise) {
        throw std::invalid_argument("AddStackNodes: the pose fix needs true_pose and its noise");
      }
      const PoseFixConfig& fix = config.pose_fix;
      const auto fix_topic = Topic<stack::PoseFix>(graph, "/pose_fix", PoseFixType());
      const Duration period = FromSeconds(1.0 / fix.rate_hz);
      AddSourceNode(graph, sw("pose_fix"), fix_topic, period, period,
                    [fix, true_pose = context.true_pose,
                     rng = std::make_shared<Rng>(*context.pose_fix_noise)](Time now) {
                      const world::Pose2 truth = true_pose();
                      stack::PoseFix f;
                      f.stamp = now;
                      f.X_map_base = world::Pose2{
                          truth.x_m + rng->Normal(0.0, fix.position_stddev_m),
                          truth.y_m + rng->Normal(0.0, fix.position_stddev_m),
                          world::WrapAngle(truth.yaw_rad + rng->Normal(0.0, fix.yaw_stddev_rad))};
                      const double var_p =
                          std::max(fix.position_stddev_m * fix.position_stddev_m, kMinFixVariance);
                      const double var_y =
                          std::max(fix.yaw_stddev_rad * fix.yaw_stddev_rad, kMinFixVariance);
                      f.covariance = Eigen::Vector3d(var_p, var_p, var_y).asDiagonal();
                      return f;
                    });
      b.Keep<stack::PoseFix>(node, fix_topic, [state](const stack::PoseFix& f, Time) {
        state->pending.pose_fixes.push_back(f);
      });
    }
    const auto out = graph.AddPublisher(node, odometry);
    const stack::LocalizationEkfParams params = config.localization;
    graph.AddTimer(node, config.localization.period, config.localization.period,
                   [state, params, out, on_estimate = hooks.on_estimate](Time now, Outbox& outbox) {
                     state->pending.now = now;
                     stack::LocalizationEkfOutput estimate =
                         stack::StepLocalizationEkf(params, state->pending, &state->ekf);
                     state->pending = {};
                     if (on_estimate) on_estimate(estimate);
                     const Time stamp = estimate.stamp;
                     outbox.Publish(out, std::move(estimate), stamp);
                   });
  }

  // ---- intersection client: every 100 ms on the estimated position ----
  {
    struct State {
      std::optional<stack::LocalizationEkfOutput> odom;
    };
    auto state = std::make_shared<State>();
    const NodeId node = graph.AddNode(sw("vehicle_communication"));
    b.KeepLatest(node, odometry, state, &State::odom);
    const auto out = graph.AddPublisher(node, free_topic);
    graph.AddTimer(node, context.intersection_client_period, context.intersection_client_period,
                   [state, out, client = hooks.intersection_client](Time, Outbox& outbox) {
                     if (!state->odom) return;
                     const IntersectionFree free{client(state->odom->X_map_base.position())};
                     outbox.Publish(out, free, state->odom->stamp);
                   });
  }

  // ---- behaviour: the gate, the goals, recovery (3 Hz) ----
  {
    struct State {
      stack::BehaviorState behavior;
      std::optional<stack::LocalizationEkfOutput> odom;
      bool intersection_free{true};
      bool collision_ahead{false};
      bool plan_failed{false};
    };
    auto state = std::make_shared<State>();
    const NodeId node = graph.AddNode(sw("bt_navigator"));
    b.KeepLatest(node, odometry, state, &State::odom);
    b.Keep<IntersectionFree>(node, free_topic, [state](const IntersectionFree& f, Time) {
      state->intersection_free = f.free;
    });
    b.Keep<ControllerStatus>(node, status_topic, [state](const ControllerStatus& s, Time) {
      state->collision_ahead = s.collision_ahead;
    });
    b.Keep<PathMessage>(node, plan_topic,
                        [state](const PathMessage& p, Time) { state->plan_failed = !p.ok; });
    const auto out = graph.AddPublisher(node, behavior_topic);
    graph.AddTimer(node, config.behavior.tick_period, config.behavior.tick_period,
                   [state, out, params = config.behavior, route = context.route,
                    mission_done = hooks.mission_done,
                    on_behavior = hooks.on_behavior](Time now, Outbox& outbox) {
                     if (!state->odom) return;
                     const stack::BehaviorInput input{
                         .now = now,
                         .p_map = state->odom->X_map_base.position(),
                         .intersection_free = state->intersection_free,
                         .collision_ahead = state->collision_ahead,
                         .plan_failed = state->plan_failed,
                         .mission_done = mission_done && mission_done()};
                     stack::BehaviorOutput result =
                         stack::StepBehavior(params, *route, input, &state->behavior);
                     if (result.clear_costmaps)
                       state->plan_failed = false;  // planned again after recovery
                     if (on_behavior) on_behavior(result);
                     outbox.Publish(out, std::move(result), state->odom->stamp);
                   });
  }

  // ---- global planner: through the behaviour's goals, at 1 Hz ----
  {
    struct State {
      std::optional<stack::GlobalCostmap> costmap;
      std::optional<stack::LocalizationEkfOutput> odom;
      std::vector<world::Vec2> goals;
      std::uint64_t plans{0};
    };
    auto state = std::make_shared<State>();
    state->costmap.emplace(config.global_costmap, *context.static_map);
    state->costmap->Update();
    const NodeId node = graph.AddNode(sw("planner_server"));
    b.KeepLatest(node, odometry, state, &State::odom);
    b.Keep<stack::BehaviorOutput>(
        node, behavior_topic,
        [state](const stack::BehaviorOutput& o, Time) { state->goals = o.goals; });
    const auto out = graph.AddPublisher(node, plan_topic);
    graph.AddTimer(
        node, config.planner_period, config.planner_period,
        [state, out, params = config.planner](Time, Outbox& outbox) {
          if (!state->odom || state->goals.empty()) return;
          stack::GlobalPlan plan = stack::PlanThroughPoses(
              params, state->costmap->costmap(), state->odom->X_map_base.position(), state->goals);
          PathMessage message{
              .path = std::make_shared<const std::vector<world::Vec2>>(std::move(plan.path_m)),
              .id = ++state->plans,
              .ok = plan.ok()};
          const std::size_t poses = message.path->size();
          outbox.Publish(out, std::move(message), state->odom->stamp, PathType(poses).bytes);
        });
  }

  // ---- local costmap: obstacle layer from the grid + inflation, rolling, 5 Hz ----
  {
    struct State {
      std::unique_ptr<stack::LocalCostmap> costmap;
      std::vector<stack::CostmapMark> pending;
      std::optional<stack::LocalizationEkfOutput> odom;
    };
    auto state = std::make_shared<State>();
    state->costmap = std::make_unique<stack::LocalCostmap>(config.local_costmap);
    const NodeId node = graph.AddNode(sw("local_costmap"));
    b.KeepLatest(node, odometry, state, &State::odom);
    b.Keep<stack::Grid234>(
        node, perception.obstacles,
        [state, layer = config.obstacle_layer, grid_params = *context.obstacle_grid](
            const stack::Grid234& grid, Time) {
          if (!state->odom) return;  // no transform for it yet
          std::vector<stack::CostmapMark> marks =
              stack::StepObstacleLayer(layer, grid_params, grid, state->odom->X_odom_base);
          state->pending.insert(state->pending.end(), marks.begin(), marks.end());
        });
    b.Keep<stack::BehaviorOutput>(
        node, behavior_topic,
        [state, params = config.local_costmap](const stack::BehaviorOutput& o, Time) {
          if (!o.clear_costmaps) return;
          state->costmap = std::make_unique<stack::LocalCostmap>(params);
          state->pending.clear();
        });
    const auto out = graph.AddPublisher(node, costmap_topic);
    const Duration period = FromSeconds(1.0 / config.local_costmap.update_rate_hz);
    graph.AddTimer(node, period, period, [state, out](Time, Outbox& outbox) {
      if (!state->odom) return;
      const stack::Costmap2D& grid = state->costmap->Step(
          {.p_robot = state->odom->X_odom_base.position(), .marks = std::move(state->pending)});
      state->pending.clear();
      outbox.Publish(out, CostmapMessage{std::make_shared<const stack::Costmap2D>(grid)},
                     state->odom->stamp);
    });
  }

  // ---- controller server: LaneController or FollowPath by zone, 20 Hz ----
  {
    struct State {
      std::optional<stack::LocalizationEkfOutput> odom;
      std::optional<Stamped<stack::LanePoints>> lanes;
      std::optional<PathMessage> path;
      std::shared_ptr<const stack::Costmap2D> costmap;
      bool hold{true};      // nothing to do before the behaviour's first goals
      bool stopped{false};  // the zero velocity of the last hold was published
      stack::PathFollowerState follower;
    };
    auto state = std::make_shared<State>();
    const NodeId node = graph.AddNode(sw("controller_server"));
    b.KeepLatest(node, odometry, state, &State::odom);
    b.Keep<stack::LanePoints>(node, perception.lanes,
                              [state](const stack::LanePoints& l, Time stamp) {
                                state->lanes = Stamped<stack::LanePoints>{l, stamp};
                              });
    b.Keep<PathMessage>(node, plan_topic, [state](const PathMessage& p, Time) {
      if (p.ok) state->path = p;
    });
    b.Keep<CostmapMessage>(node, costmap_topic,
                           [state](const CostmapMessage& c, Time) { state->costmap = c.costmap; });
    b.Keep<stack::BehaviorOutput>(
        node, behavior_topic,
        [state](const stack::BehaviorOutput& o, Time) { state->hold = o.hold; });
    const auto out = graph.AddPublisher(node, cmd_vel);
    const auto status_out = graph.AddPublisher(node, status_topic);
    graph.AddTimer(
        node, config.controller_period, config.controller_period,
        [state, out, status_out, lane_params = config.lane_controller,
         follow_params = config.follow_path, intersections = context.intersections,
         X_map_odom = context.X_map_odom, on_control = hooks.on_control](Time, Outbox& outbox) {
          if (!state->odom) return;
          const stack::LocalizationEkfOutput& odom = *state->odom;
          if (state->hold) {
            // cancelled: one zero velocity (Nav2's publishZeroVelocity), then silence
            if (!state->stopped) outbox.Publish(out, Twist{}, odom.stamp);
            state->stopped = true;
            outbox.Publish(status_out, ControllerStatus{}, odom.stamp);
            return;
          }
          state->stopped = false;
          stack::LethalQuery is_lethal;
          if (state->costmap) {
            is_lethal = [costmap = state->costmap, X_map_odom](const world::Vec2& p_map) {
              const std::optional<std::uint8_t> cost = costmap->CostAt(
                  stack::OdomFromMap(X_map_odom, {p_map.x(), p_map.y(), 0.0}).position());
              return cost && *cost == stack::kLethalObstacle;
            };
          }
          const bool follow = stack::UseFollowPath(*intersections, odom.X_map_base.position());
          Twist twist;
          bool collision = false;
          Time stamp = odom.stamp;
          if (follow) {
            if (state->path) {
              const stack::PathFollowerOutput r =
                  stack::StepPathFollower(follow_params,
                                          {.path = *state->path->path,
                                           .path_id = state->path->id,
                                           .X_F_base = odom.X_map_base,
                                           .speed_mps = odom.speed_mps,
                                           .is_lethal = is_lethal},
                                          &state->follower);
              twist = {r.speed_mps, r.yaw_rate_rad_per_s};
              collision = r.collision_ahead;
            }
          } else if (state->lanes) {
            std::vector<world::Vec2> points;
            const stack::LanePoints& lanes = state->lanes->value;
            if (lanes.valid != 0) {
              points.reserve(lanes.points.size());
              for (const stack::LanePoint& p : lanes.points) points.emplace_back(p.x_m, p.y_m);
            }
            const stack::LaneControllerOutput r =
                stack::StepLaneController(lane_params, {.lane_points_base = points,
                                                        .lanes_valid = lanes.valid != 0,
                                                        .speed_mps = odom.speed_mps,
                                                        .X_F_base = odom.X_map_base,
                                                        .is_lethal = is_lethal});
            twist = {r.speed_mps, r.yaw_rate_rad_per_s};
            collision = r.collision_ahead;
            stamp = state->lanes->stamp;
          }
          if (on_control) on_control(follow, collision);
          outbox.Publish(out, twist, stamp);
          outbox.Publish(status_out, ControllerStatus{collision, follow}, odom.stamp);
        });
  }

  // ---- cruise control: PID on speed, 30 Hz, watchdog ----
  {
    struct State {
      stack::CruiseControlState cruise;
      std::optional<stack::VelocityCommand> command;
      std::optional<stack::OdometrySpeed> odometry;
      Time command_stamp{kZeroTime};
      bool stopped_sent{false};  // the watchdog's zero output went out
    };
    auto state = std::make_shared<State>();
    const NodeId node = graph.AddNode(sw("carcontroller"));
    b.Keep<Twist>(node, cmd_vel, [state, &kernel](const Twist& t, Time stamp) {
      state->command = stack::VelocityCommand{kernel.Now(), t.speed_mps, t.yaw_rate_rad_per_s};
      state->command_stamp = stamp;
    });
    b.Keep<stack::LocalizationEkfOutput>(
        node, odometry, [state, &kernel](const stack::LocalizationEkfOutput& o, Time) {
          state->odometry = stack::OdometrySpeed{kernel.Now(), o.speed_mps};
        });
    const auto out = graph.AddPublisher(node, command_topic);
    graph.AddTimer(node, config.cruise_control.period, config.cruise_control.period,
                   [state, out, params = config.cruise_control](Time now, Outbox& outbox) {
                     const stack::CruiseControlOutput r = stack::StepCruiseControl(
                         params,
                         {.now = now, .command = state->command, .odometry = state->odometry},
                         &state->cruise);
                     state->command.reset();
                     state->odometry.reset();
                     // While the watchdog holds the car the output stays zero: it goes out once
                     // (the PWM generator holds it), so that the end-to-end latency on
                     // /carcontrol/command is measured on commands derived from fresh input.
                     const bool stopped = r.stopped != stack::CruiseStop::kNone;
                     if (stopped && state->stopped_sent) return;
                     state->stopped_sent = stopped;
                     outbox.Publish(out, vehicle::ActuatorCommand{r.throttle, r.curvature_per_m},
                                    state->command_stamp);
                   });
  }

  // ---- rt_carcontrol: the PWM generator takes the command ----
  {
    const NodeId node = graph.AddNode(sw("rt_carcontrol"));
    graph.AddSubscription<vehicle::ActuatorCommand>(
        node, command_topic,
        [actuate = hooks.actuate](const vehicle::ActuatorCommand& c, Time, Outbox&) {
          if (actuate) actuate(c);
        });
  }
}

}  // namespace autonomsim::sim
