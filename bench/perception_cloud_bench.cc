// Point cloud and obstacle grid (issue 5) on a rendered lab-track depth frame: the car on the
// south straight with a 0.3 m box on its lane ahead. Run from the repository root (the fixture
// reads scenarios/tracks/lab.yaml):
//
//     build/bin/bench_perception --benchmark_filter=PointCloud --benchmark_repetitions=3
//
// BM_PointCloudObstacleGrid is the figure of merit: what the simulated obstacle node computes per
// frame, the fused depth→grid path (bit-identical to cloud then grid). Target: <= 1 ms.
// BM_PointCloudThenObstacleGrid is the unfused pair for comparison (it writes the 4.9 MB cloud and
// reads it back); BM_PointCloud the cloud alone.
#include <benchmark/benchmark.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <memory>
#include <utility>
#include <vector>

#include "stack/obstacle_grid.h"
#include "stack/point_cloud.h"
#include "stack/tests/track_frames.h"
#include "vehicle/camera_model.h"
#include "vehicle/ray_caster.h"
#include "world/floor_raster.h"

namespace autonomsim::stack {
namespace {

struct CloudScene {
  CloudScene() {
    const testing::TrackFrames frames;
    const world::Pose2 pose = frames.PoseOnRoute("outer_loop", 3.3);
    // the box's near face 0.625 m ahead of the chassis centre, on the car's axis
    const double c = std::cos(pose.yaw_rad), s = std::sin(pose.yaw_rad);
    const world::Pose2 X_map_box{pose.x_m + 0.775 * c, pose.y_m + 0.775 * s, pose.yaw_rad};
    const vehicle::Prism box{world::OrientedBox{X_map_box, 0.3, 0.3}, 0.3,
                             vehicle::SceneAppearance{}.obstacle()};
    depth = frames.Render(pose, {&box, 1}).depth;
    P = frames.depth_camera().Info().P;
  }
  DepthImageView view() const { return DepthImageView{depth.width, depth.height, depth.mm}; }

  vehicle::DepthImage depth;
  std::array<double, 12> P{};
};

const CloudScene& TheCloudScene() {
  static const CloudScene scene;
  return scene;
}

void BM_PointCloudObstacleGrid(benchmark::State& state) {
  const CloudScene& scene = TheCloudScene();
  const PointCloudParams cloud_params;
  const ObstacleGridParams grid_params;
  for (auto _ : state) {
    Grid234 grid = StepDepthToGrid(cloud_params, grid_params, scene.view(), scene.P);
    benchmark::DoNotOptimize(grid);
  }
}
BENCHMARK(BM_PointCloudObstacleGrid)->Unit(benchmark::kMicrosecond);

// The fused grid node as it runs in the loop: consecutive frames share their floor rows, which
// the memo does not count again (the same frame each iteration: only its first is counted whole).
void BM_PointCloudObstacleGridMemo(benchmark::State& state) {
  const CloudScene& scene = TheCloudScene();
  const PointCloudParams cloud_params;
  const ObstacleGridParams grid_params;
  DepthGridMemo memo;
  for (auto _ : state) {
    Grid234 grid = StepDepthToGrid(cloud_params, grid_params, scene.view(), scene.P, &memo);
    benchmark::DoNotOptimize(grid);
  }
}
BENCHMARK(BM_PointCloudObstacleGridMemo)->Unit(benchmark::kMicrosecond);

// The same, told which columns may have changed (none: the same frame again), as the renderer's
// DepthRowHistory tells the node: nothing is compared.
void BM_PointCloudObstacleGridMemoTold(benchmark::State& state) {
  const CloudScene& scene = TheCloudScene();
  const PointCloudParams cloud_params;
  const ObstacleGridParams grid_params;
  DepthGridMemo memo;
  const std::vector<std::pair<int, int>> none(PointCloud640::kHeight, {0, 0});
  StepDepthToGrid(cloud_params, grid_params, scene.view(), scene.P, &memo);
  for (auto _ : state) {
    Grid234 grid = StepDepthToGrid(cloud_params, grid_params, scene.view(), scene.P, &memo, none);
    benchmark::DoNotOptimize(grid);
  }
}
BENCHMARK(BM_PointCloudObstacleGridMemoTold)->Unit(benchmark::kMicrosecond);

// A car crossing ahead frame after frame, as the loop's depth camera renders it into one buffer
// with its DepthRowHistory: the frames and what the history said changed since the frame before
// (a cycle: frame 0 follows the last one).
struct MovingCarFrames {
  MovingCarFrames() {
    const testing::TrackFrames frames;
    const world::Pose2 pose = frames.PoseOnRoute("outer_loop", 3.3);
    vehicle::CameraRenderer renderer(
        std::make_shared<const vehicle::CameraRays>(frames.depth_camera()),
        std::make_shared<const vehicle::FloorTexture>(world::RasterizeFloor(frames.track())),
        vehicle::SceneAppearance{}.surround());
    const double c = std::cos(pose.yaw_rad), s = std::sin(pose.yaw_rad);
    vehicle::DepthImage buffer;
    vehicle::DepthRowHistory history;
    constexpr int kFrames = 16;
    for (int pass = 0; pass < 2; ++pass) {  // the second pass knows frame 0's predecessor
      for (int k = 0; k < kFrames; ++k) {
        // 1.0 to 1.3 m ahead, drifting from right to left at 2 cm and 1.5 cm per frame
        const double x_m = 1.0 + 0.02 * k, y_m = -0.12 + 0.015 * k;
        const world::Pose2 X_map_other{pose.x_m + c * x_m - s * y_m, pose.y_m + s * x_m + c * y_m,
                                       pose.yaw_rad + 0.02 * k};
        const vehicle::Prism car{world::OrientedBox{X_map_other, 0.525, 0.296}, 0.2,
                                 vehicle::SceneAppearance{}.car_body(1)};
        renderer.RenderDepth(pose, {&car, 1}, &buffer, &history);
        if (pass == 0) continue;
        depth.push_back(buffer);
        changed.emplace_back(history.changed_columns().begin(), history.changed_columns().end());
      }
    }
    P = frames.depth_camera().Info().P;
  }
  DepthImageView view(std::size_t k) const {
    return DepthImageView{depth[k].width, depth[k].height, depth[k].mm};
  }

