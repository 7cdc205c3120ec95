// Sensor sampling: topics and sizes, rates and phases, lazy camera frames (identical whether
// rendered or not), seeded noise, and the other sensors in a small driving world.
#include "sim/car/sensors.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <memory>
#include <optional>
#include <vector>

#include "sim/core/config.h"
#include "sim/core/priorities.h"
#include "sim/core/track_loader.h"
#include "world/floor_raster.h"

namespace autonomsim::sim {
namespace {

std::uint64_t Fnv1a(const void* data, std::size_t bytes) {
  const auto* p = static_cast<const unsigned char*>(data);
  std::uint64_t h = 0xcbf29ce484222325ULL;
  for (std::size_t i = 0; i < bytes; ++i) {
    h ^= p[i];
    h *= 0x100000001b3ULL;
  }
  return h;
}

const world::FloorRaster& LabFloor() {
  static const world::FloorRaster raster =
      world::RasterizeFloor(LoadTrack("scenarios/tracks/lab.yaml"));
  return raster;
}

// Two cars on the lab track's outer south lane, car 1 ahead of car 0, a box beside the lane; the
// physics world steps on the kernel and both cars drive slowly ahead.
struct DrivingWorld {
  explicit DrivingWorld(std::uint64_t seed, SensorSuiteParams params = {})
      : physics(vehicle::PhysicsParams{}), streams(seed) {
    physics.AddCar(0, vehicle::CarParams{}, world::Pose2{0.2, -2.17, 0.0});
    physics.AddCar(1, vehicle::CarParams{}, world::Pose2{1.6, -2.17, 0.0});
    physics.AddObstacle(vehicle::ObstacleBox{"box", {1.0, -1.8, 0.3}, 0.2, 0.2, 0.2}, true);
    physics.car(0).SetCommand({.throttle = 0.15, .curvature_per_m = 0.0});
    physics.car(1).SetCommand({.throttle = 0.1, .curvature_per_m = 0.0});
    environment =
        std::make_unique<SensorEnvironment>(&physics, LabFloor(), vehicle::SceneAppearance{});
    kernel.SchedulePeriodic(
        kZeroTime, physics.step(), [this] { physics.Step(); }, kPriorityPhysics);
    for (int id : {0, 1}) {
      suites.push_back(std::make_unique<SensorSuite>(&kernel, environment.get(), id, params,
                                                     streams, physics.step()));
    }
  }

  Kernel kernel;
  vehicle::PhysicsWorld physics;
  RngStreams streams;
  std::unique_ptr<SensorEnvironment> environment;
  std::vector<std::unique_ptr<SensorSuite>> suites;
};

SensorSuiteParams WithCameraNoise() {
  SensorSuiteParams params;
  params.color_camera.noise.enabled = true;
  params.depth_camera.noise.enabled = true;
  return params;
}

TEST(SensorParamsTest, DefaultsValidateAndBadValuesNameTheirPath) {
  EXPECT_NO_THROW(SensorSuiteParams{}.Validate());
  SensorSuiteParams params;
  params.depth_camera.camera.clip_near_m = -1.0;
  try {
    params.Validate();
    FAIL() << "no error";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("depth_camera.camera.clip_near_m"));
  }
  params = SensorSuiteParams{};
  params.imu.rate_hz = 0.0;
  EXPECT_THROW(params.Validate(), std::invalid_argument);
  params = SensorSuiteParams{};
  params.depth_camera.camera.name = params.color_camera.camera.name;
  EXPECT_THROW(params.Validate(), std::invalid_argument);
}

TEST(SensorParamsTest, ScenarioFilesCanSetEveryKey) {
  // the resolved form (JSON, which is YAML) reads back to the same params
  const nlohmann::json resolved = ToJson(SensorSuiteParams{});
  EXPECT_EQ(resolved["depth_camera"]["topic"], "/depth/image_raw");
  EXPECT_EQ(resolved["color_camera"]["camera"]["K"].size(), 9u);
  EXPECT_EQ(resolved["wheel_speed"]["encoder"]["standstill_timeout_s"], 0.5);
  const ConfigSource source{"sensors.yaml", {}};
  const auto back = ReadConfig<SensorSuiteParams>(YAML::Load(resolved.dump()), source);
  EXPECT_EQ(ToJson(back), resolved);
  // a partial file changes only what it names; a misspelt key is an error naming its path
  const auto noisy = ReadConfig<SensorSuiteParams>(
      YAML::Load("{color_camera: {noise: {enabled: true}, camera: {mount: {pitch_deg: 20}}}}"),
      source);
  EXPECT_TRUE(noisy.color_camera.noise.enabled);
  EXPECT_EQ(noisy.color_camera.camera.mount.pitch_deg, 20.0);
  EXPECT_EQ(noisy.color_camera.camera.K, vehicle::ColorCameraParams().K);
  try {
    ReadConfig<SensorSuiteParams>(YAML::Load("{depth_camera: {camera: {mount: {pich_deg: 1}}}}"),
                                  source);
    FAIL() << "no error";
  } catch (const ConfigError& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("depth_camera.camera.mount"));
    EXPECT_THAT(e.what(), ::testing::HasSubstr("pitch_deg"));
  }
}

