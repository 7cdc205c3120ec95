// The ray-cast cameras (issue 3). BM_RenderRgbd is the figure of merit: one 640×480 depth frame
// (the depth camera) and one 640×480 colour frame (the colour camera, lens distortion on) of a car
// on the lab track with another car and a box in view, on one thread. Target: <= 1 ms.
// BM_RenderRgbdCameras and BM_RenderRgbdGl: the ray caster and the GL backend side by side, at
// 640×480 and 1280×720, for 1 and 4 RGB-D cameras.
//
//     build/bin/bench_camera --benchmark_filter=BM_RenderRgbd
#include <benchmark/benchmark.h>

#include <memory>
#include <string>
#include <vector>

#include "sim/car/perception_nodes.h"
#include "sim/core/track_loader.h"
#include "stack/lane_detection.h"
#include "vehicle/camera_model.h"
#include "vehicle/gl_camera.h"
#include "vehicle/ray_caster.h"
#include "world/floor_raster.h"

namespace autonomsim {
namespace {

struct Scene {
  Scene() {
    const world::Track track =
        sim::LoadTrack(std::string(AUTONOMSIM_SOURCE_DIR) + "/scenarios/tracks/lab.yaml");
    floor = std::make_shared<const vehicle::FloorTexture>(world::RasterizeFloor(track));
    color_rays = std::make_shared<const vehicle::CameraRays>(
        vehicle::CameraModel(vehicle::ColorCameraParams()));
    depth_rays = std::make_shared<const vehicle::CameraRays>(
        vehicle::CameraModel(vehicle::DepthCameraParams()));
    const vehicle::SceneAppearance appearance;
    // the real car's start pose (reference §1), another car 1.2 m ahead on its lane, a box on the
    // lane's left edge
    prisms.push_back(
        vehicle::Prism{world::OrientedBox{world::Pose2{2.16, -2.17, 0.05}, 0.525, 0.296}, 0.2,
                       appearance.car_body(1)});
    prisms.push_back(vehicle::Prism{world::OrientedBox{world::Pose2{1.9, -1.95, 0.3}, 0.2, 0.2},
                                    0.2, appearance.obstacle()});
  }

