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
#include <vector>

#include "stack/obstacle_grid.h"
#include "stack/point_cloud.h"
#include "stack/tests/track_frames.h"
#include "vehicle/camera_model.h"
#include "vehicle/ray_caster.h"

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

// The same, told which rows may have changed (none: the same frame again), as the renderer's
// DepthRowHistory tells the node: no row is compared.
void BM_PointCloudObstacleGridMemoTold(benchmark::State& state) {
  const CloudScene& scene = TheCloudScene();
  const PointCloudParams cloud_params;
  const ObstacleGridParams grid_params;
  DepthGridMemo memo;
  const std::vector<std::uint8_t> none(PointCloud640::kHeight, 0);
  StepDepthToGrid(cloud_params, grid_params, scene.view(), scene.P, &memo);
  for (auto _ : state) {
    Grid234 grid = StepDepthToGrid(cloud_params, grid_params, scene.view(), scene.P, &memo, none);
    benchmark::DoNotOptimize(grid);
  }
}
BENCHMARK(BM_PointCloudObstacleGridMemoTold)->Unit(benchmark::kMicrosecond);

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