  std::vector<vehicle::DepthImage> depth;
  std::vector<std::vector<std::pair<int, int>>> changed;
  std::array<double, 12> P{};
};

// The fused grid node on MovingCarFrames, told what changed as the loop tells it: one frame per
// iteration.
void BM_PointCloudObstacleGridMemoMoving(benchmark::State& state) {
  static const MovingCarFrames frames;
  const PointCloudParams cloud_params;
  const ObstacleGridParams grid_params;
  DepthGridMemo memo;
  StepDepthToGrid(cloud_params, grid_params, frames.view(frames.depth.size() - 1), frames.P, &memo);
  std::size_t k = 0;
  for (auto _ : state) {
    Grid234 grid = StepDepthToGrid(cloud_params, grid_params, frames.view(k), frames.P, &memo,
                                   frames.changed[k]);
    benchmark::DoNotOptimize(grid);
    k = (k + 1) % frames.depth.size();
  }
}
BENCHMARK(BM_PointCloudObstacleGridMemoMoving)->Unit(benchmark::kMicrosecond);

void BM_PointCloudThenObstacleGrid(benchmark::State& state) {
  const CloudScene& scene = TheCloudScene();
  const PointCloudParams cloud_params;
  const ObstacleGridParams grid_params;
  PointCloud640 cloud;
  for (auto _ : state) {
    StepPointCloud(cloud_params, scene.view(), scene.P, &cloud);
    Grid234 grid = StepObstacleGrid(grid_params, cloud);
    benchmark::DoNotOptimize(grid);
  }
}
BENCHMARK(BM_PointCloudThenObstacleGrid)->Unit(benchmark::kMicrosecond);

void BM_PointCloud(benchmark::State& state) {
  const CloudScene& scene = TheCloudScene();
  const PointCloudParams cloud_params;
  PointCloud640 cloud;
  for (auto _ : state) {
    StepPointCloud(cloud_params, scene.view(), scene.P, &cloud);
    benchmark::DoNotOptimize(cloud.points.data());
    benchmark::ClobberMemory();
  }
  state.SetBytesProcessed(state.iterations() *
                          static_cast<std::int64_t>(PointCloud640::kModeledBytes));
}
BENCHMARK(BM_PointCloud)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace autonomsim::stack
