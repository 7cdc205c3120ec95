#include "stack/obstacle_grid.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>
#include <utility>

#include "world/validation.h"

namespace autonomsim::stack {
namespace {

constexpr int kWidth = PointCloud640::kWidth;

// A frame's counts before saturation: a counter that saturates at every increment ends at
// min(n, 255), so the frame counts plainly and saturates once (Finish). The last slot takes the
// points past the box's far edges, which the real code drops.
using FrameCounts = std::array<std::uint32_t, Grid234::kCells + 1>;
constexpr int kDropped = Grid234::kCells;

// The parameters as the real code holds them: floats, except the cell size (a double literal,
// which the cell edges stand for).
struct GridConstants {
  std::array<float, 12> m;  // row-major [M | t]
  float x_min, x_max, y_min, y_max, z_min, z_max;
  detail::CellEdges x_cells, y_cells;
};

GridConstants MakeGridConstants(const ObstacleGridParams& p) {
  p.Validate();
  std::array<float, 12> m;
  for (int i = 0; i < 12; ++i) m[i] = static_cast<float>(p.X_base_camera[i]);
  return GridConstants{.m = m,
                       .x_min = static_cast<float>(p.x_min_m),
                       .x_max = static_cast<float>(p.x_max_m),
                       .y_min = static_cast<float>(p.y_min_m),
                       .y_max = static_cast<float>(p.y_max_m),
                       .z_min = static_cast<float>(p.z_min_m),
                       .z_max = static_cast<float>(p.z_max_m),
                       .x_cells = detail::CellEdges(p.cell_size_m, Grid234::kCellsX),
                       .y_cells = detail::CellEdges(p.cell_size_m, Grid234::kCellsY)};
}

// Counts kCount camera-frame points (neighbouring pixels of one image row): add(cell, n) for each
// run of n neighbouring points in one cell (cell kDropped: in the box, past its far edges; n may
// be 0). Two passes: the transform and the box test, which the compiler vectorizes (fixed trip
// count, no aliasing, no early exits), then the cells of the points inside the box, if any.
template <int kCount, class Add>
[[gnu::always_inline]] inline void CountPoints(const GridConstants& g, const float* __restrict x,
                                               const float* __restrict y, const float* __restrict z,
                                               Add add) {
  static_assert(kCount % 8 == 0);
  alignas(64) float dx[kCount];
  alignas(64) float dy[kCount];
  alignas(64) std::uint8_t inside[kCount];
  std::uint8_t any_inside = 0;
  const std::array<float, 12>& m = g.m;
  for (int i = 0; i < kCount; ++i) {
    // the real code's order: M0·x + M1·y + M2·z + t·1, left to right
    const float bx = m[0] * x[i] + m[1] * y[i] + m[2] * z[i] + m[3];
    const float by = m[4] * x[i] + m[5] * y[i] + m[6] * z[i] + m[7];
    const float bz = m[8] * x[i] + m[9] * y[i] + m[10] * z[i] + m[11];
    // & rather than &&: every comparison is made anyway, and the loop stays branch-free.
    inside[i] = (bx >= g.x_min) & (bx <= g.x_max) & (by >= g.y_min) & (by <= g.y_max) &
                (bz >= g.z_min) & (bz <= g.z_max);
    any_inside |= inside[i];
    dx[i] = bx - g.x_min;
    dy[i] = by - g.y_min;
  }
  if (!any_inside) return;
  // Neighbouring pixels mostly fall into one cell: while they do, count the run; then add it.
  int cell = kDropped;
  std::uint32_t run = 0;
  float x_lo = 1.0f, x_hi = 0.0f, y_lo = 1.0f, y_hi = 0.0f;  // the run's cell: none yet
  for (int word = 0; word < kCount; word += 8) {
    std::uint64_t bits;
    std::memcpy(&bits, inside + word, sizeof bits);
    if (bits == 0) continue;
    for (int i = word; i < word + 8; ++i) {
      if (!inside[i]) continue;
      if (dx[i] >= x_lo && dx[i] < x_hi && dy[i] >= y_lo && dy[i] < y_hi) {
        ++run;
        continue;
      }
      add(cell, run);
      run = 1;
      // dx, dy >= 0 here: the real code's uint8_t conversion truncates, i.e. floors
      const int gx = g.x_cells.Index(dx[i]);
      const int gy = g.y_cells.Index(dy[i]);
      if (gx < Grid234::kCellsX && gy < Grid234::kCellsY) {
        cell = Grid234::Index(gx, gy);
        x_lo = g.x_cells.edge(gx);
        x_hi = g.x_cells.edge(gx + 1);
        y_lo = g.y_cells.edge(gy);
        y_hi = g.y_cells.edge(gy + 1);
      } else {
        cell = kDropped;
        x_lo = 1.0f, x_hi = 0.0f;
      }
    }
  }
  add(cell, run);
}

// A whole row's points into the frame's counts.
AUTONOMSIM_ROW_KERNEL void CountRow(const GridConstants& g, const float* __restrict x,
                                    const float* __restrict y, const float* __restrict z,
                                    FrameCounts* counts) {
  CountPoints<kWidth>(g, x, y, z, [counts](int cell, std::uint32_t n) { (*counts)[cell] += n; });
}

// A segment's points (detail::kSegmentWidth of them) as runs, none of count 0, into runs[0, k);
// returns k (at most kSegmentWidth: a run holds a point).
AUTONOMSIM_ROW_KERNEL int CountSegment(const GridConstants& g, const float* __restrict x,
                                       const float* __restrict y, const float* __restrict z,
                                       detail::CellRun* __restrict runs) {
  int k = 0;
  CountPoints<detail::kSegmentWidth>(g, x, y, z, [runs, &k](int cell, std::uint32_t n) {
    if (n != 0) {
      runs[k++] = detail::CellRun{static_cast<std::uint16_t>(cell), static_cast<std::uint16_t>(n)};
    }
  });
  return k;
}

// A memo segment's runs: its own, or `more` where they are more than it holds.
std::span<const detail::CellRun> RunsOf(const detail::MemoSegment& segment,
                                        const std::vector<detail::CellRun>& more) {
  if (segment.runs > detail::MemoSegment::kFewRuns) return more;
  return {segment.few_runs.data(), segment.runs};
}

// Replaces a segment's runs, and what they added to `total`, with those of its depth values (its
// depth_mm, pixels [col0, col0 + kSegmentWidth) of `row`).
void RecountSegment(const detail::CloudConstants& k, const GridConstants& g, int row, int col0,
                    detail::MemoSegment* segment, std::vector<detail::CellRun>* more,
                    FrameCounts* total) {
  constexpr int kSegment = detail::kSegmentWidth;
  for (const detail::CellRun& run : RunsOf(*segment, *more)) (*total)[run.cell] -= run.count;
  alignas(64) float x[kSegment], y[kSegment], z[kSegment];
  std::array<detail::CellRun, kSegment> runs;
  detail::CameraPointsOfSegment(k, row, col0, segment->depth_mm.data(), x, y, z);
  const int n = CountSegment(g, x, y, z, runs.data());
  segment->runs = static_cast<std::uint16_t>(n);
  if (n > detail::MemoSegment::kFewRuns) {
    more->assign(runs.begin(), runs.begin() + n);
  } else {
    std::copy(runs.begin(), runs.begin() + n, segment->few_runs.begin());
  }
  for (const detail::CellRun& run : RunsOf(*segment, *more)) (*total)[run.cell] += run.count;
}

Grid234 Finish(const FrameCounts& counts) {
  Grid234 grid;
  for (int c = 0; c < Grid234::kCells; ++c) {
    grid.data[c] = static_cast<std::uint8_t>(counts[c] < 255 ? counts[c] : 255);
  }
  return grid;
}

}  // namespace

namespace detail {

CellEdges::CellEdges(double cell_m, int cells)
    : cells_(cells), per_cell_(static_cast<float>(1.0 / cell_m)) {
  Require(cell_m > 0.0 && std::isfinite(cell_m) && cells >= 1 && cells <= kMaxCells,
          [&] { return "CellEdges: bad cell size " + Num(cell_m) + " or count " + Num(cells); });
  const auto index_at_least = [cell_m](float d, int k) {
    return static_cast<double>(d) / cell_m >= k;
  };
  edge_[0] = 0.0f;
  for (int k = 1; k <= cells; ++k) {
    // start near k·cell, step down below the edge, then up onto it
    float d = static_cast<float>(k * cell_m);
    while (index_at_least(d, k)) d = std::nextafter(d, 0.0f);
    while (!index_at_least(d, k)) d = std::nextafter(d, std::numeric_limits<float>::infinity());
    edge_[k] = d;
  }
}

}  // namespace detail

void ObstacleGridParams::Validate() const {
  for (int i = 0; i < 12; ++i) {
    Require(std::isfinite(X_base_camera[i]), [&] {
      return "X_base_camera: entry " + std::to_string(i) + " is " + Num(X_base_camera[i]);
    });
  }
  const auto check_range = [](const char* lo_key, double lo, const char* hi_key, double hi) {
    Require(std::isfinite(lo) && std::isfinite(hi) && lo < hi, [&] {
      return std::string(lo_key) + " must be < " + hi_key + ", got " + Num(lo) + " and " + Num(hi);
    });
  };
  check_range("x_min_m", x_min_m, "x_max_m", x_max_m);
  check_range("y_min_m", y_min_m, "y_max_m", y_max_m);
  check_range("z_min_m", z_min_m, "z_max_m", z_max_m);
  Require(std::isfinite(cell_size_m) && cell_size_m > 0.0,
          [&] { return "cell_size_m must be > 0, got " + Num(cell_size_m); });
  // Grid234 has a fixed shape; a box of another size would need another message.
  const auto spans = [this](double lo, double hi, int cells) {
    return std::abs((hi - lo) / cell_size_m - cells) < 1e-6;
  };
  Require(spans(x_min_m, x_max_m, Grid234::kCellsX), [&] {
    return "x_max_m - x_min_m must be 18 cells of cell_size_m, got " + Num(x_max_m - x_min_m) +
           " m for cell_size_m " + Num(cell_size_m);
  });
  Require(spans(y_min_m, y_max_m, Grid234::kCellsY), [&] {
    return "y_max_m - y_min_m must be 13 cells of cell_size_m, got " + Num(y_max_m - y_min_m) +
           " m for cell_size_m " + Num(cell_size_m);
  });
}

Grid234 StepObstacleGrid(const ObstacleGridParams& params, const PointCloud640& cloud) {
  const GridConstants g = MakeGridConstants(params);
  Require(cloud.points.size() == static_cast<std::size_t>(PointCloud640::kPoints), [&] {
    return "obstacle grid: the cloud holds " + Num(cloud.points.size()) + " points, not 640x480";
  });
  FrameCounts counts{};
  alignas(64) float x[kWidth], y[kWidth], z[kWidth];
  for (int row = 0; row < PointCloud640::kHeight; ++row) {
    const CloudPoint* in = cloud.points.data() + row * kWidth;
    for (int col = 0; col < kWidth; ++col) {
      x[col] = in[col].x_m;
      y[col] = in[col].y_m;
      z[col] = in[col].z_m;
    }
    CountRow(g, x, y, z, &counts);
  }
  return Finish(counts);
}

// FarthestCountedDepths_m's slacks, ours, not the lab's, with room to spare: the box is widened
// by kCountedBoxSlack_m for the float arithmetic of the points (below 1e-5 m for a point within
// a few metres), which matters where a ray grazes a face; the bound is moved kCountedDepthSlack_m
// farther for the rounding of the depth to millimetres (0.5 mm).
constexpr double kCountedBoxSlack_m = 0.001;
constexpr double kCountedDepthSlack_m = 0.01;

std::vector<float> FarthestCountedDepths_m(const PointCloudParams& cloud_params,
                                           const ObstacleGridParams& params,
                                           const std::array<double, 12>& P) {
  const detail::CloudConstants k = detail::MakeCloudConstants(cloud_params, P);
  params.Validate();
  Eigen::Matrix3d M;  // camera → base_link, p_base = M · p_camera + t
  Eigen::Vector3d t;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) M(r, c) = params.X_base_camera[4 * r + c];
    t(r) = params.X_base_camera[4 * r + 3];
  }
  // the box widened by its slack, relative to the camera's position t
  const Eigen::Vector3d below =
      Eigen::Vector3d(params.x_min_m, params.y_min_m, params.z_min_m).array() - kCountedBoxSlack_m -
      t.array();
  const Eigen::Vector3d above =
      Eigen::Vector3d(params.x_max_m, params.y_max_m, params.z_max_m).array() + kCountedBoxSlack_m -
      t.array();
  constexpr int kHeight = PointCloud640::kHeight;
  constexpr float kInfinite = std::numeric_limits<float>::infinity();
  // a pixel without a return is the camera's own position: inside the box, every pixel counts
  if ((below.array() <= 0.0).all() && (above.array() >= 0.0).all()) {
    return std::vector<float>(PointCloud640::kPoints, kInfinite);
  }
  // Pixel (u, v) with depth value d back-projects to s · (1, -(u - cx) / fx, -(v - cy) / fy) in
  // the camera's frame, s = d · m_per_mm (StepPointCloud), so to t + s · a in base_link with
  // a = M · that direction: along each axis the box holds an interval of s, and the pixel's
  // points in the box are those of the three intervals' intersection.
  const double m_per_mm = static_cast<double>(k.m_per_mm);
  std::vector<float> farthest(PointCloud640::kPoints, -kInfinite);
  for (int v = 0; v < kHeight; ++v) {
    for (int u = 0; u < kWidth; ++u) {
      const Eigen::Vector3d a = M * Eigen::Vector3d(1.0, -(u - static_cast<double>(k.cx)) / k.fx,
                                                    -(v - static_cast<double>(k.cy)) / k.fy);
      double s_lo = 0.0, s_hi = std::numeric_limits<double>::infinity();
      for (int j = 0; j < 3; ++j) {
        if (a(j) == 0.0) {  // parallel to the slab: inside it everywhere or nowhere
          if (below(j) > 0.0 || above(j) < 0.0) s_hi = -1.0;
          continue;
        }
        s_lo = std::max(s_lo, std::min(below(j) / a(j), above(j) / a(j)));
        s_hi = std::min(s_hi, std::max(below(j) / a(j), above(j) / a(j)));
      }
      if (s_lo > s_hi) continue;
      // s = d · m_per_mm and d is the optical depth in millimetres, rounded
      farthest[static_cast<std::size_t>(v * kWidth + u)] =
          static_cast<float>(s_hi / (m_per_mm * 1000.0) + kCountedDepthSlack_m);
    }
  }
  return farthest;
}

