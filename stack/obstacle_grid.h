// Obstacle detection (reference §4; paper §IV-C, code/reconros_ws/carcontrol/src/rt_obstacle) and
// its costmap layer (code/ros_ws/src/obstacle_layer).
//
// Grid: every cloud point is moved from the camera's forward/left/up frame to base_link by the
// fixed 3×4 transform, p_base = M · p_cam + t; points inside the obstacle box are counted in an
// 18 × 13 grid of 0.05 m cells on the ground plane, uint8 counters saturating at 255. As in the
// real code, all in float, in its order: (M00·x + M01·y + M02·z) + t0, the box test inclusive on
// every side, then
//   gx = trunc(double(x − x_min) / cell),  gy = trunc(double(y − y_min) / cell)
// (the difference in float, the division in double, as the real `uint8_t gx = x / 0.05`; we get
// the same integers without the division, see detail::CellEdges). So a cell is indexed by its
// lower edge: cell gx holds x ∈ [x_min + gx·cell, x_min + (gx+1)·cell), up to the rounding of
// those two operations. A point on the box's far edge (x = 1.2, gx = 18) is in
// the box but past the last cell and is dropped, as the real code's index check drops it (y cannot
// reach gy = 13 with the default box: 0.325f + 0.325f = 0.65f and 0.65f / 0.05 < 13).
//
// Layer: reference §4 writes each cell at "its centre (gx·0.05 + 0.3, gy·0.05 − 0.325)", but with
// the lower-edge indexing above that point is the cell's lower corner (least x, least y), half a
// cell (0.025 m) behind and to the right of its centre. The real layer marks that corner; so do we
// by default (mark_at_cell_centre = false).
//
// Fused path: the hardware runs point cloud and grid in one slot (reference §4) and never writes
// the cloud. StepDepthToGrid does the same and gives bit for bit the grid of StepPointCloud then
// StepObstacleGrid (it calls the same row kernels); PointCloud640::kModeledBytes still says what an
// unfused mapping moves.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <utility>
#include <vector>

#include "stack/costmap.h"
#include "stack/point_cloud.h"
#include "world/geometry.h"
#include "world/time.h"

namespace autonomsim::stack {

// The fixed-size Iceoryx message: 234 counters and 6 bytes of padding (reference §4: the real
// code's uint8_t grid[13 * 18 + 6], written out as 30 64-bit words).
struct Grid234 {
  static constexpr int kCellsX = 18;  // forward
  static constexpr int kCellsY = 13;  // lateral, from right (y_min) to left
  static constexpr int kCells = kCellsX * kCellsY;
  static constexpr std::size_t kModeledBytes = 240;  // reference §4, §8

  static constexpr int Index(int gx, int gy) { return gx * kCellsY + gy; }  // reference §4
  std::uint8_t count(int gx, int gy) const { return data[Index(gx, gy)]; }

  std::array<std::uint8_t, kModeledBytes> data{};  // [Index(gx, gy)]; bytes 234..239 stay 0

  friend bool operator==(const Grid234&, const Grid234&) = default;
};
static_assert(sizeof(Grid234) == Grid234::kModeledBytes);

struct ObstacleGridParams {
  // reference §2/§4: the obstacle code's camera→base matrix, row-major [M | t] (its 4×4 without
  // the last row); the real code holds it as floats. M is a rotation about y by ≈0.1501 rad
  // written to five digits, t = (−0.155, 0, 0.264) m.
  std::array<double, 12> X_base_camera{0.98875,  0.0, 0.14955, -0.155,  //
                                       0.0,      1.0, 0.0,     0.0,     //
                                       -0.14955, 0.0, 0.98875, 0.264};
  // reference §4: the obstacle box in base_link, metres, bounds inclusive.
  double x_min_m{0.3};
  double x_max_m{1.2};
  double y_min_m{-0.325};
  double y_max_m{0.325};
  double z_min_m{0.02};
  double z_max_m{0.5};
  double cell_size_m{0.05};  // reference §4

