#include "sim/loop/faults.h"

#include <fmt/format.h>

#include <numbers>

#include "sim/loop/simulation_impl.h"

namespace autonomsim::sim {

using detail::CarAgent;

std::string DescribeFault(const FaultClause& fault) {
  const FaultArgs& a = fault.args();
  std::vector<std::string> parts;
  if (a.direction) parts.push_back("direction " + *a.direction);
  if (a.loss) parts.push_back(fmt::format("loss {}", *a.loss));
  if (a.node) parts.push_back("node " + *a.node);
  if (fault.kind().starts_with("camera_")) parts.push_back("camera " + a.camera.value_or("color"));
  if (a.gyro_bias_rad_per_s)
    parts.push_back(fmt::format("gyro bias {:+} rad/s", *a.gyro_bias_rad_per_s));
  if (fault.kind() == "localization_jump") {
    parts.push_back(fmt::format("jump ({}, {}) m, {} deg", a.dx_m.value_or(0.0),
                                a.dy_m.value_or(0.0), a.dyaw_deg.value_or(0.0)));
  }
  if (a.for_s) {
    parts.push_back(fmt::format("for {} s", *a.for_s));
  } else {
    parts.push_back(LastsWithoutEnd(fault) ? "to the end" : "instantaneous");
  }
  return fmt::format("{}", fmt::join(parts, ", "));
}

bool LastsWithoutEnd(const FaultClause& fault) {
  const std::string kind = fault.kind();
  return !(kind == "server_restart" || kind == "localization_jump" || kind == "imu_bias_step");
}

namespace {

// What a fault does when it begins and when it ends (nothing, for an instantaneous one).
struct FaultActions {
  std::function<void()> begin;
  std::function<void()> end;
};

}  // namespace

void Simulation::Impl::ScheduleFaults() {
  for (std::size_t i = 0; i < scenario.faults.size(); ++i) {
    const FaultClause& fault = scenario.faults[i];
    const std::string kind = fault.kind();
    const FaultArgs& a = fault.args();
    CarAgent* agent = a.car ? &agents[agent_index.at(*a.car)] : nullptr;
    const std::size_t car_index = a.car ? agent_index.at(*a.car) : 0;
    FaultActions actions;

    if (kind == "v2i_partition" || kind == "v2i_loss_burst" || kind == "broker_outage") {
      const std::string direction = a.direction.value_or("both");
      const V2ILinkFault link_fault{.car = a.car,
                                    .up = direction != "down",
                                    .down = direction != "up",
                                    .loss = a.loss.value_or(1.0),
                                    .cause = kind};
      auto handle = std::make_shared<int>(-1);
      actions.begin = [this, link_fault, handle] { *handle = link->AddFault(link_fault); };
      actions.end = [this, handle] { link->RemoveFault(*handle); };
    } else if (kind == "server_restart") {
      if (a.for_s) {
        actions.begin = [this] {
          server.Restart();
          link->set_server_down(true);
        };
        actions.end = [this] { link->set_server_down(false); };
      } else {
        actions.begin = [this] { server.Restart(); };
      }
    } else if (kind == "car_stall") {
      actions.begin = [agent] {
        agent->stalled = true;
        agent->car->SetCommand(agent->applied());
      };
      actions.end = [agent] {
        agent->stalled = false;
        agent->car->SetCommand(agent->applied());
      };
    } else if (kind == "node_crash" || kind == "node_hang") {
      NodeGraph& graph = boards[car_index]->graph();
      if (!graph.HasNode(*a.node)) {
        const std::string message =
            fmt::format("car {}'s board has no node '{}'; its nodes: {}", *a.car, *a.node,
                        fmt::join(graph.node_names(), ", "));
        if (loaded.error_at) throw loaded.error_at({"faults", i, kind, "node"}, message);
        throw ConfigError(message);
      }
      if (kind == "node_crash") {
        actions.begin = [&graph, node = *a.node] { graph.CrashNode(node); };
      } else {
        actions.begin = [&graph, node = *a.node] { graph.HangNode(node); };
        actions.end = [&graph, node = *a.node] { graph.ResumeNode(node); };
      }
    } else if (kind == "camera_freeze" || kind == "camera_blackout") {
      SensorSuite* suite = sensors[car_index].get();
      const bool color = a.camera.value_or("color") == "color";
      const auto set = [suite, color](SensorSuite::CameraFault f) {
        if (color) {
          suite->SetColorCameraFault(f);
        } else {
          suite->SetDepthCameraFault(f);
        }
      };
      const SensorSuite::CameraFault f = kind == "camera_freeze"
                                             ? SensorSuite::CameraFault::kFreeze
                                             : SensorSuite::CameraFault::kBlackout;
      actions.begin = [set, f] { set(f); };
      actions.end = [set] { set(SensorSuite::CameraFault::kNone); };
    } else if (kind == "imu_bias_step") {
      SensorSuite* suite = sensors[car_index].get();
      const double step = *a.gyro_bias_rad_per_s;
      actions.begin = [suite, step] { suite->StepGyroBias(step); };
      if (a.for_s) actions.end = [suite, step] { suite->StepGyroBias(-step); };
    } else if (kind == "localization_jump") {
      const double dyaw_rad = a.dyaw_deg.value_or(0.0) * std::numbers::pi / 180.0;
      actions.begin = [agent, dx = a.dx_m.value_or(0.0), dy = a.dy_m.value_or(0.0), dyaw_rad] {
        agent->stack_controls.jump_localization(dx, dy, dyaw_rad);
      };
    } else {
      throw std::logic_error("ScheduleFaults: no actions for fault kind " + kind);
    }

    // the events, and the actions at their instants
    const Time begin_at = FromSeconds(a.at_s);
    const int car = a.car.value_or(-1);
    kernel.ScheduleAt(
        begin_at,
        [this, begin = std::move(actions.begin), kind, car, detail = DescribeFault(fault)] {
          Emit(Event{.t = kernel.Now(),
                     .type = "fault_begin",
                     .car = car,
                     .fault = kind,
                     .detail = detail});
          begin();
        },
        kPriorityWorldChange);
    std::optional<Time> end_at;
    if (a.for_s) end_at = begin_at + FromSeconds(*a.for_s);
    if (!a.for_s && !LastsWithoutEnd(fault)) end_at = begin_at;
    if (!end_at || *end_at > end) continue;
    kernel.ScheduleAt(
        *end_at,
        [this, finish = std::move(actions.end), kind, car] {
          if (finish) finish();
          Emit(Event{.t = kernel.Now(), .type = "fault_end", .car = car, .fault = kind});
        },
        kPriorityWorldChange);
  }
}

}  // namespace autonomsim::sim
