// The rest of a car's stack as nodes on its board (`driver: stack`): localization, behaviour,
// planning, control, cruise control and the intersection client, fed by the perception nodes
// (sim/car/perception_nodes.h) and the car's IMU and Hall sensor, and driving the car's actuators.
// Every node runs a pure component of stack/ and is timed by the platform model, so a slower
// perception mapping, a loaded CPU or a DDS topic changes when the car steers and brakes.
//
//   imu_driver (100 Hz) ──/bno055/imu──────┐
//   hall_sensor (10 Hz) ──/modelcar/speed──┴→ ekf_filter_node (20 Hz) ──/odometry/filtered──→ all
//   obstacle_detection ──/local_costmap/obstacles──→ local_costmap (5 Hz)
//                                                     ──/local_costmap/costmap_raw──┐
//   vehicle_communication (10 Hz, V2I) ──/intersection_free──→ bt_navigator (100 Hz) │
//   bt_navigator ──/behavior──→ planner_server (1 Hz) ──/plan──┐                     │
//   lane detection ──/lane_detector/central_line/point_cloud──┴→ controller_server (20 Hz)
//   controller_server ──/cmd_vel──→ carcontroller (30 Hz) ──/carcontrol/command──→ rt_carcontrol
//   controller_server ──/controller/status──→ bt_navigator
//
// As in Nav2, the behaviour's hold (intersection wait, recovery) cancels the controller, which
// then publishes one zero velocity and nothing more; the cruise control's 1 s watchdog cuts the
// throttle after that. The nodes are wiring: what they decide lives in the pure components of
// stack/ (the controller server's cycle in stack/controller_server.h, the plan-failure latch in
// stack/behavior.h, the watchdog's single zero output in stack/cruise_control.h). A callback that
// only keeps the latest message (most subscriptions here) costs the profile's `subscription_cache`
// entry; each node's main job costs the node's entry. Where a ROS message carries strings (headers)
// its type is variable-size and its topic uses DDS; the fixed-size ones (cmd_vel, the actuator
// command) default to zero-copy, like the perception topics.
#pragma once

#include <functional>
#include <optional>
#include <vector>

#include "sim/car/perception_nodes.h"
#include "sim/car/sensors.h"
#include "sim/car/stack_config.h"
#include "sim/core/config.h"
#include "sim/core/kernel.h"
#include "sim/core/random.h"
#include "sim/platform/node_graph.h"
#include "stack/behavior.h"
#include "stack/costmap.h"
#include "stack/cruise_control.h"
#include "stack/global_planner.h"
#include "stack/lane_controller.h"
#include "stack/localization_ekf.h"
#include "stack/obstacle_grid.h"
#include "stack/path_follower.h"
#include "vehicle/car.h"
#include "world/occupancy_map.h"
#include "world/polyline.h"
#include "world/track_spec.h"

namespace autonomsim::sim {

// The stack's parameters (StackConfig, PoseFixConfig): sim/car/stack_config.h.

// What the stack knows of the world: the map a real car is given, and where it starts.
struct StackContext {
  const world::Polyline* route{nullptr};  // the lanes to drive (the behaviour's goals)
  const std::vector<world::IntersectionSpec>* intersections{nullptr};  // the zone boxes
  // The planner's global costmap (static map + inflation), built once per run for the cars whose
  // global_costmap parameters are equal: 3.7 MB a grid at the map's resolution.
  const stack::GlobalCostmap* global_costmap{nullptr};
  const stack::ObstacleGridParams* obstacle_grid{nullptr};  // the grid's geometry (perception)
  world::Pose2 X_map_odom;  // static map→odom: the start pose (reference §6)
  Duration intersection_client_period{Milliseconds(100)};
  // Whether the intersection client is told that the navigation failed (its release_on_failure):
  // vehicle_communication then also subscribes to the behaviour's output.
  bool intersection_client_watches_navigation{false};
  // For the pose fix (localization.use_pose_fix): the true chassis pose now, and its noise.
  std::function<world::Pose2()> true_pose;
  std::optional<Rng> pose_fix_noise;
};

// How the stack reaches the car and the simulation around it.
struct StackHooks {
  // The intersection client's step on the estimated position (and whether the navigation has
  // failed, as far as the node knows); returns may_proceed, or nothing while the lab's blocking
  // client is stuck in its wait (the node publishes nothing then). It sends its requests and
  // frees over the V2I link itself.
  std::function<std::optional<bool>(const world::Vec2& p_map, bool navigation_failed)>
      intersection_client;
  // The actuator command, when rt_carcontrol receives it.
  std::function<void(const vehicle::ActuatorCommand&)> actuate;
  // Whether the operator has ended the drive (laps done).
  std::function<bool()> mission_done;
  // Every behaviour tick's result, with the estimated pose it used (events, metrics).
  std::function<void(const stack::BehaviorOutput&)> on_behavior;
  // Every EKF estimate.
  std::function<void(const stack::LocalizationEkfOutput&)> on_estimate;
  // Every controller cycle that drove: which controller ran, whether it saw a collision ahead.
  std::function<void(bool follow_path, bool collision_ahead)> on_control;
};

// The pose_fix node's sample: the true chassis pose plus Gaussian noise (x, y, then yaw drawn from
// `noise`; the yaw wrapped), the covariance the configured variances but at least (1 mm)² and
// (1 mrad)², since the EKF inverts it.
stack::PoseFix DrawPoseFix(const PoseFixConfig& config, const world::Pose2& X_map_base_true,
                           Time now, Rng* noise);

// What faults reach inside the stack (sim/loop/faults.h).
struct StackControls {
  // Moves the EKF's estimate: map-frame (dx_m, dy_m), heading dyaw_rad
  // (stack::JumpLocalizationEstimate).
  std::function<void(double dx_m, double dy_m, double dyaw_rad)> jump_localization;
};

// Adds the nodes and topics above to `graph`. `kernel` gives the arrival times the cruise
// control's watchdog needs. The perception topics must be on the same graph.
StackControls AddStackNodes(NodeGraph& graph, const Kernel& kernel, const StackConfig& config,
                            SensorSuite& sensors, const PerceptionTopics& perception,
                            const StackContext& context, StackHooks hooks);

}  // namespace autonomsim::sim