TEST(SensorSuiteTest, StreamsUseTheRealTopicsAndMessageSizes) {
  DrivingWorld world(1);
  const SensorSuite& suite = *world.suites[0];
  EXPECT_EQ(suite.color_stream().topic, "/image");
  EXPECT_EQ(suite.color_stream().type.name, "Image640rgb");
  EXPECT_EQ(suite.color_stream().type.bytes, 921600);
  EXPECT_EQ(suite.depth_stream().topic, "/depth/image_raw");
  EXPECT_EQ(suite.depth_stream().type.name, "Image640mono");
  EXPECT_EQ(suite.depth_stream().type.bytes, 614400);
  EXPECT_EQ(suite.params().depth_camera.info_topic, "/depth/camera_info");
  EXPECT_EQ(suite.imu_stream().topic, "/bno055/imu");
  EXPECT_EQ(suite.wheel_speed_stream().topic, "/modelcar/speed");
  EXPECT_EQ(suite.range_stream().topic, "/modelcar/front_range");
  EXPECT_EQ(suite.color_stream().period, Duration{33333333});  // 30 fps
  EXPECT_EQ(suite.depth_stream().period, Duration{33333333});
  EXPECT_EQ(suite.imu_stream().period, Milliseconds(10));  // 100 Hz
  EXPECT_EQ(suite.wheel_speed_stream().period, Milliseconds(100));
  EXPECT_EQ(suite.range_stream().period, Milliseconds(100));

  // a rendered frame has exactly the published size
  std::vector<CameraFrame> color_frames, depth_frames;
  world.suites[0]->OnColorFrame([&](const CameraFrame& f) { color_frames.push_back(f); });
  world.suites[0]->OnDepthFrame([&](const CameraFrame& f) { depth_frames.push_back(f); });
  world.kernel.RunUntil(Milliseconds(100));
  ASSERT_FALSE(color_frames.empty());
  ASSERT_FALSE(depth_frames.empty());
  vehicle::ColorImage color;
  vehicle::DepthImage depth;
  color_frames[0].Render(&color, nullptr);
  depth_frames[0].Render(nullptr, &depth);
  EXPECT_EQ(static_cast<std::int64_t>(color.bgr.size()), color_frames[0].bytes());
  EXPECT_EQ(static_cast<std::int64_t>(depth.mm.size() * 2), depth_frames[0].bytes());
  EXPECT_EQ(color_frames[0].bytes(), 921600);
  EXPECT_EQ(depth_frames[0].bytes(), 614400);
  EXPECT_EQ(color_frames[0].topic(), "/image");
}

TEST(SensorSuiteTest, SensorsSampleAtTheirRatesFromAPerCarPhase) {
  DrivingWorld world(3);
  std::map<int, std::vector<Time>> color, depth, imu, speed, range;
  for (int id : {0, 1}) {
    SensorSuite& suite = *world.suites[static_cast<std::size_t>(id)];
    suite.OnColorFrame([&, id](const CameraFrame& f) {
      EXPECT_EQ(f.stamp, world.kernel.Now());
      EXPECT_EQ(f.car_id, id);
      EXPECT_EQ(f.sequence, color[id].size());
      color[id].push_back(f.stamp);
    });
    suite.OnDepthFrame([&, id](const CameraFrame& f) { depth[id].push_back(f.stamp); });
    suite.OnImu([&, id](const vehicle::ImuReading& r) { imu[id].push_back(r.stamp); });
    suite.OnWheelSpeed([&, id](const WheelSpeedMessage& m) { speed[id].push_back(m.stamp); });
    suite.OnRange([&, id](const RangeMessage& m) { range[id].push_back(m.stamp); });
  }
  world.kernel.RunUntil(std::chrono::seconds(2) - Duration{1});
  for (int id : {0, 1}) {
    const SensorSuite& suite = *world.suites[static_cast<std::size_t>(id)];
    EXPECT_EQ(color[id].size(), 60u);
    EXPECT_EQ(depth[id].size(), 60u);
    EXPECT_EQ(imu[id].size(), 200u);
    EXPECT_EQ(speed[id].size(), 20u);
    EXPECT_EQ(range[id].size(), 20u);
    EXPECT_LT(suite.color_stream().first, suite.color_stream().period);
    for (std::size_t k = 0; k < color[id].size(); ++k) {
      EXPECT_EQ(color[id][k], suite.color_stream().first +
                                  static_cast<std::int64_t>(k) * suite.color_stream().period);
    }
  }
  // the phases are per car (and per sensor)
  EXPECT_NE(world.suites[0]->color_stream().first, world.suites[1]->color_stream().first);
  EXPECT_NE(world.suites[0]->color_stream().first, world.suites[0]->depth_stream().first);
}

