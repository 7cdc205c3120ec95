#include "stack/obstacle_grid.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "stack/point_cloud.h"
#include "stack/tests/track_frames.h"
#include "vehicle/camera_model.h"
#include "vehicle/ray_caster.h"

namespace autonomsim::stack {
namespace {

constexpr int kW = PointCloud640::kWidth;
constexpr int kH = PointCloud640::kHeight;

// Camera frame = base frame: cloud points are then base points, to test the box and the cells.
ObstacleGridParams IdentityTransform() {
  ObstacleGridParams p;
  p.X_base_camera = {1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0};
  return p;
}

// A cloud of the given points; every other point is a zero-depth pixel's (the camera's origin,
// outside the box).
PointCloud640 CloudOf(const std::vector<std::array<float, 3>>& points) {
  PointCloud640 cloud;
  cloud.points.assign(kW * kH, CloudPoint{0.0f, -0.0f, -0.0f, 0});
  for (std::size_t i = 0; i < points.size(); ++i) {
    cloud.points[i] = CloudPoint{points[i][0], points[i][1], points[i][2], 0};
  }
  return cloud;
}

int Total(const Grid234& grid) {
  int total = 0;
  for (int i = 0; i < Grid234::kCells; ++i) total += grid.data[i];
  return total;
}

TEST(ObstacleGridTest, MessageLayout) {
  EXPECT_EQ(sizeof(Grid234), 240u);
  EXPECT_EQ(Grid234::kCells, 234);
  EXPECT_EQ(Grid234::Index(0, 0), 0);
  EXPECT_EQ(Grid234::Index(0, 12), 12);
  EXPECT_EQ(Grid234::Index(1, 0), 13);
  EXPECT_EQ(Grid234::Index(17, 12), 233);
}

TEST(ObstacleGridTest, CountsAPointInTheCellOfItsLowerEdge) {
  // cell (3, 5) holds x in [0.45, 0.5), y in [-0.075, -0.025)
  const float x0 = 0.45f, y0 = -0.075f;
  const Grid234 grid = StepObstacleGrid(
      IdentityTransform(), CloudOf({{0.475f, -0.05f, 0.1f},            // the centre
                                    {x0 + 0.001f, y0 + 0.001f, 0.1f},  // near the corner
                                    {x0 + 0.049f, y0 + 0.049f, 0.1f},  // far corner
                                    {x0 - 0.001f, -0.05f, 0.1f},       // cell (2, 5)
                                    {0.475f, y0 - 0.001f, 0.1f}}));    // cell (3, 4)
  EXPECT_EQ(grid.count(3, 5), 3);
  EXPECT_EQ(grid.data[3 * 13 + 5], 3);
  EXPECT_EQ(grid.count(2, 5), 1);
  EXPECT_EQ(grid.count(3, 4), 1);
  EXPECT_EQ(Total(grid), 5);
}

TEST(ObstacleGridTest, BoxLimitsAreInclusive) {
  const ObstacleGridParams params = IdentityTransform();
  const auto count = [&](float x, float y, float z) {
    return Total(StepObstacleGrid(params, CloudOf({{x, y, z}})));
  };
  EXPECT_EQ(count(0.3f, 0.0f, 0.1f), 1);
  EXPECT_EQ(count(0.2999f, 0.0f, 0.1f), 0);
  EXPECT_EQ(count(0.5f, -0.325f, 0.1f), 1);
  EXPECT_EQ(count(0.5f, -0.3251f, 0.1f), 0);
  EXPECT_EQ(count(0.5f, 0.325f, 0.1f), 1);
  EXPECT_EQ(count(0.5f, 0.3251f, 0.1f), 0);
  EXPECT_EQ(count(0.5f, 0.0f, 0.02f), 1);
  EXPECT_EQ(count(0.5f, 0.0f, 0.0199f), 0);
  EXPECT_EQ(count(0.5f, 0.0f, 0.5f), 1);
  EXPECT_EQ(count(0.5f, 0.0f, 0.5001f), 0);
  EXPECT_EQ(count(1.1999f, 0.0f, 0.1f), 1);
  EXPECT_EQ(count(1.2001f, 0.0f, 0.1f), 0);
  // the floor (z = 0) and the camera's origin never count
  EXPECT_EQ(count(0.5f, 0.0f, 0.0f), 0);
  EXPECT_EQ(count(0.0f, -0.0f, -0.0f), 0);
}

TEST(ObstacleGridTest, EdgesOfTheBoxLandInTheOuterCellsOrAreDropped) {
  const ObstacleGridParams params = IdentityTransform();
  // y = +0.325 (the left edge) is in the last column: 0.65f / 0.05 < 13
  EXPECT_EQ(StepObstacleGrid(params, CloudOf({{0.525f, 0.325f, 0.1f}})).count(4, 12), 1);
  EXPECT_EQ(StepObstacleGrid(params, CloudOf({{0.3f, -0.325f, 0.1f}})).count(0, 0), 1);
  EXPECT_EQ(StepObstacleGrid(params, CloudOf({{1.1999f, 0.0f, 0.1f}})).count(17, 6), 1);
  // x = 1.2 is in the box but (1.2f − 0.3f) / 0.05 ≥ 18: past the last row, dropped as the real
  // code's index check drops it
  EXPECT_EQ(Total(StepObstacleGrid(params, CloudOf({{1.2f, 0.0f, 0.1f}}))), 0);
}

// The cell index without a division is the real code's trunc(double(d) / 0.05), for every float
// within 3000 ulps of each edge and on a sweep across the whole box.
TEST(ObstacleGridTest, CellEdgesIndexAsTheRealCodesDivision) {
  for (int cells : {Grid234::kCellsX, Grid234::kCellsY}) {
    const detail::CellEdges edges(0.05, cells);
    const auto division = [cells](float d) {
      const int k = static_cast<int>(static_cast<double>(d) / 0.05);
      return k < cells ? k : cells;
    };
    std::vector<float> samples;
    for (int k = 0; k <= cells + 1; ++k) {
      float d = static_cast<float>(k * 0.05);
      for (int i = 0; i < 3000; ++i) d = std::nextafter(d, 0.0f);
      for (int i = 0; i < 6000; ++i, d = std::nextafter(d, 1.0f)) samples.push_back(d);
    }
    for (int i = 0; i <= 200000; ++i) samples.push_back(0.05f * cells * (i / 200000.0f));
    for (float d : samples) ASSERT_EQ(edges.Index(d), division(d)) << cells << " cells, d " << d;
  }
}

TEST(ObstacleGridTest, CountersSaturateAt255) {
  std::vector<std::array<float, 3>> points;
  for (int i = 0; i < 300; ++i) points.push_back({0.475f, -0.05f, 0.1f});  // cell (3, 5)
  for (int i = 0; i < 254; ++i) points.push_back({0.525f, 0.0f, 0.2f});    // cell (4, 6)
  for (int i = 0; i < 255; ++i) points.push_back({1.175f, 0.3f, 0.3f});    // cell (17, 12)
  const Grid234 grid = StepObstacleGrid(IdentityTransform(), CloudOf(points));
  EXPECT_EQ(grid.count(3, 5), 255);
  EXPECT_EQ(grid.count(4, 6), 254);
  EXPECT_EQ(grid.count(17, 12), 255);
  for (int i = Grid234::kCells; i < 240; ++i) EXPECT_EQ(grid.data[i], 0) << "padding byte " << i;
}

TEST(ObstacleGridTest, MovesPointsFromTheCameraToBase) {
  // With the real transform, the camera-frame point that maps to base (0.875, 0.1, 0.25): solve
  // M · p + t = b for p (M is a near-rotation: invert it properly).
  const ObstacleGridParams params;
  Eigen::Matrix3d M;
  Eigen::Vector3d t;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) M(r, c) = params.X_base_camera[r * 4 + c];
    t(r) = params.X_base_camera[r * 4 + 3];
  }
  const Eigen::Vector3d p_cam = M.inverse() * (Eigen::Vector3d(0.875, 0.1, 0.25) - t);
  const Grid234 grid = StepObstacleGrid(
      params, CloudOf({{static_cast<float>(p_cam.x()), static_cast<float>(p_cam.y()),
                        static_cast<float>(p_cam.z())}}));
  // x: (0.875 − 0.3) / 0.05 = 11.5; y: (0.1 + 0.325) / 0.05 = 8.5
  EXPECT_EQ(grid.count(11, 8), 1);
  EXPECT_EQ(Total(grid), 1);
}

