// The lab's lane detection where it departs from ours (stack/lane_detection.h: the enums and
// options above LaneDetectionParams): rt_laneplanner's combined image, rt_polyfit's fit and
// message, and the PnP floor projection both of the lab's pipelines use.
#include <bit>
#include <cmath>
#include <limits>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "stack/lane_detection.h"
#include "world/plumb_bob.h"
#include "world/validation.h"

namespace autonomsim::stack {

void LaneCombinedReference(const cv::Mat& bgr, const LaneThresholds& thresholds,
                           const cv::Mat& image_to_birds_eye, cv::Mat* combined) {
  cv::Mat hsv;
  cv::cvtColor(bgr, hsv, cv::COLOR_BGR2HSV);
  const auto scalar = [](const std::array<int, 3>& a) { return cv::Scalar(a[0], a[1], a[2]); };
  cv::Mat yellow, white;
  cv::inRange(hsv, scalar(thresholds.yellow.lower_hsv), scalar(thresholds.yellow.upper_hsv),
              yellow);
  cv::inRange(hsv, scalar(thresholds.white.lower_hsv), scalar(thresholds.white.upper_hsv), white);
  // rt_laneplanner.cpp:138: combined = white + (yellow >> 1), an ap_uint<8> (wraps)
  cv::Mat sum(bgr.rows, bgr.cols, CV_8UC1);
  for (int r = 0; r < bgr.rows; ++r) {
    for (int c = 0; c < bgr.cols; ++c) {
      sum.at<std::uint8_t>(r, c) = static_cast<std::uint8_t>(
          (white.at<std::uint8_t>(r, c) + (yellow.at<std::uint8_t>(r, c) >> 1)) & 0xff);
    }
  }
  cv::warpPerspective(sum, *combined, image_to_birds_eye,
                      cv::Size(kLaneImageWidth, kLaneImageHeight));
}

BirdsEyeRowSums RowSumsOfCombined(const cv::Mat& combined) {
  Require(combined.type() == CV_8UC1 && combined.cols == kLaneImageWidth &&
              combined.rows == kLaneImageHeight,
          "the combined bird's-eye image must be 640x480 mono8");
  BirdsEyeRowSums sums;
  for (int r = 0; r < combined.rows; ++r) {
    const std::uint8_t* p = combined.ptr<std::uint8_t>(r);
    for (int c = 0; c < combined.cols; ++c) {
      auto& rows = p[c] == 255 ? sums.white : sums.yellow;
      if (p[c] != 255 && p[c] != 127) continue;
      ++rows[static_cast<std::size_t>(r)].count;
      rows[static_cast<std::size_t>(r)].col_sum += c;
    }
  }
  return sums;
}

LanePnpPose LabPnpPose(const LaneCameraCalibration& camera,
                       std::span<const std::array<double, 2>> floor_points_m) {
  camera.Validate();
  const Eigen::Isometry3d X_camera_base = camera.X_base_camera.inverse();
  const auto& K = camera.K;
  std::vector<cv::Point3d> world;
  std::vector<cv::Point2d> image;
  for (const auto& p : floor_points_m) {
    const Eigen::Vector3d p_cam = X_camera_base * Eigen::Vector3d(p[0], p[1], 0.0);
    const auto where = [&] { return "PnP floor point (" + Num(p[0]) + ", " + Num(p[1]) + ") m"; };
    Require(p_cam.z() > 0.0, [&] { return where() + " is behind the camera"; });
    const Eigen::Vector2d d = world::Distort(camera.D, p_cam.head<2>() / p_cam.z());
    const double u = K[0] * d.x() + K[1] * d.y() + K[2];
    const double v = K[4] * d.y() + K[5];
    // a point the camera does not see cannot be picked in its image
    if (!(u >= 0.0 && u < kLaneImageWidth && v >= 0.0 && v < kLaneImageHeight)) continue;
    world.emplace_back(p[0], p[1], 0.0);
    image.emplace_back(std::round(v), std::round(u));  // (row, col), as real_pointsets.yml:4-8
  }
  Require(world.size() >= 4, "the PnP calibration needs at least 4 floor points in the image");
  const cv::Mat K_cv(3, 3, CV_64F, const_cast<double*>(K.data()));
  const cv::Mat D_cv(5, 1, CV_64F, const_cast<double*>(camera.D.data()));
  cv::Mat rvec, tvec, R;
  cv::solvePnP(world, image, K_cv, D_cv, rvec, tvec);  // lane_detector.cpp:47-49
  cv::Rodrigues(rvec, R);
  // lane_detector.cpp:50-53: the rotation and K inverted with cv::Mat::inv (LU)
  const cv::Mat R_inv = R.inv();
  const cv::Mat K_inv = K_cv.inv();
  LanePnpPose pose;
  for (int i = 0; i < 3; ++i) {
    pose.t(i) = tvec.at<double>(i);
    for (int j = 0; j < 3; ++j) {
      pose.R_inv(i, j) = R_inv.at<double>(i, j);
      pose.K_inv(i, j) = K_inv.at<double>(i, j);
    }
  }
  return pose;
}

Eigen::Vector2d ProjectLabPnp(const LanePnpPose& pose, double a, double b) {
  const Eigen::Vector3d uv1(a, b, 1.0);
  const double s = (pose.R_inv * pose.t).z() / (pose.R_inv * pose.K_inv * uv1).z();
  const Eigen::Vector3d p = pose.R_inv * (s * pose.K_inv * uv1 - pose.t);
  return p.head<2>();
}

Eigen::Vector2f ProjectLabPnpFloat(const LanePnpPose& pose, float a, float b) {
  // rt_polyfit.cpp:170-241, in its order of operations
  const Eigen::Matrix3f R = pose.R_inv.cast<float>();
  const Eigen::Matrix3f K = pose.K_inv.cast<float>();
  const Eigen::Vector3f t = pose.t.cast<float>();
  const float uv1[3] = {a, b, 1.0F};
  float tmp1[3][3] = {};
  float tmp2 = 0.0F;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      for (int k = 0; k < 3; ++k) tmp1[i][j] += R(i, k) * K(k, j);
    }
  }
  for (int k = 0; k < 3; ++k) tmp2 += R(2, k) * t(k);
  float ray_z = 0.0F;
  for (int k = 0; k < 3; ++k) ray_z += tmp1[2][k] * uv1[k];
  const float s = tmp2 / ray_z;
  float tmp4[3];
  for (int i = 0; i < 3; ++i) {
    float tmp3 = 0.0F;
    for (int k = 0; k < 3; ++k) tmp3 += K(i, k) * uv1[k];
    tmp4[i] = tmp3 * s - t(i);
  }
  Eigen::Vector2f p = Eigen::Vector2f::Zero();
  for (int i = 0; i < 2; ++i) {
    for (int k = 0; k < 3; ++k) p(i) += R(i, k) * tmp4[k];
  }
  return p;
}

