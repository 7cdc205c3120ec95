#include "stack/lane_detection.h"

#include <Eigen/QR>
#include <algorithm>
#include <bit>
#include <climits>
#include <cmath>
#include <cstring>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif
#include <numeric>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <utility>

#include "world/bits.h"
#include "world/plumb_bob.h"
#include "world/validation.h"

namespace autonomsim::stack {
namespace {

// OpenCV's fixed-point warp (imgproc, warpPerspective/remap with INTER_LINEAR): source
// coordinates carry 5 fractional bits, and the 32 × 32 fractional positions index a table of
// bilinear weights (hence 1024 alpha indices).
constexpr int kInterBits = 5;
constexpr int kInterTabSize = 1 << kInterBits;
constexpr int kAlphaCount = kInterTabSize * kInterTabSize;
// warpPerspective computes coordinates in blocks of its own: BLOCK_SZ = 32 gives, for a 640-wide
// output, blocks of 64 columns × 16 rows, and each block restarts its row's sum at its first
// column. Reproducing the blocks reproduces the exact doubles.
constexpr int kWarpBlockSize = 32;
// OpenCV's 8-bit HSV: 12 fractional bits in its division tables.
constexpr int kHsvShift = 12;

// Two bytes read with memcpy as (first | second << 8), whatever the machine's byte order.
constexpr std::uint32_t LittleEndianPair(std::uint16_t read) {
  if constexpr (std::endian::native == std::endian::big) {
    return static_cast<std::uint32_t>((read >> 8) | ((read & 0xFFu) << 8));
  }
  return read;
}
// Newton's method for the inverse of the lens distortion (as the vehicle's camera model does).

using Point = std::array<double, 2>;

double Cross(const Point& o, const Point& a, const Point& b) {
  return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]);
}

// Near left, near right, far left, far right → a convex quadrilateral (walked NL, NR, FR, FL).
void RequireQuadrilateral(const std::array<Point, 4>& q, const std::string& key) {
  for (const Point& p : q) {
    Require(std::isfinite(p[0]) && std::isfinite(p[1]), [&] { return key + " must be finite"; });
  }
  const std::array<Point, 4> ring{q[0], q[1], q[3], q[2]};
  int positive = 0;
  int negative = 0;
  for (int i = 0; i < 4; ++i) {
    const double c = Cross(ring[i], ring[(i + 1) % 4], ring[(i + 2) % 4]);
    positive += c > 0.0;
    negative += c < 0.0;
  }
  Require(positive == 4 || negative == 4, [&] {
    return key + " must be a convex quadrilateral: near left, near right, far left, far right";
  });
}

void RequireHsv(const HsvRange& range, const std::string& key) {
  const std::array<int, 3> max{179, 255, 255};
  for (int i = 0; i < 3; ++i) {
    Require(range.lower_hsv[i] >= 0 && range.upper_hsv[i] <= max[i] &&
                range.lower_hsv[i] <= range.upper_hsv[i],
            [&] {
              return key + ": channel " + std::to_string(i) + " range [" + Num(range.lower_hsv[i]) +
                     ", " + Num(range.upper_hsv[i]) + "] must lie in [0, " + Num(max[i]) +
                     "] with lower <= upper";
            });
  }
}

bool InRange(const HsvRange& range, const std::array<std::uint8_t, 3>& hsv) {
  for (int i = 0; i < 3; ++i) {
    if (hsv[i] < range.lower_hsv[i] || hsv[i] > range.upper_hsv[i]) return false;
  }
  return true;
}

std::vector<cv::Point2f> ToCv(const std::array<Point, 4>& points) {
  std::vector<cv::Point2f> out;
  for (const Point& p : points) {
    out.emplace_back(static_cast<float>(p[0]), static_cast<float>(p[1]));
  }
  return out;
}

void RequireImage(const cv::Mat& bgr) {
  Require(bgr.type() == CV_8UC3 && bgr.cols == kLaneImageWidth && bgr.rows == kLaneImageHeight,
          [&] {
            return "lane detection needs a 640x480 bgr8 image, got " + Num(bgr.cols) + "x" +
                   Num(bgr.rows) + " of type " + Num(bgr.type());
          });
}

// Per bird's-eye row: how many pixels are non-zero, and the sum of their columns.
void SumRows(const cv::Mat& mask, std::array<BirdsEyeRowSums::Row, kLaneImageHeight>* rows) {
  for (int r = 0; r < mask.rows; ++r) {
    const std::uint8_t* p = mask.ptr<std::uint8_t>(r);
    BirdsEyeRowSums::Row& row = (*rows)[static_cast<std::size_t>(r)];
    row = {};
    for (int c = 0; c < mask.cols; c += 8) {
      std::uint64_t word;
      std::memcpy(&word, p + c, sizeof word);
      if (word == 0) continue;
      for (int k = 0; k < 8; ++k) {
        if (p[c + k] != 0) {
          ++row.count;
          row.col_sum += c + k;
        }
      }
    }
  }
}

// The rows holding line pixels: their index, the mean column of those pixels and how many.
void RowMeans(const std::array<BirdsEyeRowSums::Row, kLaneImageHeight>& sums,
              std::vector<double>* rows, std::vector<double>* cols, std::vector<double>* weights,
              int* total) {
  rows->clear();
  cols->clear();
  weights->clear();
  // (at most a row each: one allocation, not one per doubling)
  rows->reserve(kLaneImageHeight);
  cols->reserve(kLaneImageHeight);
  weights->reserve(kLaneImageHeight);
  *total = 0;
  for (int r = 0; r < kLaneImageHeight; ++r) {
    const BirdsEyeRowSums::Row& row = sums[static_cast<std::size_t>(r)];
    if (row.count == 0) continue;
    rows->push_back(r);
    cols->push_back(static_cast<double>(row.col_sum) / static_cast<double>(row.count));
    weights->push_back(static_cast<double>(row.count));
    *total += row.count;
  }
}

// The floor point of raw-image pixel (u, v) by the params' projection; `in_float`: rt_polyfit's
// float arithmetic (the pixel already truncated), else the software node's doubles, whose
// projection takes the pixel as ints (lane_detector.cpp:214).
std::optional<LanePoint> FloorPoint(const LaneDetectorTables& tables, double u, double v,
                                    bool in_float) {
  if (tables.params().projection == LaneProjection::kIdeal) {
    const std::optional<Eigen::Vector2d> p = FloorPointFromPixel(tables.camera(), u, v);
    if (!p) return std::nullopt;
    return LanePoint{static_cast<float>(p->x()), static_cast<float>(p->y())};
  }
  // the lab's: (row, col), as lane_detector.cpp:354 and rt_polyfit.cpp:188-189 pass it
  const LanePnpPose& pose = *tables.pnp_pose();
  if (in_float) {
    const Eigen::Vector2f p =
        ProjectLabPnpFloat(pose, static_cast<float>(v), static_cast<float>(u));
    return LanePoint{p.x(), p.y()};
  }
  const Eigen::Vector2d p = ProjectLabPnp(pose, std::trunc(v), std::trunc(u));
  return LanePoint{static_cast<float>(p.x()), static_cast<float>(p.y())};
}

}  // namespace

