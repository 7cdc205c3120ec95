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
// warp reads are thresholded, with OpenCV's 8-bit HSV integer arithmetic; output tiles whose source
// holds no line pixel are skipped).
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
#include <vector>

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

// The two documented threshold sets (reference §5): "real_car" and "simulation" (theirs, Gazebo).
// Throws std::invalid_argument naming the known sets.
LaneThresholds LaneThresholdsByName(const std::string& name);

// The colour camera as the lane detection needs it, as plain data (the node converts the vehicle's
// camera model): the raw image's intrinsics and plumb_bob distortion, and the optical frame (z
// forward, x right, y down) in base_link (x forward, y left, z up; origin on the floor).
struct LaneCameraCalibration {
  std::array<double, 9> K{1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0};  // row-major
  std::array<double, 5> D{0.0, 0.0, 0.0, 0.0, 0.0};  // k1, k2, p1, p2, k3 (ROS/OpenCV order)
  Eigen::Isometry3d X_base_camera{Eigen::Isometry3d::Identity()};

  void Validate() const;  // fx, fy > 0, finite; the camera above the floor
};

struct LaneDetectionParams {
  // Which HSV set: "simulation" by default. Our renderer paints white RGB(255,255,255) and yellow
  // RGB(235,235,0) (reference §1); OpenCV's 8-bit BGR2HSV gives white (0, 0, 255) and yellow
  // (30, 255, 235). The real car's white needs H 70–90, which a pure white (H = 0, no hue at all)
  // never has: its camera sees the lab's white with a tint. Their simulation's white (H 0–179, S
  // ≤ 35, V ≥ 215) and yellow (H 10–100, S ≥ 70, V ≥ 95) take both of our colours and leave the
  // black floor (V 0) and the grey wall (110, 110, 110: S 0, V 110) out.
  std::string thresholds{"simulation"};
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

  template <class V>
  void Describe(V& v) {
    v("thresholds", thresholds);
    v("warp_source_px", warp_source_px);
    v("warp_destination_px", warp_destination_px);
    v("yellow_min_px", yellow_min_px);
    v("line_min_px", line_min_px);
    v("sample_row_step_px", sample_row_step_px);
    v("normal_shift_px", normal_shift_px);
    v("anchor_rows_px", anchor_rows_px);
    v("anchor_col_px", anchor_col_px);
    v("anchor_repeats", anchor_repeats);
  }
  // A known threshold set, finite warp points forming a proper quadrilateral, counts >= 0,
  // line_min_px <= yellow_min_px, step > 0, shift >= 0, at least one anchor row and repeat.
  void Validate() const;
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

// The 3rd-order trajectory through the shifted samples (row, col) and the anchors.
std::optional<RowPolynomial> FitTrajectory(const LaneDetectionParams& params,
                                           std::span<const Eigen::Vector2d> shifted_row_col);

// Where the ray through raw-image pixel (u, v) meets the floor, (x, y) in base_link; nullopt if
// the distortion cannot be inverted there or the ray does not point down at the floor.
std::optional<Eigen::Vector2d> FloorPointFromPixel(const LaneCameraCalibration& camera, double u,
                                                   double v);

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

  // The class a pixel of this colour gets: bit 0 yellow, bit 1 white (the thresholds' HSV boxes,
  // in OpenCV's 8-bit HSV); a pure function of the colour.
  std::uint8_t ClassOf(std::uint8_t b, std::uint8_t g, std::uint8_t r) const;

 private:
  friend class LaneDetector;
  // The padded class image's row stride: one zero pixel each side, and a zero row above and below.
  static constexpr int kClassStride = kLaneImageWidth + 2;
  struct Tile {
    std::uint32_t begin, end;        // into the per-pixel arrays
    std::uint16_t cell_x0, cell_y0;  // source cells read (inclusive)
    std::uint16_t cell_x1, cell_y1;
  };
  struct WarpSource;  // each output pixel's source pixel and bilinear weights (the constructor's)
  // The active output pixels (whose source square touches the image) by tile, and the source
  // spans they read.
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
  // Active output pixels (whose source square touches the image), grouped by output tile.
  std::vector<Tile> tiles_;
  std::vector<std::uint32_t> pixel_dst_;  // output index
  std::vector<std::uint32_t> pixel_src_;  // top-left neighbour in the padded class image
  std::vector<std::uint16_t> pixel_lut_;  // alpha · 16
  std::vector<SourceSpan> spans_;         // the source pixels the warp reads
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
  void ComputeRowSums(const cv::Mat& bgr, BirdsEyeRowSums* sums);
  // The detector's class image for a producer to fill (ClassImageRegion); then
  // ComputeRowSumsFromClasses gives ComputeRowSums of the image whose classes were written.
  ClassImageRegion MutableClassRegion();
  void ComputeRowSumsFromClasses(BirdsEyeRowSums* sums);
  // The rest, from the bird's-eye masks or their row sums (the same result): Step is
  // ComputeRowSums then Fit. The real hardware runs the two in separate slots (reference §8: lane
  // planner, polynomial fit). Fit(sums) is FitLanePoints(*tables(), sums).
  LanePoints Fit(const BirdsEyeMasks& masks, LaneDetectionTrace* trace = nullptr);
  LanePoints Fit(const BirdsEyeRowSums& sums, LaneDetectionTrace* trace = nullptr);

 private:
  using Tile = LaneDetectorTables::Tile;
  static constexpr int kClassStride = LaneDetectorTables::kClassStride;

  // The classes of the source pixels into classes_, and the line cells from them.
  void Classify(const cv::Mat& bgr);
  void FindLineCells();   // cell_any_ from classes_, then IndexLineCells
  void IndexLineCells();  // cell_prefix_ from cell_any_
  bool AnyLineCell(const Tile& tile) const;
  // The warp over classes_: visit(output index, yellow value, white value) for each output pixel
  // that may be non-zero (the others stay 0, the border value).
  template <class Visit>
  void ForEachWarpedLinePixel(Visit visit) const;
  // The row sums of the bird's-eye masks, from classes_.
  void SumWarpedClasses(BirdsEyeRowSums* sums);

  std::shared_ptr<const LaneDetectorTables> tables_;
  // Scratch: per source pixel bit 0 yellow, bit 1 white, with a 1-pixel zero border; and per
  // source cell whether it holds a line pixel, as an inclusive 2D prefix count.
  std::vector<std::uint8_t> classes_;
  std::vector<std::uint8_t> cell_any_;
  std::vector<int> cell_prefix_;
  BirdsEyeRowSums sums_;
};

}  // namespace autonomsim::stack
