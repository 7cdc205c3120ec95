// The lane detector's tables are built once per distinct parameters and camera, and shared.
#include "sim/car/perception_nodes.h"

#include <gtest/gtest.h>

#include "vehicle/camera_model.h"

namespace autonomsim::sim {
namespace {

TEST(LaneTablesCacheTest, CarsWithTheSameParametersAndCameraShareOneTable) {
  LaneTablesCache cache;
  const stack::LaneDetectionParams params;
  const vehicle::CameraModel camera(vehicle::ColorCameraParams());
  const auto first = cache.Get(params, camera);
  EXPECT_EQ(cache.Get(params, vehicle::CameraModel(vehicle::ColorCameraParams())), first);

  stack::LaneDetectionParams other_params;
  other_params.yellow_min_px += 1;
  EXPECT_NE(cache.Get(other_params, camera), first);
  vehicle::CameraParams other_camera = vehicle::ColorCameraParams();
  other_camera.mount.pitch_deg += 1.0;
  const auto moved = cache.Get(params, vehicle::CameraModel(other_camera));
  EXPECT_NE(moved, first);
  EXPECT_EQ(cache.Get(params, camera), first);
  EXPECT_EQ(cache.Get(params, vehicle::CameraModel(other_camera)), moved);
}

}  // namespace
}  // namespace autonomsim::sim
