// Lane detection (reference §5; paper §IV-D): the colour camera's raw bgr8 image in, 30 points of
// the car's lane centre in base_link out.
//
//   BGR → HSV → white and yellow masks → bird's-eye warp of each (640×480) → choose the line
//   (yellow with ≥ 2000 pixels, else white; neither: invalid if white < 1000) → col = f(row), a
//   2nd-order least-squares fit on the chosen mask's pixels → 30 samples at rows i·16 → each moved
//   150 px along the curve normal towards the lane centre → 3rd-order re-fit with anchors (rows
//   480/470/460 at col 320, 60× each) → sampled at rows i·16 → warped back into the image →
//   undistorted and intersected with the floor in base_link.
//
// The mask+warp stage, which is most of the work, has two implementations that give bit-identical
// bird's-eye masks: LaneMasksReference (cv::cvtColor + cv::inRange + cv::warpPerspective, as the
// real node writes it) and LaneDetector's own (per-pixel warp coordinates and OpenCV's fixed-point
// bilinear weights precomputed once, since the homography is constant; only the source pixels the
// warp reads are thresholded, with OpenCV's 8-bit HSV integer arithmetic; only the output pixels
// whose 2×2 source square holds a line pixel are visited).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <opencv2/core.hpp>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "world/enum_names.h"

namespace autonomsim::stack {

// Image sizes (reference §2: 640×480 bgr8; §5: the bird's-eye view is 640×480 too).
inline constexpr int kLaneImageWidth = 640;
inline constexpr int kLaneImageHeight = 480;

// An inclusive HSV box on OpenCV's 8-bit scale: H 0–179, S and V 0–255.
struct HsvRange {
  std::array<int, 3> lower_hsv{0, 0, 0};
  std::array<int, 3> upper_hsv{179, 255, 255};

  template <class V>
  void Describe(V& v) {
    v("lower_hsv", lower_hsv);
    v("upper_hsv", upper_hsv);
  }
  void Validate() const;  // H in [0, 179], S and V in [0, 255], lower <= upper
};

struct LaneThresholds {
  HsvRange white;
  HsvRange yellow;
};

// The two documented threshold sets (reference §5): "simulation" (theirs, Gazebo) and "real_car".
enum class LaneThresholdSet { kSimulation, kRealCar };
LaneThresholds LaneThresholdsOf(LaneThresholdSet set);

// The colour camera as the lane detection needs it, as plain data (the node converts the vehicle's
// camera model): the raw image's intrinsics and plumb_bob distortion, and the optical frame (z
// forward, x right, y down) in base_link (x forward, y left, z up; origin on the floor).
struct LaneCameraCalibration {
  std::array<double, 9> K{1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0};  // row-major
  std::array<double, 5> D{0.0, 0.0, 0.0, 0.0, 0.0};  // k1, k2, p1, p2, k3 (ROS/OpenCV order)
  Eigen::Isometry3d X_base_camera{Eigen::Isometry3d::Identity()};

  void Validate() const;  // fx, fy > 0, finite; the camera above the floor
};

// Where the lab's code departs from the pipeline above, each a `perception.lane_detection` key
// (docs/lab-stack.md, "The options"). The defaults are ours, which keeps a scenario without a
// preset as it was; `stack.preset: lab` sets the lab's. Lab paths: MohnessWaizy/AutonomROS, under
// code/reconros_ws/laneplanner/src/ (rt_*) and code/ros_ws/src/autonomros_lane_detection/src/.
//
// hw_pixel_classes, which bird's-eye pixels are line pixels (the hardware lane planner only):
//   non_zero  ours and the software node's (lane_detector.cpp:99, 265, 273: findNonZero and
//             countNonZero of each warped mask): every pixel the bilinear warp left non-zero.
//   exact     the hardware's: rt_laneplanner.cpp:134-142 adds the white mask and the yellow mask
//             shifted right by one (255 + 127; both: 382 in 8 bits, 126) into one image and warps
//             that bilinearly; rt_polyfit.cpp:53-74 counts a pixel white only if its warped value
//             is exactly 255, yellow only if exactly 127. A line's blended edge pixels drop out,
//             and a white edge pixel blended down to exactly 127 counts as yellow.
enum class BirdsEyeClasses { kNonZero, kExact };
// hw_no_line, when the hardware's fit says "no line" (the `valid` it writes):
//   white_below_min  ours, the software node's rule (lane_detector.cpp:265-276): yellow if it has
//                    >= yellow_min_px, else white, and no line if white < line_min_px;
//   both_below_min   rt_polyfit.cpp:80-96, 246-248: yellow if it has >= yellow_min_px, else the
//                    white fit whatever its count; `valid` 0 only if white and yellow are both
//                    below line_min_px. So with 1000 <= yellow < 2000 and white < 1000 it fits the
//                    few white pixels (a fit of nothing if there are none) and says valid.
enum class HwNoLine { kWhiteBelowMin, kBothBelowMin };
// projection, from a raw-image pixel to the floor (both mappings):
//   ideal        ours: the pixel undistorted and its ray intersected with the floor.
//   pnp_swapped  the lab's: a pose from cv::solvePnP of hand-picked floor points whose pixels are
//                written (row, col) (params/real_pointsets.yml), with K and D; each pixel is then
//                projected with R⁻¹, t and K⁻¹ as (row, col, 1) as well, without undistortion
//                (lane_detector.cpp:47-53, 214-236, called with (point.y, point.x) at :354 and
//                truncated to int by its signature; rt_polyfit.cpp:169-241 the same numbers
//                hard-coded, in float, screen (row, col) at :188-189). See LabPnpPose.
enum class LaneProjection { kIdeal, kPnpSwapped };
// sw_no_line, what the software node publishes without a line:
//   invalid  ours: valid = 0 and zero points, so the LaneController has no carrot and stops;
//   silent   lane_detector.cpp:273-276: nothing, so the controller drives on the last points it
//            got (lane_controller.cpp:348-357, 562-565).
enum class SwNoLine { kInvalid, kSilent };

}  // namespace autonomsim::stack

