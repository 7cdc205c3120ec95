#include "stack/obstacle_grid.h"

#include <cmath>
#include <string>

#include "world/validation.h"

namespace autonomsim::stack {
namespace {

constexpr int kWidth = PointCloud640::kWidth;

// The parameters as the real code holds them: floats, except the cell size (a double literal).
struct GridConstants {
  std::array<float, 12> m;  // row-major [M | t]
  float x_min, x_max, y_min, y_max, z_min, z_max;
  double cell;
};

GridConstants MakeGridConstants(const ObstacleGridParams& p) {
  p.Validate();
  GridConstants g{};
  for (int i = 0; i < 12; ++i) g.m[i] = static_cast<float>(p.X_base_camera[i]);
  g.x_min = static_cast<float>(p.x_min_m);
  g.x_max = static_cast<float>(p.x_max_m);
  g.y_min = static_cast<float>(p.y_min_m);
  g.y_max = static_cast<float>(p.y_max_m);
  g.z_min = static_cast<float>(p.z_min_m);
  g.z_max = static_cast<float>(p.z_max_m);
  g.cell = p.cell_size_m;
  return g;
}

// Counts one image row of camera-frame points into the grid. Two passes: the transform and box
// test, which the compiler vectorizes (fixed trip count, no aliasing, no early exits), then the
// scatter into the counters for the few points inside the box.
void CountRow(const GridConstants& g, const float* __restrict x, const float* __restrict y,
              const float* __restrict z, Grid234* grid) {
  alignas(64) float dx[kWidth];
  alignas(64) float dy[kWidth];
  alignas(64) std::int32_t inside[kWidth];
  const std::array<float, 12>& m = g.m;
  for (int i = 0; i < kWidth; ++i) {
    // the real code's order: M0·x + M1·y + M2·z + t·1, left to right
    const float bx = m[0] * x[i] + m[1] * y[i] + m[2] * z[i] + m[3];
    const float by = m[4] * x[i] + m[5] * y[i] + m[6] * z[i] + m[7];
    const float bz = m[8] * x[i] + m[9] * y[i] + m[10] * z[i] + m[11];
    // & rather than &&: every comparison is made anyway, and the loop stays branch-free.
    inside[i] = (bx >= g.x_min) & (bx <= g.x_max) & (by >= g.y_min) & (by <= g.y_max) &
                (bz >= g.z_min) & (bz <= g.z_max);
    dx[i] = bx - g.x_min;
    dy[i] = by - g.y_min;
  }
  for (int i = 0; i < kWidth; ++i) {
    if (!inside[i]) continue;
    // both >= 0 here; truncation is floor, as the real code's conversion to uint8_t
    const int gx = static_cast<int>(static_cast<double>(dx[i]) / g.cell);
    const int gy = static_cast<int>(static_cast<double>(dy[i]) / g.cell);
    if (gx >= Grid234::kCellsX || gy >= Grid234::kCellsY) continue;  // the far edges
    std::uint8_t& count = grid->data[Grid234::Index(gx, gy)];
    if (count < 255) ++count;
  }
}

}  // namespace

void ObstacleGridParams::Validate() const {
  for (int i = 0; i < 12; ++i) {
    Require(std::isfinite(X_base_camera[i]),
            "X_base_camera: entry " + std::to_string(i) + " is " + Num(X_base_camera[i]));
  }
  const auto check_range = [](const char* lo_key, double lo, const char* hi_key, double hi) {
    Require(std::isfinite(lo) && std::isfinite(hi) && lo < hi,
            std::string(lo_key) + " must be < " + hi_key + ", got " + Num(lo) + " and " + Num(hi));
  };
  check_range("x_min_m", x_min_m, "x_max_m", x_max_m);
  check_range("y_min_m", y_min_m, "y_max_m", y_max_m);
  check_range("z_min_m", z_min_m, "z_max_m", z_max_m);
  Require(std::isfinite(cell_size_m) && cell_size_m > 0.0,
          "cell_size_m must be > 0, got " + Num(cell_size_m));
  // Grid234 has a fixed shape; a box of another size would need another message.
  const auto spans = [this](double lo, double hi, int cells) {
    return std::abs((hi - lo) / cell_size_m - cells) < 1e-6;
  };
  Require(spans(x_min_m, x_max_m, Grid234::kCellsX),
          "x_max_m - x_min_m must be 18 cells of cell_size_m, got " + Num(x_max_m - x_min_m) +
              " m for cell_size_m " + Num(cell_size_m));
  Require(spans(y_min_m, y_max_m, Grid234::kCellsY),
          "y_max_m - y_min_m must be 13 cells of cell_size_m, got " + Num(y_max_m - y_min_m) +
              " m for cell_size_m " + Num(cell_size_m));
}

Grid234 StepObstacleGrid(const ObstacleGridParams& params, const PointCloud640& cloud) {
  const GridConstants g = MakeGridConstants(params);
  Require(cloud.points.size() == static_cast<std::size_t>(PointCloud640::kPoints),
          "obstacle grid: the cloud holds " + Num(cloud.points.size()) + " points, not 640x480");
  Grid234 grid;
  alignas(64) float x[kWidth], y[kWidth], z[kWidth];
  for (int row = 0; row < PointCloud640::kHeight; ++row) {
    const CloudPoint* in = cloud.points.data() + row * kWidth;
    for (int col = 0; col < kWidth; ++col) {
      x[col] = in[col].x_m;
      y[col] = in[col].y_m;
      z[col] = in[col].z_m;
    }
    CountRow(g, x, y, z, &grid);
  }
  return grid;
}

Grid234 StepDepthToGrid(const PointCloudParams& cloud_params, const ObstacleGridParams& params,
                        const DepthImageView& depth, const std::array<double, 12>& P) {
  const detail::CloudConstants k = detail::MakeCloudConstants(cloud_params, P);
  const GridConstants g = MakeGridConstants(params);
  detail::CheckDepthImage(depth);
  Grid234 grid;
  alignas(64) float x[kWidth], y[kWidth], z[kWidth];
  for (int row = 0; row < PointCloud640::kHeight; ++row) {
    detail::CameraPointsOfRow(k, row, depth.mm.data() + row * kWidth, x, y, z);
    CountRow(g, x, y, z, &grid);
  }
  return grid;
}

void ObstacleLayerParams::Validate() const {
  Require(lethal_above_count >= 0 && lethal_above_count <= 254,
          "lethal_above_count must be in [0, 254], got " + Num(lethal_above_count));
}

std::vector<CostmapMark> StepObstacleLayer(const ObstacleLayerParams& layer,
                                           const ObstacleGridParams& grid_params,
                                           const Grid234& grid, const world::Pose2& X_odom_base) {
  layer.Validate();
  grid_params.Validate();
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