// A renderer may leave out what lies beyond a pixel's FarthestCountedDepths_m (issue 38): no
// depth value beyond its pixel's bound is counted, with either scale, and the bounds are within
// a few centimetres of tight.
TEST(ObstacleGridTest, NoDepthBeyondItsPixelsFarthestCountedDepthIsCounted) {
  const ObstacleGridParams grid;  // the lab's box
  const std::array<double, 12> P = vehicle::CameraModel(vehicle::DepthCameraParams()).Info().P;
  const auto total = [&](const PointCloudParams& cloud, const std::vector<std::uint16_t>& image) {
    const Grid234 g = StepDepthToGrid(cloud, grid, DepthImageView{kW, kH, image}, P);
    int n = 0;
    for (std::uint8_t c : g.data) n += c;
    return n;
  };
  for (const bool hardware_scale : {false, true}) {
    PointCloudParams cloud;
    cloud.hardware_scale = hardware_scale;
    const std::vector<float> bound_m = FarthestCountedDepths_m(cloud, grid, P);
    ASSERT_EQ(bound_m.size(), static_cast<std::size_t>(kW * kH));
    // a wall of one depth value wherever that is beyond the pixel's bound (0 elsewhere): every
    // value up to 1.6 m (the box's farthest corner is 1.42 m ahead), every 97th beyond
    int pixels_beyond = 0;
    for (int mm = 1; mm <= 65535; mm += mm < 1600 ? 1 : 97) {
      std::vector<std::uint16_t> image(kW * kH, 0);
      for (int i = 0; i < kW * kH; ++i) {
        if (mm > 1000.0 * bound_m[i]) image[i] = static_cast<std::uint16_t>(mm);
      }
      if (mm == 700) pixels_beyond = static_cast<int>(std::count(image.begin(), image.end(), 700));
      ASSERT_EQ(total(cloud, image), 0) << mm << " mm, hardware_scale " << hardware_scale;
    }
    EXPECT_GT(pixels_beyond, kW * kH / 10);  // the sides and the bottom of the image
    // tight: a little short of its bound, most pixels that have one are counted (a row at a
    // time, so that no cell's count saturates; the best of four distances, as a ray's path
    // through the box may be short)
    int with_bound = 0, counted = 0;
    for (int v = 0; v < kH; v += 4) {
      int in_row = 0, best = 0;
      for (const double short_mm : {12.0, 20.0, 30.0, 60.0}) {
        std::vector<std::uint16_t> short_of(kW * kH, 0);
        in_row = 0;
        for (int i = v * kW; i < (v + 1) * kW; ++i) {
          if (!std::isfinite(bound_m[i])) continue;
          ASSERT_TRUE(bound_m[i] > 0.4f && bound_m[i] < 1.5f) << i << ": " << bound_m[i];
          ++in_row;
          short_of[i] = static_cast<std::uint16_t>(std::lround(1000.0 * bound_m[i] - short_mm));
        }
        best = std::max(best, total(cloud, short_of));
      }
      with_bound += in_row;
      counted += best;
    }
    EXPECT_GT(with_bound, kW * kH / 4 / 2);
    EXPECT_GT(counted, with_bound * 9 / 10) << "hardware_scale " << hardware_scale;
  }
  // a box around the camera counts a pixel without a return: every depth is of interest
  ObstacleGridParams around = grid;
  around.x_min_m = -0.5;
  around.x_max_m = 0.4;
  for (const float b : FarthestCountedDepths_m(PointCloudParams{}, around, P)) {
    ASSERT_TRUE(std::isinf(b) && b > 0.0f);
  }
}