namespace autonomsim {
template <>
struct NameTable<stack::LaneThresholdSet> {
  static constexpr std::array<std::pair<stack::LaneThresholdSet, std::string_view>, 2> kEntries{
      {{stack::LaneThresholdSet::kSimulation, "simulation"},
       {stack::LaneThresholdSet::kRealCar, "real_car"}}};
};
template <>
struct NameTable<stack::BirdsEyeClasses> {
  static constexpr std::array<std::pair<stack::BirdsEyeClasses, std::string_view>, 2> kEntries{
      {{stack::BirdsEyeClasses::kNonZero, "non_zero"}, {stack::BirdsEyeClasses::kExact, "exact"}}};
};
template <>
struct NameTable<stack::HwNoLine> {
  static constexpr std::array<std::pair<stack::HwNoLine, std::string_view>, 2> kEntries{
      {{stack::HwNoLine::kWhiteBelowMin, "white_below_min"},
       {stack::HwNoLine::kBothBelowMin, "both_below_min"}}};
};
template <>
struct NameTable<stack::LaneProjection> {
  static constexpr std::array<std::pair<stack::LaneProjection, std::string_view>, 2> kEntries{
      {{stack::LaneProjection::kIdeal, "ideal"},
       {stack::LaneProjection::kPnpSwapped, "pnp_swapped"}}};
};
template <>
struct NameTable<stack::SwNoLine> {
  static constexpr std::array<std::pair<stack::SwNoLine, std::string_view>, 2> kEntries{
      {{stack::SwNoLine::kInvalid, "invalid"}, {stack::SwNoLine::kSilent, "silent"}}};
};
}  // namespace autonomsim

