#include <algorithm>
#include <string>

#include "sim/loop/simulation_impl.h"

namespace autonomsim::sim {

using detail::CarAgent;

namespace {

// A behaviour event's text: the mode, and the recovery action with the retries so far.
std::string BehaviorDetail(const stack::BehaviorOutput& out) {
  std::string detail = stack::ToString(out.mode);
  if (out.recovery != stack::RecoveryAction::kNone) {
    detail += std::string(" (") + std::string(ToName(out.recovery)) + ", retry " +
              std::to_string(out.retries) + ")";
  }
  return detail;
}

}  // namespace

std::unique_ptr<Board> Simulation::Impl::MakeBoard(CarAgent* agent, const PlatformProfile& profile,
                                                   SensorSuite* suite) {
  const CarConfig& config = *agent->config;
  const std::string name = "car" + std::to_string(config.id);
  auto board = std::make_unique<Board>(kernel, name, config.platform, profile, &streams);
  NodeGraph& graph = board->graph();
  // The camera drivers as the lab runs them (reference §2, §8), each a process with its own cost
  // in the profile: Cam2Image for the colour camera (code/ros_ws/src/camera/src/cam2image.cpp),
  // AstraSDK for the depth camera (code/ros_ws/src/astra_pro). Each publishes its frames, captured
  // at its stream's instants. The QoS depth of each: ColorImageDepth (sim/car/perception_nodes.h).
  const auto camera_topic = [&](const SensorStream& stream, int depth) {
    return graph.AddTopic<CameraFrame>(
        {.name = stream.topic,
         .type = MessageType{stream.type.name, stream.type.bytes, true},
         .depth = depth});
  };
  const NodeMappingConfig color_driver{.cost = "cam2image"};
  const NodeMappingConfig depth_driver{.cost = "astra_sdk"};
  const SensorStream& color = suite->color_stream();
  const SensorStream& depth = suite->depth_stream();
  const TopicId<CameraFrame> image = camera_topic(color, ColorImageDepth(config.platform.mapping));
  const TopicId<CameraFrame> depth_image = camera_topic(depth, TopicSpec{}.depth);
  AddSourceNode(
      graph, NodeSpec{.name = suite->color_camera().params().camera.name, .mapping = color_driver},
      image, color.first, color.period, [suite, agent](Time) {
        CameraFrame frame = suite->CaptureColorFrame();
        // the car's pose now, which is the frame's unless the camera froze (then the detection is
        // judged against where the car really is)
        agent->lanes.OnFrame(frame.stamp, agent->car->pose());
        return frame;
      });
  AddSourceNode(
      graph, NodeSpec{.name = suite->depth_camera().params().camera.name, .mapping = depth_driver},
      depth_image, depth.first, depth.period, [suite](Time) { return suite->CaptureDepthFrame(); });

  if (config.perception.enabled) {
    agent->metrics.perception.emplace();
    PerceptionHooks hooks{
        .on_grid = [this, agent](const stack::Grid234& grid, Time) { JudgeGrid(agent, grid); },
        .on_lanes = [this, agent](const stack::LanePoints& lanes,
                                  Time stamp) { JudgeLanes(agent, lanes, stamp); }};
    const PerceptionTopics topics =
        AddPerceptionNodes(graph, config.perception, config.platform.mapping, *suite, image,
                           depth_image, perception_tables, std::move(hooks));
    if (config.drives_by_stack()) AddStack(agent, suite, topics, &graph);
  }
  if (SlotExecutor* executor = board->platform().slot_executor()) {
    // a slot's reconfiguration as events: begin (it serves nothing from here) and end
    const auto emit = [this, id = config.id](EventKind kind) {
      return [this, id, kind](const SlotExecutor::Reconfiguration& r) {
        Emit(Event{.t = kernel.Now(),
                   .type = kind,
                   .car = id,
                   .detail = "slot " + std::to_string(r.slot) + ": " + r.node +
                             (r.replaced ? " (replacing " + *r.replaced + ")" : "")});
      };
    };
    executor->OnReconfigureBegin(emit(EventKind::kReconfigureBegin));
    executor->OnReconfigured(emit(EventKind::kReconfigureEnd));
  }
  try {
    board->Finish(kZeroTime);
  } catch (const UnknownPlatformName& e) {  // a typo in the scenario: say where
    throw loaded.ErrorAt("cars[" + std::to_string(agent_index.at(config.id)) + "].platform." +
                             e.field + "." + e.name,
                         e.detail);
  }
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
  const stack::GlobalCostmapParams& costmap_params = config.stack.global_costmap;
  const stack::GlobalCostmap* global_costmap = nullptr;
  for (const auto& built : global_costmaps) {
    if (built->params() == costmap_params) global_costmap = built.get();
  }
  if (global_costmap == nullptr) {
    global_costmaps.push_back(std::make_unique<stack::GlobalCostmap>(costmap_params, *static_map));
    global_costmap = global_costmaps.back().get();
  }
  const StackContext context{
      .route = &agent->route->path,
      .intersections = &loaded.track.spec().intersections,
      .global_costmap = global_costmap,
      .obstacle_grid = &config.perception.obstacle_grid,
      .X_map_odom = agent->car->pose(),  // the start pose
      .intersection_client_period = config.intersection_client.tick_period,
      .intersection_client_watches_navigation =
          config.intersection_client.release_on_failure && !config.intersection_client.blocking,
      .true_pose = [agent] { return agent->car->pose(); },
      .pose_fix_noise = streams.Stream("car" + std::to_string(id) + "/pose_fix/noise")};
  StackHooks hooks{
      .intersection_client =
          [this, agent](const world::Vec2& p, bool navigation_failed) {
            return StepClient(agent, p, navigation_failed);
          },
      .actuate =
          [agent](const vehicle::ActuatorCommand& command) {
            agent->command = command;
            agent->car->SetCommand(agent->applied());
          },
      .mission_done = [agent] { return agent->route_monitor.parked(); },
      .on_behavior =
          [this, agent, id](const stack::BehaviorOutput& out) {
            StackMetrics& m = *agent->metrics.stack;
            if (out.recovery != stack::RecoveryAction::kNone) ++m.recoveries;
            if (out.mode == stack::BehaviorMode::kFailed) m.navigation_failed = true;
            if (out.mode != agent->behavior_mode || out.recovery != stack::RecoveryAction::kNone) {
              agent->behavior_mode = out.mode;
              Emit(Event{.t = kernel.Now(),
                         .type = EventKind::kBehavior,
                         .car = id,
                         .detail = BehaviorDetail(out)});
            }
          },
      .on_estimate =
          [agent](const stack::LocalizationEkfOutput& estimate) {
            StackMetrics& m = *agent->metrics.stack;
            const double error =
                (estimate.X_map_base.position() - agent->car->pose().position()).norm();
            m.max_localization_error_m = std::max(m.max_localization_error_m.value_or(0.0), error);
            m.final_localization_error_m = error;
            agent->estimate = estimate.X_map_base;
          },
      .on_control =
          [agent](bool follow_path, bool collision) {
            StackMetrics& m = *agent->metrics.stack;
            ++m.control_cycles;
            if (follow_path) ++m.follow_path_cycles;
            if (collision) ++m.collision_cycles;
          }};
  agent->stack_controls =
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
  agent->lanes.OnLanes(lane_judge, loaded.track, *agent->route, lanes, stamp,
                       &*agent->metrics.perception);
}

}  // namespace autonomsim::sim