// Renders the frames of both cameras of car 0 whose sequence numbers `render` picks; returns the
// images' hashes by (camera, sequence).
std::map<std::pair<int, std::uint64_t>, std::uint64_t> RenderSome(
    std::uint64_t seed, const std::function<bool(std::uint64_t)>& render, std::uint64_t* rendered) {
  DrivingWorld world(seed, WithCameraNoise());
  std::map<std::pair<int, std::uint64_t>, std::uint64_t> hashes;
  vehicle::ColorImage color;
  vehicle::DepthImage depth;
  world.suites[0]->OnColorFrame([&](const CameraFrame& f) {
    if (!render(f.sequence)) return;
    f.Render(&color, nullptr);
    hashes[{0, f.sequence}] = Fnv1a(color.bgr.data(), color.bgr.size());
  });
  world.suites[0]->OnDepthFrame([&](const CameraFrame& f) {
    if (!render(f.sequence)) return;
    f.Render(nullptr, &depth);
    hashes[{1, f.sequence}] = Fnv1a(depth.mm.data(), depth.mm.size() * 2);
  });
  world.kernel.RunUntil(std::chrono::seconds(1));
  *rendered = world.suites[0]->color_camera().frames_rendered() +
              world.suites[0]->depth_camera().frames_rendered();
  return hashes;
}

TEST(SensorSuiteTest, FramesNobodyProcessesAreNotRenderedAndNothingElseChanges) {
  std::uint64_t rendered_all = 0;
  std::uint64_t rendered_some = 0;
  const auto all = RenderSome(
      5, [](std::uint64_t) { return true; }, &rendered_all);
  const auto some = RenderSome(
      5, [](std::uint64_t s) { return s % 3 == 1; }, &rendered_some);
  EXPECT_EQ(rendered_all, 60u);  // 30 + 30 in one second
  EXPECT_EQ(rendered_some, 20u);
  ASSERT_EQ(some.size(), 20u);
  for (const auto& [key, hash] : some) {
    ASSERT_TRUE(all.count(key)) << key.first << "/" << key.second;
    EXPECT_EQ(all.at(key), hash) << "camera " << key.first << " frame " << key.second;
  }
  // and the frames differ from each other: the cars move
  EXPECT_NE(all.at({0, 1}), all.at({0, 4}));
}

TEST(SensorSuiteTest, CameraNoiseIsSeeded) {
  std::uint64_t rendered = 0;
  const auto a = RenderSome(
      5, [](std::uint64_t s) { return s < 3; }, &rendered);
  const auto b = RenderSome(
      5, [](std::uint64_t s) { return s < 3; }, &rendered);
  const auto c = RenderSome(
      6, [](std::uint64_t s) { return s < 3; }, &rendered);
  EXPECT_EQ(a, b);
  // another seed: other phases and other noise, so other pictures
  for (const auto& [key, hash] : a) EXPECT_NE(c.at(key), hash);
}

TEST(SensorSuiteTest, WithoutNoiseAFrameIsTheRenderersExactPicture) {
  DrivingWorld world(2);
  std::vector<CameraFrame> frames;
  world.suites[0]->OnDepthFrame([&](const CameraFrame& f) { frames.push_back(f); });
  world.kernel.RunUntil(Milliseconds(500));
  ASSERT_GT(frames.size(), 10u);
  const CameraFrame& frame = frames.back();
  vehicle::DepthImage via_frame, direct;
  frame.Render(nullptr, &via_frame);
  vehicle::CameraRenderer renderer(std::make_shared<const vehicle::CameraRays>(
                                       vehicle::CameraModel(vehicle::DepthCameraParams())),
                                   std::make_shared<const vehicle::FloorTexture>(LabFloor()),
                                   vehicle::SceneAppearance{}.surround());
  renderer.Render(frame.X_map_car, frame.prisms, nullptr, &direct);
  EXPECT_EQ(via_frame.mm, direct.mm);
  // the frame holds the world of its instant: car 1 and the box, not car 0 itself
  ASSERT_EQ(frame.prisms.size(), 2u);
  EXPECT_EQ(frame.prisms[1].footprint.pose.x_m, 1.0);
}