namespace autonomsim::stack {

struct LaneDetectionParams {
  // Which HSV set: "simulation" by default. Our renderer paints white RGB(255,255,255) and yellow
  // RGB(235,235,0) (reference §1); OpenCV's 8-bit BGR2HSV gives white (0, 0, 255) and yellow
  // (30, 255, 235). The real car's white needs H 70–90, which a pure white (H = 0, no hue at all)
  // never has: its camera sees the lab's white with a tint. Their simulation's white (H 0–179, S
  // ≤ 35, V ≥ 215) and yellow (H 10–100, S ≥ 70, V ≥ 95) take both of our colours and leave the
  // black floor (V 0) and the grey wall (110, 110, 110: S 0, V 110) out.
  LaneThresholdSet thresholds{LaneThresholdSet::kSimulation};
  // The bird's-eye warp, source (raw image) → destination (bird's-eye) points, (col, row) in px,
  // order: near left, near right, far left, far right. Destination: reference §5.
  //
  // Source: re-derived for our camera, because the real car's points, (−361, 480), (996, 480),
  // (218, 221), (418, 221) (reference §5), do not fit it. Evidence: through our colour camera
  // (reference §2's K, D and mount) they see a skewed patch of floor reaching 1.8–2.0 m ahead,
  // (0.29, +0.31), (0.30, −0.39), (1.81, +0.16), (1.97, −0.70) m in base_link, not the road ahead
  // from ≈ 0.28 to ≈ 0.89 m that reference §5 derives for them. They were picked on the real car's
  // images, in which straight ahead lies near column 318: so say the real car's own PnP
  // correspondences (AutonomROS params/real_pointsets.yml, 11 floor points with their pixels),
  // which sit a near-constant (+65, −42) px from where our camera images the same floor points
  // (ours: cx 262 and no yaw in the §2 mount, straight ahead near column 250).
  // Method: (1) the floor quadrilateral the real points see through the real car's camera, i.e.
  // the floor→image homography least-squares fitted to those correspondences (residuals ≤ 5 px,
  // one 20 px), is (0.267, +0.303), (0.266, −0.295), (0.904, +0.201), (0.889, −0.184) m: rows
  // 480→0 cover 0.27→0.90 m and the car's centre line falls on column ≈ 322, as the §5 anchors
  // (col 320) assume. Seen by our camera that quadrilateral gives (−482.5, 535.0), (875.3, 513.6),
  // (149.1, 261.3), (359.5, 262.7). (2) But it narrows from 0.60 m at the near edge (the lane's two
  // lines, ±0.30 ≈ ±0.31 m) to 0.39 m at the far edge, so the constant 150 px shift of §5 would be
  // 0.28 m near and only 0.18 m far; and our camera sees the yellow line only beyond ≈ 0.6 m. With
  // those points the lane centre at 0.5 m comes out 2.8 cm (yellow) and 4.1 cm (white) off on a
  // straight. So we keep the real quadrilateral's depth (0.267 → 0.897 m, the mean of its far
  // corners) and its near edge on the lane's lines, and square it: the rectangle x ∈ [0.267,
  // 0.897] m, y = ±0.31 m (reference §1: lane centres 0.62 m apart), i.e. columns 160 and 480
  // are the car's lane lines at every row and column 320 its centre line. Our camera (with its
  // lens distortion) sees those corners at the points below; the lane test re-derives them.
  std::array<std::array<double, 2>, 4> warp_source_px{
      {{-522.16, 541.76}, {927.50, 519.78}, {91.55, 262.92}, {423.51, 263.07}}};
  std::array<std::array<double, 2>, 4> warp_destination_px{
      {{160.0, 480.0}, {480.0, 480.0}, {160.0, 0.0}, {480.0, 0.0}}};  // reference §5
  int yellow_min_px{2000};  // reference §5: yellow is the line if it has at least this many pixels
  int line_min_px{1000};    // reference §5: fewer white pixels than this (and no yellow): invalid
  double sample_row_step_px{16.0};  // reference §5: sample i (0..29) at row i·16
  double normal_shift_px{150.0};    // reference §5: from the line towards the lane centre
  std::vector<double> anchor_rows_px{480.0, 470.0, 460.0};  // reference §5
  double anchor_col_px{320.0};                              // reference §5
  int anchor_repeats{60};                                   // reference §5
  // The lab's departures (see the enums above).
  BirdsEyeClasses hw_pixel_classes{BirdsEyeClasses::kNonZero};
  HwNoLine hw_no_line{HwNoLine::kWhiteBelowMin};
  // rt_polyfit.cpp:107-114, 157, 165-166: the line's samples, the shifted points, the trajectory's
  // samples and their raw-image pixels are each truncated to integers (int64_t, towards zero).
  bool hw_truncate_points{false};
  // rt_polyfit.cpp:249, 258: `valid` and then the 30 points are both written at the message's
  // offset 0, while the message is `uint64 valid` then the points (LanePoints.msg of the lab's
  // carcontrol and ros_ws iceoryx_msg). The receiver's `valid` is point 0's two floats (x in the
  // low word), never 0; its point k is the fit's point k + 1; its point 29 is never written
  // (LabHardwareMessage).
  bool hw_valid_overwrite{false};
  LaneProjection projection{LaneProjection::kIdeal};
  SwNoLine sw_no_line{SwNoLine::kInvalid};
  // The floor points of the lab's PnP calibration, (x forward, y left) in m on the floor
  // (params/real_pointsets.yml:10-14, worldpoints, z 0; the origin taken as base_link's).
  std::array<std::array<double, 2>, 11> pnp_floor_points_m{{{0.3, 0.15},
                                                            {0.3, 0.0},
                                                            {0.3, -0.15},
                                                            {0.55, 0.15},
                                                            {0.55, 0.0},
                                                            {0.55, -0.15},
                                                            {0.8, 0.15},
                                                            {0.8, 0.0},
                                                            {0.8, -0.15},
                                                            {1.6, 0.15},
                                                            {1.6, -0.15}}};