Grid234 StepDepthToGrid(const PointCloudParams& cloud_params, const ObstacleGridParams& params,
                        const DepthImageView& depth, const std::array<double, 12>& P) {
  const detail::CloudConstants k = detail::MakeCloudConstants(cloud_params, P);
  const GridConstants g = MakeGridConstants(params);
  detail::CheckDepthImage(depth);
  FrameCounts counts{};
  alignas(64) float x[kWidth], y[kWidth], z[kWidth];
  for (int row = 0; row < PointCloud640::kHeight; ++row) {
    detail::CameraPointsOfRow(k, row, depth.mm.data() + row * kWidth, x, y, z);
    CountRow(g, x, y, z, &counts);
  }
  return Finish(counts);
}

Grid234 StepDepthToGrid(const PointCloudParams& cloud_params, const ObstacleGridParams& params,
                        const DepthImageView& depth, const std::array<double, 12>& P,
                        DepthGridMemo* memo, std::span<const std::pair<int, int>> changed_columns) {
  const detail::CloudConstants k = detail::MakeCloudConstants(cloud_params, P);
  const GridConstants g = MakeGridConstants(params);
  detail::CheckDepthImage(depth);
  std::array<float, 24> key;
  std::copy(g.m.begin(), g.m.end(), key.begin());
  const std::array<float, 12> rest{
      g.x_min, g.x_max, g.y_min, g.y_max, g.z_min,    g.z_max,
      k.fx,    k.fy,    k.cx,    k.cy,    k.m_per_mm, static_cast<float>(params.cell_size_m)};
  std::copy(rest.begin(), rest.end(), key.begin() + 12);
  Require(changed_columns.empty() || changed_columns.size() == PointCloud640::kHeight, [&] {
    return "obstacle grid: " + Num(changed_columns.size()) + " changed column ranges for " +
           Num(PointCloud640::kHeight) + " rows";
  });
  const bool reset = !memo->valid_ || memo->key_ != key;
  constexpr int kSegments = DepthGridMemo::kSegmentsPerRow;
  if (reset) {
    memo->valid_ = true;
    memo->key_ = key;
    memo->segments_.assign(PointCloud640::kHeight * kSegments, detail::MemoSegment{});
    memo->more_runs_.assign(PointCloud640::kHeight * kSegments, {});
    memo->counts_.fill(0);
  }
  constexpr int kSegment = detail::kSegmentWidth;
  for (int row = 0; row < PointCloud640::kHeight; ++row) {
    auto [begin, end] = changed_columns.empty() ? std::pair{0, kWidth} : changed_columns[row];
    Require(begin >= 0 && begin <= end && end <= kWidth, [&] {
      return "obstacle grid: row " + Num(row) + "'s changed columns [" + Num(begin) + ", " +
             Num(end) + ") are not a range within [0, 640]";
    });
    if (reset) {
      begin = 0;
      end = kWidth;
    }
    for (int segment = begin / kSegment; segment * kSegment < end; ++segment) {
      const std::uint16_t* in = depth.mm.data() + row * kWidth + segment * kSegment;
      const std::size_t s = static_cast<std::size_t>(row * kSegments + segment);
      detail::MemoSegment& last = memo->segments_[s];
      const std::size_t bytes = kSegment * sizeof(std::uint16_t);
      if (!reset && std::memcmp(in, last.depth_mm.data(), bytes) == 0) continue;
      std::memcpy(last.depth_mm.data(), in, bytes);
      RecountSegment(k, g, row, segment * kSegment, &last, &memo->more_runs_[s], &memo->counts_);
    }
  }
  return Finish(memo->counts_);
}

