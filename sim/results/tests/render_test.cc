// The render command's logic: the world at T is the full run's world at T, and the folder holds
// what the cameras saw, as files that read back exactly.
#include "sim/results/render.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstring>
#include <fstream>
#include <map>
#include <opencv2/imgcodecs.hpp>

#include "sim/loop/simulation.h"

namespace autonomsim::sim {
namespace {

namespace fs = std::filesystem;

constexpr const char* kObstacleScenario = "scenarios/static_obstacle.yaml";

bool BitIdentical(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

TEST(RenderTest, TheSnapshotIsTheFullRunsWorldAtThatInstant) {
  const LoadedScenario scenario = LoadScenario(kObstacleScenario);
  const RunRecord full = RunScenario(scenario);
  for (const double t_s : {3.0, 12.0, 13.35}) {
    const Time t = FromSeconds(t_s);
    const WorldSnapshot snapshot = SnapshotAt(scenario, t);
    ASSERT_EQ(snapshot.cars.size(), 2u);
    for (const CarBody& car : snapshot.cars) {
      const auto sample =
          std::find_if(full.trajectory.begin(), full.trajectory.end(),
                       [&](const TrajectorySample& s) { return s.t == t && s.car == car.id; });
      ASSERT_NE(sample, full.trajectory.end());
      EXPECT_TRUE(BitIdentical(car.pose.x_m, sample->x_m)) << t_s << " s, car " << car.id;
      EXPECT_TRUE(BitIdentical(car.pose.y_m, sample->y_m)) << t_s << " s, car " << car.id;
      EXPECT_TRUE(BitIdentical(car.pose.yaw_rad, sample->yaw_rad)) << t_s << " s, car " << car.id;
    }
    // the box stands from 5 s to 25 s
    EXPECT_EQ(snapshot.obstacles.size(), t_s >= 5.0 ? 1u : 0u) << t_s;
  }
  EXPECT_EQ(SnapshotAt(scenario, FromSeconds(25.0)).obstacles.size(), 0u);
  // at 0: the start poses, no simulation needed
  const WorldSnapshot start = SnapshotAt(scenario, kZeroTime);
  EXPECT_EQ(start.cars[0].pose.x_m, scenario.cars[0].start_pose.x_m);
  EXPECT_THROW(SnapshotAt(scenario, FromSeconds(91.0)), std::invalid_argument);
  EXPECT_THROW(SnapshotAt(scenario, FromSeconds(-1.0)), std::invalid_argument);
}

TEST(RenderTest, SeveralSnapshotsFromOneRunAreEachInstantsOwn) {
  const LoadedScenario scenario = LoadScenario(kObstacleScenario);
  const std::vector<Time> times{kZeroTime, FromSeconds(3.0), FromSeconds(12.0), FromSeconds(13.35)};
  const std::vector<WorldSnapshot> snapshots = SnapshotsAt(scenario, times);
  ASSERT_EQ(snapshots.size(), times.size());
  for (std::size_t k = 0; k < times.size(); ++k) {
    const WorldSnapshot one = SnapshotAt(scenario, times[k]);
    EXPECT_EQ(snapshots[k].t, times[k]);
    EXPECT_EQ(snapshots[k].obstacles.size(), one.obstacles.size());
    for (std::size_t c = 0; c < one.cars.size(); ++c) {
      EXPECT_TRUE(BitIdentical(snapshots[k].cars[c].pose.x_m, one.cars[c].pose.x_m)) << k;
      EXPECT_TRUE(BitIdentical(snapshots[k].cars[c].pose.yaw_rad, one.cars[c].pose.yaw_rad)) << k;
    }
  }
  EXPECT_THROW(SnapshotsAt(scenario, {FromSeconds(2.0), FromSeconds(1.0)}), std::invalid_argument);
  EXPECT_THROW(SnapshotsAt(scenario, {FromSeconds(1.0), FromSeconds(1.0005)}),
               std::invalid_argument);  // several instants are whole milliseconds
}

TEST(RenderTest, LabelsNameEachPixelsSurfaceAndObject) {
  const LoadedScenario scenario = LoadScenario(kObstacleScenario);
  const WorldSnapshot snapshot = SnapshotAt(scenario, FromSeconds(13.0));
  const CarCameras cameras(scenario.track, SensorSuiteParams{}, scenario.scenario.appearance);
  const std::vector<RenderedCamera> rendered =
      cameras.Render(snapshot, 1, RngStreams(scenario.scenario.seed), true);
  const std::vector<std::string>& classes = cameras.ClassNames();
  EXPECT_THAT(classes, ::testing::ElementsAre("none", "floor", "line:white", "line:yellow", "car",
                                              "obstacle"));
  const nlohmann::json instances = cameras.InstancesJson(snapshot, 1);
  ASSERT_EQ(instances.size(), 2u);  // car 0, then the box
  EXPECT_EQ(instances[0]["car"], 0);
  EXPECT_EQ(instances[1]["kind"], "obstacle");
  for (const RenderedCamera& camera : rendered) {
    ASSERT_EQ(camera.classes.size(), camera.instances.size());
    std::map<std::string, int> seen;
    for (std::size_t i = 0; i < camera.classes.size(); ++i) {
      const std::string& name = classes.at(camera.classes[i]);
      ++seen[name];
      // an object's pixels are of its class, and only objects' pixels carry an instance
      const char* expected = camera.instances[i] == 2   ? "obstacle"
                             : camera.instances[i] == 1 ? "car"
                                                        : nullptr;
      if (expected != nullptr) {
        ASSERT_EQ(name, expected) << camera.name << " " << i;
      } else {
        ASSERT_TRUE(name != "obstacle" && name != "car") << camera.name << " " << i;
      }
      // a painted line's pixels are that paint in the colour image (no noise by default)
      if (camera.has_color && name == "line:yellow") {
        ASSERT_GT(camera.color.bgr[3 * i + 2], 200) << i;  // red
        ASSERT_LT(camera.color.bgr[3 * i], 100) << i;      // blue
      }
    }
    EXPECT_GT(seen["obstacle"], 500) << camera.name;
    EXPECT_GT(seen["floor"], 10000) << camera.name;
    EXPECT_GT(seen["none"], 10000) << camera.name;
    EXPECT_GT(seen["line:white"] + seen["line:yellow"], 1000) << camera.name;
  }
}

TEST(RenderTest, TheObstacleAheadShowsInBothCameras) {
  // at 13 s car 1 slows for the box ahead of it on the inner lane
  const LoadedScenario scenario = LoadScenario(kObstacleScenario);
  const WorldSnapshot snapshot = SnapshotAt(scenario, FromSeconds(13.0));
  WorldSnapshot without = snapshot;
  without.obstacles.clear();
  const RngStreams streams(scenario.scenario.seed);
  const SensorSuiteParams sensors;
  const vehicle::SceneAppearance appearance;
  const auto with_box = RenderCameras(scenario.track, snapshot, 1, sensors, appearance, streams);
  const auto no_box = RenderCameras(scenario.track, without, 1, sensors, appearance, streams);
  ASSERT_EQ(with_box.size(), 2u);
  EXPECT_EQ(with_box[0].name, "color_camera");
  EXPECT_EQ(with_box[1].name, "depth_camera");
  for (std::size_t c = 0; c < 2; ++c) {
    int nearer = 0;
    for (std::size_t i = 0; i < with_box[c].depth.mm.size(); ++i) {
      const std::uint16_t a = with_box[c].depth.mm[i];
      const std::uint16_t b = no_box[c].depth.mm[i];
      if (a != b) {
        EXPECT_TRUE(b == 0 || (a != 0 && a < b)) << with_box[c].name << " pixel " << i;
        ++nearer;
      }
    }
    EXPECT_GT(nearer, 2000) << with_box[c].name;
  }
  EXPECT_THROW(RenderCameras(scenario.track, snapshot, 5, sensors, appearance, streams),
               std::invalid_argument);
}

TEST(RenderTest, TheFolderHoldsEachCamerasFilesAndTheyReadBack) {
  const LoadedScenario scenario = LoadScenario(kObstacleScenario);
  const Time t = FromSeconds(12.0);
  const WorldSnapshot snapshot = SnapshotAt(scenario, t);
  const auto cameras = RenderCameras(scenario.track, snapshot, 1, SensorSuiteParams{},
                                     vehicle::SceneAppearance{}, RngStreams(1));
  const fs::path out = fs::temp_directory_path() / ("render_test_" + std::to_string(::getpid()));
  WriteRenderFolder(cameras, t, 1, out);
  for (const RenderedCamera& camera : cameras) {
    const fs::path dir = out / camera.name;
    // Only what the camera's stream publishes: the colour camera's /image, the depth camera's
    // /depth/image_raw (with its preview).
    EXPECT_EQ(camera.has_color, camera.name == "color_camera") << camera.name;
    EXPECT_EQ(camera.has_depth, camera.name == "depth_camera") << camera.name;
    EXPECT_EQ(fs::exists(dir / "color.png"), camera.has_color) << dir;
    EXPECT_EQ(fs::exists(dir / "depth.png"), camera.has_depth) << dir;
    EXPECT_EQ(fs::exists(dir / "depth_preview.png"), camera.has_depth) << dir;
    EXPECT_TRUE(fs::exists(dir / "camera_info.json")) << dir;
    if (camera.has_depth) {
      const cv::Mat depth = cv::imread((dir / "depth.png").string(), cv::IMREAD_UNCHANGED);
      ASSERT_EQ(depth.type(), CV_16UC1);
      ASSERT_EQ(depth.cols, 640);
      ASSERT_EQ(depth.rows, 480);
      EXPECT_EQ(std::memcmp(depth.data, camera.depth.mm.data(), camera.depth.mm.size() * 2), 0);
    }
    if (camera.has_color) {
      const cv::Mat color = cv::imread((dir / "color.png").string(), cv::IMREAD_COLOR);
      ASSERT_EQ(color.type(), CV_8UC3);
      EXPECT_EQ(std::memcmp(color.data, camera.color.bgr.data(), camera.color.bgr.size()), 0);
    }

    std::ifstream in(dir / "camera_info.json");
    const nlohmann::json info = nlohmann::json::parse(in);
    EXPECT_EQ(info["width"], 640);
    EXPECT_EQ(info["height"], 480);
    EXPECT_EQ(info["K"].size(), 9u);
    EXPECT_EQ(info["D"].size(), 5u);
    EXPECT_EQ(info["P"].size(), 12u);
    EXPECT_EQ(info["P"].get<std::vector<double>>(),
              std::vector<double>(camera.info.P.begin(), camera.info.P.end()));
    ASSERT_EQ(info["X_map_camera"].size(), 16u);
    const auto car = std::find_if(snapshot.cars.begin(), snapshot.cars.end(),
                                  [](const CarBody& c) { return c.id == 1; });
    const Eigen::Matrix4d expected =
        vehicle::CameraModel(camera.params).X_map_camera(car->pose).matrix();
    for (int k = 0; k < 16; ++k) {
      EXPECT_EQ(info["X_map_camera"][static_cast<std::size_t>(k)].get<double>(),
                expected(k / 4, k % 4));
    }
  }
  fs::remove_all(out);
}

// The preview's colour bar: the picture unchanged on the left, the bar's top in the nearest
// colour and its bottom in the farthest, the "no return" swatch black.
TEST(RenderTest, TheDepthPreviewCarriesAColourBar) {
  vehicle::DepthImage depth;
  depth.width = 64;
  depth.height = 200;
  depth.mm.assign(64 * 200, 0);
  for (std::size_t i = 0; i < depth.mm.size(); ++i)
    depth.mm[i] = static_cast<std::uint16_t>(600 + i);
  const cv::Mat out = DepthPreviewWithColourBar(depth, 0.6, 8.0);
  ASSERT_EQ(out.type(), CV_8UC3);
  ASSERT_EQ(out.cols, 64 + kColourBarPanelWidthPx);
  ASSERT_EQ(out.rows, 200);
  const std::vector<std::uint8_t> preview = DepthPreview(depth, 0.6, 8.0);
  for (int r = 0; r < 200; ++r) {
    ASSERT_EQ(std::memcmp(out.ptr<std::uint8_t>(r), preview.data() + 3 * 64 * r, 3 * 64), 0) << r;
  }
  auto colour_of = [](double m) {
    vehicle::DepthImage one;
    one.width = one.height = 1;
    one.mm = {static_cast<std::uint16_t>(std::lround(1000 * m))};
    const std::vector<std::uint8_t> c = DepthPreview(one, 0.6, 8.0);
    return cv::Vec3b(c[0], c[1], c[2]);
  };
  const int bar_x = 64 + 10 + 5;
  EXPECT_EQ(out.at<cv::Vec3b>(30, bar_x), colour_of(0.6));
  EXPECT_EQ(out.at<cv::Vec3b>(200 - 60, bar_x), colour_of(8.0));
  EXPECT_EQ(out.at<cv::Vec3b>(200 - 34, bar_x), cv::Vec3b(0, 0, 0));
}

TEST(RenderTest, TheDepthPreviewIsBlackWithoutReturnAndRedNear) {
  vehicle::DepthImage depth;
  depth.width = 3;
  depth.height = 1;
  depth.mm = {0, 600, 8000};
  const std::vector<std::uint8_t> bgr = DepthPreview(depth, 0.6, 8.0);
  ASSERT_EQ(bgr.size(), 9u);
  EXPECT_EQ(bgr[0] + bgr[1] + bgr[2], 0);
  EXPECT_GT(bgr[5], bgr[3]);  // near: more red than blue
  EXPECT_GT(bgr[6], bgr[8]);  // far: more blue than red
}

}  // namespace
}  // namespace autonomsim::sim