  template <class V>
  void Describe(V& v) {
    v("thresholds", thresholds,
      "the HSV thresholds: `simulation`, the lab's Gazebo set, or `real_car`");
    v("warp_source_px", warp_source_px,
      "the bird's-eye warp's source points in the raw image, (col, row): near left, near right, "
      "far left, far right");
    v("warp_destination_px", warp_destination_px, "their places in the bird's-eye image");
    v("yellow_min_px", yellow_min_px, "yellow is the line if it has at least this many pixels");
    v("line_min_px", line_min_px, "fewer white pixels than this, and no yellow: no line");
    v("sample_row_step_px", sample_row_step_px, "the line is sampled every this many rows");
    v("normal_shift_px", normal_shift_px,
      "samples move this far from the line towards the lane's centre");
    v("anchor_rows_px", anchor_rows_px,
      "rows of extra points at the car's position that pin the fitted trajectory");
    v("anchor_col_px", anchor_col_px, "their column");
    v("anchor_repeats", anchor_repeats, "how many times each counts in the fit");
    v("hw_pixel_classes", hw_pixel_classes,
      "the hardware lane planner's line pixels: `non_zero`, ours, or `exact`, the lab's");
    v("hw_no_line", hw_no_line,
      "when the hardware fit says no line: `white_below_min`, ours, or `both_below_min`, the "
      "lab's");
    v("hw_truncate_points", hw_truncate_points,
      "the hardware fit truncates its points to integers, as the lab's (true)");
    v("hw_valid_overwrite", hw_valid_overwrite,
      "the hardware fit writes `valid` over point 0, as the lab's (true)");
    v("projection", projection,
      "from a pixel to the floor: `ideal`, ours, or `pnp_swapped`, the lab's");
    v("sw_no_line", sw_no_line,
      "the software node without a line: `invalid`, ours, or `silent`, the lab's");
    v("pnp_floor_points_m", pnp_floor_points_m,
      "`pnp_swapped`: the lab's calibration points on the floor, (x, y) in base_link");
  }
  // A known threshold set, finite warp points forming a proper quadrilateral, counts >= 0,
  // line_min_px <= yellow_min_px, step > 0, shift >= 0, at least one anchor row and repeat.
  void Validate() const;
  bool operator==(const LaneDetectionParams&) const = default;
};

// The message (reference §5): 30 × (float32 x, y) in base_link + uint64 valid = 248 bytes.
struct LanePoint {
  float x_m{0.0F};
  float y_m{0.0F};
};
struct LanePoints {
  static constexpr int kCount = 30;
  // Ordered as the real node sends them: bird's-eye row 0 (farthest) first. All zero if invalid.
  std::array<LanePoint, kCount> points{};
  std::uint64_t valid{0};
};
inline constexpr std::size_t kLanePointsBytes = 248;  // reference §5 / §8: LanePoints 248 B
static_assert(sizeof(LanePoints) == kLanePointsBytes, "LanePoints must model the 248-byte message");

// Bird's-eye masks, 640×480 CV_8UC1 each; not binary (the bilinear warp blends 0 and 255 at
// edges), and a pixel counts as a line pixel where it is non-zero, as in the real node.
struct BirdsEyeMasks {
  cv::Mat yellow;
  cv::Mat white;
};

// What the fit reads of the bird's-eye masks: per row, how many pixels are non-zero (line pixels)
// and the sum of their columns. The fit of these is the fit of the masks, bit for bit.
struct BirdsEyeRowSums {
  struct Row {
    std::int32_t count{0};
    std::int64_t col_sum{0};
    friend bool operator==(const Row&, const Row&) = default;
  };
  std::array<Row, kLaneImageHeight> yellow{};
  std::array<Row, kLaneImageHeight> white{};
  friend bool operator==(const BirdsEyeRowSums&, const BirdsEyeRowSums&) = default;
};

// The row sums of a pair of masks.
BirdsEyeRowSums RowSumsOfMasks(const BirdsEyeMasks& masks);

// The plain OpenCV mask+warp stage: cvtColor(BGR2HSV), inRange per colour, warpPerspective of each
// mask with OpenCV's defaults (INTER_LINEAR, BORDER_CONSTANT 0), as the real node calls it.
// `image_to_birds_eye` is the 3×3 CV_64F homography (LaneDetector::image_to_birds_eye()).
void LaneMasksReference(const cv::Mat& bgr, const LaneThresholds& thresholds,
                        const cv::Mat& image_to_birds_eye, BirdsEyeMasks* masks);

enum class LaneLine { kNone, kYellow, kWhite };

// col = Σ c[k] · row^k, row and col in bird's-eye pixels.
struct RowPolynomial {
  std::vector<double> coefficients;  // c[0] first
  double operator()(double row) const;
  double Slope(double row) const;  // d col / d row
};

// Weighted least squares col = f(row) of the given degree (rows are rescaled internally, so rows
// in the hundreds cost no precision). nullopt if the points do not determine it (fewer distinct
// rows than coefficients) or an input is not finite.
std::optional<RowPolynomial> FitRowPolynomial(std::span<const double> rows,
                                              std::span<const double> cols,
                                              std::span<const double> weights, int degree);

// The point of `line` at `row` moved `shift_px` along the curve's normal towards the lane centre
// (right-hand traffic: the yellow centre line is on the car's left, a white line on its right, so
// the lane centre is to the right (+col) of yellow and to the left of white). Returns (row, col).
// This is the real node's shift, (Δrow, Δcol) = s·shift·(slope, −1)/√(1 + slope²) with s = −1 for
// yellow, +1 for white, written so that a slope of exactly 0 does not divide by zero.
Eigen::Vector2d ShiftTowardsLaneCentre(const RowPolynomial& line, double row, LaneLine which,
                                       double shift_px);

// That move alone, (Δrow, Δcol).
Eigen::Vector2d LaneCentreShift(const RowPolynomial& line, double row, LaneLine which,
                                double shift_px);

// The 3rd-order trajectory through the shifted samples (row, col) and the anchors.
std::optional<RowPolynomial> FitTrajectory(const LaneDetectionParams& params,
                                           std::span<const Eigen::Vector2d> shifted_row_col);

// Where the ray through raw-image pixel (u, v) meets the floor, (x, y) in base_link; nullopt if
// the distortion cannot be inverted there or the ray does not point down at the floor.
std::optional<Eigen::Vector2d> FloorPointFromPixel(const LaneCameraCalibration& camera, double u,
                                                   double v);

// rt_laneplanner's bird's-eye image (rt_laneplanner.cpp:129-142): the white mask plus the yellow
// mask shifted right by one bit, in 8 bits (0, 127, 255; both 126), warped bilinearly. Warped here
// with cv::warpPerspective as LaneMasksReference: the FPGA's xf::cv::warpTransform has
// fixed-point weights of its own (not modelled), so where exactly a blend lands on 255 or 127 can
// differ from the real slot's in a few pixels.
void LaneCombinedReference(const cv::Mat& bgr, const LaneThresholds& thresholds,
                           const cv::Mat& image_to_birds_eye, cv::Mat* combined);
// Its row sums as rt_polyfit counts them (rt_polyfit.cpp:53-74): white where exactly 255, yellow
// where exactly 127.
BirdsEyeRowSums RowSumsOfCombined(const cv::Mat& combined);

// The lab's floor projection as data: the pose cv::solvePnP gave (R⁻¹ = rotationMatrix.inv(), t)
// and K⁻¹ (lane_detector.cpp:47-53; rt_polyfit.cpp:170-176 holds the same numbers for the real
// car: solvePnP of params/real_pointsets.yml with params/real_intrinsics.yml, K and D, gives them
// to the last digit).
struct LanePnpPose {
  Eigen::Matrix3d R_inv{Eigen::Matrix3d::Identity()};
  Eigen::Vector3d t{Eigen::Vector3d::Zero()};
  Eigen::Matrix3d K_inv{Eigen::Matrix3d::Identity()};
};

// The pose the lab's node would compute for `camera`: the lab's floor points (x, y, 0) imaged by
// this camera with its distortion, rounded to whole pixels (the lab picked whole pixels) and
// written (row, col) as in the lab's file, then cv::solvePnP (iterative) with the camera's K and D,
// as the node's init. The lab's constants are for the real car's camera and mount, and ours differ
// (see warp_source_px): so the method is carried over, not the numbers. Points the camera does not
// see are left out, as nobody could pick them (ours: (0.3, +0.15) at column −40 and (0.3, 0) at
// row 485, of the lab's 11). Throws if a point is behind the camera or fewer than 4 are seen.
LanePnpPose LabPnpPose(const LaneCameraCalibration& camera,
                       std::span<const std::array<double, 2>> floor_points_m);

// The lab's formula for the pixel it passes as (a, b) (it passes (row, col)): s = (R⁻¹t)_z /
// (R⁻¹K⁻¹(a, b, 1))_z, p = R⁻¹(s·K⁻¹(a, b, 1) − t); (x, y) of p. In doubles as the software node
// (lane_detector.cpp:214-236), or in float as rt_polyfit (rt_polyfit.cpp:178-241).
Eigen::Vector2d ProjectLabPnp(const LanePnpPose& pose, double a, double b);
Eigen::Vector2f ProjectLabPnpFloat(const LanePnpPose& pose, float a, float b);

namespace detail {
// OpenCV's 8-bit BGR2HSV (H 0–179) in its integer arithmetic; exposed for the exhaustive test.
std::array<std::uint8_t, 3> BgrToHsv8(std::uint8_t b, std::uint8_t g, std::uint8_t r);
}  // namespace detail

// What one step saw, for tests and debugging.
struct LaneDetectionTrace {
  LaneLine line{LaneLine::kNone};
  int yellow_px{0};  // non-zero bird's-eye pixels
  int white_px{0};   // -1: not counted (yellow sufficed)
  std::optional<RowPolynomial> line_fit;
  std::optional<RowPolynomial> trajectory;
};

// The detector's fixed part (params, validated once, and everything computed from them and the
// camera): the homographies, OpenCV's 8-bit HSV division tables and the warp's per-pixel tables
// (which source pixels each bird's-eye pixel reads, with which bilinear weights). Immutable after
// construction, so one instance can be shared read-only by any number of detectors and threads:
// the lane planner's and the polynomial fit's nodes share one.
class LaneDetectorTables {
 public:
  LaneDetectorTables(const LaneDetectionParams& params, const LaneCameraCalibration& camera);

