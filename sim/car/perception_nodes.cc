#include "sim/car/perception_nodes.h"

#include <algorithm>
#include <limits>
#include <memory>
#include <opencv2/core.hpp>
#include <optional>
#include <utility>

#include "sim/core/config.h"
#include "stack/point_cloud.h"

namespace autonomsim::sim {
namespace {

// The real build's slots (reference §8): 0 point cloud + obstacle grid, 1 lane planner (HSV,
// threshold, warp), 2 polynomial fit.
const NodeMappingConfig kSlot0{.target = Target::kHw, .slot = 0};
const NodeMappingConfig kSlot1{.target = Target::kHw, .slot = 1};
const NodeMappingConfig kSlot2{.target = Target::kHw, .slot = 2};
const NodeMappingConfig kSoftware{.target = Target::kSw};

// The node's target as the board will map it: its configured mapping, else its default.
bool InHardware(const std::map<std::string, NodeMappingConfig>& mapping, const std::string& node,
                const NodeMappingConfig& fallback) {
  const auto it = mapping.find(node);
  return (it != mapping.end() ? it->second.target : fallback.target) == Target::kHw;
}

// Messages between perception nodes that the rest of the stack does not read. Like the real
// sensor_msgs they carry the stamp of the frame they derive from.
struct CloudMessage {  // /points, PointCloud640
  std::shared_ptr<const stack::PointCloud640> cloud;
  Time stamp{};
};
// /camera/bird_view, Image640mono on the wire (its size is the message type's). What poly_fit
// reads of the bird's-eye image, its per-row line pixel counts and column sums, is what the C++
// message carries: the fit of those is the fit of the masks (stack::BirdsEyeRowSums).
struct BirdViewMessage {
  stack::BirdsEyeRowSums sums;
  Time stamp{};
};

// What a frame's images are a function of, where they come from the scene alone (no noise, not
// the GL backend: CameraFrame::LabelsFromScene, DepthFromScene): the car's pose, the blackout and
// the prisms the camera may see (nearer than what the consumer reads), in the frame's order. A
// node keeps its last frame's and its result: a car that stands while nothing it sees moves (a
// queue at an intersection) has the same result again, without rendering.
struct SceneKey {
  world::Pose2 pose;
  bool blackout{false};
  int variant{0};                      // what else the node's result depends on
  std::vector<vehicle::Prism> prisms;  // those it may see
  friend bool operator==(const SceneKey&, const SceneKey&) = default;  // exactly, bit for bit
};

SceneKey SceneOf(const CameraFrame& frame, const vehicle::DepthInterest* interest, int variant) {
  SceneKey key{.pose = frame.X_map_car, .blackout = frame.blackout, .variant = variant};
  for (const vehicle::Prism& prism : frame.prisms) {
    if (frame.MaySee(prism, interest)) key.prisms.push_back(prism);
  }
  return key;
}

// What a node keeps between frames: scratch buffers, and (the fused node) the last frame's scene
// and grid.
struct DepthScratch {
  vehicle::DepthImage depth;
  vehicle::DepthRowHistory history;  // the renderer rewrites only pixels that can have changed
  stack::DepthGridMemo grid_memo;    // the fused node's: it counts only the segments that changed
  std::optional<SceneKey> last;      // the fused node's last frame (DepthFromScene), and its grid
  stack::Grid234 last_grid;
};

// `interest`: what the consumer reads (CameraFrame::RenderDepth), or null: every pixel.
stack::DepthImageView RenderDepth(const CameraFrame& frame, DepthScratch* scratch,
                                  const vehicle::DepthInterest* interest) {
  frame.RenderDepth(&scratch->depth, &scratch->history, interest);
  return stack::DepthImageView{scratch->depth.width, scratch->depth.height, scratch->depth.mm};
}

// The colour image where `reads` says its consumer reads it (demand-driven sensing).
cv::Mat RenderColor(const CameraFrame& frame, vehicle::ColorImage* color,
                    const vehicle::RowSpans& reads) {
  frame.Render(color, nullptr, reads);
  return cv::Mat(color->height, color->width, CV_8UC3, color->bgr.data());
}

// The input-independent part of a perception step: the component's params and the camera data.
struct GridParams {
  stack::PointCloudParams cloud;
  stack::ObstacleGridParams grid;
  std::array<double, 12> P{};
  std::function<void(const stack::Grid234&, Time)> hook;
  // The fused node reads no pixel's depth beyond its bound here (stack::FarthestCountedDepths_m);
  // the point cloud node, which publishes every point, reads all (null).
  std::shared_ptr<const vehicle::DepthInterest> interest;
};

stack::Grid234 Report(const GridParams& params, stack::Grid234 grid, Time stamp) {
  if (params.hook) params.hook(grid, stamp);
  return grid;
}

// The fused node's grid of a frame: its last one again where the scene it may see (nearer than
// the grid reads) is the last frame's, else counted from the frame's depth.
stack::Grid234 FusedGrid(const GridParams& p, const CameraFrame& frame, DepthScratch* scratch) {
  std::optional<SceneKey> key;
  if (frame.DepthFromScene()) {
    key = SceneOf(frame, p.interest.get(), 0);
    if (scratch->last && *scratch->last == *key) return scratch->last_grid;
  }
  scratch->last_grid =
      stack::StepDepthToGrid(p.cloud, p.grid, RenderDepth(frame, scratch, p.interest.get()), p.P,
                             &scratch->grid_memo, scratch->history.changed_columns());
  scratch->last = std::move(key);
  return scratch->last_grid;
}

TopicId<stack::Grid234> AddObstacleNodes(NodeGraph& graph, const PerceptionConfig& config,
                                         const std::map<std::string, NodeMappingConfig>& mapping,
                                         const SensorSuite& sensors,
                                         TopicId<CameraFrame> depth_image,
                                         PerceptionTablesCache& tables,
                                         std::function<void(const stack::Grid234&, Time)> hook) {
  // depth 1: the costmap's obstacle layer subscribes with QoS(1), best effort
  // (code/ros_ws/src/obstacle_layer/src/obstacle_layer.cpp:32-37)
  const auto obstacles =
      graph.AddTopic<stack::Grid234>({.name = kObstaclesTopic, .type = msg::Grid234(), .depth = 1});
  GridParams params{
      .grid = config.obstacle_grid, .P = sensors.depth_camera().Info().P, .hook = std::move(hook)};

  if (InHardware(mapping, "obstacle_detection", kSlot0)) {
    // Point cloud and grid fused in one slot; the cloud is never written (reference §4).
    params.cloud.hardware_scale = true;
    params.interest = tables.DepthInterest(params.cloud, params.grid, sensors.depth_camera());
    AddComponentNode(graph, NodeSpec{.name = "obstacle_detection", .mapping = kSlot0}, depth_image,
                     obstacles, std::move(params), std::make_shared<DepthScratch>(),
                     [](const GridParams& p, const CameraFrame& frame, DepthScratch* scratch) {
                       return Report(p, FusedGrid(p, frame, scratch), frame.stamp);
                     });
    return obstacles;
  }

  const auto points =
      graph.AddTopic<CloudMessage>({.name = "/points", .type = msg::PointCloud640()});
  params.cloud.hardware_scale = InHardware(mapping, "point_cloud", kSlot0);
  AddComponentNode(graph, NodeSpec{.name = "point_cloud", .mapping = kSlot0}, depth_image, points,
                   params, std::make_shared<DepthScratch>(),
                   [](const GridParams& p, const CameraFrame& frame, DepthScratch* scratch) {
                     auto cloud = std::make_shared<stack::PointCloud640>();
                     stack::StepPointCloud(p.cloud, RenderDepth(frame, scratch, nullptr), p.P,
                                           cloud.get());
                     return CloudMessage{std::move(cloud), frame.stamp};
                   });
  AddComponentNode(graph, NodeSpec{.name = "obstacle_detection", .mapping = kSoftware}, points,
                   obstacles, std::move(params), std::shared_ptr<void>(),
                   [](const GridParams& p, const CloudMessage& in, void*) {
                     return Report(p, stack::StepObstacleGrid(p.grid, *in.cloud), in.stamp);
                   });
  return obstacles;
}

// The lane nodes' fixed part: the detector's tables, read-only and shared by the nodes (each node
// that computes row sums has a detector of its own on them, LaneScratch), and what the renderer
// is asked for.
struct LaneParams {
  std::shared_ptr<const stack::LaneDetectorTables> tables;
  std::shared_ptr<const vehicle::RowSpans> reads;  // the image pixels the detector reads
  vehicle::ColourLabel line_class;                 // LaneLineClass(tables)
  std::function<void(const stack::LanePoints&, Time)> hook;
};

// What a node that computes the bird's-eye row sums keeps between frames: scratch, and the last
// frame's sums with what they were computed from.
struct LaneScratch {
  explicit LaneScratch(std::shared_ptr<const stack::LaneDetectorTables> tables)
      : detector(std::move(tables)) {}
  stack::LaneDetector detector;  // its class image and line bits
  vehicle::ColorImage color;
  std::optional<SceneKey> last;  // the last frame's (LabelsFromScene), and its sums
  stack::BirdsEyeRowSums last_sums;
  std::vector<std::pair<int, int>> nonzero_columns;  // the renderer's, per image row
};

// The bird's-eye row sums of a frame. The detector reads a function of each pixel's colour alone,
// its line class, so the renderer labels the pixels it reads with their colour's class (a few
// colours in view) in the class image the detector hands out, instead of drawing them for the
// detector to classify one by one; with colour noise on, the colour image it is.
void LaneRowSums(const LaneParams& p, const CameraFrame& frame, LaneScratch* scratch,
                 stack::BirdsEyeRowSums* sums,
                 stack::BirdsEyeClasses count = stack::BirdsEyeClasses::kNonZero) {
  stack::LaneDetector& detector = scratch->detector;
  if (frame.LabelsFromScene()) {
    SceneKey key = SceneOf(frame, nullptr, static_cast<int>(count));
    if (scratch->last && *scratch->last == key) {
      *sums = scratch->last_sums;
      return;
    }
    const stack::ClassImageRegion classes = detector.MutableClassRegion();
    frame.RenderLabels(*p.reads, p.line_class,
                       vehicle::LabelView{.origin = classes.pixels.data(),
                                          .stride = classes.stride,
                                          .nonzero_columns = &scratch->nonzero_columns});
    detector.ComputeRowSumsFromClasses(sums, count, scratch->nonzero_columns);
    scratch->last = std::move(key);
    scratch->last_sums = *sums;
  } else {
    detector.ComputeRowSums(RenderColor(frame, &scratch->color, *p.reads), sums, count);
  }
}

stack::LanePoints Report(const LaneParams& params, stack::LanePoints lanes, Time stamp) {
  if (params.hook) params.hook(lanes, stamp);
  return lanes;
}

TopicId<stack::LanePoints> AddLaneNodes(NodeGraph& graph, const PerceptionConfig& config,
                                        const std::map<std::string, NodeMappingConfig>& mapping,
                                        const SensorSuite& sensors, TopicId<CameraFrame> image,
                                        PerceptionTablesCache& tables,
                                        std::function<void(const stack::LanePoints&, Time)> hook) {
  // depth 1: the LaneController subscribes with depth 1 (autonomros_lane_detection/src/
  // lane_controller.cpp:179); the ROS 2 lane detector publishes with depth 1
  // (lane_detector.cpp:31-32)
  const auto lanes = graph.AddTopic<stack::LanePoints>(
      {.name = kLanePointsTopic, .type = msg::LanePoints(), .depth = 1});
  LaneParams params{
      .tables = tables.LaneTables(config.lane_detection, sensors.color_camera().model()),
      .reads = nullptr,
      .hook = std::move(hook)};
  params.reads = std::make_shared<const vehicle::RowSpans>(
      LaneDetectorReads(*params.tables, sensors.color_camera().model().height()));
  params.line_class = LaneLineClass(params.tables);

  if (mapping.count("lane_detection") != 0) {
    if (InHardware(mapping, "lane_detection", kSoftware)) {
      throw ConfigError(
          "platform.mapping: lane_detection is the ROS 2 software node; in hardware the lane "
          "detection is two nodes: map lane_planner and poly_fit");
    }
    AddComponentNode(
        graph, NodeSpec{.name = "lane_detection", .mapping = kSoftware}, image, lanes, params,
        std::make_shared<LaneScratch>(params.tables),
        [](const LaneParams& p, const CameraFrame& frame,
           LaneScratch* scratch) -> std::optional<stack::LanePoints> {
          stack::BirdsEyeRowSums sums;
          LaneRowSums(p, frame, scratch, &sums);
          const stack::LanePoints fitted = scratch->detector.Fit(sums);
          // sw_no_line silent: nothing published (lane_detector.cpp:273-276)
          if (fitted.valid == 0 && p.tables->params().sw_no_line == stack::SwNoLine::kSilent) {
            return std::nullopt;
          }
          return Report(p, fitted, frame.stamp);
        });
    return lanes;
  }

  const auto bird_view =
      graph.AddTopic<BirdViewMessage>({.name = "/camera/bird_view", .type = msg::Image640mono()});
  AddComponentNode(graph, NodeSpec{.name = "lane_planner", .mapping = kSlot1}, image, bird_view,
                   params, std::make_shared<LaneScratch>(params.tables),
                   [](const LaneParams& p, const CameraFrame& frame, LaneScratch* scratch) {
                     BirdViewMessage out{.stamp = frame.stamp};
                     LaneRowSums(p, frame, scratch, &out.sums, p.tables->params().hw_pixel_classes);
                     return out;
                   });
  AddComponentNode(graph, NodeSpec{.name = "poly_fit", .mapping = kSlot2}, bird_view, lanes,
                   std::move(params), std::shared_ptr<void>(),
                   [](const LaneParams& p, const BirdViewMessage& in, void*) {
                     return Report(p, stack::FitLanePointsHardware(*p.tables, in.sums), in.stamp);
                   });
  return lanes;
}

}  // namespace

vehicle::RowSpans LaneDetectorReads(const stack::LaneDetectorTables& detector, int height) {
  vehicle::RowSpans reads;
  reads.columns.assign(static_cast<std::size_t>(height), {0, 0});
  for (const stack::LaneDetectorTables::SourceSpan& span : detector.source_spans()) {
    // (a camera of another size has no lane detection: its Step refuses the image)
    if (span.row < height)
      reads.columns[static_cast<std::size_t>(span.row)] = {span.col_begin, span.col_end};
  }
  return reads;
}

vehicle::ColourLabel LaneLineClass(std::shared_ptr<const stack::LaneDetectorTables> detector) {
  return [detector = std::move(detector)](const vehicle::Bgr& c) {
    return detector->ClassOf(c[0], c[1], c[2]);
  };
}

int ColorImageDepth(const std::map<std::string, NodeMappingConfig>& mapping) {
  return mapping.count("lane_detection") != 0 ? 1 : TopicSpec{}.depth;
}

stack::LaneCameraCalibration LaneCalibration(const vehicle::CameraModel& camera) {
  const vehicle::CameraInfo info = camera.Info();
  stack::LaneCameraCalibration calibration;
  calibration.K = info.K;
  calibration.D = info.D;
  calibration.X_base_camera = camera.X_base_camera();
  return calibration;
}

std::shared_ptr<const vehicle::DepthInterest> PerceptionTablesCache::DepthInterest(
    const stack::PointCloudParams& cloud, const stack::ObstacleGridParams& grid,
    const CameraSensor& depth_camera) {
  return depth_interests_.Get({cloud, grid, &depth_camera.rays()}, [&] {
    return std::make_shared<const vehicle::DepthInterest>(
        depth_camera.rays(), stack::FarthestCountedDepths_m(cloud, grid, depth_camera.Info().P));
  });
}

std::shared_ptr<const stack::LaneDetectorTables> PerceptionTablesCache::LaneTables(
    const stack::LaneDetectionParams& params, const vehicle::CameraModel& camera) {
  return lane_tables_.Get({params, camera.params()}, [&] {
    return std::make_shared<const stack::LaneDetectorTables>(params, LaneCalibration(camera));
  });
}

PerceptionTopics AddPerceptionNodes(NodeGraph& graph, const PerceptionConfig& config,
                                    const std::map<std::string, NodeMappingConfig>& mapping,
                                    const SensorSuite& sensors, TopicId<CameraFrame> image,
                                    TopicId<CameraFrame> depth_image, PerceptionTablesCache& tables,
                                    PerceptionHooks hooks) {
  PerceptionTopics topics;
  topics.obstacles = AddObstacleNodes(graph, config, mapping, sensors, depth_image, tables,
                                      std::move(hooks.on_grid));
  topics.lanes =
      AddLaneNodes(graph, config, mapping, sensors, image, tables, std::move(hooks.on_lanes));
  return topics;
}

}  // namespace autonomsim::sim