BirdsEyeRowSums RowSumsOfMasks(const BirdsEyeMasks& masks) {
  BirdsEyeRowSums sums;
  for (const cv::Mat* mask : {&masks.yellow, &masks.white}) {
    Require(
        mask->type() == CV_8UC1 && mask->cols == kLaneImageWidth && mask->rows == kLaneImageHeight,
        [&] {
          return "bird's-eye masks must be 640x480 mono8, got " + Num(mask->cols) + "x" +
                 Num(mask->rows) + " of type " + Num(mask->type());
        });
  }
  SumRows(masks.yellow, &sums.yellow);
  SumRows(masks.white, &sums.white);
  return sums;
}

void HsvRange::Validate() const { RequireHsv(*this, "hsv range"); }

LaneThresholds LaneThresholdsOf(LaneThresholdSet set) {
  // reference §5, table "white H,S,V | yellow H,S,V"
  switch (set) {
    case LaneThresholdSet::kRealCar:
      return {.white = {{70, 0, 195}, {90, 87, 255}}, .yellow = {{30, 95, 50}, {34, 255, 255}}};
    case LaneThresholdSet::kSimulation:
      return {.white = {{0, 0, 215}, {179, 35, 255}}, .yellow = {{10, 70, 95}, {100, 255, 255}}};
  }
  throw std::invalid_argument("LaneThresholdsOf: not a threshold set");
}

void LaneCameraCalibration::Validate() const {
  for (double k : K) Require(std::isfinite(k), "camera K must be finite");
  for (double d : D) Require(std::isfinite(d), "camera D must be finite");
  Require(K[0] > 0.0 && K[4] > 0.0,
          [&] { return "camera K: fx and fy must be > 0, got " + Num(K[0]) + ", " + Num(K[4]); });
  Require(X_base_camera.matrix().allFinite(), "camera X_base_camera must be finite");
  Require(X_base_camera.translation().z() > 0.0, [&] {
    return "camera must be above the floor, got z = " + Num(X_base_camera.translation().z());
  });
}

void LaneDetectionParams::Validate() const {
  RequireQuadrilateral(warp_source_px, "warp_source_px");
  RequireQuadrilateral(warp_destination_px, "warp_destination_px");
  Require(yellow_min_px >= 0,
          [&] { return "yellow_min_px must be >= 0, got " + Num(yellow_min_px); });
  Require(line_min_px >= 0 && line_min_px <= yellow_min_px,
          [&] { return "line_min_px must be in [0, yellow_min_px], got " + Num(line_min_px); });
  Require(std::isfinite(sample_row_step_px) && sample_row_step_px > 0.0,
          [&] { return "sample_row_step_px must be > 0, got " + Num(sample_row_step_px); });
  Require(std::isfinite(normal_shift_px) && normal_shift_px >= 0.0,
          [&] { return "normal_shift_px must be >= 0, got " + Num(normal_shift_px); });
  Require(!anchor_rows_px.empty(), "anchor_rows_px must not be empty");
  for (double row : anchor_rows_px) {
    Require(std::isfinite(row), [&] { return "anchor_rows_px must be finite, got " + Num(row); });
  }
  Require(std::isfinite(anchor_col_px), "anchor_col_px must be finite");
  Require(anchor_repeats >= 1,
          [&] { return "anchor_repeats must be >= 1, got " + Num(anchor_repeats); });
  for (const auto& p : pnp_floor_points_m) {
    Require(std::isfinite(p[0]) && std::isfinite(p[1]), "pnp_floor_points_m must be finite");
  }
}

void LaneMasksReference(const cv::Mat& bgr, const LaneThresholds& thresholds,
                        const cv::Mat& image_to_birds_eye, BirdsEyeMasks* masks) {
  cv::Mat hsv;
  cv::cvtColor(bgr, hsv, cv::COLOR_BGR2HSV);
  const auto scalar = [](const std::array<int, 3>& a) { return cv::Scalar(a[0], a[1], a[2]); };
  cv::Mat mask;
  const cv::Size size(kLaneImageWidth, kLaneImageHeight);
  cv::inRange(hsv, scalar(thresholds.yellow.lower_hsv), scalar(thresholds.yellow.upper_hsv), mask);
  cv::warpPerspective(mask, masks->yellow, image_to_birds_eye, size);
  cv::inRange(hsv, scalar(thresholds.white.lower_hsv), scalar(thresholds.white.upper_hsv), mask);
  cv::warpPerspective(mask, masks->white, image_to_birds_eye, size);
}

double RowPolynomial::operator()(double row) const {
  double value = 0.0;
  for (auto it = coefficients.rbegin(); it != coefficients.rend(); ++it) value = value * row + *it;
  return value;
}

double RowPolynomial::Slope(double row) const {
  double value = 0.0;
  for (std::size_t k = coefficients.size(); k-- > 1;) {
    value = value * row + static_cast<double>(k) * coefficients[k];
  }
  return value;
}

std::optional<RowPolynomial> FitRowPolynomial(std::span<const double> rows,
                                              std::span<const double> cols,
                                              std::span<const double> weights, int degree) {
  Require(degree >= 0 && rows.size() == cols.size() && rows.size() == weights.size(),
          "FitRowPolynomial: rows, cols and weights must have one size, degree >= 0");
  const int n = static_cast<int>(rows.size());
  const int unknowns = degree + 1;
  double scale = 1.0;
  std::vector<double> distinct;
  distinct.reserve(rows.size());
  for (int i = 0; i < n; ++i) {
    if (!std::isfinite(rows[i]) || !std::isfinite(cols[i]) || !(weights[i] >= 0.0)) {
      return std::nullopt;
    }
    if (weights[i] > 0.0) distinct.push_back(rows[i]);
    scale = std::max(scale, std::abs(rows[i]));
  }
  // (the rows of RowMeans come in order: then no sort is needed)
  if (!std::is_sorted(distinct.begin(), distinct.end()))
    std::sort(distinct.begin(), distinct.end());
  if (std::unique(distinct.begin(), distinct.end()) - distinct.begin() < unknowns) {
    return std::nullopt;
  }
  Eigen::MatrixXd A(n, unknowns);
  Eigen::VectorXd b(n);
  for (int i = 0; i < n; ++i) {
    const double w = std::sqrt(weights[i]);
    const double t = rows[i] / scale;
    double power = 1.0;
    for (int k = 0; k < unknowns; ++k, power *= t) A(i, k) = w * power;
    b(i) = w * cols[i];
  }
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(A);
  if (qr.rank() < unknowns) return std::nullopt;
  const Eigen::VectorXd c = qr.solve(b);
  RowPolynomial poly;
  poly.coefficients.reserve(static_cast<std::size_t>(unknowns));
  double power = 1.0;
  for (int k = 0; k < unknowns; ++k, power *= scale) poly.coefficients.push_back(c(k) / power);
  if (!std::all_of(poly.coefficients.begin(), poly.coefficients.end(),
                   [](double v) { return std::isfinite(v); })) {
    return std::nullopt;
  }
  return poly;
}