  const LaneDetectionParams& params() const { return params_; }
  const LaneCameraCalibration& camera() const { return camera_; }
  const LaneThresholds& thresholds() const { return thresholds_; }
  // 3×3 CV_64F, raw image (col, row) → bird's-eye (col, row), and back.
  const cv::Mat& image_to_birds_eye() const { return image_to_birds_eye_; }
  const cv::Mat& birds_eye_to_image() const { return birds_eye_to_image_; }

  // The pixels of the input image that the detector reads (the source pixels of its warp), at
  // most one span per row, rows ascending: an image whose other pixels hold anything gives the
  // same result.
  struct SourceSpan {
    int row, col_begin, col_end;  // [col_begin, col_end)
  };
  const std::vector<SourceSpan>& source_spans() const { return spans_; }

  // The lab's PnP pose for this camera (LabPnpPose); set only if params().projection is
  // pnp_swapped.
  const std::optional<LanePnpPose>& pnp_pose() const { return pnp_pose_; }

  // The class a pixel of this colour gets: bit 0 yellow, bit 1 white (the thresholds' HSV boxes,
  // in OpenCV's 8-bit HSV); a pure function of the colour.
  std::uint8_t ClassOf(std::uint8_t b, std::uint8_t g, std::uint8_t r) const;

 private:
  friend class LaneDetector;
  // The padded class image's row stride: one zero pixel each side, and a zero row above and below.
  static constexpr int kClassStride = kLaneImageWidth + 2;
  // The class image's line pixels as bits: a row of kLineWords words per padded row, bit c of a
  // row's words for padded column c.
  static constexpr int kLineWords = (kClassStride + 63) / 64;
  static_assert(kLineWords <= 16, "a row's words with a line pixel are one 16-bit mask");
  struct WarpSource;  // each output pixel's source pixel and bilinear weights (the constructor's)
  // The active output pixels (whose source square touches the image) in the order of their
  // squares, and the source spans they read.
  void IndexActivePixels(const WarpSource& source);