TEST(ObstacleGridTest, ValidateNamesTheBadKey) {
  ObstacleGridParams p;
  EXPECT_NO_THROW(p.Validate());
  p.x_max_m = 1.3;  // 20 cells, not 18
  try {
    p.Validate();
    FAIL() << "no throw";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("x_max_m"), std::string::npos) << e.what();
  }
  p = ObstacleGridParams{};
  p.z_min_m = 0.6;
  EXPECT_THROW(p.Validate(), std::invalid_argument);
  p = ObstacleGridParams{};
  p.X_base_camera[5] = std::nan("");
  EXPECT_THROW(p.Validate(), std::invalid_argument);
  EXPECT_THROW(ObstacleLayerParams{.lethal_above_count = 255}.Validate(), std::invalid_argument);
}

// --- the costmap layer ---

TEST(ObstacleGridLayerTest, LethalAboveTheThreshold) {
  Grid234 grid;
  grid.data[Grid234::Index(2, 3)] = 250;
  grid.data[Grid234::Index(2, 4)] = 251;
  grid.data[Grid234::Index(5, 0)] = 255;
  const std::vector<CostmapMark> marks =
      StepObstacleLayer(ObstacleLayerParams{}, ObstacleGridParams{}, grid, world::Pose2{});
  ASSERT_EQ(marks.size(), 234u);
  std::set<int> lethal;
  for (int i = 0; i < 234; ++i) {
    if (marks[i].lethal) lethal.insert(i);
  }
  EXPECT_EQ(lethal, (std::set<int>{Grid234::Index(2, 4), Grid234::Index(5, 0)}));
  // a lower threshold from the params
  const std::vector<CostmapMark> low = StepObstacleLayer(
      ObstacleLayerParams{.lethal_above_count = 249}, ObstacleGridParams{}, grid, world::Pose2{});
  EXPECT_TRUE(low[Grid234::Index(2, 3)].lethal);
}

