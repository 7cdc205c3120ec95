// The camera model: its CameraInfo, its mounts (checked against the reference's transform), and
// the plumb_bob model, checked against OpenCV's projectPoints as an independent implementation.
#include "vehicle/camera_model.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <numbers>
#include <opencv2/calib3d.hpp>
#include <stdexcept>
#include <string>
#include <vector>

namespace autonomsim::vehicle {
namespace {

using ::testing::HasSubstr;

std::string InvalidArgumentMessage(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "(no std::invalid_argument thrown)";
}

TEST(CameraParamsTest, TheRealCarsCamerasValidate) {
  EXPECT_NO_THROW(ColorCameraParams().Validate());
  EXPECT_NO_THROW(DepthCameraParams().Validate());
  EXPECT_NO_THROW(CameraParams{}.Validate());
}

TEST(CameraParamsTest, BadValuesNameTheirKey) {
  CameraParams p = DepthCameraParams();
  p.K[0] = 0.0;
  EXPECT_THAT(InvalidArgumentMessage([&] { p.Validate(); }), HasSubstr("fx"));
  p = DepthCameraParams();
  p.clip_far_m = 70.0;
  EXPECT_THAT(InvalidArgumentMessage([&] { p.Validate(); }), HasSubstr("clip_far_m"));
  p = DepthCameraParams();
  p.clip_near_m = 0.0;
  EXPECT_THAT(InvalidArgumentMessage([&] { p.Validate(); }), HasSubstr("clip_near_m"));
  p = DepthCameraParams();
  p.width_px = 0;
  EXPECT_THAT(InvalidArgumentMessage([&] { p.Validate(); }), HasSubstr("width_px"));
  p = DepthCameraParams();
  p.P[10] = 2.0;
  EXPECT_THAT(InvalidArgumentMessage([&] { p.Validate(); }), HasSubstr("P"));
  p = DepthCameraParams();
  p.mount.pitch_deg = 200.0;
  EXPECT_THAT(InvalidArgumentMessage([&] { p.Validate(); }), HasSubstr("pitch_deg"));
  p = DepthCameraParams();
  p.D[0] = std::nan("");
  EXPECT_THAT(InvalidArgumentMessage([&] { p.Validate(); }), HasSubstr("D[0]"));
}

TEST(CameraModelTest, DepthMountIsTheObstacleCodesTransform) {
  // reference §2: camera→base rotation about y by 0.15 rad, R as printed there (the obstacle
  // code's matrix, whose entries are those of 0.1501 rad to 5 digits), translation
  // (-0.155, 0, 0.264); the camera body frame (x forward, y left, z up) is the optical frame
  // turned.
  const CameraModel camera(DepthCameraParams());
  Eigen::Matrix3d R_body_optical;
  R_body_optical << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  const Eigen::Matrix3d R_base_body = camera.X_base_camera().linear() * R_body_optical.transpose();
  Eigen::Matrix3d expected;
  expected << 0.98875, 0, 0.14955, 0, 1, 0, -0.14955, 0, 0.98875;
  EXPECT_LT((R_base_body - expected).cwiseAbs().maxCoeff(), 1e-5) << R_base_body;
  EXPECT_LT((camera.X_base_camera().translation() - Eigen::Vector3d(-0.155, 0.0, 0.264)).norm(),
            1e-12);
}

TEST(CameraModelTest, ColorCameraLooksForwardPitchedDown) {
  const CameraModel camera(ColorCameraParams());
  const Eigen::Vector3d axis = camera.X_base_camera().linear() * Eigen::Vector3d::UnitZ();
  const double pitch = 15.4 * std::numbers::pi / 180.0;
  EXPECT_LT((axis - Eigen::Vector3d(std::cos(pitch), 0.0, -std::sin(pitch))).norm(), 1e-12);
  // optical x is the car's right, optical y points down-ish
  EXPECT_LT(
      (camera.X_base_camera().linear() * Eigen::Vector3d::UnitX() - Eigen::Vector3d(0.0, -1.0, 0.0))
          .norm(),
      1e-12);
  EXPECT_LT((camera.X_base_camera().translation() - Eigen::Vector3d(0.137, -0.007, 0.133)).norm(),
            1e-12);
}

TEST(CameraModelTest, DepthIntrinsicsSpanTheGazeboFieldOfView) {
  // reference §2: HFOV 1.0472 rad over 640 columns, whose outer edges are at u = -0.5 and 639.5
  const CameraModel camera(DepthCameraParams());
  const auto left = camera.NormalizedRay(-0.5, 239.5);
  const auto right = camera.NormalizedRay(639.5, 239.5);
  ASSERT_TRUE(left && right);
  EXPECT_NEAR(std::atan(right->x()) - std::atan(left->x()), 1.0472, 1e-12);
  EXPECT_NEAR(left->y(), 0.0, 1e-12);
}

TEST(CameraModelTest, CameraInfoFollowsRosSemantics) {
  const CameraParams color = ColorCameraParams();
  const CameraInfo info = CameraModel(color).Info();
  EXPECT_EQ(info.width, 640);
  EXPECT_EQ(info.height, 480);
  EXPECT_EQ(info.distortion_model, "plumb_bob");
  EXPECT_EQ(info.K, color.K);
  EXPECT_EQ(info.D, color.D);
  EXPECT_EQ(info.P, color.P);  // the rectified projection
  EXPECT_EQ(info.R, (std::array<double, 9>{1, 0, 0, 0, 1, 0, 0, 0, 1}));

  CameraParams ideal = color;
  ideal.lens_distortion = false;  // an ideal pinhole image through K: D = 0, P = [K | 0]
  const CameraInfo ideal_info = CameraModel(ideal).Info();
  EXPECT_EQ(ideal_info.D, (std::array<double, 5>{0, 0, 0, 0, 0}));
  EXPECT_EQ(ideal_info.P, (std::array<double, 12>{color.K[0], 0, color.K[2], 0, 0, color.K[4],
                                                  color.K[5], 0, 0, 0, 1, 0}));
}

TEST(CameraModelTest, ProjectMatchesOpenCvProjectPoints) {
  for (const bool distortion : {true, false}) {
    CameraParams params = ColorCameraParams();
    params.lens_distortion = distortion;
    const CameraModel camera(params);
    std::vector<cv::Point3d> points;
    for (double x = -1.2; x <= 1.2; x += 0.2) {
      for (double y = -0.9; y <= 0.9; y += 0.15) points.emplace_back(x * 2.0, y * 2.0, 2.0);
    }
    const cv::Matx33d K(params.K.data());
    const std::vector<double> D = distortion ? std::vector<double>(params.D.begin(), params.D.end())
                                             : std::vector<double>(5, 0.0);
    std::vector<cv::Point2d> expected;
    cv::projectPoints(points, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K, D, expected);
    for (std::size_t i = 0; i < points.size(); ++i) {
      const auto pixel = camera.Project({points[i].x, points[i].y, points[i].z});
      ASSERT_TRUE(pixel.has_value());
      EXPECT_NEAR(pixel->x(), expected[i].x, 1e-9);
      EXPECT_NEAR(pixel->y(), expected[i].y, 1e-9);
    }
  }
}

TEST(CameraModelTest, NormalizedRayInvertsProjectOverTheWholeImage) {
  const CameraModel camera(ColorCameraParams());
  double worst = 0.0;
  for (int v = 0; v < camera.height(); v += 7) {
    for (int u = 0; u < camera.width(); u += 7) {
      const auto ray = camera.NormalizedRay(u, v);
      ASSERT_TRUE(ray.has_value()) << u << "," << v;
      const auto pixel = camera.Project({ray->x(), ray->y(), 1.0});
      ASSERT_TRUE(pixel.has_value());
      worst = std::max(worst, (*pixel - Eigen::Vector2d(u, v)).norm());
    }
  }
  EXPECT_LT(worst, 1e-9);
}

// The ray table is built a row at a time (CameraRays): the same bits as pixel by pixel, with the
// lens and without it, and where a wide lens's model folds (nullopt) as well.
TEST(CameraModelTest, NormalizedRaysOfARowAreThoseOfItsPixels) {
  CameraParams wide = ColorCameraParams();
  wide.K[0] = wide.K[4] = 150.0;  // a wider view reaches beyond the model's monotone range
  for (const CameraParams& params : {ColorCameraParams(), DepthCameraParams(), wide}) {
    const CameraModel camera(params);
    std::vector<std::optional<Eigen::Vector2d>> rays;
    for (int v = 0; v < camera.height(); v += 3) {
      camera.NormalizedRaysOfRow(v, &rays);
      ASSERT_EQ(rays.size(), static_cast<std::size_t>(camera.width()));
      for (int u = 0; u < camera.width(); ++u) {
        const auto ray = camera.NormalizedRay(u, v);
        const auto& of_row = rays[static_cast<std::size_t>(u)];
        ASSERT_EQ(of_row.has_value(), ray.has_value()) << params.name << " " << u << "," << v;
        if (ray) {
          ASSERT_EQ(of_row->x(), ray->x()) << params.name << " " << u << "," << v;
          ASSERT_EQ(of_row->y(), ray->y()) << params.name << " " << u << "," << v;
        }
      }
    }
  }
}

TEST(CameraModelTest, NothingBehindTheCameraProjects) {
  const CameraModel camera(DepthCameraParams());
  EXPECT_FALSE(camera.Project({0.0, 0.0, -1.0}).has_value());
  EXPECT_FALSE(camera.Project({1.0, 0.0, 0.0}).has_value());
}

TEST(CameraModelTest, MapPoseComposesTheCarPose) {
  const CameraModel camera(DepthCameraParams());
  const world::Pose2 car{1.0, -2.0, std::numbers::pi / 2};  // facing north
  const Eigen::Isometry3d X = camera.X_map_camera(car);
  // the camera sits 0.155 m behind the chassis centre, i.e. south of it, 0.264 m up
  EXPECT_LT((X.translation() - Eigen::Vector3d(1.0, -2.155, 0.264)).norm(), 1e-12);
  const Eigen::Vector3d axis = X.linear() * Eigen::Vector3d::UnitZ();
  EXPECT_NEAR(axis.x(), 0.0, 1e-12);
  EXPECT_NEAR(axis.y(), 0.98875, 1e-5);
  EXPECT_NEAR(axis.z(), -0.14955, 1e-5);
}

}  // namespace
}  // namespace autonomsim::vehicle
