// The messages between the stack's nodes that have no type of their own in stack/ (sim/car/
// stack_nodes.h wires them). In a header so that a recorder can tap their topics
// (NodeGraph::Tap, sim/results/mcap_recording.h).
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "stack/costmap.h"
#include "world/geometry.h"

namespace autonomsim::sim {

struct CostmapMessage {  // /local_costmap/costmap_raw, in the odom frame
  std::shared_ptr<const stack::Costmap2D> costmap;
};
struct PathMessage {  // /plan, in the map frame
  std::shared_ptr<const std::vector<world::Vec2>> path;
  std::uint64_t id{0};
  bool ok{false};
};
struct IntersectionFree {  // /intersection_free (the lab's /intersection_check)
  bool free{true};
};
// /cmd_vel carries stack::Twist, /controller/status stack::ControllerStatus, /odometry/filtered
// stack::LocalizationEkfOutput, /carcontrol/command vehicle::ActuatorCommand.

}  // namespace autonomsim::sim