  LaneDetectionParams params_;
  LaneCameraCalibration camera_;
  LaneThresholds thresholds_;
  cv::Mat image_to_birds_eye_;
  cv::Mat birds_eye_to_image_;
  // OpenCV's 8-bit HSV division tables.
  std::array<int, 256> sdiv_{};
  std::array<int, 256> hdiv_{};
  // No colour darker than this (V below both ranges' lower bounds) is in a line class.
  int v_min_{0};
  // The bilinear warp of a 0/255 mask: output for (alpha index, which of the 4 neighbours are 255).
  std::vector<std::uint8_t> warp_lut_;  // 1024 × 16
  // The bilinear warp of rt_laneplanner's combined image (neighbour values 0, 127, 255, 126 for
  // classes 0-3): 1 where the output is exactly 127, 2 where exactly 255, else 0, for (alpha
  // index, yellow bits | white bits << 4).
  std::vector<std::uint8_t> exact_lut_;  // 1024 × 256
  // exact_lut_'s entries for the patterns of one colour, for (alpha index, neighbour bits): bits
  // 0-1 those yellow bits and no white, bits 2-3 those white bits and no yellow.
  std::vector<std::uint8_t> exact_single_lut_;  // 1024 × 16
  std::optional<LanePnpPose> pnp_pose_;
  // What the warp of a square whose neighbour pattern is p (yellow bits | white bits << 4) gives
  // whatever the output's alpha: bits 0-1 the yellow output (nonzero mask, or exactly 127), bits
  // 2-3 the white one (nonzero, or exactly 255), each kNever, kAlways or kDepends on the alpha.
  // Per BirdsEyeClasses, from warp_lut_ and exact_lut_ (a square of one class, or of none, does
  // not depend on it: the weights sum to one).
  enum SquareOutput : std::uint8_t { kNever = 0, kAlways = 1, kDepends = 2 };
  using SquareOutputTable = std::array<std::array<std::uint8_t, 256>, 2>;
  static SquareOutputTable SquareOutputs(const std::vector<std::uint8_t>& warp_lut,
                                         const std::vector<std::uint8_t>& exact_lut);
  SquareOutputTable square_outputs_{};
  // Active output pixels (whose source square touches the image), ordered by their square's top
  // left pixel in the padded class image (then by output index): the pixels of the squares whose
  // top left is padded index p are pixels_[square_start_[p], square_start_[p + 1]).
  // One 32-bit word per pixel: bits 0-8 the output row, 9-18 the output column, 19-28 the alpha
  // index.
  struct WarpPixel {
    static constexpr int kRowBits = 9, kColBits = 10, kAlphaBits = 10;
    static constexpr int kColShift = kRowBits, kAlphaShift = kColShift + kColBits;
    static std::uint32_t Pack(int row, int col, int alpha) {
      return static_cast<std::uint32_t>(row) | (static_cast<std::uint32_t>(col) << kColShift) |
             (static_cast<std::uint32_t>(alpha) << kAlphaShift);
    }
    static int Row(std::uint32_t w) { return static_cast<int>(w & ((1u << kRowBits) - 1)); }
    static int Col(std::uint32_t w) {
      return static_cast<int>((w >> kColShift) & ((1u << kColBits) - 1));
    }
    // the alpha index · 16 (an index into the 16-pattern tables)
    static int Alpha16(std::uint32_t w) {
      return static_cast<int>((w >> (kAlphaShift - 4)) & (((1u << kAlphaBits) - 1) << 4));
    }
  };
  std::vector<std::uint32_t> pixels_;
  std::vector<std::uint32_t> square_start_;  // (kLaneImageHeight + 1) · kClassStride + 1
  std::vector<SourceSpan> spans_;            // the source pixels the warp reads
};

// The line classes of a source image (LaneDetectorTables::ClassOf of each pixel's colour), as a
// detector hands its own class buffer to a producer that knows each pixel's class without the
// colour image (a renderer whose floor has few colours labels each colour once). The producer
// writes the class of pixel (u, v) at pixels[v · stride + u] for every pixel of `spans`; the
// detector reads no other pixel, and `pixels` ends at the image's last pixel.
struct ClassImageRegion {
  std::span<std::uint8_t> pixels;
  std::ptrdiff_t stride{0};
  std::span<const LaneDetectorTables::SourceSpan> spans;
};

// The fit stage (what the polynomial fit's slot runs: reference §8), from the bird's-eye masks'
// row sums: the line, its fit, the shifted samples, the trajectory and the points in base_link.
// Reads the tables only.
LanePoints FitLanePoints(const LaneDetectorTables& tables, const BirdsEyeRowSums& sums,
                         LaneDetectionTrace* trace = nullptr);

namespace detail {
// How a fit turns a line into points: rt_polyfit truncates (hw_truncate_points) and projects in
// float.
struct LaneFitRules {
  bool truncate{false};
  bool in_float{false};
};
// The line pixels of one mask's row sums.
int PixelCount(const std::array<BirdsEyeRowSums::Row, kLaneImageHeight>& sums);
// From the chosen line's row sums: its fit, the shifted samples, the trajectory and the 30 floor
// points by the params' projection (the trace's fits set); nullopt if a fit is undetermined or a
// point does not reach the floor.
std::optional<std::array<LanePoint, LanePoints::kCount>> LanePointsOfLine(
    const LaneDetectorTables& tables,
    const std::array<BirdsEyeRowSums::Row, kLaneImageHeight>& sums, LaneLine line,
    const LaneFitRules& rules, LaneDetectionTrace* trace);
}  // namespace detail

// The polynomial fit's slot as rt_polyfit computes it, with the params' hw_* options and
// projection; the message as its receiver reads it. With every option ours it is FitLanePoints.
// Both counts are taken (the trace's white_px is never -1); the line is yellow with >=
// yellow_min_px, else white, and hw_no_line decides `valid`. Not modelled: rt_polyfit solves the
// normal equations of its integer moment sums by LU (xf::solver::gelinearsolver, rt_polyfit.cpp:
// 101, 147), ours by QR; a fit the pixels do not determine divides by a zero pivot there: its
// points are taken as not-a-number (what the slot's double-to-int64 conversion makes of that is
// unknown), which only the overwritten message shows (else `valid` is 0).
LanePoints FitLanePointsHardware(const LaneDetectorTables& tables, const BirdsEyeRowSums& sums,
                                 LaneDetectionTrace* trace = nullptr);

// What the receiver reads when rt_polyfit writes `written` (valid word, then the 30 points, both
// at offset 0: rt_polyfit.cpp:249, 258) into a message laid out `uint64 valid` then the points:
// `valid` is point 0's (x bits | y bits << 32, little-endian as the ZCU104's A53), point k is
// written point k + 1, and point 29 holds what the loaned chunk held before: assumed zero (a fresh
// shared-memory chunk; which earlier messages reuse the chunk and what they left is unknown).
LanePoints LabHardwareMessage(const std::array<LanePoint, LanePoints::kCount>& written);

// A detector: shared, read-only tables (LaneDetectorTables) plus scratch buffers of its own, so
// an output depends on its input alone. One detector per thread (and per node); detectors that
// share tables share no mutable state.
//
// Two ways to feed the mask+warp stage: a colour image (ComputeMasks, ComputeRowSums, Step), or
// line classes a producer writes into the detector's own class image: MutableClassRegion() hands
// out that region (ClassImageRegion), then ComputeRowSumsFromClasses reads it. The region stays
// valid as long as the detector; the colour-image calls overwrite it.
class LaneDetector {
 public:
  using SourceSpan = LaneDetectorTables::SourceSpan;