LanePoints LabHardwareMessage(const std::array<LanePoint, LanePoints::kCount>& written) {
  LanePoints received;
  // rt_polyfit.cpp:252-256: a point's word is x's bits low, y's bits high
  received.valid =
      (static_cast<std::uint64_t>(std::bit_cast<std::uint32_t>(written[0].y_m)) << 32) |
      std::bit_cast<std::uint32_t>(written[0].x_m);
  for (int k = 0; k + 1 < LanePoints::kCount; ++k) {
    received.points[static_cast<std::size_t>(k)] = written[static_cast<std::size_t>(k + 1)];
  }
  received.points[LanePoints::kCount - 1] = LanePoint{};  // never written: assumed zero
  return received;
}

LanePoints FitLanePointsHardware(const LaneDetectorTables& tables, const BirdsEyeRowSums& sums,
                                 LaneDetectionTrace* trace) {
  const LaneDetectionParams& params = tables.params();
  LaneDetectionTrace local;
  LaneDetectionTrace& t = trace != nullptr ? *trace : local;
  t = LaneDetectionTrace{};
  // rt_polyfit.cpp:47-77 counts both; :80-96 yellow with >= 2000, else white
  t.yellow_px = detail::PixelCount(sums.yellow);
  t.white_px = detail::PixelCount(sums.white);
  const LaneLine line = t.yellow_px >= params.yellow_min_px ? LaneLine::kYellow : LaneLine::kWhite;
  const bool white_short = t.white_px < params.line_min_px;
  const bool valid = params.hw_no_line == HwNoLine::kBothBelowMin
                         ? !(white_short && t.yellow_px < params.line_min_px)  // :246-248
                         : line == LaneLine::kYellow || !white_short;
  t.line = valid ? line : LaneLine::kNone;
  if (!valid && !params.hw_valid_overwrite) return LanePoints{};  // the receiver reads valid 0

  const detail::LaneFitRules rules{.truncate = params.hw_truncate_points, .in_float = true};
  auto points = detail::LanePointsOfLine(
      tables, line == LaneLine::kYellow ? sums.yellow : sums.white, line, rules, &t);
  if (!params.hw_valid_overwrite) {
    LanePoints out;
    if (!points) return out;
    out.points = *points;
    out.valid = 1;
    return out;
  }
  if (!points) {
    constexpr float kNan = std::numeric_limits<float>::quiet_NaN();
    points.emplace().fill(LanePoint{kNan, kNan});
  }
  return LabHardwareMessage(*points);
}

}  // namespace autonomsim::stack
