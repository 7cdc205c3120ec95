#include "sim/loop/faults.h"

#include <fmt/format.h>

#include <algorithm>
#include <numbers>

#include "sim/loop/simulation_impl.h"

namespace autonomsim::sim {

using detail::CarAgent;

namespace {

// What a fault does when it begins and when it ends (nothing, for an instantaneous one).
struct FaultActions {
  std::function<void()> begin;
  std::function<void()> end;
};

// What faults strike in a run: its cars, server, link, boards and sensors.
struct FaultTargets {
  const LoadedScenario& loaded;
  std::vector<CarAgent>& agents;
  const std::map<int, std::size_t>& agent_index;
  TrafficLightNode& server;
  EmbeddedV2ILink* link;
  std::vector<std::unique_ptr<Board>>& boards;
  std::vector<std::unique_ptr<SensorSuite>>& sensors;

  CarAgent* agent(int car) const { return &agents[agent_index.at(car)]; }
  SensorSuite* suite(int car) const { return sensors[agent_index.at(car)].get(); }
};

// A fault on the V2I link: added when it begins, removed when it ends.
FaultActions LinkFaultActions(const FaultTargets& sim, V2ILinkFault link_fault) {
  auto handle = std::make_shared<int>(-1);
  EmbeddedV2ILink* link = sim.link;
  return {.begin = [link, link_fault, handle] { *handle = link->AddFault(link_fault); },
          .end = [link, handle] { link->RemoveFault(*handle); }};
}

// The actions of each kind, by overload: adding a kind to FaultClause without its overload here
// does not compile.
FaultActions ActionsOf(const V2iPartitionFault& f, const FaultTargets& sim) {
  const LinkDirection direction = f.direction.value_or(LinkDirection::kBoth);
  return LinkFaultActions(sim, {.car = f.car,
                                .up = direction != LinkDirection::kDown,
                                .down = direction != LinkDirection::kUp,
                                .loss = 1.0,
                                .cause = std::string(ToName(f.kKind))});
}
FaultActions ActionsOf(const V2iLossBurstFault& f, const FaultTargets& sim) {
  return LinkFaultActions(sim,
                          {.car = f.car, .loss = f.loss, .cause = std::string(ToName(f.kKind))});
}
FaultActions ActionsOf(const BrokerOutageFault& f, const FaultTargets& sim) {
  FaultActions link = LinkFaultActions(sim, {.cause = std::string(ToName(f.kKind))});
  TrafficLightNode* server = &sim.server;
  // the server sees its broker go, too: its leases pause (TrafficLightServer::OnDisconnected)
  FaultActions actions{.begin = [begin = link.begin, server] {
    begin();
    server->BrokerDown();
  }};
  if (link.end) {
    actions.end = [end = link.end, server] {
      end();
      server->BrokerUp();
    };
  }
  return actions;
}

FaultActions ActionsOf(const ServerRestartFault& f, const FaultTargets& sim) {
  TrafficLightNode* server = &sim.server;
  EmbeddedV2ILink* link = sim.link;
  if (!f.for_s) return {.begin = [server] { server->Restart(); }};
  return {.begin =
              [server, link] {
                server->Restart();
                link->set_server_down(true);
              },
          .end = [link] { link->set_server_down(false); }};
}

FaultActions ActionsOf(const CarStallFault& f, const FaultTargets& sim) {
  CarAgent* agent = sim.agent(f.car);
  const auto set = [agent](bool stalled) {
    agent->stalled = stalled;
    agent->car->SetCommand(agent->applied());
  };
  return {.begin = [set] { set(true); }, .end = [set] { set(false); }};
}

// The node's board; it has the node (else the scenario's error, located at the fault's node).
NodeGraph& BoardWithNode(const FaultTargets& sim, const FaultClause& fault, int car,
                         const std::string& node) {
  const std::vector<FaultClause>& listed = sim.loaded.scenario.faults;
  const bool injected = std::none_of(listed.begin(), listed.end(),
                                     [&](const FaultClause& f) { return &f == &fault; });
  const std::unique_ptr<Board>& board = sim.boards[sim.agent_index.at(car)];
  if (injected && (!board || !board->graph().HasNode(node))) {  // Simulation::Inject's
    throw ConfigError(fmt::format(
        "{}.node: car {} has no node '{}'{}", ToName(KindOf(fault)), car, node,
        board ? "; its nodes: " + fmt::format("{}", fmt::join(board->graph().node_names(), ", "))
              : " (no board)"));
  }
  NodeGraph& graph = board->graph();
  if (!graph.HasNode(node)) {
    const std::size_t i = static_cast<std::size_t>(&fault - listed.data());
    throw sim.loaded.ErrorAt(fmt::format("faults[{}].{}.node", i, ToName(KindOf(fault))),
                             fmt::format("car {}'s board has no node '{}'; its nodes: {}", car,
                                         node, fmt::join(graph.node_names(), ", ")));
  }
  return graph;
}

FaultActions ActionsOf(const NodeCrashFault& f, const FaultTargets& sim, const FaultClause& fault) {
  NodeGraph& graph = BoardWithNode(sim, fault, f.car, f.node);
  return {.begin = [&graph, node = f.node] { graph.CrashNode(node); }};
}
FaultActions ActionsOf(const NodeHangFault& f, const FaultTargets& sim, const FaultClause& fault) {
  NodeGraph& graph = BoardWithNode(sim, fault, f.car, f.node);
  return {.begin = [&graph, node = f.node] { graph.HangNode(node); },
          .end = [&graph, node = f.node] { graph.ResumeNode(node); }};
}

FaultActions ActionsOf(const RemapFault& f, const FaultTargets& sim, const FaultClause& fault) {
  NodeGraph& graph = BoardWithNode(sim, fault, f.car, f.node);
  try {
    graph.CheckRemap(f.node, f.target);  // before the run: the node can run there
  } catch (const ConfigError& e) {
    const std::vector<FaultClause>& listed = sim.loaded.scenario.faults;
    const auto at = std::find_if(listed.begin(), listed.end(),
                                 [&](const FaultClause& c) { return &c == &fault; });
    if (at == listed.end()) throw ConfigError(std::string("remap: ") + e.what());  // injected
    throw sim.loaded.ErrorAt(
        fmt::format("faults[{}].remap.target", static_cast<std::size_t>(at - listed.begin())),
        e.what());
  }
  return {.begin = [&graph, node = f.node, target = f.target] { graph.RemapNode(node, target); }};
}

template <FaultKind Kind>
FaultActions ActionsOf(const CameraFault<Kind>& f, const FaultTargets& sim) {
  SensorSuite* suite = sim.suite(f.car);
  const bool color = f.camera == CameraChoice::kColor;
  const auto set = [suite, color](SensorSuite::CameraFault fault) {
    if (color) {
      suite->SetColorCameraFault(fault);
    } else {
      suite->SetDepthCameraFault(fault);
    }
  };
  SensorSuite::CameraFault what = Kind == FaultKind::kCameraFreeze
                                      ? SensorSuite::CameraFault::kFreeze
                                      : SensorSuite::CameraFault::kBlackout;
  return {.begin = [set, what] { set(what); },
          .end = [set] { set(SensorSuite::CameraFault::kNone); }};
}

FaultActions ActionsOf(const ImuBiasStepFault& f, const FaultTargets& sim) {
  SensorSuite* suite = sim.suite(f.car);
  const double step = f.gyro_bias_rad_per_s;
  FaultActions actions{.begin = [suite, step] { suite->StepGyroBias(step); }};
  if (f.for_s) actions.end = [suite, step] { suite->StepGyroBias(-step); };
  return actions;
}

FaultActions ActionsOf(const LocalizationJumpFault& f, const FaultTargets& sim) {
  CarAgent* agent = sim.agent(f.car);
  const double dyaw_rad = f.dyaw_deg.value_or(0.0) * std::numbers::pi / 180.0;
  return {.begin = [agent, dx = f.dx_m.value_or(0.0), dy = f.dy_m.value_or(0.0), dyaw_rad] {
    agent->stack_controls.jump_localization(dx, dy, dyaw_rad);
  }};
}

}  // namespace

void Simulation::Impl::ScheduleFaults() {
  for (const FaultClause& fault : scenario.faults) ScheduleFault(fault);
}

void Simulation::Impl::ScheduleFault(const FaultClause& fault) {
  const FaultTargets targets{loaded, agents, agent_index, server, link.get(), boards, sensors};
  FaultActions actions = std::visit(
      [&](const auto& f) {
        if constexpr (requires { ActionsOf(f, targets, fault); }) {
          return ActionsOf(f, targets, fault);
        } else {
          return ActionsOf(f, targets);
        }
      },
      fault);
  // the events, and the actions at their instants
  const FaultKind kind = KindOf(fault);
  const Time begin_at = FromSeconds(FaultStart_s(fault));
  if (begin_at >= end) return;  // never strikes (the scenario's load warned)
  const int car = FaultCar(fault).value_or(-1);
  kernel.ScheduleAt(
      begin_at,
      [this, begin = std::move(actions.begin), kind, car, detail = DescribeFault(fault)] {
        Emit(Event{.t = kernel.Now(),
                   .type = EventKind::kFaultBegin,
                   .car = car,
                   .fault = kind,
                   .detail = detail});
        begin();
      },
      kPriorityWorldChange);
  const std::optional<double> for_s = FaultDuration_s(fault);
  std::optional<Time> end_at;
  if (for_s) end_at = begin_at + FromSeconds(*for_s);
  if (!for_s && !LastsWithoutEnd(fault)) end_at = begin_at;
  if (!end_at || *end_at > end) return;
  kernel.ScheduleAt(
      *end_at,
      [this, finish = std::move(actions.end), kind, car] {
        if (finish) finish();
        Emit(Event{.t = kernel.Now(), .type = EventKind::kFaultEnd, .car = car, .fault = kind});
      },
      kPriorityWorldChange);
}

}  // namespace autonomsim::sim
