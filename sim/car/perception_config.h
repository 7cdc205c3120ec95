// A car's `perception:` entry and the lane detection's topic name. Kept apart from the nodes
// (sim/car/perception_nodes.h: node graph, sensors) so that a scenario can name them without the
// simulator's machinery.
#pragma once

#include "stack/lane_detection.h"
#include "stack/obstacle_grid.h"

namespace autonomsim::sim {

// A car's `perception:` entry.
struct PerceptionConfig {
  bool enabled{false};
  stack::ObstacleGridParams obstacle_grid;
  stack::LaneDetectionParams lane_detection;

  template <class V>
  void Describe(V& v) {
    v("enabled", enabled,
      "run the perception nodes on the car's board (point cloud, obstacles, lanes); `driver: "
      "stack` needs it");
    v("obstacle_grid", obstacle_grid,
      "the obstacle detection's grid from the depth camera's points");
    v("lane_detection", lane_detection, "the lane detection on the colour camera");
  }
  void Validate() const {}  // the parts validate themselves
};

// The lane detection's output topic (reference §5), read by the controller and by sweeps' tables.
inline constexpr const char* kLanePointsTopic = "/lane_detector/central_line/point_cloud";
inline constexpr const char* kObstaclesTopic = "/local_costmap/obstacles";

}  // namespace autonomsim::sim