  template <class V>
  void Describe(V& v) {
    v("X_base_camera", X_base_camera,
      "the depth camera in base_link as the obstacle code holds it: a 3×4 [R t], row-major");
    v("x_min_m", x_min_m, "the obstacle box in base_link: nearest x");
    v("x_max_m", x_max_m, "farthest x");
    v("y_min_m", y_min_m, "rightmost y");
    v("y_max_m", y_max_m, "leftmost y");
    v("z_min_m", z_min_m, "lowest z: points below are floor");
    v("z_max_m", z_max_m, "highest z");
    v("cell_size_m", cell_size_m, "the grid's cell size");
  }
  // Finite values, min < max, cell_size_m > 0, and the box's x and y extents are 18 and 13 cells
  // (Grid234's fixed shape).
  void Validate() const;
  friend bool operator==(const ObstacleGridParams&, const ObstacleGridParams&) = default;
};

// The grid of a cloud. Throws std::invalid_argument if the cloud does not hold 640×480 points.
Grid234 StepObstacleGrid(const ObstacleGridParams& params, const PointCloud640& cloud);

// The fused path: the grid of a depth image, equal bit for bit to StepObstacleGrid of
// StepPointCloud of the same inputs, without writing the 4.9 MB cloud.
Grid234 StepDepthToGrid(const PointCloudParams& cloud_params, const ObstacleGridParams& params,
                        const DepthImageView& depth, const std::array<double, 12>& P);

namespace detail {

// A cell of Grid234 (Index; or Grid234::kCells for the points in the box past its far edges,
// which the grid drops) and how many neighbouring points of a row fell in it.
struct CellRun {
  std::uint16_t cell;
  std::uint16_t count;
};

// A segment of a depth row as DepthGridMemo keeps it: its depth values in the last frame and the
// runs of points they counted (a cell may appear more than once), held next to the depth, which
// is read anyway, where they are few (a segment of a car's face meets a few cells).
struct MemoSegment {
  static constexpr int kFewRuns = 7;
  std::array<std::uint16_t, kSegmentWidth> depth_mm;
  std::uint16_t runs;  // how many; the memo holds them elsewhere where they are more than kFewRuns
  std::array<CellRun, kFewRuns> few_runs;
};

}  // namespace detail

// What a depth-to-grid node remembers between frames so that it counts only what changed: the
// last frame's depth, what each segment of a row (detail::kSegmentWidth pixels) added to the grid,
// and their sum. A segment whose depth values are the same as last time adds what it added then
// (the bare floor repeats in every frame; another car covers a few segments of a row, and only
// those are counted again). Exact: each pixel's cell is decided by its own depth value alone, with
// the same float arithmetic whichever segment holds it, and the counts are summed as integers, so
// the grid is the one StepDepthToGrid computes from scratch (tested). Forgets everything when the
// parameters change.
class DepthGridMemo {
 public:
  DepthGridMemo() = default;

 private:
  friend Grid234 StepDepthToGrid(const PointCloudParams&, const ObstacleGridParams&,
                                 const DepthImageView&, const std::array<double, 12>&,
                                 DepthGridMemo*, std::span<const std::pair<int, int>>);
  static constexpr int kSegmentsPerRow = PointCloud640::kWidth / detail::kSegmentWidth;
  std::array<float, 24> key_{};  // the constants the segments were counted with
  bool valid_{false};
  std::vector<detail::MemoSegment> segments_;  // [row · kSegmentsPerRow + segment]
  // per segment, the same index: its runs where they are more than MemoSegment::kFewRuns
  std::vector<std::vector<detail::CellRun>> more_runs_;
  std::array<std::uint32_t, Grid234::kCells + 1> counts_{};  // the sum of every segment's runs
};

// StepDepthToGrid counting only the segments that differ from the memo's (which it then updates).
// `changed_columns`, if not empty, is one range of columns [begin, end) per row from whoever wrote
// the image (e.g. vehicle::DepthRowHistory; 0 <= begin <= end <= 640): a pixel outside its row's
// range is promised to be the one the memo saw last, and only the segments that meet the range
// are compared. Empty: every pixel may differ.
Grid234 StepDepthToGrid(const PointCloudParams& cloud_params, const ObstacleGridParams& params,
                        const DepthImageView& depth, const std::array<double, 12>& P,
                        DepthGridMemo* memo,
                        std::span<const std::pair<int, int>> changed_columns = {});

// Per pixel of a 640 × 480 depth image (row-major), the farthest optical depth (metres, as a
// depth camera measures it) at which the grid can count it: a depth value d back-projects to a
// point d · m_per_mm ahead of the camera (StepPointCloud), and the pixel's ray leaves the box at
// some distance; 1 mm is added to the box for the float arithmetic, 1 cm to the bound for the
// rounding to millimetres. -inf where the ray never enters the box; +inf everywhere where a pixel
// without a return (depth 0, the camera's own position) falls inside the box. A pixel whose depth
// is beyond its bound is not counted, nor is anything behind it: a renderer may leave out a
// surface beyond the bound (vehicle::DepthInterest), and the grid is the same. Throws
// std::invalid_argument for a P that StepPointCloud refuses.
std::vector<float> FarthestCountedDepths_m(const PointCloudParams& cloud_params,
                                           const ObstacleGridParams& params,
                                           const std::array<double, 12>& P);

struct ObstacleLayerParams {
  // reference §4: a cell is an obstacle when its count is above 250.
  int lethal_above_count{250};
  // reference §4: the real layer marks the cell's lower corner (see the top of this file);
  // true marks the centre instead.
  bool mark_at_cell_centre{false};
  // How long a grid waits for the transform at its arrival (TransformAt) before it is dropped:
  // canTransform("odom", "base_link", now, 1 s), obstacle_layer.cpp:46.
  Duration transform_timeout{std::chrono::seconds(1)};