void ObstacleLayerParams::Validate() const {
  Require(lethal_above_count >= 0 && lethal_above_count <= 254,
          [&] { return "lethal_above_count must be in [0, 254], got " + Num(lethal_above_count); });
  Require(transform_timeout > Duration{0}, [&] {
    return "transform_timeout_s must be > 0, got " + Num(ToSeconds(transform_timeout));
  });
}

std::optional<world::Pose2> TransformAt(const std::optional<StampedPose>& before,
                                        const StampedPose& newest, Time now) {
  if (newest.stamp == now) return newest.X_odom_base;
  if (newest.stamp < now || !before || before->stamp > now) return std::nullopt;
  const double f = ToSeconds(now - before->stamp) / ToSeconds(newest.stamp - before->stamp);
  const world::Pose2& a = before->X_odom_base;
  const world::Pose2& b = newest.X_odom_base;
  return world::Pose2{a.x_m + f * (b.x_m - a.x_m), a.y_m + f * (b.y_m - a.y_m),
                      world::WrapAngle(a.yaw_rad + f * world::WrapAngle(b.yaw_rad - a.yaw_rad))};
}

std::vector<CostmapMark> StepObstacleLayer(const ObstacleLayerParams& layer,
                                           const ObstacleGridParams& grid_params,
                                           const Grid234& grid, const world::Pose2& X_odom_base) {
  const double offset_m = layer.mark_at_cell_centre ? 0.5 * grid_params.cell_size_m : 0.0;
  const double c = std::cos(X_odom_base.yaw_rad);
  const double s = std::sin(X_odom_base.yaw_rad);
  std::vector<CostmapMark> marks;
  marks.reserve(Grid234::kCells);
  for (int gx = 0; gx < Grid234::kCellsX; ++gx) {
    for (int gy = 0; gy < Grid234::kCellsY; ++gy) {
      // the real layer's point: gx * 0.05 + 0.3, gy * 0.05 - 0.325 (base_link)
      const double x_base = gx * grid_params.cell_size_m + grid_params.x_min_m + offset_m;
      const double y_base = gy * grid_params.cell_size_m + grid_params.y_min_m + offset_m;
      const world::Vec2 p_odom(X_odom_base.x_m + c * x_base - s * y_base,
                               X_odom_base.y_m + s * x_base + c * y_base);
      marks.push_back(CostmapMark{p_odom, grid.count(gx, gy) > layer.lethal_above_count});
    }
  }
  return marks;
}

}  // namespace autonomsim::stack
