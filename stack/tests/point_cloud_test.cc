#include "stack/point_cloud.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstddef>
#include <stdexcept>
#include <vector>

#include "stack/tests/track_frames.h"
#include "vehicle/camera_model.h"

namespace autonomsim::stack {
namespace {

constexpr int kW = PointCloud640::kWidth;
constexpr int kH = PointCloud640::kHeight;

// A round-numbered camera, so that points can be computed by hand.
constexpr std::array<double, 12> kP{500.0, 0.0, 320.0, 0.0, 0.0, 500.0,
                                    240.0, 0.0, 0.0,   0.0, 1.0, 0.0};

struct OnePixel {
  std::vector<std::uint16_t> mm = std::vector<std::uint16_t>(kW * kH, 0);
  DepthImageView view() const { return DepthImageView{kW, kH, mm}; }
};

PointCloud640 Cloud(const OnePixel& image, bool hardware_scale = false,
                    const std::array<double, 12>& P = kP) {
  PointCloud640 cloud;
  StepPointCloud(PointCloudParams{.hardware_scale = hardware_scale}, image.view(), P, &cloud);
  return cloud;
}

TEST(PointCloudTest, MessageLayout) {
  EXPECT_EQ(sizeof(CloudPoint), 16u);
  // their PointCloud2 converter's fields: x, y, z float32 at offsets 0, 4, 8; the fourth at 12
  EXPECT_EQ(offsetof(CloudPoint, x_m), 0u);
  EXPECT_EQ(offsetof(CloudPoint, y_m), 4u);
  EXPECT_EQ(offsetof(CloudPoint, z_m), 8u);
  EXPECT_EQ(offsetof(CloudPoint, padding), 12u);
  EXPECT_EQ(PointCloud640::kModeledBytes, 640u * 480u * 16u);
  EXPECT_EQ(PointCloud640::kModeledBytes, 4'915'200u);
}

TEST(PointCloudTest, HandComputedPixel) {
  // column 420, row 140, 2000 mm: u − cx·d = 420·2000 − 320·2000 = 200000, / fx = 400;
  // v − cy·d = 140·2000 − 240·2000 = −200000, / fy = −400. Scaled by 0.001: (2, −0.4, 0.4).
  OnePixel image;
  image.mm[140 * kW + 420] = 2000;
  const CloudPoint p = Cloud(image).points[140 * kW + 420];
  EXPECT_FLOAT_EQ(p.x_m, 2.0f);
  EXPECT_FLOAT_EQ(p.y_m, -0.4f);
  EXPECT_FLOAT_EQ(p.z_m, 0.4f);
  EXPECT_EQ(p.padding, 0u);
  // bit for bit the real code's float expression
  EXPECT_EQ(p.x_m, 2000.0f * 0.001f);
  EXPECT_EQ(p.y_m, -400.0f * 0.001f);
}

TEST(PointCloudTest, AxisConventionIsForwardLeftUp) {
  OnePixel image;
  const int centre = 240 * kW + 320;       // on the optical axis
  const int right_below = 400 * kW + 600;  // right of and below the principal point
  const int left_above = 10 * kW + 5;
  image.mm[centre] = 1500;
  image.mm[right_below] = 1500;
  image.mm[left_above] = 1500;
  const PointCloud640 cloud = Cloud(image);
  EXPECT_FLOAT_EQ(cloud.points[centre].x_m, 1.5f);
  EXPECT_EQ(cloud.points[centre].y_m, 0.0f);
  EXPECT_EQ(cloud.points[centre].z_m, 0.0f);
  // x is the depth itself for every pixel (optical z), not the range along the ray
  EXPECT_FLOAT_EQ(cloud.points[right_below].x_m, 1.5f);
  EXPECT_LT(cloud.points[right_below].y_m, 0.0f);  // right is −y (left is +y)
  EXPECT_LT(cloud.points[right_below].z_m, 0.0f);  // below is −z
  EXPECT_GT(cloud.points[left_above].y_m, 0.0f);
  EXPECT_GT(cloud.points[left_above].z_m, 0.0f);
  EXPECT_FLOAT_EQ(cloud.points[left_above].y_m, (320.0f - 5.0f) * 1500.0f / 500.0f * 0.001f);
  EXPECT_FLOAT_EQ(cloud.points[left_above].z_m, (240.0f - 10.0f) * 1500.0f / 500.0f * 0.001f);
}

TEST(PointCloudTest, HardwareScaleIsOneOver1024) {
  OnePixel image;
  image.mm[140 * kW + 420] = 2000;
  const CloudPoint sw = Cloud(image, false).points[140 * kW + 420];
  const CloudPoint hw = Cloud(image, true).points[140 * kW + 420];
  // reference §3: 1/1024 m per mm in hardware; all three values are exact in binary
  EXPECT_EQ(hw.x_m, 1.953125f);
  EXPECT_EQ(hw.y_m, -0.390625f);
  EXPECT_EQ(hw.z_m, 0.390625f);
  EXPECT_NEAR(hw.x_m / sw.x_m, 1000.0 / 1024.0, 1e-6);
  EXPECT_EQ(PointCloudParams{.hardware_scale = true}.m_per_mm(), 1.0f / 1024.0f);
  EXPECT_EQ(PointCloudParams{}.m_per_mm(), 0.001f);
}

TEST(PointCloudTest, ZeroDepthBecomesTheCameraOrigin) {
  OnePixel image;  // all zero: no return anywhere
  const PointCloud640 cloud = Cloud(image);
  ASSERT_EQ(cloud.points.size(), static_cast<std::size_t>(kW * kH));
  for (int i : {0, 123, 240 * kW + 320, kW * kH - 1}) {
    const CloudPoint& p = cloud.points[i];
    EXPECT_EQ(p.x_m, 0.0f);
    EXPECT_EQ(p.y_m, 0.0f);
    EXPECT_EQ(p.z_m, 0.0f);
    EXPECT_FALSE(std::signbit(p.x_m));
    EXPECT_TRUE(std::signbit(p.y_m));  // −(0 / fx) · s, as the real code computes it
    EXPECT_TRUE(std::signbit(p.z_m));
    EXPECT_EQ(p.padding, 0u);
  }
}

TEST(PointCloudTest, RejectsInputsItCannotModel) {
  OnePixel image;
  PointCloud640 cloud;
  const PointCloudParams params;
  auto P = kP;
  P[3] = -30.0;  // Tx of a stereo pair's second camera
  EXPECT_THROW(StepPointCloud(params, image.view(), P, &cloud), std::invalid_argument);
  P = kP;
  P[0] = 0.0;
  EXPECT_THROW(StepPointCloud(params, image.view(), P, &cloud), std::invalid_argument);
  const std::vector<std::uint16_t> small(320 * 240, 0);
  EXPECT_THROW(StepPointCloud(params, DepthImageView{320, 240, small}, kP, &cloud),
               std::invalid_argument);
}

TEST(PointCloudTest, ReusesTheCloudsMemory) {
  OnePixel image;
  PointCloud640 cloud;
  StepPointCloud(PointCloudParams{}, image.view(), kP, &cloud);
  const CloudPoint* first = cloud.points.data();
  image.mm[7] = 900;
  StepPointCloud(PointCloudParams{}, image.view(), kP, &cloud);
  EXPECT_EQ(cloud.points.data(), first);
  EXPECT_FLOAT_EQ(cloud.points[7].x_m, 0.9f);
}

// On a rendered frame of the empty road, every point with a return lies on the floor once moved
// into base_link by the camera's own mount: the cloud's convention agrees with the renderer's.
TEST(PointCloudTest, RenderedFloorPointsLieOnTheFloor) {
  const testing::TrackFrames frames;
  const vehicle::CameraModel& camera = frames.depth_camera();
  const world::Pose2 pose = frames.PoseOnRoute("outer_loop", 3.3);
  const testing::RgbdFrame frame = frames.Render(pose);
  PointCloud640 cloud;
  StepPointCloud(PointCloudParams{}, DepthImageView{kW, kH, frame.depth.mm}, camera.Info().P,
                 &cloud);
  // forward/left/up = (optical z, −optical x, −optical y)
  const Eigen::Isometry3d& X_base_optical = camera.X_base_camera();
  int returns = 0;
  double worst_m = 0.0;
  for (int i = 0; i < kW * kH; ++i) {
    if (frame.depth.mm[i] == 0) continue;
    ++returns;
    const CloudPoint& p = cloud.points[i];
    const Eigen::Vector3d p_optical(-p.y_m, -p.z_m, p.x_m);
    const Eigen::Vector3d p_base = X_base_optical * p_optical;
    worst_m = std::max(worst_m, std::abs(p_base.z()));
  }
  // the floor from the near clip (0.6 m, the lowest rows see it nearer) to the far clip (8 m)
  EXPECT_GT(returns, kW * kH / 3);
  // depth is rounded to 1 mm; the floor's height error stays well under that
  EXPECT_LT(worst_m, 0.001);
}

}  // namespace
}  // namespace autonomsim::stack