Eigen::Vector2d LaneCentreShift(const RowPolynomial& line, double row, LaneLine which,
                                double shift_px) {
  const double slope = line.Slope(row);
  const double sign = which == LaneLine::kYellow ? -1.0 : 1.0;
  const Eigen::Vector2d normal = Eigen::Vector2d(slope, -1.0) / std::sqrt(1.0 + slope * slope);
  return sign * shift_px * normal;
}

Eigen::Vector2d ShiftTowardsLaneCentre(const RowPolynomial& line, double row, LaneLine which,
                                       double shift_px) {
  return Eigen::Vector2d(row, line(row)) + LaneCentreShift(line, row, which, shift_px);
}

std::optional<RowPolynomial> FitTrajectory(const LaneDetectionParams& params,
                                           std::span<const Eigen::Vector2d> shifted_row_col) {
  std::vector<double> rows, cols, weights;
  const std::size_t n = shifted_row_col.size() + params.anchor_rows_px.size();
  rows.reserve(n);
  cols.reserve(n);
  weights.reserve(n);
  for (const Eigen::Vector2d& p : shifted_row_col) {
    rows.push_back(p.x());
    cols.push_back(p.y());
    weights.push_back(1.0);
  }
  // Each anchor repeated anchor_repeats times weighs exactly like one point of that weight.
  for (double row : params.anchor_rows_px) {
    rows.push_back(row);
    cols.push_back(params.anchor_col_px);
    weights.push_back(params.anchor_repeats);
  }
  return FitRowPolynomial(rows, cols, weights, 3);
}

std::optional<Eigen::Vector2d> FloorPointFromPixel(const LaneCameraCalibration& camera, double u,
                                                   double v) {
  const auto& K = camera.K;
  const double yd = (v - K[5]) / K[4];
  const Eigen::Vector2d target((u - K[2] - K[1] * yd) / K[0], yd);
  const std::optional<Eigen::Vector2d> undistorted = world::Undistort(camera.D, target);
  // The radial model must still grow with the radius there, or it no longer describes the lens.
  if (!undistorted || !world::RadialGrowsAt(camera.D, undistorted->squaredNorm())) {
    return std::nullopt;
  }
  const Eigen::Vector2d& x = *undistorted;

  const Eigen::Vector3d direction =
      camera.X_base_camera.linear() * Eigen::Vector3d(x.x(), x.y(), 1);
  const Eigen::Vector3d origin = camera.X_base_camera.translation();
  if (!(direction.z() < 0.0)) return std::nullopt;
  const double t = -origin.z() / direction.z();
  return Eigen::Vector2d(origin.x() + t * direction.x(), origin.y() + t * direction.y());
}

namespace detail {

std::array<std::uint8_t, 3> BgrToHsv8(std::uint8_t b, std::uint8_t g, std::uint8_t r) {
  const int v = std::max({b, g, r});
  const int diff = v - std::min({b, g, r});
  const int sdiv = v == 0 ? 0 : static_cast<int>(std::lrint((255 << kHsvShift) / (1.0 * v)));
  const int hdiv = diff == 0 ? 0 : static_cast<int>(std::lrint((180 << kHsvShift) / (6.0 * diff)));
  const int s = (diff * sdiv + (1 << (kHsvShift - 1))) >> kHsvShift;
  int h = v == r ? g - b : v == g ? b - r + 2 * diff : r - g + 4 * diff;
  h = (h * hdiv + (1 << (kHsvShift - 1))) >> kHsvShift;
  if (h < 0) h += 180;
  return {static_cast<std::uint8_t>(h), static_cast<std::uint8_t>(s), static_cast<std::uint8_t>(v)};
}

}  // namespace detail

namespace {

// OpenCV's bilinear weights, as its own remap (which warpPerspective calls) applies them: for each
// of the 1024 fractional positions a and each of the 16 ways k the 2×2 neighbours can be 0 or 255,
// the 8-bit result of its fixed-point sum, at [a · 16 + k]. Pattern k sits at columns 3k, 3k + 1
// of a 2-row probe image.
std::vector<std::uint8_t> OpenCvBilinearTable() {
  cv::Mat probe(2, 3 * 16, CV_8UC1, cv::Scalar(0));
  cv::Mat map_xy(16, kAlphaCount, CV_16SC2);
  cv::Mat map_alpha(16, kAlphaCount, CV_16UC1);
  for (int k = 0; k < 16; ++k) {
    for (int bit = 0; bit < 4; ++bit) {
      if ((k >> bit) & 1) probe.at<std::uint8_t>(bit >> 1, 3 * k + (bit & 1)) = 255;
    }
    for (int a = 0; a < kAlphaCount; ++a) {
      map_xy.at<cv::Vec2s>(k, a) = cv::Vec2s(static_cast<short>(3 * k), 0);
      map_alpha.at<std::uint16_t>(k, a) = static_cast<std::uint16_t>(a);
    }
  }
  cv::Mat out;
  cv::remap(probe, out, map_xy, map_alpha, cv::INTER_LINEAR, cv::BORDER_CONSTANT, 0);
  std::vector<std::uint8_t> table(kAlphaCount * 16);
  for (int k = 0; k < 16; ++k) {
    for (int a = 0; a < kAlphaCount; ++a) table[a * 16 + k] = out.at<std::uint8_t>(k, a);
  }
  return table;
}

// The bilinear warp of rt_laneplanner's combined image, by the same probe: neighbour k of pattern
// p has class (bit k of p: yellow) | (bit 4 + k of p: white) << 1 and the combined value of that
// class (white 255 + yellow 127 in 8 bits). [a · 256 + p]: 1 if the output is exactly 127, 2 if
// exactly 255 (rt_polyfit.cpp:53, 64), else 0.
std::vector<std::uint8_t> ExactValueTable() {
  constexpr int kPatterns = 256;
  constexpr std::array<std::uint8_t, 4> kCombined{0, 127, 255, 126};
  cv::Mat probe(2, 3 * kPatterns, CV_8UC1, cv::Scalar(0));
  cv::Mat map_xy(kPatterns, kAlphaCount, CV_16SC2);
  cv::Mat map_alpha(kPatterns, kAlphaCount, CV_16UC1);
  for (int p = 0; p < kPatterns; ++p) {
    for (int k = 0; k < 4; ++k) {
      const int cls = ((p >> k) & 1) | (((p >> (4 + k)) & 1) << 1);
      probe.at<std::uint8_t>(k >> 1, 3 * p + (k & 1)) = kCombined[static_cast<std::size_t>(cls)];
    }
    for (int a = 0; a < kAlphaCount; ++a) {
      map_xy.at<cv::Vec2s>(p, a) = cv::Vec2s(static_cast<short>(3 * p), 0);
      map_alpha.at<std::uint16_t>(p, a) = static_cast<std::uint16_t>(a);
    }
  }
  cv::Mat out;
  cv::remap(probe, out, map_xy, map_alpha, cv::INTER_LINEAR, cv::BORDER_CONSTANT, 0);
  std::vector<std::uint8_t> table(static_cast<std::size_t>(kAlphaCount) * kPatterns);
  for (int p = 0; p < kPatterns; ++p) {
    for (int a = 0; a < kAlphaCount; ++a) {
      const std::uint8_t v = out.at<std::uint8_t>(p, a);
      table[static_cast<std::size_t>(a * kPatterns + p)] = v == 127 ? 1 : v == 255 ? 2 : 0;
    }
  }
  return table;
}

}  // namespace