  // With tables of its own.
  LaneDetector(const LaneDetectionParams& params, const LaneCameraCalibration& camera);
  // With shared tables (not null).
  explicit LaneDetector(std::shared_ptr<const LaneDetectorTables> tables);

  const std::shared_ptr<const LaneDetectorTables>& tables() const { return tables_; }
  const LaneDetectionParams& params() const { return tables_->params(); }
  const LaneThresholds& thresholds() const { return tables_->thresholds(); }
  const cv::Mat& image_to_birds_eye() const { return tables_->image_to_birds_eye(); }
  const cv::Mat& birds_eye_to_image() const { return tables_->birds_eye_to_image(); }
  const std::vector<SourceSpan>& source_spans() const { return tables_->source_spans(); }
  std::uint8_t ClassOf(std::uint8_t b, std::uint8_t g, std::uint8_t r) const {
    return tables_->ClassOf(b, g, r);
  }

  // `bgr`: 640×480 CV_8UC3. Throws std::invalid_argument on another size or type.
  LanePoints Step(const cv::Mat& bgr, LaneDetectionTrace* trace = nullptr);

  // The fast mask+warp stage alone: bit-identical to LaneMasksReference.
  void ComputeMasks(const cv::Mat& bgr, BirdsEyeMasks* masks);
  // The same stage as the fit reads it: RowSumsOfMasks of ComputeMasks, without writing (or
  // clearing) the two 640×480 masks.
  // With `classes` exact, the row sums of rt_laneplanner's combined image as rt_polyfit counts
  // them: RowSumsOfCombined of LaneCombinedReference, bit for bit.
  void ComputeRowSums(const cv::Mat& bgr, BirdsEyeRowSums* sums,
                      BirdsEyeClasses classes = BirdsEyeClasses::kNonZero);
  // The detector's class image for a producer to fill (ClassImageRegion); then
  // ComputeRowSumsFromClasses gives ComputeRowSums of the image whose classes were written.
  // `nonzero_columns`, if the producer knows them: per image row (one entry each), the columns
  // [begin, end) outside which every class it wrote is 0 (begin >= end: none), so that only
  // those are searched for line pixels.
  ClassImageRegion MutableClassRegion();
  void ComputeRowSumsFromClasses(BirdsEyeRowSums* sums,
                                 BirdsEyeClasses classes = BirdsEyeClasses::kNonZero,
                                 std::span<const std::pair<int, int>> nonzero_columns = {});
  // The rest, from the bird's-eye masks or their row sums (the same result): Step is
  // ComputeRowSums then Fit. The real hardware runs the two in separate slots (reference §8: lane
  // planner, polynomial fit). Fit(sums) is FitLanePoints(*tables(), sums).
  LanePoints Fit(const BirdsEyeMasks& masks, LaneDetectionTrace* trace = nullptr);
  LanePoints Fit(const BirdsEyeRowSums& sums, LaneDetectionTrace* trace = nullptr);

