// The perception part of a car's stack as nodes on its board, under the real topic names
// (AutonomROS code/reconros_ws/carcontrol/build.cfg), each node mappable to software or to a
// hardware slot through the scenario's `platform.mapping`:
//
//   obstacles, hardware (default; reference §4: point cloud and grid fused in slot 0):
//     /depth/image_raw → obstacle_detection (depth → grid) → /local_costmap/obstacles
//   obstacles, software (`obstacle_detection: {target: sw}`):
//     /depth/image_raw → point_cloud → /points → obstacle_detection → /local_costmap/obstacles
//     (point_cloud defaults to hardware in slot 0, as in the real build; map it too for all-SW)
//   lanes, hardware (default; reference §8: slot 1 HSV/threshold/warp, slot 2 polynomial fit):
//     /image → lane_planner → /camera/bird_view → poly_fit →
//     /lane_detector/central_line/point_cloud
//     (rt_laneplanner and rt_polyfit's semantics by the lane detection's hw_* options:
//     stack::FitLanePointsHardware)
//   lanes, software (`lane_detection: {target: sw}`: the ROS 2 node, reference §5):
//     /image → lane_detection → /lane_detector/central_line/point_cloud
//     (without a line it publishes nothing under sw_no_line silent)
//
// Each node runs its pure component (stack/) on the frame at once; the platform decides when the
// result is published. A point cloud computed in hardware is scaled as the real HLS code scales it
// (1/1024 m per mm, reference §3), in software by 0.001.
#pragma once

#include <functional>
#include <map>
#include <memory>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "sim/car/perception_config.h"
#include "sim/car/sensors.h"
#include "sim/core/built_once.h"
#include "sim/platform/node_graph.h"
#include "stack/lane_detection.h"
#include "stack/obstacle_grid.h"

namespace autonomsim::sim {

// The perception's parameters (PerceptionConfig) and kLanePointsTopic: sim/car/perception_config.h.

// The topics the rest of the stack reads.
struct PerceptionTopics {
  TopicId<stack::Grid234> obstacles;  // /local_costmap/obstacles
  TopicId<stack::LanePoints> lanes;   // /lane_detector/central_line/point_cloud
};

// Called with each result when its component has computed it (at the job's start; the topic
// carries it at the job's completion), with the stamp of the frame it derives from: for
// monitors that compare perception with ground truth. Either may be empty.
struct PerceptionHooks {
  std::function<void(const stack::Grid234&, Time stamp)> on_grid;
  std::function<void(const stack::LanePoints&, Time stamp)> on_lanes;
};

// The lane detector's view of a camera: its intrinsics, distortion and mount (the nodes and the
// report's lane overlay both build their lane detection from it).
stack::LaneCameraCalibration LaneCalibration(const vehicle::CameraModel& camera);

// The pixels of a camera of `height` rows that the detector reads (its source spans): what the
// lane nodes ask the renderer for (vehicle::RowSpans, demand-driven colour).
vehicle::RowSpans LaneDetectorReads(const stack::LaneDetectorTables& detector, int height);

// The detector's line class of a colour (LaneDetectorTables::ClassOf) as a renderer's label
// (vehicle::CameraRenderer::RenderLabels); the label keeps the tables alive.
vehicle::ColourLabel LaneLineClass(std::shared_ptr<const stack::LaneDetectorTables> detector);

// The keep-last depth of the colour camera's topic (/image): 1 when the lab's ROS 2 lane detector
// reads it (mapping `lane_detection`: autonomros_lane_detection/src/lane_detector.cpp:26-30
// subscribes KeepLast(1), best effort; the camera publishes KeepLast(1), camera/src/
// cam2image.cpp:56); else the graph's default, as the hardware lane planner's subscription is
// ReconROS's (build.cfg), not the lab's code. The depth camera's topic keeps the default for the
// same reason (its publisher is depth 1, astra_pro/src/astra_pro_publisher.cpp:52-53; its reader
// is ReconROS's point cloud thread).
int ColorImageDepth(const std::map<std::string, NodeMappingConfig>& mapping);

// The perception nodes' read-only tables, built once per distinct parameters and camera and
// shared by every car that has the same (issue 38):
// - the lane detector's (the warp's source of each bird's-eye pixel, the pixels it reads): ~3 ms
//   and a few MB a car at start, a fifth of a 10-car fleet's start;
// - the fused obstacle node's depth interest (stack::FarthestCountedDepths_m on the depth
//   camera's tiles): 1.2 MB a camera.
class PerceptionTablesCache {
 public:
  std::shared_ptr<const stack::LaneDetectorTables> LaneTables(
      const stack::LaneDetectionParams& params, const vehicle::CameraModel& camera);
  std::shared_ptr<const vehicle::DepthInterest> DepthInterest(const stack::PointCloudParams& cloud,
                                                              const stack::ObstacleGridParams& grid,
                                                              const CameraSensor& depth_camera);

 private:
  BuiltOnce<std::pair<stack::LaneDetectionParams, vehicle::CameraParams>, stack::LaneDetectorTables>
      lane_tables_;
  BuiltOnce<
      std::tuple<stack::PointCloudParams, stack::ObstacleGridParams, const vehicle::CameraRays*>,
      vehicle::DepthInterest>
      depth_interests_;
};

// Adds the nodes and their topics to `graph`, fed by the camera topics (the suite's frames).
// `mapping` is the board's configured mapping (it chooses the graph's shape); ConfigError for a
// mapping the shape cannot take (e.g. lane_detection in hardware: map lane_planner and poly_fit).
// The nodes' tables come from `tables`.
PerceptionTopics AddPerceptionNodes(NodeGraph& graph, const PerceptionConfig& config,
                                    const std::map<std::string, NodeMappingConfig>& mapping,
                                    const SensorSuite& sensors, TopicId<CameraFrame> image,
                                    TopicId<CameraFrame> depth_image, PerceptionTablesCache& tables,
                                    PerceptionHooks hooks = {});

}  // namespace autonomsim::sim
