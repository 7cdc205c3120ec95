// The perception nodes in the closed loop: the graph's shape follows the mapping, the real topics
// carry results at the camera rate, lanes and obstacles are seen where they are, and a run with
// perception stays deterministic.
#include "sim/car/perception_nodes.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "sim/loop/simulation.h"
#include "sim/scenario/run_record.h"

namespace autonomsim::sim {
namespace {

constexpr const char* kDefault = "scenarios/lab_two_cars_oracle.yaml";

// (and no expectations: the runs are shorter than the scenarios' deadlines)
std::vector<std::string> WithPerception(std::vector<std::string> overrides, int car_index = 0) {
  overrides.insert(
      overrides.begin(),
      {"cars[" + std::to_string(car_index) + "].perception.enabled=true", "expect=[]"});
  return overrides;
}

const NodeReport& Node(const RunRecord& record, const std::string& name) {
  const NodeReport* node = record.boards.at(0).report.FindNode(name);
  if (node == nullptr) throw std::runtime_error("no node " + name);
  return *node;
}

TEST(PerceptionNodesTest, TheDefaultMappingIsTheRealBuildAllInHardware) {
  const RunRecord record = RunScenario(LoadScenario(kDefault, WithPerception({"duration_s=4"})));
  ASSERT_EQ(record.boards.size(), 1u);
  for (const char* name : {"obstacle_detection", "lane_planner", "poly_fit"}) {
    EXPECT_THAT(Node(record, name).mapping, ::testing::StartsWith("hw")) << name;
    EXPECT_NEAR(Node(record, name).rate_hz, 30.0, 0.5) << name;
    EXPECT_EQ(Node(record, name).drops, 0u) << name;
  }
  // fused in hardware: no point cloud node, no /points topic
  EXPECT_EQ(record.boards[0].report.FindNode("point_cloud"), nullptr);
  EXPECT_EQ(record.boards[0].report.FindNode("lane_detection"), nullptr);
  ASSERT_NE(record.boards[0].report.FindTopic("/local_costmap/obstacles"), nullptr);
  EXPECT_NEAR(record.boards[0].report.FindTopic("/lane_detector/central_line/point_cloud")->rate_hz,
              30.0, 0.5);
}

TEST(PerceptionNodesTest, InSoftwareTheGraphIsTheRos2NodesAndSlower) {
  const RunRecord hw = RunScenario(LoadScenario(kDefault, WithPerception({"duration_s=4"})));
  const RunRecord sw = RunScenario(LoadScenario(
      kDefault, WithPerception({"duration_s=4", "cars[0].platform.mapping.point_cloud.target=sw",
                                "cars[0].platform.mapping.obstacle_detection.target=sw",
                                "cars[0].platform.mapping.lane_detection.target=sw"})));
  for (const char* name : {"point_cloud", "obstacle_detection", "lane_detection"}) {
    EXPECT_THAT(Node(sw, name).mapping, ::testing::StartsWith("sw")) << name;
  }
  EXPECT_EQ(sw.boards[0].report.FindNode("lane_planner"), nullptr);
  ASSERT_NE(sw.boards[0].report.FindTopic("/points"), nullptr);
  // Table I: lane detection takes 27-31 ms in software, 9-18 ms over both slots in hardware
  const double hw_lane_ms =
      Node(hw, "lane_planner").turnaround_ms.p50 + Node(hw, "poly_fit").turnaround_ms.p50;
  EXPECT_GT(Node(sw, "lane_detection").turnaround_ms.p50, hw_lane_ms);
  EXPECT_GT(sw.boards[0].report.cpu_percent, hw.boards[0].report.cpu_percent + 100.0);
  // the same frames give the same lanes either way (the component does not depend on the
  // mapping); only the last frame or two may still be in the longer software pipeline at the end.
  // In software the lane node shares the cores with the other software nodes and the camera
  // drivers (the lab's sheet: docs/model.md#table-i) and falls behind: each frame its KeepLast(1)
  // queue drops is one lane result fewer.
  ASSERT_TRUE(sw.cars[0].perception && hw.cars[0].perception);
  const std::uint64_t sw_lane_drops = Node(sw, "lane_detection").drops;
  EXPECT_GT(sw_lane_drops, 0u);
  EXPECT_NEAR(static_cast<double>(sw.cars[0].perception->lane_valid_frames + sw_lane_drops),
              static_cast<double>(hw.cars[0].perception->lane_valid_frames), 2.0);
}

// The lab's KeepLast(1) subscriptions: the obstacle layer's (obstacle_layer.cpp:32-37), the
// LaneController's (lane_controller.cpp:179) and the ROS 2 lane detector's camera image
// (lane_detector.cpp:26-30); the ReconROS threads' subscriptions keep the graph's default.
TEST(PerceptionNodesTest, TheLabsKeepLastOneTopicsHaveDepthOne) {
  const RunRecord hw = RunScenario(LoadScenario(kDefault, WithPerception({"duration_s=1"})));
  const RunRecord sw = RunScenario(LoadScenario(
      kDefault,
      WithPerception({"duration_s=1", "cars[0].platform.mapping.lane_detection.target=sw"})));
  auto depth = [](const RunRecord& record, const char* topic) {
    const TopicReport* report = record.boards.at(0).report.FindTopic(topic);
    if (report == nullptr) throw std::runtime_error(std::string("no topic ") + topic);
    return report->depth;
  };
  for (const RunRecord* record : {&hw, &sw}) {
    EXPECT_EQ(depth(*record, "/local_costmap/obstacles"), 1);
    EXPECT_EQ(depth(*record, "/lane_detector/central_line/point_cloud"), 1);
    EXPECT_EQ(depth(*record, "/depth/image_raw"), 3);
  }
  EXPECT_EQ(depth(hw, "/image"), 3);  // read by the lane planner, a ReconROS thread
  EXPECT_EQ(depth(sw, "/image"), 1);  // read by the lab's ROS 2 lane detector
}

TEST(PerceptionNodesTest, LaneDetectionInHardwareMustBeMappedAsItsTwoSlots) {
  EXPECT_THROW(
      RunScenario(LoadScenario(
          kDefault, WithPerception({"cars[0].platform.mapping.lane_detection.target=hw"}))),
      ConfigError);
}

TEST(PerceptionNodesTest, TheLaneIsSeenWhereItIs) {
  // car 0 on the outer south lane and the middle road, car 1 on the inner ring
  const RunRecord record = RunScenario(
      LoadScenario(kDefault, WithPerception({"cars[1].perception.enabled=true", "duration_s=30"})));
  for (const CarMetrics& car : record.cars) {
    ASSERT_TRUE(car.perception.has_value());
    const PerceptionMetrics& p = *car.perception;
    EXPECT_GT(p.lane_frames, 880u) << car.id;  // 30 fps
    // invalid only where little line is in view (junctions, leaving corners)
    EXPECT_GT(p.lane_valid_frames, p.lane_frames * 17 / 20) << car.id;
    // issue 5: within 3 cm of the lane centre 0.5 m ahead (judged on straights; the inner
    // ring's straights are too short between its corners and junctions to be judged, so car 1
    // has no sample, and no error: issue 34 item 3, it was 0)
    if (p.lane_error_samples > 0) {
      EXPECT_LT(p.lane_error_max_m.value(), 0.03) << car.id;
    } else {
      EXPECT_FALSE(p.lane_error_max_m.has_value()) << car.id;
      EXPECT_FALSE(p.lane_error_rms_m.has_value()) << car.id;
    }
  }
  EXPECT_GT(record.cars[0].perception->lane_error_samples, 50u);
  EXPECT_EQ(record.cars[1].perception->lane_error_samples, 0u);
}

// The lab's software node returns before publishing when it finds no line
// (autonomros_lane_detection/src/lane_detector.cpp:273-276): under sw_no_line silent the topic
// carries the valid frames only, and the controller keeps the last; ours publishes them invalid.
TEST(PerceptionNodesTest, WithoutALineTheLabsSoftwareNodePublishesNothing) {
  const auto run = [](const char* sw_no_line) {
    return RunScenario(LoadScenario(
        kDefault,
        WithPerception(
            {"duration_s=30", "cars[0].platform.mapping.lane_detection.target=sw",
             std::string("cars[0].perception.lane_detection.sw_no_line=") + sw_no_line})));
  };
  const RunRecord silent = run("silent");
  const RunRecord invalid = run("invalid");
  ASSERT_TRUE(silent.cars[0].perception && invalid.cars[0].perception);
  const PerceptionMetrics& s = *silent.cars[0].perception;
  const PerceptionMetrics& i = *invalid.cars[0].perception;
  EXPECT_LT(i.lane_valid_frames, i.lane_frames);        // frames without a line were published
  EXPECT_EQ(s.lane_valid_frames, s.lane_frames);        // ... and are not under silent
  EXPECT_EQ(s.lane_valid_frames, i.lane_valid_frames);  // the oracle drives: the same frames
}

TEST(PerceptionNodesTest, AnEmptyRoadHoldsNoObstacleAndABoxOnTheLaneFillsTheGrid) {
  // the box stands on car 1's lane from 5 s on; before it, car 1 sees only the painted road
  const RunRecord before = RunScenario(
      LoadScenario("scenarios/static_obstacle.yaml", WithPerception({"duration_s=4.9"}, 1)));
  ASSERT_TRUE(before.cars[1].perception.has_value());
  EXPECT_GT(before.cars[1].perception->grid_frames, 140u);
  EXPECT_EQ(before.cars[1].perception->grid_obstacle_frames, 0u);
  const RunRecord with_box = RunScenario(
      LoadScenario("scenarios/static_obstacle.yaml", WithPerception({"duration_s=20"}, 1)));
  EXPECT_GT(with_box.cars[1].perception->grid_obstacle_frames, 30u);  // > 1 s of frames
}

TEST(PerceptionNodesTest, ARunWithPerceptionIsDeterministic) {
  const LoadedScenario scenario = LoadScenario(kDefault, WithPerception({"duration_s=3"}));
  const RunRecord a = RunScenario(scenario);
  const RunRecord b = RunScenario(scenario);
  EXPECT_EQ(NodesCsv(a.boards), NodesCsv(b.boards));
  EXPECT_EQ(ResultSha256(a), ResultSha256(b));
  EXPECT_EQ(a.trace_json, b.trace_json);
}

}  // namespace
}  // namespace autonomsim::sim
