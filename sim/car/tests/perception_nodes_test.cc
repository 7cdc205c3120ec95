// The perception nodes' tables are built once per distinct parameters and camera, and shared.
#include "sim/car/perception_nodes.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <vector>

#include "sim/core/track_loader.h"
#include "vehicle/camera_model.h"
#include "vehicle/physics_world.h"
#include "world/floor_raster.h"

namespace autonomsim::sim {
namespace {

TEST(PerceptionTablesCacheTest, CarsWithTheSameParametersAndCameraShareOneLaneTable) {
  PerceptionTablesCache cache;
  const stack::LaneDetectionParams params;
  const vehicle::CameraModel camera(vehicle::ColorCameraParams());
  const auto first = cache.LaneTables(params, camera);
  EXPECT_EQ(cache.LaneTables(params, vehicle::CameraModel(vehicle::ColorCameraParams())), first);

  stack::LaneDetectionParams other_params;
  other_params.yellow_min_px += 1;
  EXPECT_NE(cache.LaneTables(other_params, camera), first);
  vehicle::CameraParams other_camera = vehicle::ColorCameraParams();
  other_camera.mount.pitch_deg += 1.0;
  const auto moved = cache.LaneTables(params, vehicle::CameraModel(other_camera));
  EXPECT_NE(moved, first);
  EXPECT_EQ(cache.LaneTables(params, camera), first);
  EXPECT_EQ(cache.LaneTables(params, vehicle::CameraModel(other_camera)), moved);
}

// The fused obstacle node's depth interest is its box's per-pixel bounds on the depth camera's
// tiles, built once per box, scale and camera.
TEST(PerceptionTablesCacheTest, DepthCamerasWithTheSameBoxShareOneDepthInterest) {
  const vehicle::PhysicsWorld physics(vehicle::PhysicsParams{});
  SensorEnvironment environment(&physics,
                                world::RasterizeFloor(LoadTrack("scenarios/tracks/lab.yaml")),
                                vehicle::SceneAppearance{});
  const SensorSuiteParams suite;
  const CameraSensor one(&environment, suite.depth_camera);
  const CameraSensor two(&environment, suite.depth_camera);
  PerceptionTablesCache cache;
  const stack::PointCloudParams cloud{.hardware_scale = true};
  const stack::ObstacleGridParams grid;
  const auto first = cache.DepthInterest(cloud, grid, one);
  EXPECT_EQ(cache.DepthInterest(cloud, grid, two), first);
  const std::vector<float> bounds = stack::FarthestCountedDepths_m(cloud, grid, one.Info().P);
  EXPECT_TRUE(
      std::equal(bounds.begin(), bounds.end(), first->pixels_m().begin(), first->pixels_m().end()));

  EXPECT_NE(cache.DepthInterest(stack::PointCloudParams{}, grid, one), first);
  stack::ObstacleGridParams nearer = grid;
  nearer.x_min_m -= 0.1;
  nearer.x_max_m -= 0.1;
  EXPECT_NE(cache.DepthInterest(cloud, nearer, one), first);
  EXPECT_EQ(cache.DepthInterest(cloud, grid, two), first);
}

}  // namespace
}  // namespace autonomsim::sim