// Per output pixel, warpPerspective's source coordinates: the inverse homography (it inverts the
// matrix with cv::invert, LU) evaluated in doubles in its block order, scaled to 1/32 px and
// rounded to nearest even (saturate_cast<int>), then split into the integer pixel (saturated to
// short) and the 5+5 fractional bits.
struct LaneDetectorTables::WarpSource {
  explicit WarpSource(const cv::Mat& image_to_birds_eye) {
    constexpr int W = kLaneImageWidth;
    constexpr int H = kLaneImageHeight;
    cv::Mat inverse;
    cv::invert(image_to_birds_eye, inverse);
    const double* m = inverse.ptr<double>();
    int block_h = std::min(kWarpBlockSize / 2, H);
    const int block_w = std::min(kWarpBlockSize * kWarpBlockSize / block_h, W);
    block_h = std::min(kWarpBlockSize * kWarpBlockSize / block_w, H);
    for (int y = 0; y < H; y += block_h) {
      for (int x = 0; x < W; x += block_w) {
        for (int y1 = 0; y1 < std::min(block_h, H - y); ++y1) {
          const double X0 = m[0] * x + m[1] * (y + y1) + m[2];
          const double Y0 = m[3] * x + m[4] * (y + y1) + m[5];
          const double W0 = m[6] * x + m[7] * (y + y1) + m[8];
          for (int x1 = 0; x1 < std::min(block_w, W - x); ++x1) {
            Set((y + y1) * W + x + x1, X0 + m[0] * x1, Y0 + m[3] * x1, W0 + m[6] * x1);
          }
        }
      }
    }
  }

  // Output pixel i from the homogeneous source point (X, Y, w).
  void Set(int i, double X, double Y, double w) {
    const auto saturate_short = [](int v) { return std::clamp(v, SHRT_MIN, SHRT_MAX); };
    w = w != 0.0 ? kInterTabSize / w : 0.0;
    const double fx = std::max(double{INT_MIN}, std::min(double{INT_MAX}, X * w));
    const double fy = std::max(double{INT_MIN}, std::min(double{INT_MAX}, Y * w));
    const int sx_fixed = static_cast<int>(std::lrint(fx));
    const int sy_fixed = static_cast<int>(std::lrint(fy));
    sx[i] = saturate_short(sx_fixed >> kInterBits);
    sy[i] = saturate_short(sy_fixed >> kInterBits);
    alpha[i] = (sy_fixed & (kInterTabSize - 1)) * kInterTabSize + (sx_fixed & (kInterTabSize - 1));
  }

  std::vector<int> sx = std::vector<int>(kLaneImageWidth * kLaneImageHeight);
  std::vector<int> sy = std::vector<int>(kLaneImageWidth * kLaneImageHeight);
  std::vector<int> alpha = std::vector<int>(kLaneImageWidth * kLaneImageHeight);
};

// LaneDetectorTables::square_outputs_ from the two tables: per neighbour pattern, whether each
// mask's output is set for no alpha, for every alpha, or depends on it.
LaneDetectorTables::SquareOutputTable LaneDetectorTables::SquareOutputs(
    const std::vector<std::uint8_t>& warp, const std::vector<std::uint8_t>& exact) {
  const auto state = [](int set_count) {
    return set_count == 0 ? kNever : set_count == kAlphaCount ? kAlways : kDepends;
  };
  SquareOutputTable outputs{};
  for (int p = 0; p < 256; ++p) {
    int nonzero[2] = {0, 0}, exactly[2] = {0, 0};
    for (int a = 0; a < kAlphaCount; ++a) {
      nonzero[0] += warp[static_cast<std::size_t>(a * 16 + (p & 15))] != 0;
      nonzero[1] += warp[static_cast<std::size_t>(a * 16 + (p >> 4))] != 0;
      const std::uint8_t cls = exact[static_cast<std::size_t>(a * 256 + p)];
      exactly[0] += cls == 1;
      exactly[1] += cls == 2;
    }
    outputs[static_cast<std::size_t>(BirdsEyeClasses::kNonZero)][p] =
        static_cast<std::uint8_t>(state(nonzero[0]) | (state(nonzero[1]) << 2));
    outputs[static_cast<std::size_t>(BirdsEyeClasses::kExact)][p] =
        static_cast<std::uint8_t>(state(exactly[0]) | (state(exactly[1]) << 2));
  }
  return outputs;
}

LaneDetectorTables::LaneDetectorTables(const LaneDetectionParams& params,
                                       const LaneCameraCalibration& camera)
    : params_(params), camera_(camera) {
  params_.Validate();
  camera_.Validate();
  thresholds_ = LaneThresholdsOf(params_.thresholds);
  // As the real node: cv::getPerspectiveTransform on float points, both ways.
  const auto src = ToCv(params_.warp_source_px);
  const auto dst = ToCv(params_.warp_destination_px);
  image_to_birds_eye_ = cv::getPerspectiveTransform(src, dst);
  birds_eye_to_image_ = cv::getPerspectiveTransform(dst, src);

  v_min_ = std::min(thresholds_.yellow.lower_hsv[2], thresholds_.white.lower_hsv[2]);
  for (int i = 1; i < 256; ++i) {
    sdiv_[i] = static_cast<int>(std::lrint((255 << kHsvShift) / (1.0 * i)));
    hdiv_[i] = static_cast<int>(std::lrint((180 << kHsvShift) / (6.0 * i)));
  }
  warp_lut_ = OpenCvBilinearTable();
  exact_lut_ = ExactValueTable();
  exact_single_lut_.resize(static_cast<std::size_t>(kAlphaCount) * 16);
  for (std::size_t a = 0; a < static_cast<std::size_t>(kAlphaCount); ++a) {
    for (std::size_t bits = 0; bits < 16; ++bits) {
      exact_single_lut_[a * 16 + bits] = static_cast<std::uint8_t>(
          exact_lut_[a * 256 + bits] | (exact_lut_[a * 256 + (bits << 4)] << 2));
    }
  }
  square_outputs_ = SquareOutputs(warp_lut_, exact_lut_);
  IndexActivePixels(WarpSource(image_to_birds_eye_));
  if (params_.projection == LaneProjection::kPnpSwapped) {
    pnp_pose_ = LabPnpPose(camera_, params_.pnp_floor_points_m);
  }
}