TEST(ObstacleGridLayerTest, MarksAreTheCellsLowerCornersInOdom) {
  const Grid234 grid;
  // identity odom pose: the real layer's (gx·0.05 + 0.3, gy·0.05 − 0.325)
  const std::vector<CostmapMark> base =
      StepObstacleLayer(ObstacleLayerParams{}, ObstacleGridParams{}, grid, world::Pose2{});
  for (int gx = 0; gx < 18; ++gx) {
    for (int gy = 0; gy < 13; ++gy) {
      const world::Vec2& p = base[Grid234::Index(gx, gy)].p;
      EXPECT_EQ(p.x(), gx * 0.05 + 0.3);
      EXPECT_EQ(p.y(), gy * 0.05 - 0.325);
      EXPECT_FALSE(base[Grid234::Index(gx, gy)].lethal);
    }
  }
  // the car at (1, 2) facing +y (odom): base x is odom +y, base y is odom −x
  const world::Pose2 X_odom_base{1.0, 2.0, std::numbers::pi / 2};
  const std::vector<CostmapMark> odom =
      StepObstacleLayer(ObstacleLayerParams{}, ObstacleGridParams{}, grid, X_odom_base);
  EXPECT_NEAR(odom[Grid234::Index(0, 0)].p.x(), 1.325, 1e-12);
  EXPECT_NEAR(odom[Grid234::Index(0, 0)].p.y(), 2.3, 1e-12);
  EXPECT_NEAR(odom[Grid234::Index(17, 12)].p.x(), 1.0 - 0.275, 1e-12);
  EXPECT_NEAR(odom[Grid234::Index(17, 12)].p.y(), 2.0 + 1.15, 1e-12);
  // the option: the cells' centres, half a cell further
  const std::vector<CostmapMark> centres = StepObstacleLayer(
      ObstacleLayerParams{.mark_at_cell_centre = true}, ObstacleGridParams{}, grid, X_odom_base);
  EXPECT_NEAR(centres[Grid234::Index(0, 0)].p.x(), 1.3, 1e-12);
  EXPECT_NEAR(centres[Grid234::Index(0, 0)].p.y(), 2.325, 1e-12);
}

// obstacle_layer.cpp:40-65: the callback waits in canTransform("odom", "base_link", now, 1 s) and
// places the grid with the transform at `now`, the time it runs, between the two transforms that
// bracket it.
TEST(ObstacleGridLayerTest, TheGridIsPlacedWithTheTransformAtTheCallbacksTime) {
  const StampedPose a{FromSeconds(1.00), world::Pose2{1.0, 2.0, 0.1}};
  const StampedPose b{FromSeconds(1.05), world::Pose2{1.02, 2.01, 0.2}};
  const Time now = FromSeconds(1.02);
  // the newest transform is older than now: wait for the next
  EXPECT_EQ(TransformAt(std::nullopt, a, now), std::nullopt);
  // the next one is newer: 40 % of the way from a to b
  const std::optional<world::Pose2> X = TransformAt(a, b, now);
  ASSERT_TRUE(X.has_value());
  EXPECT_NEAR(X->x_m, 1.008, 1e-12);
  EXPECT_NEAR(X->y_m, 2.004, 1e-12);
  EXPECT_NEAR(X->yaw_rad, 0.14, 1e-12);
  // exactly at a transform's stamp: that transform
  EXPECT_EQ(TransformAt(a, b, FromSeconds(1.05))->x_m, 1.02);
  EXPECT_EQ(TransformAt(std::nullopt, a, FromSeconds(1.0))->x_m, 1.0);
  // the yaw across ±π takes the shorter arc
  const StampedPose c{FromSeconds(2.0), world::Pose2{0.0, 0.0, 3.1}};
  const StampedPose d{FromSeconds(2.1), world::Pose2{0.0, 0.0, -3.1}};
  EXPECT_NEAR(std::abs(TransformAt(c, d, FromSeconds(2.05))->yaw_rad), std::numbers::pi, 1e-12);
  // nothing at or before now (only newer transforms): tf2 would extrapolate into the past, so the
  // wait can only time out
  EXPECT_EQ(TransformAt(std::nullopt, b, now), std::nullopt);
  EXPECT_EQ(TransformAt(b, StampedPose{FromSeconds(1.1), world::Pose2{}}, now), std::nullopt);
  EXPECT_THROW(ObstacleLayerParams{.transform_timeout = Duration{0}}.Validate(),
               std::invalid_argument);
}

// --- on rendered frames of the lab track ---