TEST(SensorSuiteTest, LabelsAndTheDepthHistoryGiveTheFramesOwnPicture) {
  // The consumers' cheaper renderings of a frame: labels of its colours, and depth into a buffer
  // with its history, frame after frame; a blacked-out colour camera labels black; with colour
  // noise the labels are refused (the colour must be rendered).
  DrivingWorld world(2);
  std::vector<CameraFrame> colour_frames, depth_frames;
  world.suites[0]->OnColorFrame([&](const CameraFrame& f) { colour_frames.push_back(f); });
  world.suites[0]->OnDepthFrame([&](const CameraFrame& f) { depth_frames.push_back(f); });
  world.kernel.RunUntil(Milliseconds(1000));
  world.suites[0]->SetColorCameraFault(SensorSuite::CameraFault::kBlackout);
  world.kernel.RunUntil(Milliseconds(1200));
  ASSERT_GT(colour_frames.size(), 20u);
  ASSERT_TRUE(colour_frames.back().blackout);

  const int w = colour_frames.front().camera->Info().width;
  const int h = colour_frames.front().camera->Info().height;
  vehicle::RowSpans all;
  all.columns.assign(static_cast<std::size_t>(h), {0, w});
  const vehicle::ColourLabel label = [](const vehicle::Bgr& c) {
    return static_cast<std::uint8_t>(1 + (c[0] * 7 + c[1] * 3 + c[2]) % 251);
  };
  std::vector<std::uint8_t> labels(static_cast<std::size_t>(w) * h);
  for (const CameraFrame& frame : {colour_frames[5], colour_frames.back()}) {
    vehicle::ColorImage colour;
    frame.Render(&colour, nullptr);
    ASSERT_TRUE(frame.RenderLabels(all, label, vehicle::LabelView{labels.data(), w}));
    for (std::size_t i = 0; i < labels.size(); ++i) {
      ASSERT_EQ(labels[i], label({colour.bgr[3 * i], colour.bgr[3 * i + 1], colour.bgr[3 * i + 2]}))
          << "pixel " << i << (frame.blackout ? " (blackout)" : "");
    }
  }
  // a blackout's columns that may hold a label other than 0: all where black has one, else none
  std::vector<std::pair<int, int>> nonzero;
  const vehicle::ColourLabel lines = [](const vehicle::Bgr& c) {
    return static_cast<std::uint8_t>(c[0] > 200 ? 1 : 0);
  };
  ASSERT_TRUE(colour_frames.back().RenderLabels(all, label,
                                                vehicle::LabelView{labels.data(), w, &nonzero}));
  EXPECT_EQ(nonzero, all.columns);
  ASSERT_TRUE(colour_frames.back().RenderLabels(all, lines,
                                                vehicle::LabelView{labels.data(), w, &nonzero}));
  const std::vector<std::pair<int, int>> none(static_cast<std::size_t>(h), {0, 0});
  EXPECT_EQ(nonzero, none);

  vehicle::DepthImage buffer, whole;
  vehicle::DepthRowHistory history;
  for (const CameraFrame& frame : depth_frames) {
    frame.RenderDepth(&buffer, &history);
    frame.Render(nullptr, &whole);
    ASSERT_EQ(buffer.mm, whole.mm) << "frame " << frame.sequence;
  }

  DrivingWorld noisy(2, WithCameraNoise());
  std::optional<CameraFrame> noisy_frame;
  noisy.suites[0]->OnColorFrame([&](const CameraFrame& f) { noisy_frame = f; });
  noisy.kernel.RunUntil(Milliseconds(100));
  ASSERT_TRUE(noisy_frame.has_value());
  std::fill(labels.begin(), labels.end(), 7);
  EXPECT_FALSE(noisy_frame->RenderLabels(all, label, vehicle::LabelView{labels.data(), w}));
  EXPECT_EQ(std::count(labels.begin(), labels.end(), 7), w * h);  // nothing written
}