void LaneDetectorTables::IndexActivePixels(const WarpSource& source) {
  constexpr int W = kLaneImageWidth;
  constexpr int H = kLaneImageHeight;
  constexpr int padded_w = kClassStride;
  const std::vector<int>& sx = source.sx;
  const std::vector<int>& sy = source.sy;
  // Active pixels (some of the 2×2 source square inside the image; the rest stay 0, the border
  // value), counted per square's top left (padded), then placed in that order, and the source
  // pixels each row needs.
  const auto active = [&](int i) {
    return sx[i] < W && sx[i] + 1 >= 0 && sy[i] < H && sy[i] + 1 >= 0;
  };
  const auto square = [&](int i) { return (sy[i] + 1) * padded_w + sx[i] + 1; };
  square_start_.assign(static_cast<std::size_t>(H + 1) * padded_w + 1, 0);
  std::vector<int> need_begin(H, W), need_end(H, 0);
  for (int i = 0; i < W * H; ++i) {
    if (!active(i)) continue;
    ++square_start_[static_cast<std::size_t>(square(i)) + 1];
    const int c0 = std::max(sx[i], 0), c1 = std::min(sx[i] + 1, W - 1);
    for (int r = std::max(sy[i], 0); r <= std::min(sy[i] + 1, H - 1); ++r) {
      need_begin[r] = std::min(need_begin[r], c0);
      need_end[r] = std::max(need_end[r], c1 + 1);
    }
  }
  std::partial_sum(square_start_.begin(), square_start_.end(), square_start_.begin());
  const std::size_t n = square_start_.back();
  pixels_.resize(n);
  static_assert(kLaneImageHeight <= (1 << WarpPixel::kRowBits) &&
                kLaneImageWidth <= (1 << WarpPixel::kColBits) &&
                kAlphaCount <= (1 << WarpPixel::kAlphaBits) &&
                WarpPixel::kAlphaShift + WarpPixel::kAlphaBits <= 32);
  std::vector<std::uint32_t> next(square_start_.begin(), square_start_.end() - 1);
  for (int i = 0; i < W * H; ++i) {
    if (!active(i)) continue;
    const std::uint32_t k = next[static_cast<std::size_t>(square(i))]++;
    pixels_[k] = WarpPixel::Pack(i / W, i % W, source.alpha[i]);
  }
  for (int r = 0; r < H; ++r) {
    if (need_begin[r] < need_end[r]) spans_.push_back({r, need_begin[r], need_end[r]});
  }
}

std::uint8_t LaneDetectorTables::ClassOf(std::uint8_t blue, std::uint8_t green,
                                         std::uint8_t red) const {
  const int b = blue, g = green, r = red;
  const int v = std::max({b, g, r});
  if (v < v_min_) return 0;
  // OpenCV's 8-bit BGR2HSV (see detail::BgrToHsv8), with the tables precomputed.
  const int diff = v - std::min({b, g, r});
  const int s = (diff * sdiv_[v] + (1 << (kHsvShift - 1))) >> kHsvShift;
  int h = v == r ? g - b : v == g ? b - r + 2 * diff : r - g + 4 * diff;
  h = (h * hdiv_[diff] + (1 << (kHsvShift - 1))) >> kHsvShift;
  if (h < 0) h += 180;
  const std::array<std::uint8_t, 3> hsv{static_cast<std::uint8_t>(h), static_cast<std::uint8_t>(s),
                                        static_cast<std::uint8_t>(v)};
  return static_cast<std::uint8_t>(InRange(thresholds_.yellow, hsv) |
                                   (InRange(thresholds_.white, hsv) << 1));
}

LaneDetector::LaneDetector(const LaneDetectionParams& params, const LaneCameraCalibration& camera)
    : LaneDetector(std::make_shared<const LaneDetectorTables>(params, camera)) {}

LaneDetector::LaneDetector(std::shared_ptr<const LaneDetectorTables> tables)
    : tables_(std::move(tables)) {
  Require(tables_ != nullptr, "LaneDetector needs its tables");
  classes_.assign(static_cast<std::size_t>(kClassStride) * (kLaneImageHeight + 2), 0);
  const std::size_t words =
      static_cast<std::size_t>(LaneDetectorTables::kLineWords) * (kLaneImageHeight + 2);
  line_bits_.assign(words, 0);
  yellow_bits_.assign(words, 0);
  white_bits_.assign(words, 0);
  line_words_.assign(kLaneImageHeight + 2, 0);
}

ClassImageRegion LaneDetector::MutableClassRegion() {
  // from pixel (0, 0) inside the border to the last image pixel
  constexpr std::size_t kSize = static_cast<std::size_t>(kLaneImageHeight - 1) * kClassStride +
                                static_cast<std::size_t>(kLaneImageWidth);
  return ClassImageRegion{.pixels = std::span(classes_.data() + kClassStride + 1, kSize),
                          .stride = kClassStride,
                          .spans = tables_->source_spans()};
}

void LaneDetector::Classify(const cv::Mat& bgr) {
  const LaneDetectorTables& tables = *tables_;
  const int v_min = tables.v_min_;
  constexpr int padded_w = kClassStride;
  // No pixel darker than both ranges' V bounds is a line pixel: most of the floor is black.
  // Eight pixels (24 bytes) at a time, the dark ones are told apart with word arithmetic: a byte
  // above n shows in the high bit of (byte + 127 - n) | byte (for n <= 127; a carry out of a byte
  // of 128 or more only ever follows a byte that already shows). No byte >= v_min: all 8 dark.
  constexpr std::uint64_t kOnes = 0x0101010101010101ull;
  constexpr std::uint64_t kHighBits = 0x8080808080808080ull;
  const bool word_test = v_min >= 1 && v_min <= 128;
  const std::uint64_t add = kOnes * static_cast<std::uint64_t>(127 - (v_min - 1));
  const auto all_dark = [&](const std::uint8_t* eight) {
    std::uint64_t w[3];
    std::memcpy(w, eight, sizeof w);
    return ((((w[0] + add) | w[0]) | ((w[1] + add) | w[1]) | ((w[2] + add) | w[2])) & kHighBits) ==
           0;
  };
  for (const SourceSpan& span : tables.spans_) {
    const std::uint8_t* p = bgr.ptr<std::uint8_t>(span.row);
    std::uint8_t* out = classes_.data() + (span.row + 1) * padded_w + 1;
    for (int c = span.col_begin; c < span.col_end;) {
      if (word_test && c + 8 <= span.col_end && all_dark(p + 3 * c)) {
        std::memset(out + c, 0, 8);
        c += 8;
        continue;
      }
      for (const int block_end = std::min(c + 8, span.col_end); c < block_end; ++c) {
        out[c] = tables.ClassOf(p[3 * c], p[3 * c + 1], p[3 * c + 2]);
      }
    }
  }
  FindLinePixels();
}