// The real code's per-point arithmetic transcribed one point at a time (reference §3, §4), as an
// oracle for the row kernels.
Grid234 ScalarTranscription(bool hardware_scale, const ObstacleGridParams& p,
                            const vehicle::DepthImage& depth, const std::array<double, 12>& P) {
  const float fx = static_cast<float>(P[0]), cx = static_cast<float>(P[2]);
  const float fy = static_cast<float>(P[5]), cy = static_cast<float>(P[6]);
  const float scale = hardware_scale ? 1.0f / 1024 : 0.001f;
  float m[12];
  for (int i = 0; i < 12; ++i) m[i] = static_cast<float>(p.X_base_camera[i]);
  const float box[3][2] = {{static_cast<float>(p.x_min_m), static_cast<float>(p.x_max_m)},
                           {static_cast<float>(p.y_min_m), static_cast<float>(p.y_max_m)},
                           {static_cast<float>(p.z_min_m), static_cast<float>(p.z_max_m)}};
  Grid234 grid;
  for (int pixel = 0; pixel < kW * kH; ++pixel) {
    const float depth_x = static_cast<float>(pixel % kW);
    const float depth_y = static_cast<float>(pixel / kW);
    const float depth_z = depth.mm[pixel];
    const float u = depth_x * depth_z;
    const float v = depth_y * depth_z;
    const float x = (u - (cx * depth_z)) / fx;
    const float y = (v - (cy * depth_z)) / fy;
    const float in[3] = {depth_z * scale, -x * scale, -y * scale};
    float out[3];
    for (int r = 0; r < 3; ++r) {
      out[r] = m[r * 4] * in[0] + m[r * 4 + 1] * in[1] + m[r * 4 + 2] * in[2] + m[r * 4 + 3] * 1;
    }
    if (out[0] >= box[0][0] && out[0] <= box[0][1] && out[1] >= box[1][0] && out[1] <= box[1][1] &&
        out[2] >= box[2][0] && out[2] <= box[2][1]) {
      const float gxf = out[0] - box[0][0];
      const float gyf = out[1] - box[1][0];
      const int gx = static_cast<int>(gxf / p.cell_size_m);
      const int gy = static_cast<int>(gyf / p.cell_size_m);
      if (gx >= 18 || gy >= 13) continue;
      std::uint8_t& count = grid.data[gx * 13 + gy];
      if (count < 255) ++count;
    }
  }
  return grid;
}

class ObstacleGridFramesTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { frames_ = new testing::TrackFrames(); }
  static void TearDownTestSuite() {
    delete frames_;
    frames_ = nullptr;
  }

  static DepthImageView View(const vehicle::DepthImage& depth) {
    return DepthImageView{depth.width, depth.height, depth.mm};
  }
  static std::array<double, 12> P() { return frames_->depth_camera().Info().P; }

  // A box prism whose footprint centre is at (x, y) in the car's base frame, axis-aligned with it.
  static vehicle::Prism BoxAhead(const world::Pose2& X_map_car, double x_m, double y_m,
                                 double size_m) {
    const double c = std::cos(X_map_car.yaw_rad), s = std::sin(X_map_car.yaw_rad);
    const world::Pose2 X_map_box{X_map_car.x_m + c * x_m - s * y_m,
                                 X_map_car.y_m + s * x_m + c * y_m, X_map_car.yaw_rad};
    return vehicle::Prism{world::OrientedBox{X_map_box, size_m, size_m}, size_m,
                          vehicle::SceneAppearance{}.obstacle()};
  }

  static testing::TrackFrames* frames_;
};
testing::TrackFrames* ObstacleGridFramesTest::frames_ = nullptr;

// Poses along the routes: straights, the ring's corners (curves), the T-junctions.
std::vector<std::pair<std::string, double>> RoadPoses() {
  return {{"outer_loop", 0.5}, {"outer_loop", 1.2}, {"outer_loop", 3.3}, {"outer_loop", 5.8},
          {"outer_loop", 7.0}, {"outer_loop", 7.6}, {"south_loop", 7.3}, {"south_loop", 8.0},
          {"north_loop", 7.3}, {"north_loop", 8.2}, {"inner_loop", 1.0}, {"inner_loop", 1.6},
          {"inner_loop", 4.0}};
}

TEST_F(ObstacleGridFramesTest, EmptyRoadOccupiesNoCell) {
  for (const auto& [route, s_m] : RoadPoses()) {
    for (double lateral_m : {0.0, 0.08}) {
      const world::Pose2 pose = frames_->PoseOnRoute(route, s_m, lateral_m);
      const testing::RgbdFrame frame = frames_->Render(pose);
      for (bool hardware_scale : {false, true}) {
        const Grid234 grid = StepDepthToGrid(PointCloudParams{.hardware_scale = hardware_scale},
                                             ObstacleGridParams{}, View(frame.depth), P());
        EXPECT_EQ(grid, Grid234{})
            << route << " s " << s_m << " lateral " << lateral_m << (hardware_scale ? " HW" : " SW")
            << ": " << Total(grid) << " points counted on an empty road";
      }
    }
  }
}

