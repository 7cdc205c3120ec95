#include "stack/lane_detection.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <string>
#include <vector>

#include "stack/tests/track_frames.h"
#include "vehicle/camera_model.h"

namespace autonomsim::stack {
namespace {

// The node's conversion: the vehicle's camera model as the plain data the stack takes.
LaneCameraCalibration CalibrationOf(const vehicle::CameraModel& camera) {
  LaneCameraCalibration c;
  c.K = camera.params().K;
  c.D = camera.params().lens_distortion ? camera.params().D : std::array<double, 5>{};
  c.X_base_camera = camera.X_base_camera();
  return c;
}

cv::Mat AsMat(const vehicle::ColorImage& image) {
  return cv::Mat(image.height, image.width, CV_8UC3, const_cast<std::uint8_t*>(image.bgr.data()));
}

world::Vec2 ToCar(const world::Pose2& X_map_car, const world::Vec2& p_map) {
  const double c = std::cos(X_map_car.yaw_rad), s = std::sin(X_map_car.yaw_rad);
  const world::Vec2 d = p_map - X_map_car.position();
  return {c * d.x() + s * d.y(), -s * d.x() + c * d.y()};
}

world::Vec2 ToMap(const world::Pose2& X_map_car, const world::Vec2& p_car) {
  const double c = std::cos(X_map_car.yaw_rad), s = std::sin(X_map_car.yaw_rad);
  return X_map_car.position() +
         world::Vec2(c * p_car.x() - s * p_car.y(), s * p_car.x() + c * p_car.y());
}

// Ground truth: the route's path in the car frame, followed from the car to where it is x_m ahead.
std::optional<double> RouteY(const world::Polyline& path, const world::Pose2& X_map_car,
                             double x_m) {
  const double s0 = path.Project(X_map_car.position()).s_m;
  world::Vec2 prev = ToCar(X_map_car, path.PointAt(s0));
  for (double ds = 0.001; ds < 2.0; ds += 0.001) {
    const world::Vec2 q = ToCar(X_map_car, path.PointAt(path.NormalizeS(s0 + ds)));
    if (prev.x() < x_m && q.x() >= x_m) {
      return prev.y() + (q.y() - prev.y()) * (x_m - prev.x()) / (q.x() - prev.x());
    }
    prev = q;
  }
  return std::nullopt;
}

// The output curve's y where it is x_m ahead (linear between the 30 points).
std::optional<double> OutputY(const LanePoints& lane, double x_m) {
  for (int i = 0; i + 1 < LanePoints::kCount; ++i) {
    const LanePoint& a = lane.points[i];
    const LanePoint& b = lane.points[i + 1];
    if (std::min(a.x_m, b.x_m) <= x_m && x_m <= std::max(a.x_m, b.x_m) && a.x_m != b.x_m) {
      return a.y_m + (b.y_m - a.y_m) * (x_m - a.x_m) / (b.x_m - a.x_m);
    }
  }
  return std::nullopt;
}

// Distance from p_map to the nearest painted line of the given colour.
double DistanceToPaint(const world::Track& track, const std::string& color,
                       const world::Vec2& p_map) {
  double best = 1e9;
  for (std::size_t i = 0; i < track.line_paths().size(); ++i) {
    if (track.spec().lines[i].color != color) continue;
    best = std::min(best, track.line_paths()[i].Project(p_map).distance_m);
  }
  return best;
}

class LaneTrack : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { frames_ = new testing::TrackFrames(); }
  static void TearDownTestSuite() {
    delete frames_;
    frames_ = nullptr;
  }
  static testing::TrackFrames* frames_;
};
testing::TrackFrames* LaneTrack::frames_ = nullptr;

struct Pose {
  const char* what;
  const char* route;
  double s_m;
  double lateral_m;
  double yaw_rad;
  LaneLine line;  // the line the detector must pick
};

// Lane-following poses on the lane centre, outside the corners (where the route is the painted
// lane's centre): straights, both line colours, both junctions.
const std::vector<Pose>& CentredPoses() {
  static const std::vector<Pose> poses{
      {"outer south, straight", "outer_loop", 2.5, 0.0, 0.0, LaneLine::kYellow},
      {"outer south, further", "outer_loop", 3.5, 0.0, 0.0, LaneLine::kYellow},
      {"outer north, straight", "outer_loop", 10.5, 0.0, 0.0, LaneLine::kYellow},
      {"outer north after the NE corner", "outer_loop", 9.7, 0.0, 0.0, LaneLine::kYellow},
      {"outer west after the NW corner", "outer_loop", 13.9, 0.0, 0.0, LaneLine::kWhite},
      {"inner south, straight", "inner_loop", 2.5, 0.0, 0.0, LaneLine::kYellow},
      {"inner north, straight", "inner_loop", 8.0, 0.0, 0.0, LaneLine::kYellow},
      {"middle west, straight", "south_loop", 8.5, 0.0, 0.0, LaneLine::kYellow},
      {"middle east, straight", "north_loop", 9.0, 0.0, 0.0, LaneLine::kYellow},
      {"approaching junction 0 northbound", "outer_loop", 6.0, 0.0, 0.0, LaneLine::kWhite},
      {"in junction 0 northbound (white only)", "outer_loop", 6.5, 0.0, 0.0, LaneLine::kWhite},
      {"leaving junction 0 northbound", "outer_loop", 7.0, 0.0, 0.0, LaneLine::kYellow},
      {"approaching junction 1 southbound", "outer_loop", 14.0, 0.0, 0.0, LaneLine::kWhite},
      {"in junction 1 southbound (white only)", "outer_loop", 14.5, 0.0, 0.0, LaneLine::kWhite},
      {"leaving junction 1 southbound", "outer_loop", 15.0, 0.0, 0.0, LaneLine::kYellow},
      {"approaching junction 1 westbound", "south_loop", 9.2, 0.0, 0.0, LaneLine::kYellow},
      {"approaching junction 0 eastbound", "north_loop", 9.2, 0.0, 0.0, LaneLine::kYellow},
      {"inner lane through junction 1", "inner_loop", 5.5, 0.0, 0.0, LaneLine::kYellow},
      {"inner lane through junction 0", "inner_loop", 0.0, 0.0, 0.0, LaneLine::kYellow},
      {"outer east, before junction 0", "south_loop", 5.9, 0.0, 0.0, LaneLine::kWhite},
  };
  return poses;
}

// Off the lane centre, and where the yellow line ends just ahead: the anchors (col 320 at the
// bottom rows = the car itself, reference §5) pull the near part of the curve to the car, so an
// offset car sees a lane centre biased towards itself. Reported, with a looser bound.
const std::vector<Pose>& OffsetPoses() {
  static const std::vector<Pose> poses{
      {"outer south, 5 cm left", "outer_loop", 3.0, 0.05, 0.0, LaneLine::kYellow},
      {"outer south, 5 cm right", "outer_loop", 3.5, -0.05, 0.0, LaneLine::kYellow},
      {"outer north, yawed 0.05 left", "outer_loop", 10.5, 0.0, 0.05, LaneLine::kYellow},
      {"outer north, yawed 0.05 right", "outer_loop", 11.0, 0.0, -0.05, LaneLine::kYellow},
      {"outer east, white, 4 cm left", "outer_loop", 6.7, 0.04, 0.0, LaneLine::kWhite},
      {"outer west, white, yawed 0.04 left", "outer_loop", 14.3, 0.0, 0.04, LaneLine::kWhite},
      {"junction 1 westbound, yellow ends", "south_loop", 9.5, 0.0, 0.0, LaneLine::kYellow},
      {"junction 0 eastbound, yellow ends", "north_loop", 9.5, 0.0, 0.0, LaneLine::kYellow},
  };
  return poses;
}

// In the corners the route (0.9 m fillets) and the paint (0.3–0.6 m) part ways: there the painted
// lane's centre (0.31 m from the line the detector follows) is the truth for the detector.
const std::vector<Pose>& CurvePoses() {
  static const std::vector<Pose> poses{
      {"outer SE corner, white", "outer_loop", 4.5, 0.0, 0.0, LaneLine::kWhite},
      {"outer NE corner, white", "outer_loop", 9.0, 0.0, 0.0, LaneLine::kWhite},
      {"outer NW corner, white", "outer_loop", 12.5, 0.0, 0.0, LaneLine::kWhite},
      {"inner SE corner, yellow", "inner_loop", 1.5, 0.0, 0.0, LaneLine::kYellow},
      {"inner SW corner, yellow", "inner_loop", 4.0, 0.0, 0.0, LaneLine::kYellow},
      {"inner NE corner, yellow", "inner_loop", 9.5, 0.0, 0.0, LaneLine::kYellow},
  };
  return poses;
}

TEST_F(LaneTrack, FastMasksAreBitIdenticalToOpenCv) {
  LaneDetector detector(LaneDetectionParams{}, CalibrationOf(frames_->color_camera()));
  std::vector<Pose> poses = CentredPoses();
  poses.insert(poses.end(), OffsetPoses().begin(), OffsetPoses().end());
  poses.insert(poses.end(), CurvePoses().begin(), CurvePoses().end());
  for (const Pose& p : poses) {
    const auto frame =
        frames_->Render(frames_->PoseOnRoute(p.route, p.s_m, p.lateral_m, p.yaw_rad));
    BirdsEyeMasks reference, fast;
    LaneMasksReference(AsMat(frame.color), detector.thresholds(), detector.image_to_birds_eye(),
                       &reference);
    detector.ComputeMasks(AsMat(frame.color), &fast);
    EXPECT_EQ(cv::norm(reference.yellow, fast.yellow, cv::NORM_INF), 0.0) << p.what;
    EXPECT_EQ(cv::norm(reference.white, fast.white, cv::NORM_INF), 0.0) << p.what;
    EXPECT_GT(cv::countNonZero(reference.yellow) + cv::countNonZero(reference.white), 0) << p.what;
  }
}

TEST(LaneMasks, BitIdenticalOnNoiseForBothThresholdSets) {
  // Every pixel of every colour class, blended warp edges everywhere: a hard case for exactness.
  std::mt19937 rng(5);
  cv::Mat bgr(kLaneImageHeight, kLaneImageWidth, CV_8UC3);
  for (int i = 0; i < bgr.rows * bgr.cols * 3; ++i) bgr.data[i] = static_cast<std::uint8_t>(rng());
  // Patches of our white and yellow, so that both masks have whole regions too.
  bgr(cv::Rect(100, 300, 200, 100)).setTo(cv::Scalar(255, 255, 255));
  bgr(cv::Rect(300, 280, 250, 120)).setTo(cv::Scalar(0, 235, 235));
  const vehicle::CameraModel camera(vehicle::ColorCameraParams());
  for (const char* set : {"simulation", "real_car"}) {
    LaneDetectionParams params;
    params.thresholds = set;
    LaneDetector detector(params, CalibrationOf(camera));
    BirdsEyeMasks reference, fast;
    LaneMasksReference(bgr, detector.thresholds(), detector.image_to_birds_eye(), &reference);
    detector.ComputeMasks(bgr, &fast);
    EXPECT_EQ(cv::norm(reference.yellow, fast.yellow, cv::NORM_INF), 0.0) << set;
    EXPECT_EQ(cv::norm(reference.white, fast.white, cv::NORM_INF), 0.0) << set;
  }
}

// Returns max and mean |error| at x_m ahead against the route; prints one line per pose.
std::pair<double, double> CheckPoses(const testing::TrackFrames& frames, LaneDetector* detector,
                                     const std::vector<Pose>& poses, double tolerance_m) {
  constexpr double kAhead_m = 0.5;
  double max_error = 0.0, sum_error = 0.0;
  for (const Pose& p : poses) {
    const world::Pose2 pose = frames.PoseOnRoute(p.route, p.s_m, p.lateral_m, p.yaw_rad);
    const auto frame = frames.Render(pose);
    LaneDetectionTrace trace;
    const LanePoints lane = detector->Step(AsMat(frame.color), &trace);
    EXPECT_EQ(lane.valid, 1u) << p.what;
    EXPECT_EQ(trace.line, p.line) << p.what;
    const auto truth = RouteY(frames.track().RouteByName(p.route).path, pose, kAhead_m);
    const auto got = OutputY(lane, kAhead_m);
    if (!lane.valid || !truth || !got) {
      ADD_FAILURE() << p.what << ": no lane centre at " << kAhead_m << " m";
      continue;
    }
    const double error = *got - *truth;
    std::printf("  %-38s %-6s truth %+.4f out %+.4f error %+.4f m\n", p.what,
                trace.line == LaneLine::kYellow ? "yellow" : "white", *truth, *got, error);
    EXPECT_LE(std::abs(error), tolerance_m) << p.what;
    max_error = std::max(max_error, std::abs(error));
    sum_error += std::abs(error);
  }
  return {max_error, sum_error / static_cast<double>(poses.size())};
}

TEST_F(LaneTrack, LanePointsFollowTheLaneCentre) {
  LaneDetector detector(LaneDetectionParams{}, CalibrationOf(frames_->color_camera()));
  const auto [max_error, mean_error] = CheckPoses(*frames_, &detector, CentredPoses(), 0.03);
  std::printf("lane centre at 0.5 m, %zu centred poses: max |error| %.4f m, mean %.4f m\n",
              CentredPoses().size(), max_error, mean_error);
}

TEST_F(LaneTrack, OffCentreTheAnchorsBiasTheLaneTowardsTheCar) {
  LaneDetector detector(LaneDetectionParams{}, CalibrationOf(frames_->color_camera()));
  const auto [max_error, mean_error] = CheckPoses(*frames_, &detector, OffsetPoses(), 0.06);
  std::printf("lane centre at 0.5 m, %zu offset poses: max |error| %.4f m, mean %.4f m\n",
              OffsetPoses().size(), max_error, mean_error);
}

TEST_F(LaneTrack, InCornersLanePointsFollowThePaintedLane) {
  LaneDetector detector(LaneDetectionParams{}, CalibrationOf(frames_->color_camera()));
  constexpr double kAhead_m = 0.5;
  constexpr double kHalfLane_m = 0.31;  // reference §1
  for (const Pose& p : CurvePoses()) {
    const world::Pose2 pose = frames_->PoseOnRoute(p.route, p.s_m, p.lateral_m, p.yaw_rad);
    const auto frame = frames_->Render(pose);
    LaneDetectionTrace trace;
    const LanePoints lane = detector.Step(AsMat(frame.color), &trace);
    ASSERT_EQ(lane.valid, 1u) << p.what;
    EXPECT_EQ(trace.line, p.line) << p.what;
    const auto got = OutputY(lane, kAhead_m);
    const auto route = RouteY(frames_->track().RouteByName(p.route).path, pose, kAhead_m);
    ASSERT_TRUE(got && route) << p.what;
    const world::Vec2 p_map = ToMap(pose, world::Vec2(kAhead_m, *got));
    const double paint =
        DistanceToPaint(frames_->track(), p.line == LaneLine::kYellow ? "yellow" : "white", p_map);
    std::printf("%-28s out_y %+.4f: %.4f m from the line (lane centre %.2f); route y %+.4f\n",
                p.what, *got, paint, kHalfLane_m, *route);
    EXPECT_NEAR(paint, kHalfLane_m, 0.08) << p.what;
  }
}

TEST_F(LaneTrack, NoLineInViewIsInvalid) {
  LaneDetector detector(LaneDetectionParams{}, CalibrationOf(frames_->color_camera()));
  // facing the wall from the outer lane, and from the track's centre turned towards a bare floor
  for (const world::Pose2& pose :
       {world::Pose2{0.0, -2.3, -M_PI / 2}, world::Pose2{0.0, 2.35, M_PI / 2}}) {
    const auto frame = frames_->Render(pose);
    LaneDetectionTrace trace;
    const LanePoints lane = detector.Step(AsMat(frame.color), &trace);
    EXPECT_EQ(lane.valid, 0u) << pose.x_m << ", " << pose.y_m;
    EXPECT_EQ(trace.line, LaneLine::kNone);
    for (const LanePoint& q : lane.points) EXPECT_TRUE(q.x_m == 0.0F && q.y_m == 0.0F);
  }
  const cv::Mat black(kLaneImageHeight, kLaneImageWidth, CV_8UC3, cv::Scalar(0, 0, 0));
  EXPECT_EQ(detector.Step(black).valid, 0u);
}

TEST(LaneThresholds, OurRenderedColoursPickTheSimulationSet) {
  cv::Mat bgr(1, 3, CV_8UC3);
  bgr.at<cv::Vec3b>(0, 0) = {255, 255, 255};  // white
  bgr.at<cv::Vec3b>(0, 1) = {0, 235, 235};    // yellow RGB(235, 235, 0), reference §1
  bgr.at<cv::Vec3b>(0, 2) = {110, 110, 110};  // the wall
  cv::Mat hsv;
  cv::cvtColor(bgr, hsv, cv::COLOR_BGR2HSV);
  EXPECT_EQ(hsv.at<cv::Vec3b>(0, 0), cv::Vec3b(0, 0, 255));
  EXPECT_EQ(hsv.at<cv::Vec3b>(0, 1), cv::Vec3b(30, 255, 235));
  const auto in = [&](const HsvRange& r, int i) {
    const cv::Vec3b p = hsv.at<cv::Vec3b>(0, i);
    for (int k = 0; k < 3; ++k) {
      if (p[k] < r.lower_hsv[k] || p[k] > r.upper_hsv[k]) return false;
    }
    return true;
  };
  const LaneThresholds sim = LaneThresholdsByName("simulation");
  const LaneThresholds real = LaneThresholdsByName("real_car");
  EXPECT_TRUE(in(sim.white, 0));
  EXPECT_TRUE(in(sim.yellow, 1));
  EXPECT_FALSE(in(sim.white, 2));
  EXPECT_FALSE(in(sim.yellow, 2));
  EXPECT_FALSE(in(real.white, 0));  // pure white has H = 0, outside the real car's 70–90
  EXPECT_TRUE(in(real.yellow, 1));
  EXPECT_EQ(LaneDetectionParams{}.thresholds, "simulation");
  EXPECT_THROW(LaneThresholdsByName("gazebo"), std::invalid_argument);
}

TEST(LaneThresholds, HsvMatchesOpenCvOnEveryColour) {
  cv::Mat bgr(4096, 4096, CV_8UC3);
  for (int i = 0; i < 1 << 24; ++i) {
    bgr.data[3 * i] = static_cast<std::uint8_t>(i);
    bgr.data[3 * i + 1] = static_cast<std::uint8_t>(i >> 8);
    bgr.data[3 * i + 2] = static_cast<std::uint8_t>(i >> 16);
  }
  cv::Mat hsv;
  cv::cvtColor(bgr, hsv, cv::COLOR_BGR2HSV);
  int mismatches = 0;
  for (int i = 0; i < 1 << 24; ++i) {
    const auto ours = detail::BgrToHsv8(bgr.data[3 * i], bgr.data[3 * i + 1], bgr.data[3 * i + 2]);
    mismatches += ours[0] != hsv.data[3 * i] || ours[1] != hsv.data[3 * i + 1] ||
                  ours[2] != hsv.data[3 * i + 2];
  }
  EXPECT_EQ(mismatches, 0);
}

// The warp source points' derivation (lane_detection.h), redone.
TEST(LaneWarp, SourcePointsAreTheRealQuadrilateralSquaredAndSeenByOurCamera) {
  const vehicle::CameraModel camera(vehicle::ColorCameraParams());
  const auto pixel = [&](double x, double y) {
    return *camera.Project(camera.X_base_camera().inverse() * Eigen::Vector3d(x, y, 0.0));
  };
  // The real car's PnP correspondences (AutonomROS params/real_pointsets.yml: floor (x, y) m in
  // base_link; pixels written (row, col)).
  const double floor_m[11][2] = {{0.3, 0.15},  {0.3, 0.0},    {0.3, -0.15}, {0.55, 0.15},
                                 {0.55, 0.0},  {0.55, -0.15}, {0.8, 0.15},  {0.8, 0.0},
                                 {0.8, -0.15}, {1.6, 0.15},   {1.6, -0.15}};
  const double row_col[11][2] = {{421, 31},  {449, 317}, {419, 605}, {275, 181},
                                 {276, 319}, {274, 458}, {231, 231}, {230, 319},
                                 {231, 410}, {189, 285}, {188, 364}};
  std::vector<cv::Point2d> floor, image;
  for (int i = 0; i < 11; ++i) {
    floor.emplace_back(floor_m[i][0], floor_m[i][1]);
    image.emplace_back(row_col[i][1], row_col[i][0]);
    // ours images the same floor points about (+65, -42) px away: a different camera
    const Eigen::Vector2d ours = pixel(floor_m[i][0], floor_m[i][1]);
    EXPECT_NEAR(image.back().x - ours.x(), 65.0, 12.0);
    EXPECT_NEAR(image.back().y - ours.y(), -42.0, 8.0);
  }
  const cv::Mat H = cv::findHomography(floor, image, 0);
  const std::vector<cv::Point2d> real_src{{-361, 480}, {996, 480}, {218, 221}, {418, 221}};
  std::vector<cv::Point2d> quad;
  cv::perspectiveTransform(real_src, quad, H.inv());
  // near edge ≈ 0.27 m on the lane's lines, far edge ≈ 0.90 m and narrower
  EXPECT_NEAR(quad[0].x, 0.267, 0.002);
  EXPECT_NEAR(quad[1].x, 0.266, 0.002);
  EXPECT_NEAR(quad[0].y, 0.303, 0.002);
  EXPECT_NEAR(quad[1].y, -0.295, 0.002);
  EXPECT_NEAR(0.5 * (quad[2].x + quad[3].x), 0.897, 0.002);
  EXPECT_LT(quad[2].y - quad[3].y, 0.40);
  // squared: x in [0.267, 0.897], y = ±0.31 (reference §1), seen by our camera
  const double x_near = 0.267, x_far = 0.897, half_lane = 0.31;
  const std::array<std::array<double, 2>, 4> corners{
      {{x_near, half_lane}, {x_near, -half_lane}, {x_far, half_lane}, {x_far, -half_lane}}};
  const LaneDetectionParams params;
  for (int i = 0; i < 4; ++i) {
    const Eigen::Vector2d px = pixel(corners[i][0], corners[i][1]);
    EXPECT_NEAR(params.warp_source_px[i][0], px.x(), 0.01) << i;
    EXPECT_NEAR(params.warp_source_px[i][1], px.y(), 0.01) << i;
  }
  // The real points through our camera: a skewed patch reaching far beyond 0.9 m.
  LaneCameraCalibration calibration = CalibrationOf(camera);
  const auto far_left = FloorPointFromPixel(calibration, 218, 221);
  const auto far_right = FloorPointFromPixel(calibration, 418, 221);
  ASSERT_TRUE(far_left && far_right);
  EXPECT_GT(far_left->x(), 1.7);
  EXPECT_LT(far_right->y(), -0.6);
}

TEST(LaneFit, RecoversAPolynomialAndRefusesTooFewRows) {
  std::vector<double> rows, cols, weights;
  for (int r = 0; r < 480; r += 7) {
    rows.push_back(r);
    cols.push_back(300.0 + 0.25 * r - 0.0004 * r * r);
    weights.push_back(1.0 + r % 3);
  }
  const auto fit = FitRowPolynomial(rows, cols, weights, 2);
  ASSERT_TRUE(fit);
  EXPECT_NEAR(fit->coefficients[0], 300.0, 1e-9);
  EXPECT_NEAR(fit->coefficients[1], 0.25, 1e-11);
  EXPECT_NEAR(fit->coefficients[2], -0.0004, 1e-13);
  EXPECT_NEAR(fit->Slope(100.0), 0.25 - 0.08, 1e-10);
  const std::vector<double> two_rows{10, 10, 20}, c{1, 2, 3}, w{1, 1, 1};
  EXPECT_FALSE(FitRowPolynomial(two_rows, c, w, 2));
}

TEST(LaneShift, MovesTowardsTheLaneCentreWithRightHandTraffic) {
  const RowPolynomial vertical{{200.0}};
  // yellow is on the car's left: the centre is to its right (+col); white the other way
  const Eigen::Vector2d from_yellow =
      ShiftTowardsLaneCentre(vertical, 100.0, LaneLine::kYellow, 150);
  const Eigen::Vector2d from_white = ShiftTowardsLaneCentre(vertical, 100.0, LaneLine::kWhite, 150);
  EXPECT_DOUBLE_EQ(from_yellow.x(), 100.0);
  EXPECT_DOUBLE_EQ(from_yellow.y(), 350.0);
  EXPECT_DOUBLE_EQ(from_white.x(), 100.0);
  EXPECT_DOUBLE_EQ(from_white.y(), 50.0);
  // a slanted line: moved 150 px along its normal
  const RowPolynomial slanted{{200.0, 1.0}};
  const Eigen::Vector2d q = ShiftTowardsLaneCentre(slanted, 100.0, LaneLine::kYellow, 150);
  const Eigen::Vector2d d = q - Eigen::Vector2d(100.0, 300.0);
  EXPECT_NEAR(d.norm(), 150.0, 1e-9);
  EXPECT_NEAR(d.dot(Eigen::Vector2d(1.0, 1.0)), 0.0, 1e-9);  // normal to the tangent (1, slope)
  EXPECT_GT(d.y(), 0.0);
}

TEST(LaneAnchors, PullTheTrajectoryToTheCarAtTheBottom) {
  const LaneDetectionParams params;
  std::vector<Eigen::Vector2d> centred, offset;
  for (int i = 0; i < LanePoints::kCount; ++i) {
    centred.emplace_back(16.0 * i, 320.0);
    offset.emplace_back(16.0 * i, 400.0);
  }
  const auto straight = FitTrajectory(params, centred);
  ASSERT_TRUE(straight);
  for (double row : {0.0, 240.0, 480.0}) EXPECT_NEAR((*straight)(row), 320.0, 1e-9);
  const auto bent = FitTrajectory(params, offset);
  ASSERT_TRUE(bent);
  EXPECT_NEAR((*bent)(470.0), 320.0, 8.0);   // 180 anchor points outweigh 30 samples there
  EXPECT_NEAR((*bent)(100.0), 400.0, 12.0);  // and the samples rule far from the anchors
}

TEST(LaneProjection, FloorPointsRoundTripThroughTheCameraModel) {
  const vehicle::CameraModel camera(vehicle::ColorCameraParams());
  const LaneCameraCalibration calibration = CalibrationOf(camera);
  for (const auto& [x, y] : {std::pair{0.3, 0.0}, {0.5, 0.2}, {0.9, -0.3}, {0.28, 0.4}}) {
    const auto px = camera.Project(camera.X_base_camera().inverse() * Eigen::Vector3d(x, y, 0));
    ASSERT_TRUE(px);
    const auto back = FloorPointFromPixel(calibration, px->x(), px->y());
    ASSERT_TRUE(back);
    EXPECT_NEAR(back->x(), x, 1e-9);
    EXPECT_NEAR(back->y(), y, 1e-9);
  }
  EXPECT_FALSE(FloorPointFromPixel(calibration, 262.0, 0.0));  // above the horizon
}

TEST(LaneParams, ValidateNamesTheBadKey) {
  LaneDetectionParams params;
  params.Validate();
  const auto message = [](LaneDetectionParams p) {
    try {
      p.Validate();
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  LaneDetectionParams bad = params;
  bad.thresholds = "gazebo";
  EXPECT_NE(message(bad).find("thresholds"), std::string::npos);
  bad = params;
  std::swap(bad.warp_source_px[0], bad.warp_source_px[1]);
  EXPECT_NE(message(bad).find("warp_source_px"), std::string::npos);
  bad = params;
  bad.line_min_px = 3000;
  EXPECT_NE(message(bad).find("line_min_px"), std::string::npos);
  bad = params;
  bad.anchor_repeats = 0;
  EXPECT_NE(message(bad).find("anchor_repeats"), std::string::npos);
  static_assert(sizeof(LanePoints) == 248);
}

}  // namespace
}  // namespace autonomsim::stack
