// A car's `stack:` entry: the parameters of every stack component, as one plain struct, and the
// pose fix's. Kept apart from the nodes (sim/car/stack_nodes.h: node graph, kernel) so that a
// scenario can name them without the simulator's machinery.
#pragma once

#include <chrono>
#include <optional>
#include <string>

#include "stack/behavior.h"
#include "stack/controller_server.h"
#include "stack/costmap.h"
#include "stack/cruise_control.h"
#include "stack/emergency_stop.h"
#include "stack/global_planner.h"
#include "stack/lane_controller.h"
#include "stack/localization_ekf.h"
#include "stack/obstacle_grid.h"
#include "stack/path_follower.h"
#include "world/enum_names.h"
#include "world/time.h"

namespace autonomsim::sim {

// `stack.preset`: the lab's stack as published, or every fix this simulator offers
// (sim/scenario/stack_presets.h).
enum class StackPreset { kLab, kSafe };

}  // namespace autonomsim::sim

namespace autonomsim {
template <>
struct NameTable<sim::StackPreset> {
  static constexpr std::array<std::pair<sim::StackPreset, std::string_view>, 2> kEntries{
      {{sim::StackPreset::kLab, "lab"}, {sim::StackPreset::kSafe, "safe"}}};
};
}  // namespace autonomsim

namespace autonomsim::sim {

// An external absolute pose fix for the EKF (an overhead tracking system, say). Beyond the real
// car, which has no absolute correction (reference §6): used only with
// stack.localization.use_pose_fix: true. A source node `pose_fix` publishes the true chassis pose
// with Gaussian noise at rate_hz on /pose_fix (geometry_msgs/PoseWithCovarianceStamped).
struct PoseFixConfig {
  double rate_hz{5.0};             // assumed: a modest tracking system
  double position_stddev_m{0.02};  // assumed: per axis
  double yaw_stddev_rad{0.02};     // assumed

  template <class V>
  void Describe(V& v) {
    v("rate_hz", rate_hz, "how often the fix is published");
    v("position_stddev_m", position_stddev_m, "its noise per axis");
    v("yaw_stddev_rad", yaw_stddev_rad, "its heading noise");
  }
  void Validate() const;
};

// Where the controller server runs FollowPath instead of the LaneController (reference §6:
// /controller_selector, inside the intersections' boxes).
struct ControllerSelectorConfig {
  // Beyond the lab's (0: the strict boxes). A car that stopped mid-turn in a stop box at a corner
  // (the inner lane's, at both intersections) and restarts across it leaves the box sideways,
  // where the LaneController follows whatever lane its camera sees; within this margin of the
  // boxes it keeps following its plan. stack.preset: safe sets 0.3 m (assumed: about the car's
  // width beyond the box).
  double zone_margin_m{0.0};
  // Beyond the lab's (false: its LaneController stops when it sees no line, and nothing in its
  // behaviour tree moves the car). A car that stands beside its lane with no line in view (after a
  // wait in line behind a car parked in a corner, say) stays there for good; with true, on every
  // cycle the LaneController finds no carrot FollowPath drives it on its plan back to where the
  // camera sees the line. stack.preset: safe sets true.
  bool follow_path_without_line{false};

  template <class V>
  void Describe(V& v) {
    v("zone_margin_m", zone_margin_m,
      "FollowPath (not the LaneController) drives within this margin around the intersections' "
      "boxes too (lab: 0)");
    v("follow_path_without_line", follow_path_without_line,
      "FollowPath drives the car on its plan while the lane camera sees no line (lab: false, the "
      "car stops)");
  }
  void Validate() const;  // in [0, 1] m
};

// The actuator command topic: where the end-to-end latency from the sensor stamp is measured.
inline constexpr const char* kCarCommandTopic = "/carcontrol/command";

// A car's `stack:` entry: every component's parameters (defaults: the real car's, see each).
struct StackConfig {
  stack::LocalizationEkfParams localization;
  PoseFixConfig pose_fix;  // localization.use_pose_fix only
  stack::BehaviorParams behavior;
  stack::GlobalCostmapParams global_costmap;
  stack::GlobalPlannerParams planner;
  Duration planner_period{std::chrono::seconds(1)};  // reference §6: path replanned at 1 Hz
  stack::LocalCostmapParams local_costmap;
  stack::ObstacleLayerParams obstacle_layer;
  Duration controller_period{Milliseconds(50)};  // reference §6: controller server at 20 Hz
  stack::LaneControllerParams lane_controller;
  stack::PathFollowerParams follow_path;
  ControllerSelectorConfig controller_selector;
  stack::ProgressCheckerParams progress_checker;  // reference §6: the controller server's
  stack::CruiseControlParams cruise_control;
  // Beyond the lab's stack: the ultrasonic ranger stops the car (stack/emergency_stop.h).
  stack::EmergencyStopParams emergency_stop;
  // Fills every option that departs from the lab's code (the struct's and the car's
  // intersection_client) that the scenario does not set (sim/scenario/stack_presets.h).
  std::optional<StackPreset> preset;

  template <class V>
  void Describe(V& v) {
    v("preset", preset,
      "the lab's stack as published or every fix, for this car's options the scenario leaves out "
      "([the lab's stack](lab-stack.md)); overrides the top-level `stack.preset`");
    v("localization", localization,
      "the EKF (robot_localization) that fuses IMU, wheel speed and the optional pose fix");
    v("pose_fix", pose_fix,
      "an external absolute pose, beyond the real car (with `localization.use_pose_fix`)");
    v("behavior", behavior,
      "the behaviour tree: goals along the route, the intersection gate, recoveries");
    v("global_costmap", global_costmap, "the planner's costmap over the track's static map");
    v("planner", planner, "the global planner (Nav2 Smac 2D, A* and smoother)");
    v("planner_period_s", planner_period, "how often the path is planned again");
    v("local_costmap", local_costmap,
      "the controller's rolling costmap around the car (obstacles from the depth camera)");
    v("obstacle_layer", obstacle_layer, "how the obstacle grid marks the local costmap");
    v("controller_period_s", controller_period, "how often the controller server runs");
    v("lane_controller", lane_controller, "the controller that follows the lane the camera sees");
    v("follow_path", follow_path,
      "the controller that follows the planned path (inside intersections)");
    v("controller_selector", controller_selector,
      "where FollowPath drives instead of the LaneController");
    v("progress_checker", progress_checker,
      "when the controller server gives up for lack of progress");
    v("cruise_control", cruise_control, "the car's speed PID and steering (carcontroller)");
    v("emergency_stop", emergency_stop,
      "the ultrasonic ranger stops the car, beyond the lab's stack");
  }
  void Validate() const;
};

}  // namespace autonomsim::sim