TEST_F(ObstacleGridFramesTest, BoxAheadOccupiesTheCellsOfItsNearFace) {
  // A 0.3 m cube on the lane, its near face 0.625 m ahead of the chassis centre (the middle of a
  // cell row, so that no face lies on a cell boundary), centred on the car's axis.
  constexpr double kSize_m = 0.3;
  constexpr double kNear_m = 0.625;
  const ObstacleGridParams params;
  const auto cell_x = [&](double x) { return static_cast<int>(std::floor((x - 0.3) / 0.05)); };
  const auto cell_y = [&](double y) { return static_cast<int>(std::floor((y + 0.325) / 0.05)); };
  const int gx_near = cell_x(kNear_m), gx_far = cell_x(kNear_m + kSize_m);
  const int gy_right = cell_y(-kSize_m / 2), gy_left = cell_y(kSize_m / 2);
  ASSERT_EQ(gx_near, 6);
  ASSERT_EQ(gx_far, 12);
  ASSERT_EQ(gy_right, 3);
  ASSERT_EQ(gy_left, 9);
  // Which faces the camera sees: it sits below the top (so not the top) and between the side
  // planes (so neither side): the near face alone.
  const Eigen::Vector3d camera_base = frames_->depth_camera().X_base_camera().translation();
  ASSERT_LT(camera_base.z(), kSize_m);
  ASSERT_LT(std::abs(camera_base.y()), kSize_m / 2);

  for (const auto& [route, s_m] : std::vector<std::pair<std::string, double>>{
           {"outer_loop", 3.0}, {"outer_loop", 3.6}, {"south_loop", 9.0}}) {
    const world::Pose2 pose = frames_->PoseOnRoute(route, s_m);
    const vehicle::Prism box = BoxAhead(pose, kNear_m + kSize_m / 2, 0.0, kSize_m);
    const testing::RgbdFrame frame = frames_->Render(pose, {&box, 1});
    for (bool hardware_scale : {false, true}) {
      const Grid234 grid = StepDepthToGrid(PointCloudParams{.hardware_scale = hardware_scale},
                                           params, View(frame.depth), P());
      const std::string where =
          route + " s " + std::to_string(s_m) + (hardware_scale ? " HW" : " SW");
      for (int gx = 0; gx < 18; ++gx) {
        for (int gy = 0; gy < 13; ++gy) {
          const int count = grid.count(gx, gy);
          const bool near_face = gx == gx_near && gy >= gy_right && gy <= gy_left;
          const bool footprint_pm1 =
              gx >= gx_near - 1 && gx <= gx_far + 1 && gy >= gy_right - 1 && gy <= gy_left + 1;
          if (near_face) {
            EXPECT_GT(count, 250) << where << ": near-face cell (" << gx << ", " << gy << ")";
          } else if (hardware_scale) {
            // 1/1024 draws every point 2.3 % towards the camera: the face may spill one row back
            EXPECT_TRUE(count == 0 || footprint_pm1)
                << where << ": cell (" << gx << ", " << gy << ") holds " << count;
          } else {
            EXPECT_EQ(count, 0) << where << ": cell (" << gx << ", " << gy << ") holds " << count;
          }
        }
      }
    }
  }
}