 private:
  static constexpr int kClassStride = LaneDetectorTables::kClassStride;

  // The classes of the source pixels into classes_, and the line bits from them.
  void Classify(const cv::Mat& bgr);
  // line_bits_ from classes_ (nonzero_columns: as ComputeRowSumsFromClasses', or empty).
  void FindLinePixels(std::span<const std::pair<int, int>> nonzero_columns = {});
  // The warp over classes_: visit(first, last, yellow bits, white bits) for source squares with
  // a line pixel among their four pixels and the output pixels [first, last) that read them
  // (LaneDetectorTables::WarpPixel words; the other outputs stay 0, the border value); bit k of
  // the bits: neighbour k (top left, top right, bottom left, bottom right). A run of squares
  // whose pixels are all of one colour alone is one visit.
  template <class Visit>
  void ForEachLineSquare(Visit visit);
  // uniform_runs_ and mixed_squares_ from line_bits_.
  void FindLineSquares();
  // The row sums of the bird's-eye masks, from classes_.
  void SumWarpedClasses(BirdsEyeRowSums* sums, BirdsEyeClasses classes);

  std::shared_ptr<const LaneDetectorTables> tables_;
  // Scratch: per source pixel bit 0 yellow, bit 1 white, with a 1-pixel zero border; and per
  // padded pixel whether it is a line pixel, as bits (LaneDetectorTables::kLineWords a row; the
  // words outside the spans stay 0).
  std::vector<std::uint8_t> classes_;
  std::vector<std::uint64_t> line_bits_;
  // per word of line_bits_ that is not 0: its pixels of class 1 (yellow alone) and 2 (white
  // alone); the others hold anything
  std::vector<std::uint64_t> yellow_bits_, white_bits_;
  std::vector<std::uint16_t> line_words_;  // per padded row: bit w, word w holds a line pixel
  // The squares with a line pixel: runs of those whose four pixels are one colour alone (the
  // range of pixels_ that reads them, and their pattern: yellow bits | white bits << 4), and runs
  // of the others (padded top-left indices [first, last)).
  static constexpr std::uint8_t kAllYellow = 0x0F, kAllWhite = 0xF0;
  struct UniformRun {
    std::uint32_t begin, end;
    std::uint8_t pattern;
  };
  std::vector<UniformRun> uniform_runs_;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> mixed_squares_;
  BirdsEyeRowSums sums_;
};

}  // namespace autonomsim::stack