namespace {

// The mask of the bytes of in[0, 64) that are not 0 (bit k: byte k); and, if any is, those that
// are 1 (yellow alone) and 2 (white alone).
struct ClassBits {
  std::uint64_t any{0}, yellow{0}, white{0};
};
ClassBits ClassBits64(const std::uint8_t* in) {
#if defined(__SSE2__)
  const __m128i zero = _mm_setzero_si128();
  __m128i v[4];
  for (int k = 0; k < 4; ++k) v[k] = _mm_loadu_si128(reinterpret_cast<const __m128i*>(in + 16 * k));
  // most of the 64 bytes are 0 most of the time: one test for them all first
  const __m128i any = _mm_or_si128(_mm_or_si128(v[0], v[1]), _mm_or_si128(v[2], v[3]));
  if (_mm_movemask_epi8(_mm_cmpeq_epi8(any, zero)) == 0xFFFF) return {};
  const __m128i one = _mm_set1_epi8(1), two = _mm_set1_epi8(2);
  ClassBits bits;
  for (int k = 0; k < 4; ++k) {
    const auto mask = [&](__m128i equal) {
      return static_cast<std::uint64_t>(static_cast<std::uint32_t>(_mm_movemask_epi8(equal)))
             << (16 * k);
    };
    bits.any |= mask(_mm_cmpeq_epi8(v[k], zero)) ^ (0xFFFFull << (16 * k));
    bits.yellow |= mask(_mm_cmpeq_epi8(v[k], one));
    bits.white |= mask(_mm_cmpeq_epi8(v[k], two));
  }
  return bits;
#else
  ClassBits bits;
  for (int k = 0; k < 64; ++k) {
    bits.any |= static_cast<std::uint64_t>(in[k] != 0) << k;
    bits.yellow |= static_cast<std::uint64_t>(in[k] == 1) << k;
    bits.white |= static_cast<std::uint64_t>(in[k] == 2) << k;
  }
  return bits;
#endif
}

}  // namespace

void LaneDetector::FindLinePixels(std::span<const std::pair<int, int>> nonzero_columns) {
  constexpr int kWords = LaneDetectorTables::kLineWords;
  for (const SourceSpan& span : tables_->spans_) {
    const int padded_row = span.row + 1;
    const std::uint8_t* in = classes_.data() + padded_row * kClassStride;
    const std::size_t row_word = static_cast<std::size_t>(padded_row) * kWords;
    // the padded columns to search: the span's, or the part of it that may hold a line pixel
    int begin = span.col_begin + 1, end = span.col_end + 1;
    if (!nonzero_columns.empty()) {
      const auto [first, last] = nonzero_columns[static_cast<std::size_t>(span.row)];
      begin = std::max(begin, first + 1);
      end = std::min(end, last + 1);
    }
    // the words the last frame left with a line pixel and this one does not search: cleared
    std::uint16_t stale = line_words_[static_cast<std::size_t>(padded_row)];
    std::uint16_t words = 0;
    for (int w = begin / 64; begin < end && w <= (end - 1) / 64; ++w) {
      stale &= static_cast<std::uint16_t>(~(1u << w));
      // 64 bytes from the word's first column: the row's, and beyond its end the next row's (the
      // padded image has a row below the last span's, and 64 · kLineWords <= kClassStride + 63),
      // masked off
      const int lo = std::max(begin - 64 * w, 0), hi = std::min(end - 64 * w, 64);
      const std::uint64_t keep = world::BitRange(lo, hi);
      const ClassBits bits = ClassBits64(in + 64 * w);
      const std::size_t i = row_word + static_cast<std::size_t>(w);
      line_bits_[i] = bits.any & keep;
      if (line_bits_[i] == 0) continue;
      yellow_bits_[i] = bits.yellow & keep;
      white_bits_[i] = bits.white & keep;
      words |= static_cast<std::uint16_t>(1u << w);
    }
    for (; stale != 0; stale &= stale - 1) line_bits_[row_word + std::countr_zero(stale)] = 0;
    line_words_[static_cast<std::size_t>(padded_row)] = words;
  }
}

void LaneDetector::ComputeMasks(const cv::Mat& bgr, BirdsEyeMasks* masks) {
  RequireImage(bgr);
  Classify(bgr);
  masks->yellow.create(kLaneImageHeight, kLaneImageWidth, CV_8UC1);
  masks->white.create(kLaneImageHeight, kLaneImageWidth, CV_8UC1);
  masks->yellow.setTo(0);
  masks->white.setTo(0);
  std::uint8_t* yellow = masks->yellow.ptr<std::uint8_t>();
  std::uint8_t* white = masks->white.ptr<std::uint8_t>();
  const std::uint8_t* lut = tables_->warp_lut_.data();
  using WarpPixel = LaneDetectorTables::WarpPixel;
  ForEachLineSquare(
      [&](const std::uint32_t* first, const std::uint32_t* last, int yellow_bits, int white_bits) {
        for (const std::uint32_t* w = first; w != last; ++w) {
          const int i = WarpPixel::Row(*w) * kLaneImageWidth + WarpPixel::Col(*w);
          yellow[i] = lut[WarpPixel::Alpha16(*w) + yellow_bits];
          white[i] = lut[WarpPixel::Alpha16(*w) + white_bits];
        }
      });
}