TEST_F(ObstacleGridFramesTest, FusedIsBitIdenticalToCloudThenGrid) {
  // Frames with boxes at many offsets, sizes and headings, so that many cells hold partial
  // counts, plus the empty road.
  const std::vector<std::pair<std::string, double>> poses = RoadPoses();
  const ObstacleGridParams params;
  PointCloud640 cloud;
  int frames = 0, partial_cells = 0;
  DepthGridMemo memo;
  std::array<DepthGridMemo, 2> kept;     // one per scale
  std::array<DepthGridMemo, 2> flagged;  // one per scale, told which rows changed
  std::array<std::vector<std::uint16_t>, 2> last_depth;
  int skipped_rows = 0;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    const world::Pose2 pose = frames_->PoseOnRoute(poses[i].first, poses[i].second);
    std::vector<vehicle::Prism> prisms;
    if (i % 4 != 0) {
      const double x_m = 0.45 + 0.037 * static_cast<double>(i);
      const double y_m = -0.2 + 0.031 * static_cast<double>(i);
      prisms.push_back(BoxAhead(pose, x_m, y_m, 0.08 + 0.02 * static_cast<double>(i % 5)));
      world::Pose2 tilted = pose;
      tilted.yaw_rad += 0.3 * static_cast<double>(i);
      prisms.push_back(BoxAhead(tilted, 1.0, -0.1, 0.1));
    }
    const testing::RgbdFrame frame = frames_->Render(pose, prisms);
    for (bool hardware_scale : {false, true}) {
      const PointCloudParams cloud_params{.hardware_scale = hardware_scale};
      StepPointCloud(cloud_params, View(frame.depth), P(), &cloud);
      const Grid234 unfused = StepObstacleGrid(params, cloud);
      const Grid234 fused = StepDepthToGrid(cloud_params, params, View(frame.depth), P());
      EXPECT_EQ(fused, unfused) << poses[i].first << " s " << poses[i].second;
      // remembering rows across the sequence (frames with and without boxes, one memo for
      // both scales: it forgets when they change) gives the same grid
      EXPECT_EQ(StepDepthToGrid(cloud_params, params, View(frame.depth), P(), &memo), fused)
          << poses[i].first << " s " << poses[i].second;
      EXPECT_EQ(
          StepDepthToGrid(cloud_params, params, View(frame.depth), P(), &kept[hardware_scale]),
          fused)
          << poses[i].first << " s " << poses[i].second;
      // told the columns of each row that changed since the memo's last frame (from the first
      // to the last pixel that did), the others not compared
      std::vector<std::pair<int, int>> changed(PointCloud640::kHeight, {0, kW});
      std::vector<std::uint16_t>& last = last_depth[hardware_scale];
      if (!last.empty()) {
        for (int row = 0; row < PointCloud640::kHeight; ++row) {
          int begin = kW, end = 0;
          for (int col = 0; col < kW; ++col) {
            if (frame.depth.mm[row * kW + col] != last[row * kW + col]) {
              begin = std::min(begin, col);
              end = col + 1;
            }
          }
          changed[row] = begin < end ? std::pair{begin, end} : std::pair{0, 0};
          skipped_rows += begin >= end;
        }
      }
      last = frame.depth.mm;
      EXPECT_EQ(StepDepthToGrid(cloud_params, params, View(frame.depth), P(),
                                &flagged[hardware_scale], changed),
                fused)
          << poses[i].first << " s " << poses[i].second;
      EXPECT_EQ(fused, ScalarTranscription(hardware_scale, params, frame.depth, P()))
          << poses[i].first << " s " << poses[i].second;
      for (int c = 0; c < Grid234::kCells; ++c)
        partial_cells += fused.data[c] > 0 && fused.data[c] < 255;
      ++frames;
    }
  }
  EXPECT_GE(frames, 20);
  EXPECT_GT(partial_cells, 20);  // the comparison saw unsaturated counts, not just 0 and 255
  EXPECT_GT(skipped_rows, 1000);

  // A row flagged unchanged is taken on trust: the memo's counts of its last frame.
  DepthGridMemo memo_trusting;
  const world::Pose2 pose = frames_->PoseOnRoute(poses.front().first, poses.front().second);
  const testing::RgbdFrame bare = frames_->Render(pose, {});
  const std::vector<vehicle::Prism> box{BoxAhead(pose, 0.6, 0.0, 0.2)};
  const testing::RgbdFrame boxed = frames_->Render(pose, box);
  const Grid234 bare_grid = StepDepthToGrid({}, params, View(bare.depth), P(), &memo_trusting);
  ASSERT_NE(StepDepthToGrid({}, params, View(boxed.depth), P()), bare_grid);
  const std::vector<std::pair<int, int>> none(PointCloud640::kHeight, {0, 0});
  EXPECT_EQ(StepDepthToGrid({}, params, View(boxed.depth), P(), &memo_trusting, none), bare_grid);
  EXPECT_THROW(StepDepthToGrid({}, params, View(boxed.depth), P(), &memo_trusting,
                               std::vector<std::pair<int, int>>(3, {0, kW})),
               std::invalid_argument);
  for (const std::pair<int, int>& bad : {std::pair{0, kW + 1}, std::pair{-1, 4}, std::pair{9, 8}}) {
    std::vector<std::pair<int, int>> columns(PointCloud640::kHeight, {0, 0});
    columns[100] = bad;
    EXPECT_THROW(StepDepthToGrid({}, params, View(boxed.depth), P(), &memo_trusting, columns),
                 std::invalid_argument)
        << bad.first << ", " << bad.second;
  }
}