  world::Pose2 pose{0.96, -2.18, 0.0};
  std::shared_ptr<const vehicle::FloorTexture> floor;
  std::shared_ptr<const vehicle::CameraRays> color_rays;
  std::shared_ptr<const vehicle::CameraRays> depth_rays;
  std::vector<vehicle::Prism> prisms;
};

const Scene& TheScene() {
  static const Scene scene;
  return scene;
}

vehicle::CameraRenderer Renderer(const std::shared_ptr<const vehicle::CameraRays>& rays) {
  return vehicle::CameraRenderer(rays, TheScene().floor, vehicle::SceneAppearance{}.surround());
}

void BM_RenderRgbd(benchmark::State& state) {
  const Scene& scene = TheScene();
  vehicle::CameraRenderer color_camera = Renderer(scene.color_rays);
  vehicle::CameraRenderer depth_camera = Renderer(scene.depth_rays);
  vehicle::ColorImage color;
  vehicle::DepthImage depth;
  for (auto _ : state) {
    color_camera.Render(scene.pose, scene.prisms, &color, nullptr);
    depth_camera.Render(scene.pose, scene.prisms, nullptr, &depth);
    benchmark::DoNotOptimize(color.bgr.data());
    benchmark::DoNotOptimize(depth.mm.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations());
  state.SetBytesProcessed(state.iterations() *
                          static_cast<std::int64_t>(color.bgr.size() + 2 * depth.mm.size()));
}
BENCHMARK(BM_RenderRgbd)->Unit(benchmark::kMicrosecond);

// RGB-D cameras at a resolution, N of them: the ray caster against the rasteriser (issue 20).
// A camera is a colour and a depth camera, as on the car: at 640×480 the real ones (the colour
// camera with its lens distortion); at 1280×720 the same at twice the focal length, cropped to
// 16:9. Camera k sits on car k's pose (the scene's car, then along the lane behind it), so four
// cameras see four different frames.
struct RgbdRig {
  std::vector<std::shared_ptr<const vehicle::CameraRays>> color, depth;  // one of each per size
  std::vector<world::Pose2> poses;
};

vehicle::CameraParams AtSize(vehicle::CameraParams params, int width, int height) {
  if (width == params.width_px && height == params.height_px) return params;
  const double scale = static_cast<double>(width) / params.width_px;
  params.K[0] *= scale;
  params.K[4] *= scale;
  params.K[2] = scale * (params.K[2] + 0.5) - 0.5;
  params.K[5] = scale * (params.K[5] + 0.5) - 0.5 - 0.5 * (scale * params.height_px - height);
  params.P = {params.K[0], 0.0, params.K[2], 0.0, 0.0, params.K[4],
              params.K[5], 0.0, 0.0,         0.0, 1.0, 0.0};
  params.width_px = width;
  params.height_px = height;
  return params;
}

RgbdRig Rig(int width, int height, int cameras) {
  RgbdRig rig;
  rig.color.push_back(std::make_shared<const vehicle::CameraRays>(
      vehicle::CameraModel(AtSize(vehicle::ColorCameraParams(), width, height))));
  rig.depth.push_back(std::make_shared<const vehicle::CameraRays>(
      vehicle::CameraModel(AtSize(vehicle::DepthCameraParams(), width, height))));
  for (int k = 0; k < cameras; ++k) {
    world::Pose2 pose = TheScene().pose;
    pose.x_m -= 0.35 * k;
    rig.poses.push_back(pose);
  }
  return rig;
}

// The benchmark's loop: each camera's colour and depth frame, with either backend's renderers.
template <class Renderer>
void RenderRigFrames(benchmark::State& state, const RgbdRig& rig, Renderer& color_camera,
                     Renderer& depth_camera) {
  vehicle::ColorImage color;
  vehicle::DepthImage depth;
  for (auto _ : state) {
    for (const world::Pose2& pose : rig.poses) {
      color_camera.Render(pose, TheScene().prisms, &color, nullptr);
      depth_camera.Render(pose, TheScene().prisms, nullptr, &depth);
      benchmark::DoNotOptimize(color.bgr.data());
      benchmark::DoNotOptimize(depth.mm.data());
    }
    benchmark::ClobberMemory();
  }
  const auto cameras = static_cast<std::int64_t>(rig.poses.size());
  state.SetItemsProcessed(state.iterations() * cameras);  // RGB-D frames
  state.counters["Mpx_per_s"] =
      benchmark::Counter(2.0 * color.width * color.height * static_cast<double>(cameras) * 1e-6,
                         benchmark::Counter::kIsIterationInvariantRate);
}

void BM_RenderRgbdCameras(benchmark::State& state) {
  const int width = static_cast<int>(state.range(0)), height = static_cast<int>(state.range(1));
  const int cameras = static_cast<int>(state.range(2));
  const RgbdRig rig = Rig(width, height, cameras);
  vehicle::CameraRenderer color_camera = Renderer(rig.color[0]);
  vehicle::CameraRenderer depth_camera = Renderer(rig.depth[0]);
  RenderRigFrames(state, rig, color_camera, depth_camera);
}

// The same frames from the GL backend (vehicle/gl_camera.h), read back to the CPU. Its label
// names the renderer (llvmpipe on a machine without a GPU; a GPU's name where one is lent). Skipped
// with a message where no OpenGL ES context can be made.
void BM_RenderRgbdGl(benchmark::State& state) {
  const int width = static_cast<int>(state.range(0)), height = static_cast<int>(state.range(1));
  const int cameras = static_cast<int>(state.range(2));
  std::shared_ptr<vehicle::GlScene> scene;
  try {
    scene = std::make_shared<vehicle::GlScene>(vehicle::GlContext::Create(), *TheScene().floor,
                                               vehicle::SceneAppearance{}.surround());
  } catch (const vehicle::GlUnavailable& e) {
    state.SkipWithError(e.what());
    return;
  }
  const RgbdRig rig = Rig(width, height, cameras);
  vehicle::GlCameraRenderer color_camera(scene, rig.color[0]);
  vehicle::GlCameraRenderer depth_camera(scene, rig.depth[0]);
  RenderRigFrames(state, rig, color_camera, depth_camera);
  state.SetLabel(scene->context().renderer());
}

void RgbdSizes(benchmark::internal::Benchmark* b) {
  b->ArgNames({"width", "height", "cameras"});
  for (const auto& [w, h] : {std::pair{640, 480}, std::pair{1280, 720}}) {
    for (const int cameras : {1, 4}) b->Args({w, h, cameras});
  }
  b->Unit(benchmark::kMillisecond)->UseRealTime();
}
BENCHMARK(BM_RenderRgbdCameras)->Apply(RgbdSizes);
BENCHMARK(BM_RenderRgbdGl)->Apply(RgbdSizes);

// The colour camera as the lane nodes render it in the loop: only the pixels the lane detector
// reads (its warp's source spans, a third of the image).
void BM_RenderColorLaneRegion(benchmark::State& state) {
  const Scene& scene = TheScene();
  vehicle::CameraRenderer color_camera = Renderer(scene.color_rays);
  const stack::LaneDetectorTables detector(stack::LaneDetectionParams{},
                                           sim::LaneCalibration(color_camera.camera()));
  const vehicle::RowSpans region = sim::LaneDetectorReads(detector, color_camera.camera().height());
  color_camera.set_common_floor_blocks(state.range(0) != 0);
  vehicle::ColorImage color;
  for (auto _ : state) {
    color_camera.Render(scene.pose, scene.prisms, &color, nullptr, region);
    benchmark::DoNotOptimize(color.bgr.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations());
  // the pixels asked for, and those filled as a block of the bare floor's colour, per frame
  double region_px = 0;
  for (const auto& [begin, end] : region.columns) region_px += end - begin;
  state.counters["region_px"] = region_px;
  state.counters["block_px"] = benchmark::Counter(
      static_cast<double>(color_camera.common_floor_pixels()), benchmark::Counter::kAvgIterations);
}
// /1: bare floor blocks filled at once (the default); /0: every pixel looked up
BENCHMARK(BM_RenderColorLaneRegion)
    ->ArgName("blocks")
    ->Arg(1)
    ->Arg(0)
    ->Unit(benchmark::kMicrosecond);

// The colour camera as the lane nodes render it in the loop now: the line class of each pixel the
// detector reads (CameraRenderer::RenderLabels), straight into the class image the detector hands
// out (LaneDetector::MutableClassRegion).
void BM_RenderLaneLabels(benchmark::State& state) {
  const Scene& scene = TheScene();
  vehicle::CameraRenderer color_camera = Renderer(scene.color_rays);
  stack::LaneDetector detector(stack::LaneDetectionParams{},
                               sim::LaneCalibration(color_camera.camera()));
  const vehicle::RowSpans region =
      sim::LaneDetectorReads(*detector.tables(), color_camera.camera().height());
  const vehicle::ColourLabel line_class = sim::LaneLineClass(detector.tables());
  const stack::ClassImageRegion classes = detector.MutableClassRegion();
  const vehicle::LabelView out{classes.pixels.data(), classes.stride};
  for (auto _ : state) {
    color_camera.RenderLabels(scene.pose, scene.prisms, region, line_class, out);
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_RenderLaneLabels)->Unit(benchmark::kMicrosecond);

// The same without prisms: the floor alone.
void BM_RenderRgbdEmptyTrack(benchmark::State& state) {
  const Scene& scene = TheScene();
  vehicle::CameraRenderer color_camera = Renderer(scene.color_rays);
  vehicle::CameraRenderer depth_camera = Renderer(scene.depth_rays);
  vehicle::ColorImage color;
  vehicle::DepthImage depth;
  for (auto _ : state) {
    color_camera.Render(scene.pose, {}, &color, nullptr);
    depth_camera.Render(scene.pose, {}, nullptr, &depth);
    benchmark::DoNotOptimize(color.bgr.data());
    benchmark::DoNotOptimize(depth.mm.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_RenderRgbdEmptyTrack)->Unit(benchmark::kMicrosecond);

void BM_RenderColor(benchmark::State& state) {
  const Scene& scene = TheScene();
  vehicle::CameraRenderer camera = Renderer(scene.color_rays);
  vehicle::ColorImage color;
  for (auto _ : state) {
    camera.Render(scene.pose, scene.prisms, &color, nullptr);
    benchmark::DoNotOptimize(color.bgr.data());
    benchmark::ClobberMemory();
  }
}
BENCHMARK(BM_RenderColor)->Unit(benchmark::kMicrosecond);

void BM_RenderDepth(benchmark::State& state) {
  const Scene& scene = TheScene();
  vehicle::CameraRenderer camera = Renderer(scene.depth_rays);
  vehicle::DepthImage depth;
  for (auto _ : state) {
    camera.Render(scene.pose, scene.prisms, nullptr, &depth);
    benchmark::DoNotOptimize(depth.mm.data());
    benchmark::ClobberMemory();
  }
}
BENCHMARK(BM_RenderDepth)->Unit(benchmark::kMicrosecond);

// The depth camera as the obstacle nodes render it in the loop: one buffer frame after frame, with
// its DepthRowHistory (only the rows a prism covered last frame go back to the bare floor).
void BM_RenderDepthWithHistory(benchmark::State& state) {
  const Scene& scene = TheScene();
  vehicle::CameraRenderer camera = Renderer(scene.depth_rays);
  vehicle::DepthImage depth;
  vehicle::DepthRowHistory history;
  for (auto _ : state) {
    camera.RenderDepth(scene.pose, scene.prisms, &depth, &history);
    benchmark::DoNotOptimize(depth.mm.data());
    benchmark::ClobberMemory();
  }
}
BENCHMARK(BM_RenderDepthWithHistory)->Unit(benchmark::kMicrosecond);

// The same with the scene's other car moving, as cars do in the loop: 2 cm forward and 1 cm to
// the left per frame, a cycle of 16 frames (frame 0 follows the last one).
void BM_RenderDepthWithHistoryMoving(benchmark::State& state) {
  const Scene& scene = TheScene();
  vehicle::CameraRenderer camera = Renderer(scene.depth_rays);
  vehicle::DepthImage depth;
  vehicle::DepthRowHistory history;
  std::vector<vehicle::Prism> prisms = scene.prisms;
  int k = 0;
  for (auto _ : state) {
    prisms[0].footprint.pose.x_m = scene.prisms[0].footprint.pose.x_m + 0.02 * k;
    prisms[0].footprint.pose.y_m = scene.prisms[0].footprint.pose.y_m + 0.01 * k;
    camera.RenderDepth(scene.pose, prisms, &depth, &history);
    benchmark::DoNotOptimize(depth.mm.data());
    benchmark::ClobberMemory();
    k = (k + 1) % 16;
  }
}
BENCHMARK(BM_RenderDepthWithHistoryMoving)->Unit(benchmark::kMicrosecond);

// An RGB-D frame with the seeded noise on (both images).
void BM_RenderRgbdWithNoise(benchmark::State& state) {
  const Scene& scene = TheScene();
  vehicle::CameraRenderer color_camera = Renderer(scene.color_rays);
  vehicle::CameraRenderer depth_camera = Renderer(scene.depth_rays);
  vehicle::CameraNoiseParams noise;
  noise.enabled = true;
  const vehicle::CameraParams color_params = vehicle::ColorCameraParams();
  const vehicle::CameraParams depth_params = vehicle::DepthCameraParams();
  vehicle::ColorImage color;
  vehicle::DepthImage depth;
  std::uint64_t seed = 0;
  for (auto _ : state) {
    color_camera.Render(scene.pose, scene.prisms, &color, nullptr);
    vehicle::AddCameraNoise(noise, color_params, ++seed, &color, nullptr);
    depth_camera.Render(scene.pose, scene.prisms, nullptr, &depth);
    vehicle::AddCameraNoise(noise, depth_params, seed, nullptr, &depth);
    benchmark::DoNotOptimize(color.bgr.data());
    benchmark::DoNotOptimize(depth.mm.data());
    benchmark::ClobberMemory();
  }
}
BENCHMARK(BM_RenderRgbdWithNoise)->Unit(benchmark::kMicrosecond);

// Once per distinct camera of a run: the per-pixel tables (lens undistortion included).
void BM_BuildColorCameraRays(benchmark::State& state) {
  const vehicle::CameraModel model(vehicle::ColorCameraParams());
  for (auto _ : state) {
    vehicle::CameraRays rays(model);
    benchmark::DoNotOptimize(rays.dir_x().data());
  }
}
BENCHMARK(BM_BuildColorCameraRays)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace autonomsim