void LaneDetector::FindLineSquares() {
  const LaneDetectorTables& tables = *tables_;
  constexpr int kWords = LaneDetectorTables::kLineWords;
  uniform_runs_.clear();
  mixed_squares_.clear();
  // Per top row t of the squares: a square whose left column is c holds a line pixel if column c
  // or c + 1 of row t or t + 1 does, so the left columns to visit are the bits of
  // s = x | x >> 1 (x: the two rows' bits), and each run of them is a range of squares; those
  // whose four pixels are all of one colour alone, u & u >> 1 (u: both rows' bits of that
  // colour), are taken out as runs of their own. Only the words of x that hold a bit, and those
  // before them (the bit that s carries over), are scanned (each with the word after it, for
  // that bit).
  for (std::uint32_t t = 0; t <= static_cast<std::uint32_t>(kLaneImageHeight); ++t) {
    const unsigned x_words = line_words_[t] | line_words_[t + 1];
    if (x_words == 0) continue;
    const std::size_t row_word = static_cast<std::size_t>(t) * kWords;
    const std::uint32_t row_start = t * kClassStride;
    const std::uint32_t* starts = tables.square_start_.data() + row_start;
    // bits of rows t and t + 1 in word w: the line pixels; those of one colour alone (a word
    // without line pixels holds none, whatever its colour words say)
    const auto line = [&](int w) {
      return line_bits_[row_word + w] | line_bits_[row_word + kWords + w];
    };
    const auto both_rows = [&](const std::vector<std::uint64_t>& colour, int w) -> std::uint64_t {
      if (line_bits_[row_word + w] == 0 || line_bits_[row_word + kWords + w] == 0) return 0;
      return colour[row_word + w] & colour[row_word + kWords + w];
    };
    for (unsigned words = x_words | (x_words >> 1); words != 0; words &= words - 1) {
      const int w = std::countr_zero(words);
      const bool last = w + 1 == kWords;
      // the squares with a line pixel, and those all of one colour (the word after w for
      // bit 63's square)
      const std::uint64_t x = line(w);
      const std::uint64_t any = x | (x >> 1) | (last ? 0 : line(w + 1) << 63);
      const auto all = [&](const std::vector<std::uint64_t>& colour) {
        const std::uint64_t u = both_rows(colour, w);
        if (u == 0) return u;
        return u & ((u >> 1) | (last ? 0 : both_rows(colour, w + 1) << 63));
      };
      const std::uint64_t yellow = all(yellow_bits_);
      const std::uint64_t white = all(white_bits_);
      const std::uint64_t mixed = any & ~(yellow | white);
      const auto for_each_run = [&](std::uint64_t s, auto take) {
        while (s != 0) {
          const int lo = std::countr_zero(s);
          const int hi = lo + std::countr_one(s >> lo);
          // (squares no output pixel reads are left out)
          if (starts[64 * w + lo] != starts[64 * w + hi]) take(64 * w + lo, 64 * w + hi);
          s = hi == 64 ? 0 : s & (~0ull << hi);
        }
      };
      for_each_run(mixed, [&](int lo, int hi) {
        mixed_squares_.push_back({row_start + static_cast<std::uint32_t>(lo),
                                  row_start + static_cast<std::uint32_t>(hi)});
      });
      for_each_run(yellow, [&](int lo, int hi) {
        uniform_runs_.push_back({starts[lo], starts[hi], kAllYellow});
      });
      for_each_run(white, [&](int lo, int hi) {
        uniform_runs_.push_back({starts[lo], starts[hi], kAllWhite});
      });
    }
  }
}

template <class Visit>
void LaneDetector::ForEachLineSquare(Visit visit) {
  FindLineSquares();
  const std::uint32_t* pixels = tables_->pixels_.data();
  for (const UniformRun& run : uniform_runs_) {
    visit(pixels + run.begin, pixels + run.end, run.pattern & 15, run.pattern >> 4);
  }
  const std::uint8_t* classes = classes_.data();
  const std::uint32_t* starts = tables_->square_start_.data();
  constexpr int stride = kClassStride;
  for (const auto& [first, last] : mixed_squares_) {
    for (std::uint32_t square = first; square < last; ++square) {
      const std::uint32_t begin = starts[square], end = starts[square + 1];
      if (begin == end) continue;
      // the 2×2 source classes c0 c1 / c2 c3 (each 0..3: yellow bit 0, white bit 1) as the bytes
      // of one word; a class bit of each byte gathered into 4 bits by one multiply (the partial
      // products land on distinct bits, so nothing carries into bits 24-27)
      const std::uint8_t* p = classes + square;
      std::uint16_t top, bottom;
      std::memcpy(&top, p, sizeof top);
      std::memcpy(&bottom, p + stride, sizeof bottom);
      const std::uint32_t quad = LittleEndianPair(top) | (LittleEndianPair(bottom) << 16);
      constexpr std::uint32_t kLowBits = 0x01010101u, kGather = 0x01020408u;
      const int yellow_bits = static_cast<int>(((quad & kLowBits) * kGather) >> 24);
      const int white_bits = static_cast<int>((((quad >> 1) & kLowBits) * kGather) >> 24);
      visit(pixels + begin, pixels + end, yellow_bits, white_bits);
    }
  }
}

void LaneDetector::ComputeRowSums(const cv::Mat& bgr, BirdsEyeRowSums* sums,
                                  BirdsEyeClasses classes) {
  RequireImage(bgr);
  Classify(bgr);
  SumWarpedClasses(sums, classes);
}

void LaneDetector::ComputeRowSumsFromClasses(BirdsEyeRowSums* sums, BirdsEyeClasses classes,
                                             std::span<const std::pair<int, int>> nonzero_columns) {
  Require(nonzero_columns.empty() || nonzero_columns.size() == kLaneImageHeight, [&] {
    return "ComputeRowSumsFromClasses: " + std::to_string(nonzero_columns.size()) +
           " rows of nonzero columns for an image of " + std::to_string(kLaneImageHeight);
  });
  FindLinePixels(nonzero_columns);
  SumWarpedClasses(sums, classes);
}