TEST_F(ObstacleGridFramesTest, TheSegmentMemoIsTheWholeGridWithPatchesAtRowEndsAndSegmentEdges) {
  // A box ahead on the lane, and over it, frame after frame, patches of depth that move, grow,
  // appear and disappear: at the start and the end of rows, one or two columns wide across a
  // segment's edge, exactly one segment, whole rows, and frames with none. Their depths (450 to
  // 849 mm, a new pattern each frame) put points in many cells of the box, at the row ends too.
  const world::Pose2 pose = frames_->PoseOnRoute("outer_loop", 3.3);
  const std::vector<vehicle::Prism> box{BoxAhead(pose, 0.7, 0.1, 0.2)};
  const vehicle::DepthImage base = frames_->Render(pose, box).depth;
  constexpr int kSegment = detail::kSegmentWidth;
  struct Patch {
    int c0, c1, r0, r1;  // columns [c0, c1), rows [r0, r1)
  };
  const auto patches_of = [](int k) {
    std::vector<Patch> patches;
    if (k == 7 || k == 13) return patches;  // none: every patch disappears
    patches.push_back({0, 20 + 4 * k, 150, 200});
    patches.push_back({kW - 1 - 3 * k, kW, 180 + 2 * k, 260 + 2 * k});
    const int edge = kSegment * (1 + k % (kW / kSegment - 1));
    patches.push_back({edge - 1, edge + 1, 120, 300});
    patches.push_back(k % 2 == 0 ? Patch{kSegment - 1, kSegment, 90, 330}
                                 : Patch{kSegment, kSegment + 1, 90, 330});
    if (k % 5 == 0) patches.push_back({0, kW, 200 + k, 205 + k});
    if (k % 3 == 1) patches.push_back({2 * kSegment, 3 * kSegment, 100, 340});
    return patches;
  };
  const ObstacleGridParams params;
  std::array<DepthGridMemo, 2> told, untold;  // one per scale
  DepthGridMemo alternating;                  // both scales: it forgets at each change
  std::vector<std::pair<int, int>> painted_before(kH, {0, 0});
  int frames = 0, partial_cells = 0, told_rows = 0;
  for (int k = 0; k < 24; ++k) {
    vehicle::DepthImage depth = base;
    std::vector<std::pair<int, int>> painted(kH, {kW, 0});
    for (const Patch& patch : patches_of(k)) {
      for (int row = patch.r0; row < patch.r1; ++row) {
        for (int col = patch.c0; col < patch.c1; ++col) {
          depth.mm[row * kW + col] =
              static_cast<std::uint16_t>(450 + (col * 7 + row * 13 + k * 29) % 400);
        }
        painted[row] = {std::min(painted[row].first, patch.c0),
                        std::max(painted[row].second, patch.c1)};
      }
    }
    // what the renderer's DepthRowHistory would say: the columns painted now or in the last frame
    std::vector<std::pair<int, int>> changed(kH);
    for (int row = 0; row < kH; ++row) {
      if (painted[row].first >= painted[row].second) painted[row] = {0, 0};
      const auto [b0, e0] = painted_before[row];
      const auto [b1, e1] = painted[row];
      changed[row] = b0 == e0   ? painted[row]
                     : b1 == e1 ? painted_before[row]
                                : std::pair{std::min(b0, b1), std::max(e0, e1)};
      told_rows +=
          changed[row].first < changed[row].second && changed[row].second - changed[row].first < kW;
    }
    painted_before = painted;
    for (bool hardware_scale : {false, true}) {
      const PointCloudParams cloud_params{.hardware_scale = hardware_scale};
      const std::string where = "frame " + std::to_string(k) + (hardware_scale ? " HW" : " SW");
      const Grid234 whole = StepDepthToGrid(cloud_params, params, View(depth), P());
      EXPECT_EQ(StepDepthToGrid(cloud_params, params, View(depth), P(), &told[hardware_scale],
                                k == 0 ? std::vector<std::pair<int, int>>{} : changed),
                whole)
          << where << ", told the changed columns";
      EXPECT_EQ(StepDepthToGrid(cloud_params, params, View(depth), P(), &untold[hardware_scale]),
                whole)
          << where << ", told nothing";
      EXPECT_EQ(StepDepthToGrid(cloud_params, params, View(depth), P(), &alternating, changed),
                whole)
          << where << ", after the other scale";
      for (int c = 0; c < Grid234::kCells; ++c)
        partial_cells += whole.data[c] > 0 && whole.data[c] < 255;
      ++frames;
    }
  }
  EXPECT_GT(partial_cells, frames * 20);  // many cells hold counts that the patches changed
  EXPECT_GT(told_rows, 24 * 100);         // most rows are told a part of them changed
}

// Random depths everywhere (a fixed seed): points all over the box, at every rounding.
TEST_F(ObstacleGridFramesTest, FusedIsBitIdenticalOnNoise) {
  std::uint64_t state = 0x243F6A8885A308D3ull;
  const auto next = [&state] {  // splitmix64
    std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  };
  vehicle::DepthImage depth{kW, kH, std::vector<std::uint16_t>(kW * kH)};
  PointCloud640 cloud;
  const ObstacleGridParams params;
  for (int frame = 0; frame < 4; ++frame) {
    for (auto& mm : depth.mm) {
      const std::uint64_t r = next();
      mm = (r & 7) == 0 ? 0 : static_cast<std::uint16_t>(300 + (r >> 8) % 1500);
    }
    for (bool hardware_scale : {false, true}) {
      const PointCloudParams cloud_params{.hardware_scale = hardware_scale};
      StepPointCloud(cloud_params, View(depth), P(), &cloud);
      const Grid234 fused = StepDepthToGrid(cloud_params, params, View(depth), P());
      EXPECT_EQ(fused, StepObstacleGrid(params, cloud));
      EXPECT_EQ(fused, ScalarTranscription(hardware_scale, params, depth, P()));
      EXPECT_GT(Total(fused), 1000);
    }
  }
}

}  // namespace
}  // namespace autonomsim::stack