  template <class V>
  void Describe(V& v) {
    v("lethal_above_count", lethal_above_count, "a cell with more points than this is an obstacle");
    v("mark_at_cell_centre", mark_at_cell_centre,
      "mark a cell's centre (false: its lower corner, as the lab's layer does)");
    v("transform_timeout_s", transform_timeout,
      "how long a grid waits for the car's pose at its time before it is dropped");
  }
  // lethal_above_count in [0, 254] (255 would make no cell lethal); transform_timeout > 0
  void Validate() const;
};

// An odom→base_link transform as the EKF publishes it, stamped with its measurement time.
struct StampedPose {
  Time stamp{kZeroTime};
  world::Pose2 X_odom_base;
};

// The transform the layer places a grid with (obstacle_layer.cpp:40-65): the grid callback reads
// the node's clock (`now`), waits in canTransform("odom", "base_link", now, 1 s) and places every
// cell with the transform at `now`, not at the frame's stamp. tf2 has it once a transform stamped
// at or after `now` is in its buffer, with one at or before it: the two are interpolated (the
// position linearly, the yaw along the shorter arc, as slerp turns a planar rotation). From the
// newest transform received and the one before it: the transform at `now`, or nullopt while it is
// not available yet (the callback waits for the next transform, or drops the grid after
// transform_timeout; `before` older than `now` is never missing after the first transform).
std::optional<world::Pose2> TransformAt(const std::optional<StampedPose>& before,
                                        const StampedPose& newest, Time now);

// The costmap layer's step (reference §4): all 234 cells as costmap marks (stack/costmap.h), in
// Index order, each LETHAL or FREE at its point in base_link moved into odom by X_odom_base (the
// odom→base_link transform when the grid arrived); `p` of a mark is in the odom frame. The params
// as their Validate accepts them: the layer's node validates them once, when it is built.
std::vector<CostmapMark> StepObstacleLayer(const ObstacleLayerParams& layer,
                                           const ObstacleGridParams& grid_params,
                                           const Grid234& grid, const world::Pose2& X_odom_base);

namespace detail {

// The real code's cell index, trunc(double(d) / cell_m) for a float d >= 0 (at most `cells`: past
// the last cell), without the double division. The quotient is monotone in d, so it is >= k
// exactly when d >= edge[k], the least float for which it is; the edges are found once by
// stepping over neighbouring floats, and an index is a multiply, to guess, and a compare or two
// against the edges, to correct the guess.
class CellEdges {
 public:
  CellEdges(double cell_m, int cells);

  int Index(float d) const {
    const float guess = d * per_cell_;
    int k = guess >= static_cast<float>(cells_) ? cells_ : static_cast<int>(guess);
    while (k < cells_ && d >= edge_[k + 1]) ++k;
    while (k > 0 && d < edge_[k]) --k;
    return k;
  }
  // Index(d) == k exactly when edge(k) <= d < edge(k + 1), for k < cells.
  float edge(int k) const { return edge_[k]; }

 private:
  static constexpr int kMaxCells = 32;
  int cells_;
  float per_cell_;                           // 1 / cell_m, a guess only
  std::array<float, kMaxCells + 1> edge_{};  // [k]: the least d with an index >= k; [0] = 0
};

}  // namespace detail
}  // namespace autonomsim::stack