void LaneDetector::SumWarpedClasses(BirdsEyeRowSums* sums, BirdsEyeClasses classes) {
  using Tables = LaneDetectorTables;
  using WarpPixel = Tables::WarpPixel;
  // Per row a pixel's column plus 1 << kCountShift, summed in one word (one store per pixel, not
  // two): a row's column sum stays below 640 · 640 < 2^kCountShift.
  constexpr int kCountShift = 40;
  static_assert(std::uint64_t{kLaneImageWidth} * kLaneImageWidth <
                (std::uint64_t{1} << kCountShift));
  std::array<std::uint64_t, kLaneImageHeight> packed_yellow{}, packed_white{};
  const auto add = [](std::array<std::uint64_t, kLaneImageHeight>& rows, std::uint32_t w) {
    rows[static_cast<std::size_t>(WarpPixel::Row(w))] +=
        static_cast<std::uint64_t>(WarpPixel::Col(w)) + (std::uint64_t{1} << kCountShift);
  };
  const std::uint8_t* outputs = tables_->square_outputs_[static_cast<std::size_t>(classes)].data();
  // the nonzero masks: each its own 0/255 image's warp. The exact classes: the combined image's
  // warp, counted where exactly 127 (yellow) or 255 (white); where the four neighbours hold one
  // colour (or none) the 16 KB single-colour table answers, and only a pixel beside both colours
  // looks up the 256 KB one.
  const std::uint8_t* warp = tables_->warp_lut_.data();
  const std::uint8_t* exact = tables_->exact_lut_.data();
  const std::uint8_t* single = tables_->exact_single_lut_.data();
  const bool nonzero = classes == BirdsEyeClasses::kNonZero;
  ForEachLineSquare(
      [&](const std::uint32_t* first, const std::uint32_t* last, int yellow_bits, int white_bits) {
        const int pattern = yellow_bits | (white_bits << 4);
        const int yellow = outputs[pattern] & 3, white = outputs[pattern] >> 2;
        if (yellow != Tables::kDepends && white != Tables::kDepends) {
          // the same for each of the square's outputs (the squares inside a line: 77 % of the
          // outputs visited in the default scenario)
          const auto add_all = [&](std::array<std::uint64_t, kLaneImageHeight>& rows) {
            for (const std::uint32_t* w = first; w != last; ++w) add(rows, *w);
          };
          if (yellow == Tables::kAlways) add_all(packed_yellow);
          if (white == Tables::kAlways) add_all(packed_white);
          return;
        }
        for (const std::uint32_t* w = first; w != last; ++w) {
          const int alpha16 = WarpPixel::Alpha16(*w);
          if (nonzero) {
            if (warp[alpha16 + yellow_bits] != 0) add(packed_yellow, *w);
            if (warp[alpha16 + white_bits] != 0) add(packed_white, *w);
            continue;
          }
          const std::uint8_t cls = white_bits == 0    ? single[alpha16 + yellow_bits] & 3
                                   : yellow_bits == 0 ? single[alpha16 + white_bits] >> 2
                                                      : exact[(alpha16 << 4) + pattern];
          if (cls == 1) add(packed_yellow, *w);
          if (cls == 2) add(packed_white, *w);
        }
      });
  const auto unpack = [](const std::array<std::uint64_t, kLaneImageHeight>& packed,
                         std::array<BirdsEyeRowSums::Row, kLaneImageHeight>& rows) {
    for (std::size_t r = 0; r < rows.size(); ++r) {
      rows[r].count = static_cast<std::int32_t>(packed[r] >> kCountShift);
      rows[r].col_sum =
          static_cast<std::int64_t>(packed[r] & ((std::uint64_t{1} << kCountShift) - 1));
    }
  };
  unpack(packed_yellow, sums->yellow);
  unpack(packed_white, sums->white);
}

LanePoints LaneDetector::Step(const cv::Mat& bgr, LaneDetectionTrace* trace) {
  ComputeRowSums(bgr, &sums_);
  return Fit(sums_, trace);
}

LanePoints LaneDetector::Fit(const BirdsEyeMasks& masks, LaneDetectionTrace* trace) {
  return Fit(RowSumsOfMasks(masks), trace);
}

LanePoints LaneDetector::Fit(const BirdsEyeRowSums& sums, LaneDetectionTrace* trace) {
  return FitLanePoints(*tables_, sums, trace);
}

namespace detail {

int PixelCount(const std::array<BirdsEyeRowSums::Row, kLaneImageHeight>& sums) {
  int total = 0;
  for (const BirdsEyeRowSums::Row& row : sums) total += row.count;
  return total;
}

std::optional<std::array<LanePoint, LanePoints::kCount>> LanePointsOfLine(
    const LaneDetectorTables& tables,
    const std::array<BirdsEyeRowSums::Row, kLaneImageHeight>& sums, LaneLine line,
    const LaneFitRules& rules, LaneDetectionTrace* trace) {
  const LaneDetectionParams& params = tables.params();
  const auto cut = [&](double v) { return rules.truncate ? std::trunc(v) : v; };
  // col = f(row) over the line's pixels: per row, its pixels' mean column weighted by their count
  // (the same least-squares problem as one equation per pixel)
  std::vector<double> rows, cols, weights;
  int total = 0;
  RowMeans(sums, &rows, &cols, &weights, &total);
  trace->line_fit = FitRowPolynomial(rows, cols, weights, 2);
  if (!trace->line_fit) return std::nullopt;

  // samples moved to the lane centre, and the trajectory through them and the anchors
  std::array<Eigen::Vector2d, LanePoints::kCount> shifted;
  for (int i = 0; i < LanePoints::kCount; ++i) {
    const double row = i * params.sample_row_step_px;
    if (!rules.truncate) {
      shifted[i] = ShiftTowardsLaneCentre(*trace->line_fit, row, line, params.normal_shift_px);
      continue;
    }
    // rt_polyfit.cpp:107-114: the line's column truncated, then each shifted coordinate
    const Eigen::Vector2d shift =
        LaneCentreShift(*trace->line_fit, row, line, params.normal_shift_px);
    shifted[i] = {cut(row + shift.x()), cut(cut((*trace->line_fit)(row)) + shift.y())};
  }
  trace->trajectory = FitTrajectory(params, shifted);
  if (!trace->trajectory) return std::nullopt;

  // back into the raw image, and down onto the floor
  const double* h = tables.birds_eye_to_image().ptr<double>();
  std::array<LanePoint, LanePoints::kCount> points;
  for (int i = 0; i < LanePoints::kCount; ++i) {
    const double row = i * params.sample_row_step_px;
    const double col = cut((*trace->trajectory)(row));
    const double w = h[6] * col + h[7] * row + h[8];
    const double u = cut((h[0] * col + h[1] * row + h[2]) / w);
    const double v = cut((h[3] * col + h[4] * row + h[5]) / w);
    const std::optional<LanePoint> p = FloorPoint(tables, u, v, rules.in_float);
    if (!p) return std::nullopt;
    points[static_cast<std::size_t>(i)] = *p;
  }
  return points;
}

}  // namespace detail

LanePoints FitLanePoints(const LaneDetectorTables& tables, const BirdsEyeRowSums& sums,
                         LaneDetectionTrace* trace) {
  const LaneDetectionParams& params = tables.params();
  LaneDetectionTrace local;
  LaneDetectionTrace& t = trace != nullptr ? *trace : local;
  t = LaneDetectionTrace{};
  t.white_px = -1;
  LanePoints out;

  // choose the line: yellow if it has enough pixels, else white, else nothing
  t.yellow_px = detail::PixelCount(sums.yellow);
  t.line = LaneLine::kYellow;
  if (t.yellow_px < params.yellow_min_px) {
    t.white_px = detail::PixelCount(sums.white);
    t.line = LaneLine::kWhite;
    if (t.white_px < params.line_min_px) {
      t.line = LaneLine::kNone;
      return out;
    }
  }
  const auto points = detail::LanePointsOfLine(
      tables, t.line == LaneLine::kYellow ? sums.yellow : sums.white, t.line, {}, &t);
  if (!points) return out;
  out.points = *points;
  out.valid = 1;
  return out;
}

}  // namespace autonomsim::stack
