// The lab's lane detection where it departs from ours (issue 31 item 1), one rule per test, on
// hand-made bird's-eye images and row sums. Lab paths: MohnessWaizy/AutonomROS, rt_* under
// code/reconros_ws/laneplanner/src/, the rest under code/ros_ws/src/autonomros_lane_detection/.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <vector>

#include "stack/lane_detection.h"
#include "stack/tests/lane_classes.h"
#include "stack/tests/track_frames.h"
#include "vehicle/camera_model.h"
#include "world/plumb_bob.h"

namespace autonomsim::stack {
namespace {

LaneCameraCalibration LabTestCamera() {
  const vehicle::CameraModel camera(vehicle::ColorCameraParams());
  LaneCameraCalibration c;
  c.K = camera.params().K;
  c.D = camera.params().D;
  c.X_base_camera = camera.X_base_camera();
  return c;
}

cv::Mat LabTestMat(const vehicle::ColorImage& image) {
  return cv::Mat(image.height, image.width, CV_8UC3, const_cast<std::uint8_t*>(image.bgr.data()));
}

// A line in the row sums: `count` pixels in every row of [first, last] whose columns sum to
// `col_sum(row)`.
template <class ColSum>
void AddRowSumsLine(std::array<BirdsEyeRowSums::Row, kLaneImageHeight>* rows, int first, int last,
                    int count, ColSum col_sum) {
  for (int r = first; r <= last; ++r) (*rows)[static_cast<std::size_t>(r)] = {count, col_sum(r)};
}

// rt_polyfit.cpp:53-74: only a warped value of exactly 255 is white, exactly 127 yellow; the
// combined image of rt_laneplanner.cpp:138 (white + (yellow >> 1)) holds 126 where both were set.
TEST(LaneHardwareTest, CountsOnlyWarpedPixelsOfExactly255AsWhiteAnd127AsYellow) {
  cv::Mat combined = cv::Mat::zeros(kLaneImageHeight, kLaneImageWidth, CV_8UC1);
  const std::uint8_t row10[] = {255, 254, 127, 128, 126, 1, 255, 127};
  for (int c = 0; c < 8; ++c) combined.at<std::uint8_t>(10, 100 + c) = row10[c];
  const BirdsEyeRowSums sums = RowSumsOfCombined(combined);
  EXPECT_EQ(sums.white[10].count, 2);
  EXPECT_EQ(sums.white[10].col_sum, 100 + 106);
  EXPECT_EQ(sums.yellow[10].count, 2);
  EXPECT_EQ(sums.yellow[10].col_sum, 102 + 107);
  // the non-zero count of the same pixels as masks would take all eight
  int non_zero = 0;
  for (std::uint8_t v : row10) non_zero += v != 0;
  EXPECT_EQ(non_zero, 8);
}

// A white stripe through the warp: its blended edges are non-zero but not 255, so the exact count
// is smaller; a yellow stripe's edges blend 127 with 0 and drop out as well.
TEST(LaneHardwareTest, ALinesBlendedEdgesDropOutOfTheExactCount) {
  LaneDetector detector(LaneDetectionParams{}, LabTestCamera());
  cv::Mat bgr = cv::Mat::zeros(kLaneImageHeight, kLaneImageWidth, CV_8UC3);
  // columns in the raw image that the warp reads at an angle (every blend occurs)
  cv::line(bgr, {200, 479}, {300, 270}, cv::Scalar(255, 255, 255), 9);
  cv::line(bgr, {420, 479}, {340, 270}, cv::Scalar(0, 235, 235), 9);
  BirdsEyeRowSums non_zero, exact;
  detector.ComputeRowSums(bgr, &non_zero, BirdsEyeClasses::kNonZero);
  detector.ComputeRowSums(bgr, &exact, BirdsEyeClasses::kExact);
  int nz_white = 0, nz_yellow = 0, ex_white = 0, ex_yellow = 0;
  for (int r = 0; r < kLaneImageHeight; ++r) {
    nz_white += non_zero.white[r].count;
    nz_yellow += non_zero.yellow[r].count;
    ex_white += exact.white[r].count;
    ex_yellow += exact.yellow[r].count;
  }
  std::printf("  white: non-zero %d exact %d; yellow: non-zero %d exact %d\n", nz_white, ex_white,
              nz_yellow, ex_yellow);
  EXPECT_GT(ex_white, 0);
  EXPECT_GT(ex_yellow, 0);
  EXPECT_LT(ex_white, nz_white);
  EXPECT_LT(ex_yellow, nz_yellow);
}

// The fast path's exact counts are RowSumsOfCombined of the plain OpenCV combined image, bit for
// bit: on rendered track frames (both ways to feed it) and on noise holding every class, both
// line colours in one pixel included (126: neither class).
TEST(LaneHardwareTest, FastExactCountsAreBitIdenticalToTheCombinedReference) {
  const testing::TrackFrames frames;
  LaneDetector detector(LaneDetectionParams{}, LabTestCamera());
  const auto check = [&](const cv::Mat& bgr, const char* what) {
    cv::Mat combined;
    LaneCombinedReference(bgr, detector.thresholds(), detector.image_to_birds_eye(), &combined);
    BirdsEyeRowSums fast;
    detector.ComputeRowSums(bgr, &fast, BirdsEyeClasses::kExact);
    EXPECT_EQ(fast, RowSumsOfCombined(combined)) << what;
    return fast;
  };
  for (const auto& [route, s_m] : {std::pair{"outer_loop", 2.5},
                                   {"outer_loop", 6.5},
                                   {"outer_loop", 9.0},
                                   {"inner_loop", 4.0},
                                   {"south_loop", 9.2}}) {
    const auto frame = frames.Render(frames.PoseOnRoute(route, s_m));
    const BirdsEyeRowSums fast = check(LabTestMat(frame.color), route);
    // from a producer's classes
    testing::WriteLineClasses(detector, frame.color);
    BirdsEyeRowSums from_classes;
    detector.ComputeRowSumsFromClasses(&from_classes, BirdsEyeClasses::kExact);
    EXPECT_EQ(from_classes, fast) << route;
  }
  std::mt19937 rng(7);
  cv::Mat noise(kLaneImageHeight, kLaneImageWidth, CV_8UC3);
  for (int i = 0; i < noise.rows * noise.cols * 3; ++i)
    noise.data[i] = static_cast<std::uint8_t>(rng());
  noise(cv::Rect(100, 300, 200, 100)).setTo(cv::Scalar(255, 255, 255));
  noise(cv::Rect(300, 280, 250, 120)).setTo(cv::Scalar(0, 235, 235));
  check(noise, "noise");
  // a colour in both classes: a test-only threshold set is not offered, so check the 126 rule on
  // the reference alone: both masks set give 126, which is neither class
  cv::Mat both = cv::Mat::zeros(kLaneImageHeight, kLaneImageWidth, CV_8UC1);
  both.setTo(126);
  const BirdsEyeRowSums none = RowSumsOfCombined(both);
  EXPECT_EQ(none, BirdsEyeRowSums{});
}

// rt_polyfit.cpp:80-96, 246-248: yellow with >= 2000, else the white fit; `valid` 0 only when
// both are below 1000. The software node (lane_detector.cpp:265-276) has no line with white <
// 1000 whatever the yellow.
TEST(LaneHardwareTest, FitsTheFewWhitePixelsWhenYellowIsShortOfTwoThousand) {
  BirdsEyeRowSums sums;
  AddRowSumsLine(&sums.yellow, 200, 479, 5, [](int r) { return 5 * (200 + r / 8); });  // 1400 px
  AddRowSumsLine(&sums.white, 100, 279, 5, [](int r) { return 5 * (470 + r / 16); });  // 900 px
  LaneDetectionParams params;
  params.hw_no_line = HwNoLine::kBothBelowMin;
  const LaneDetectorTables lab(params, LabTestCamera());
  LaneDetectionTrace trace;
  const LanePoints fitted = FitLanePointsHardware(lab, sums, &trace);
  EXPECT_EQ(trace.yellow_px, 1400);
  EXPECT_EQ(trace.white_px, 900);
  EXPECT_EQ(trace.line, LaneLine::kWhite);
  EXPECT_EQ(fitted.valid, 1u);
  ASSERT_TRUE(trace.line_fit);
  EXPECT_NEAR((*trace.line_fit)(160.0), 470.0 + 10.0, 1.0);  // the white pixels' line
  // ours: no line
  const LaneDetectorTables ours(LaneDetectionParams{}, LabTestCamera());
  EXPECT_EQ(FitLanePointsHardware(ours, sums, &trace).valid, 0u);
  EXPECT_EQ(trace.line, LaneLine::kNone);
  EXPECT_EQ(FitLanePoints(ours, sums).valid, 0u);
  // both below 1000: `valid` 0 under the lab's rule too
  BirdsEyeRowSums few;
  AddRowSumsLine(&few.yellow, 300, 479, 5, [](int r) { return 5 * (200 + r / 8); });  // 900 px
  AddRowSumsLine(&few.white, 100, 279, 5, [](int r) { return 5 * (470 + r / 16); });  // 900 px
  EXPECT_EQ(FitLanePointsHardware(lab, few).valid, 0u);
}

// rt_polyfit.cpp:107-114: the line's column at row i·16 truncated, then row + Δrow and col + Δcol
// truncated. The line col = 400.5 + row/4 (white: Δ = 150 · (0.25, −1) / √1.0625 = (36.38,
// −145.52)) gives the integer points (16i + 36, 254 + 4i), and the trajectory is their fit with
// the anchors; untruncated it is the fit of (16i + 36.38, 254.98 + 4i).
TEST(LaneHardwareTest, TruncatesTheSamplesAndTheShiftedPointsToIntegers) {
  BirdsEyeRowSums sums;
  AddRowSumsLine(&sums.white, 0, 479, 4,
                 [](int r) { return std::int64_t{1602} + r; });  // 400.5 + r/4
  LaneDetectionParams params;
  params.hw_truncate_points = true;
  const LaneDetectorTables truncating(params, LabTestCamera());
  LaneDetectionTrace trace;
  FitLanePointsHardware(truncating, sums, &trace);
  ASSERT_TRUE(trace.trajectory);
  std::vector<Eigen::Vector2d> by_hand, untruncated;
  const double d = 1.0 / std::sqrt(1.0625);
  for (int i = 0; i < LanePoints::kCount; ++i) {
    by_hand.emplace_back(16 * i + 36, 254 + 4 * i);
    untruncated.emplace_back(16 * i + 150 * 0.25 * d, 400.5 + 4 * i - 150 * d);
  }
  const auto expected = FitTrajectory(params, by_hand);
  const auto smooth = FitTrajectory(params, untruncated);
  double moved = 0.0;
  for (double row = 0.0; row <= 464.0; row += 16.0) {
    EXPECT_NEAR((*trace.trajectory)(row), (*expected)(row), 1e-6) << row;
    moved = std::max(moved, std::abs((*smooth)(row) - (*expected)(row)));
  }
  EXPECT_GT(moved, 0.5);  // the truncation moves the trajectory by more than half a pixel
}

// rt_polyfit.cpp:157, 165-166: the trajectory's samples and their raw-image pixels truncated, so
// each floor point is where the ray through a whole pixel meets the floor.
TEST(LaneHardwareTest, EachFloorPointIsTheImageOfAWholePixel) {
  const testing::TrackFrames frames;
  LaneDetectionParams params;
  params.hw_truncate_points = true;
  LaneDetector detector(params, LabTestCamera());
  BirdsEyeRowSums sums;
  detector.ComputeRowSums(LabTestMat(frames.Render(frames.PoseOnRoute("outer_loop", 2.5)).color),
                          &sums);
  const LanePoints lanes = FitLanePointsHardware(*detector.tables(), sums);
  ASSERT_EQ(lanes.valid, 1u);
  const LaneCameraCalibration camera = LabTestCamera();
  const Eigen::Isometry3d X_camera_base = camera.X_base_camera.inverse();
  for (const LanePoint& p : lanes.points) {
    const Eigen::Vector3d p_cam = X_camera_base * Eigen::Vector3d(p.x_m, p.y_m, 0.0);
    const Eigen::Vector2d d = world::Distort(camera.D, p_cam.head<2>() / p_cam.z());
    const double u = camera.K[0] * d.x() + camera.K[2];
    const double v = camera.K[4] * d.y() + camera.K[5];
    // float points: a few thousandths of a pixel
    EXPECT_NEAR(u, std::round(u), 0.02) << p.x_m;
    EXPECT_NEAR(v, std::round(v), 0.02) << p.x_m;
  }
}

// rt_polyfit.cpp:249, 258 write `valid` and then the points at offset 0 of a message laid out
// `uint64 valid; LanePoint[30] points` (carcontrol/msg/iceoryx_msg/msg/LanePoints.msg): the
// receiver reads point 0's floats as `valid` (x low, rt_polyfit.cpp:252-256), point k + 1 as its
// point k, and a point 29 nothing wrote.
TEST(LaneHardwareTest, TheReceiverReadsPointZeroAsValidAndThePointsShiftedByOne) {
  std::array<LanePoint, LanePoints::kCount> written;
  for (int i = 0; i < LanePoints::kCount; ++i) {
    written[static_cast<std::size_t>(i)] = {0.9F - 0.02F * static_cast<float>(i), 0.01F * i};
  }
  const LanePoints received = LabHardwareMessage(written);
  std::uint64_t word = 0;
  std::memcpy(&word, written.data(), sizeof word);  // the first 8 bytes written, little-endian
  EXPECT_EQ(received.valid, word);
  EXPECT_EQ(received.valid & 0xffffffffu, std::bit_cast<std::uint32_t>(0.9F));
  for (int k = 0; k + 1 < LanePoints::kCount; ++k) {
    EXPECT_EQ(received.points[k].x_m, written[k + 1].x_m) << k;
    EXPECT_EQ(received.points[k].y_m, written[k + 1].y_m) << k;
  }
  EXPECT_EQ(received.points[29].x_m, 0.0F);
  EXPECT_EQ(received.points[29].y_m, 0.0F);
  // `valid` is never 0 for a point ahead of the car: the controller always takes the points
  // (lane_controller.cpp:348), even when the fit set valid to 0 (no line at all)
  LaneDetectionParams params;
  params.hw_valid_overwrite = true;
  params.hw_no_line = HwNoLine::kBothBelowMin;
  const LaneDetectorTables lab(params, LabTestCamera());
  BirdsEyeRowSums few;  // 450 white pixels: a line by the fit, no line by the count
  AddRowSumsLine(&few.white, 300, 389, 5, [](int r) { return 5 * (470 + r / 16); });
  const LanePoints overwritten = FitLanePointsHardware(lab, few);
  EXPECT_NE(overwritten.valid, 0u);
  EXPECT_TRUE(std::isfinite(overwritten.points[0].x_m));
  // nothing at all: a fit of nothing; its points are not numbers, and `valid` is not 0 either
  const LanePoints nothing = FitLanePointsHardware(lab, BirdsEyeRowSums{});
  EXPECT_NE(nothing.valid, 0u);
  EXPECT_TRUE(std::isnan(nothing.points[0].x_m));
}

// With every option ours the hardware fit is the software fit, bit for bit.
TEST(LaneHardwareTest, WithEveryOptionOursItIsTheSoftwareFit) {
  const testing::TrackFrames frames;
  LaneDetector detector(LaneDetectionParams{}, LabTestCamera());
  for (double s_m : {2.5, 4.5, 6.5, 9.0, 12.5, 14.5}) {
    BirdsEyeRowSums sums;
    detector.ComputeRowSums(LabTestMat(frames.Render(frames.PoseOnRoute("outer_loop", s_m)).color),
                            &sums);
    const LanePoints sw = FitLanePoints(*detector.tables(), sums);
    const LanePoints hw = FitLanePointsHardware(*detector.tables(), sums);
    EXPECT_EQ(std::memcmp(&sw, &hw, sizeof sw), 0) << s_m;
  }
}

// rt_polyfit.cpp:170-176 hard-codes R⁻¹, t and K⁻¹: they are cv::solvePnP of the lab's
// params/real_pointsets.yml (pixels written (row, col)) with params/real_intrinsics.yml's K and D,
// as lane_detector.cpp:47-53 computes them at start-up.
TEST(LanePnpTest, TheHardCodedPoseIsSolvePnpOfTheLabsPointSets) {
  const std::vector<cv::Point2d> image{{421, 31},  {449, 317}, {419, 605}, {275, 181},
                                       {276, 319}, {274, 458}, {231, 231}, {230, 319},
                                       {231, 410}, {189, 285}, {188, 364}};
  const LaneDetectionParams params;
  std::vector<cv::Point3d> world;
  for (const auto& p : params.pnp_floor_points_m) world.emplace_back(p[0], p[1], 0);
  const cv::Mat K =
      (cv::Mat_<double>(3, 3) << 426.392783, 0, 262.008827, 0, 428.576351, 302.228592, 0, 0, 1);
  const cv::Mat D = (cv::Mat_<double>(5, 1) << -0.210058, 0.043931, 0.004976, -0.004611, 0);
  cv::Mat rvec, tvec, R;
  cv::solvePnP(world, image, K, D, rvec, tvec);
  cv::Rodrigues(rvec, R);
  const cv::Mat R_inv = R.inv();
  const double hard_coded_R[3][3] = {
      {-0.2673452550386417, 0.04594220078070565, 0.962504975984929},
      {0.01289720370866832, -0.9986026996828118, 0.05124753967457311},
      {0.9635144922339365, 0.02611440931028619, 0.2663791675066841}};
  const double hard_coded_t[3] = {0.1649449070508159, -0.009324807078981687, -0.09606275043777565};
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(tvec.at<double>(i), hard_coded_t[i], 1e-9);
    for (int j = 0; j < 3; ++j) EXPECT_NEAR(R_inv.at<double>(i, j), hard_coded_R[i][j], 1e-9);
  }
  const cv::Mat K_inv = K.inv();
  EXPECT_NEAR(K_inv.at<double>(0, 0), 0.002345255454288494, 1e-15);
  EXPECT_NEAR(K_inv.at<double>(1, 2), -0.7051919484003447, 1e-12);
}

// The lab's projection carried over to our camera (LabPnpPose): it reproduces the calibration's
// near points to a few centimetres, but it neither undistorts nor applies K to the right axes, so
// it misses the far ones more; the ideal projection (ours) hits every one.
TEST(LanePnpTest, OnOurCameraTheLabsProjectionMissesTheFarPointsMore) {
  const LaneCameraCalibration camera = LabTestCamera();
  const LaneDetectionParams params;
  const LanePnpPose pose = LabPnpPose(camera, params.pnp_floor_points_m);
  const Eigen::Isometry3d X_camera_base = camera.X_base_camera.inverse();
  double near_max = 0.0, far_max = 0.0;
  for (const auto& p : params.pnp_floor_points_m) {
    const Eigen::Vector3d p_cam = X_camera_base * Eigen::Vector3d(p[0], p[1], 0.0);
    const Eigen::Vector2d d = world::Distort(camera.D, p_cam.head<2>() / p_cam.z());
    const double u = camera.K[0] * d.x() + camera.K[2];
    const double v = camera.K[4] * d.y() + camera.K[5];
    if (u < 0.0 || u >= kLaneImageWidth || v < 0.0 || v >= kLaneImageHeight) continue;
    const Eigen::Vector2d lab = ProjectLabPnp(pose, std::trunc(v), std::trunc(u));
    const Eigen::Vector2d ideal = *FloorPointFromPixel(camera, u, v);
    const double error = (lab - Eigen::Vector2d(p[0], p[1])).norm();
    std::printf("  floor (%.2f, %+.2f): lab (%.3f, %+.3f) error %.3f m; ideal error %.4f m\n", p[0],
                p[1], lab.x(), lab.y(), error, (ideal - Eigen::Vector2d(p[0], p[1])).norm());
    EXPECT_LT((ideal - Eigen::Vector2d(p[0], p[1])).norm(), 1e-6);
    double& worst = p[0] < 1.0 ? near_max : far_max;
    worst = std::max(worst, error);
    // the float arithmetic of rt_polyfit gives the same point to a millimetre
    const Eigen::Vector2f lab_float = ProjectLabPnpFloat(pose, static_cast<float>(std::trunc(v)),
                                                         static_cast<float>(std::trunc(u)));
    EXPECT_NEAR(lab_float.x(), lab.x(), 1e-3);
    EXPECT_NEAR(lab_float.y(), lab.y(), 1e-3);
  }
  EXPECT_LT(near_max, 0.05);
  EXPECT_GT(far_max, near_max);
}

// A projection through the lab's pose is the projection the lab's pipelines use: under
// pnp_swapped both fits project with it, (row, col) swapped, and their points differ from the
// ideal projection's.
TEST(LanePnpTest, BothFitsProjectWithThePoseOnTheSwappedPixel) {
  const testing::TrackFrames frames;
  LaneDetectionParams params;
  params.projection = LaneProjection::kPnpSwapped;
  LaneDetector lab(params, LabTestCamera());
  LaneDetector ours(LaneDetectionParams{}, LabTestCamera());
  ASSERT_TRUE(lab.tables()->pnp_pose());
  EXPECT_FALSE(ours.tables()->pnp_pose());
  BirdsEyeRowSums sums;
  lab.ComputeRowSums(LabTestMat(frames.Render(frames.PoseOnRoute("outer_loop", 2.5)).color), &sums);
  LaneDetectionTrace trace;
  const LanePoints sw = FitLanePoints(*lab.tables(), sums, &trace);
  const LanePoints hw = FitLanePointsHardware(*lab.tables(), sums);
  const LanePoints ideal = FitLanePoints(*ours.tables(), sums);
  ASSERT_EQ(sw.valid, 1u);
  const double* h = lab.birds_eye_to_image().ptr<double>();
  double differ = 0.0;
  for (int i = 0; i < LanePoints::kCount; ++i) {
    const double row = 16.0 * i;
    const double col = (*trace.trajectory)(row);
    const double w = h[6] * col + h[7] * row + h[8];
    const double u = (h[0] * col + h[1] * row + h[2]) / w;
    const double v = (h[3] * col + h[4] * row + h[5]) / w;
    // the software node passes (row, col) to an int-taking projection (lane_detector.cpp:214, 354)
    const Eigen::Vector2d p =
        ProjectLabPnp(*lab.tables()->pnp_pose(), std::trunc(v), std::trunc(u));
    EXPECT_FLOAT_EQ(sw.points[i].x_m, static_cast<float>(p.x())) << i;
    EXPECT_FLOAT_EQ(sw.points[i].y_m, static_cast<float>(p.y())) << i;
    // the slot's pixel is not truncated here (hw_truncate_points off): within a pixel's worth
    EXPECT_NEAR(hw.points[i].x_m, sw.points[i].x_m, 0.03) << i;
    differ =
        std::max(differ, std::abs(static_cast<double>(sw.points[i].y_m - ideal.points[i].y_m)));
  }
  std::printf("  the lab's projection moves the lane centre by up to %.3f m sideways\n", differ);
  EXPECT_GT(differ, 0.001);
}

}  // namespace
}  // namespace autonomsim::stack