TEST(SensorSuiteTest, CamerasCanBeDrivenFromOutside) {
  // without their own timers the cameras publish nothing; frames captured at the stream's
  // instants equal those the timers would have published
  DrivingWorld timed(9);
  std::vector<CameraFrame> published;
  timed.suites[0]->OnDepthFrame([&](const CameraFrame& f) { published.push_back(f); });
  timed.kernel.RunUntil(Milliseconds(300));

  DrivingWorld driven(9);
  auto suite = std::make_unique<SensorSuite>(
      &driven.kernel, driven.environment.get(), 0, SensorSuiteParams{}, driven.streams,
      driven.physics.step(), SensorSuiteOptions{.camera_timers = false});
  driven.suites[0] = std::move(suite);  // replaces car 0's suite (its timers cancelled)
  std::vector<CameraFrame> captured;
  bool called = false;
  driven.suites[0]->OnDepthFrame([&](const CameraFrame&) { called = true; });
  const SensorStream& stream = driven.suites[0]->depth_stream();
  driven.kernel.SchedulePeriodic(
      stream.first, stream.period,
      [&] { captured.push_back(driven.suites[0]->CaptureDepthFrame()); }, kPrioritySensor);
  driven.kernel.RunUntil(Milliseconds(300));
  EXPECT_FALSE(called);
  ASSERT_EQ(captured.size(), published.size());
  vehicle::DepthImage a, b;
  for (std::size_t k = 0; k < captured.size(); ++k) {
    EXPECT_EQ(captured[k].stamp, published[k].stamp);
    EXPECT_EQ(captured[k].sequence, published[k].sequence);
    EXPECT_EQ(captured[k].noise_seed, published[k].noise_seed);
    captured[k].Render(nullptr, &a);
    published[k].Render(nullptr, &b);
    EXPECT_EQ(a.mm, b.mm) << k;
  }
}

TEST(SensorSuiteTest, ImuWheelSpeedAndRangeFollowTheCar) {
  DrivingWorld world(4);
  std::vector<vehicle::ImuReading> imu;
  std::vector<WheelSpeedMessage> speed;
  std::vector<RangeMessage> range;
  world.suites[0]->OnImu([&](const vehicle::ImuReading& r) { imu.push_back(r); });
  world.suites[0]->OnWheelSpeed([&](const WheelSpeedMessage& m) { speed.push_back(m); });
  world.suites[0]->OnRange([&](const RangeMessage& m) { range.push_back(m); });
  world.kernel.RunUntil(std::chrono::seconds(6));
  const vehicle::Car& car = world.physics.car(0);
  const vehicle::Car& ahead = world.physics.car(1);
  // wheel speed: the car has reached its steady speed; the reading is one pulse interval old
  ASSERT_FALSE(speed.empty());
  EXPECT_NEAR(speed.back().speed_mps, car.forward_speed_mps(), 0.02 * car.forward_speed_mps());
  EXPECT_EQ(speed.front().speed_mps, 0.0);  // before two pulses
  // IMU: heading and gravity
  ASSERT_FALSE(imu.empty());
  EXPECT_NEAR(imu.back().yaw_rad, car.pose().yaw_rad, 0.05);
  EXPECT_NEAR(imu.back().accel_z_mps2, 9.80665, 0.1);
  // ultrasonic: the gap to car 1's rear, from car 0's front bumper
  ASSERT_FALSE(range.empty());
  const double gap = ahead.pose().x_m - car.pose().x_m - vehicle::CarParams{}.length_m;
  EXPECT_NEAR(range.back().range_m, gap, 0.05);
  EXPECT_NEAR(range.back().field_of_view_rad, 0.366, 1e-12);
}

TEST(SensorSuiteTest, ScenePrismsLeaveOutTheOwnCar) {
  const vehicle::SceneAppearance appearance;
  const std::vector<CarBody> cars{{0, {0, 0, 0}, 0.5, 0.3, 0.2}, {3, {1, 0, 0}, 0.5, 0.3, 0.2}};
  const std::vector<vehicle::ObstacleBox> boxes{{"b", {2, 0, 0}, 0.2, 0.2, 0.4}};
  const auto prisms = ScenePrisms(cars, boxes, appearance, 0);
  ASSERT_EQ(prisms.size(), 2u);
  EXPECT_EQ(prisms[0].bgr, appearance.car_body(3));
  EXPECT_EQ(prisms[1].bgr, appearance.obstacle());
  EXPECT_EQ(prisms[1].height_m, 0.4);
}

}  // namespace
}  // namespace autonomsim::sim
