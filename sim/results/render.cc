#include "sim/results/render.h"

#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <memory>
#include <numbers>
#include <numeric>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "sim/core/files.h"
#include "sim/loop/simulation.h"
#include "sim/results/png.h"
#include "world/floor_raster.h"
#include "world/validation.h"

namespace autonomsim::sim {
namespace {

namespace fs = std::filesystem;

template <std::size_t N>
nlohmann::json Array(const std::array<double, N>& values) {
  return nlohmann::json(std::vector<double>(values.begin(), values.end()));
}

}  // namespace

WorldSnapshot SnapshotWithPoses(const Scenario& scenario, const std::vector<world::Pose2>& poses,
                                Time t) {
  if (poses.size() != scenario.cars.size()) {
    throw std::invalid_argument("SnapshotWithPoses: " + std::to_string(poses.size()) +
                                " poses for " + std::to_string(scenario.cars.size()) + " cars");
  }
  WorldSnapshot snapshot;
  snapshot.t = t;
  for (const ObstacleConfig& o : scenario.obstacles) {
    if (!o.PresentAt(t)) continue;
    snapshot.obstacles.push_back(vehicle::ObstacleBox{
        o.name, world::Pose2{o.x_m, o.y_m, o.yaw_deg * std::numbers::pi / 180.0}, o.length_m,
        o.width_m, o.height_m});
  }
  for (std::size_t i = 0; i < scenario.cars.size(); ++i) {
    const CarConfig& car = scenario.cars[i];
    snapshot.cars.push_back(
        CarBody{car.id, poses[i], car.vehicle.length_m, car.vehicle.width_m, car.vehicle.height_m});
  }
  return snapshot;
}

WorldSnapshot SnapshotAt(const LoadedScenario& scenario, Time t) {
  if (t < kZeroTime || t > scenario.scenario.duration) {
    throw std::invalid_argument("the instant " + Num(ToSeconds(t)) +
                                " s is outside the scenario's [0, " +
                                Num(ToSeconds(scenario.scenario.duration)) + "] s");
  }
  return SnapshotsAt(scenario, {t}).front();
}

std::vector<WorldSnapshot> SnapshotsAt(const LoadedScenario& scenario,
                                       const std::vector<Time>& times) {
  // the trajectory's period: one instant's own time; several, their common divisor in ms
  const Time ms = std::chrono::milliseconds(1);
  std::int64_t step_ms = 0;
  for (std::size_t k = 0; k < times.size(); ++k) {
    const Time t = times[k];
    if (t < kZeroTime || t > scenario.scenario.duration ||
        (times.size() > 1 && t % ms != Time{0}) || (k > 0 && t <= times[k - 1])) {
      throw std::invalid_argument(
          "the instants must ascend, be whole milliseconds and lie within the scenario's [0, " +
          Num(ToSeconds(scenario.scenario.duration)) + "] s; " + Num(ToSeconds(t)) + " s does not");
    }
    step_ms = std::gcd(step_ms, static_cast<std::int64_t>(t / ms));
  }
  std::vector<WorldSnapshot> out;
  if (times.empty()) return out;
  std::vector<world::Pose2> start_poses;
  for (const LoadedCar& car : scenario.cars) start_poses.push_back(car.start_pose);
  if (times.back() == kZeroTime) {
    return {SnapshotWithPoses(scenario.scenario, start_poses, kZeroTime)};
  }
  LoadedScenario cut = scenario;
  cut.scenario.duration = times.back();
  // samples at 0, the period, ...: each instant's is taken before the (skipped) physics step of
  // that instant, and nothing before it depends on the duration or the sampling period
  cut.scenario.output.trajectory_period = times.size() == 1 ? times.back() : step_ms * ms;
  Simulation simulation(cut);
  simulation.Run();
  for (const Time t : times) {
    std::vector<world::Pose2> poses = start_poses;
    for (std::size_t i = 0; i < cut.scenario.cars.size() && t > kZeroTime; ++i) {
      const int id = cut.scenario.cars[i].id;
      const auto& samples = simulation.record().trajectory;
      const auto sample =
          std::find_if(samples.begin(), samples.end(),
                       [&](const TrajectorySample& s) { return s.car == id && s.t == t; });
      if (sample == samples.end()) {
        throw std::logic_error("SnapshotsAt: no trajectory sample of car " + std::to_string(id) +
                               " at " + Num(ToSeconds(t)) + " s");
      }
      poses[i] = world::Pose2{sample->x_m, sample->y_m, sample->yaw_rad};
    }
    out.push_back(SnapshotWithPoses(scenario.scenario, poses, t));
  }
  return out;
}

CarCameras::CarCameras(const world::Track& track, const SensorSuiteParams& sensors,
                       const vehicle::SceneAppearance& appearance, CameraBackend backend)
    : sensors_(sensors), appearance_(appearance) {
  sensors_.Validate();
  appearance_.Validate();
  const auto floor = std::make_shared<const vehicle::FloorTexture>(world::RasterizeFloor(track));
  class_names_ = {"none", "floor"};
  for (const auto& [name, rgb] : track.spec().colors_rgb) {
    paint_classes_.emplace_back(
        vehicle::Bgr{static_cast<std::uint8_t>(rgb[2]), static_cast<std::uint8_t>(rgb[1]),
                     static_cast<std::uint8_t>(rgb[0])},
        static_cast<std::uint8_t>(class_names_.size()));
    class_names_.push_back("line:" + name);
  }
  class_names_.push_back("car");
  class_names_.push_back("obstacle");
  std::shared_ptr<vehicle::GlScene> scene;
  if (backend == CameraBackend::kGl) {
    scene = std::make_shared<vehicle::GlScene>(vehicle::GlContext::Create(), *floor,
                                               appearance_.surround());
  }
  for (const CameraStreamParams* stream : {&sensors_.color_camera, &sensors_.depth_camera}) {
    const auto rays =
        std::make_shared<const vehicle::CameraRays>(vehicle::CameraModel(stream->camera));
    cameras_.push_back(
        {stream, std::make_unique<vehicle::CameraRenderer>(rays, floor, appearance_.surround()),
         scene != nullptr ? std::make_unique<vehicle::GlCameraRenderer>(scene, rays) : nullptr});
  }
}

std::uint8_t CarCameras::ClassOf(const vehicle::Bgr& floor_colour) const {
  for (const auto& [bgr, id] : paint_classes_) {
    if (bgr == floor_colour) return id;
  }
  return 1;  // the bare floor
}

nlohmann::json CarCameras::InstancesJson(const WorldSnapshot& snapshot, int car_id) const {
  nlohmann::json out = nlohmann::json::array();
  for (const CarBody& car : snapshot.cars) {  // ScenePrisms' order: the other cars, the obstacles
    if (car.id != car_id) {
      out.push_back({{"id", out.size() + 1}, {"kind", "car"}, {"car", car.id}});
    }
  }
  for (const vehicle::ObstacleBox& box : snapshot.obstacles) {
    out.push_back({{"id", out.size() + 1}, {"kind", "obstacle"}, {"name", box.name}});
  }
  return out;
}

std::vector<RenderedCamera> CarCameras::Render(const WorldSnapshot& snapshot, int car_id,
                                               const RngStreams& streams, bool labels) const {
  const auto self = std::find_if(snapshot.cars.begin(), snapshot.cars.end(),
                                 [&](const CarBody& c) { return c.id == car_id; });
  if (self == snapshot.cars.end()) {
    throw std::invalid_argument("no car " + std::to_string(car_id) + " in the scenario");
  }
  const std::vector<vehicle::Prism> prisms =
      ScenePrisms(snapshot.cars, snapshot.obstacles, appearance_, car_id);
  std::vector<RenderedCamera> out;
  for (const Camera& c : cameras_) {
    const vehicle::CameraModel& model = c.renderer->camera();
    RenderedCamera camera;
    camera.name = c.stream->camera.name;
    camera.topic = c.stream->topic;
    camera.has_color = c.stream->publish_color;
    camera.has_depth = c.stream->publish_depth;
    camera.params = c.stream->camera;
    camera.info = model.Info();
    camera.X_map_camera = model.X_map_camera(self->pose);
    if (c.gl != nullptr) {
      c.gl->Render(self->pose, prisms, &camera.color, &camera.depth);
    } else {
      c.renderer->Render(self->pose, prisms, &camera.color, &camera.depth);
    }
    const std::uint64_t seed =
        streams.Stream("car" + std::to_string(car_id) + "/" + camera.name + "/render_noise")
            .NextU64();
    vehicle::AddCameraNoise(c.stream->noise, c.stream->camera, seed, &camera.color, &camera.depth);
    if (labels) {
      if (prisms.size() > 255) {
        throw std::invalid_argument("labels: more than 255 objects in view");
      }
      const int w = camera.params.width_px, h = camera.params.height_px;
      const vehicle::RowSpans all{
          std::vector<std::pair<int, int>>(static_cast<std::size_t>(h), std::pair{0, w})};
      std::vector<std::uint8_t> prism_classes, prism_ids;
      const std::uint8_t car_class = static_cast<std::uint8_t>(class_names_.size() - 2);
      for (std::size_t k = 0; k < prisms.size(); ++k) {
        const bool is_car = k + snapshot.obstacles.size() < prisms.size();
        prism_classes.push_back(is_car ? car_class : static_cast<std::uint8_t>(car_class + 1));
        prism_ids.push_back(static_cast<std::uint8_t>(k + 1));
      }
      const vehicle::Bgr surround = appearance_.surround();
      camera.classes.resize(static_cast<std::size_t>(w) * h);
      camera.instances.resize(camera.classes.size());
      c.renderer->RenderLabels(
          self->pose, prisms, all,
          [&](const vehicle::Bgr& bgr) { return bgr == surround ? std::uint8_t{0} : ClassOf(bgr); },
          {camera.classes.data(), w}, prism_classes);
      c.renderer->RenderLabels(
          self->pose, prisms, all, [](const vehicle::Bgr&) { return std::uint8_t{0}; },
          {camera.instances.data(), w}, prism_ids);
    }
    out.push_back(std::move(camera));
  }
  return out;
}

std::vector<RenderedCamera> RenderCameras(const world::Track& track, const WorldSnapshot& snapshot,
                                          int car_id, const SensorSuiteParams& sensors,
                                          const vehicle::SceneAppearance& appearance,
                                          const RngStreams& streams, CameraBackend backend) {
  return CarCameras(track, sensors, appearance, backend).Render(snapshot, car_id, streams);
}

nlohmann::json CameraInfoJson(const RenderedCamera& camera, Time t, int car_id) {
  nlohmann::json X = nlohmann::json::array();
  const Eigen::Matrix4d m = camera.X_map_camera.matrix();
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) X.push_back(m(r, c));
  }
  nlohmann::json info = {
      {"camera", camera.name},
      {"car", car_id},
      {"t_s", ToSeconds(t)},
      {"topic", camera.topic},
      {"width", camera.info.width},
      {"height", camera.info.height},
      {"distortion_model", camera.info.distortion_model},
      {"K", Array(camera.info.K)},
      {"D", Array(camera.info.D)},
      {"R", Array(camera.info.R)},
      {"P", Array(camera.info.P)},
      {"X_map_camera", X},
      {"frames",
       "map: x east, y north, z up; camera: optical, z forward, x right, y down; matrices "
       "row-major"},
      {"lens_distortion", camera.params.lens_distortion},
  };
  if (camera.has_depth) {
    info["depth"] = "depth.png: uint16 millimetres of optical z (not ray length), 0 = no return";
    info["clip_near_m"] = camera.params.clip_near_m;
    info["clip_far_m"] = camera.params.clip_far_m;
  }
  info["images"] = nlohmann::json::array();
  if (camera.has_color) info["images"].push_back("color.png");
  if (camera.has_depth) info["images"].push_back("depth.png");
  if (!camera.classes.empty()) {
    info["images"].push_back("labels.png");
    info["images"].push_back("instances.png");
  }
  return info;
}

std::vector<std::uint8_t> DepthPreview(const vehicle::DepthImage& depth, double near_m,
                                       double far_m) {
  cv::Mat grey(depth.height, depth.width, CV_8UC1);
  const double near_mm = 1000.0 * near_m;
  const double span_mm = 1000.0 * (far_m - near_m);
  for (int v = 0; v < depth.height; ++v) {
    for (int u = 0; u < depth.width; ++u) {
      const std::uint16_t mm = depth.mm[static_cast<std::size_t>(v) * depth.width + u];
      // TURBO runs blue (0) to red (255): near is red
      const double f = std::clamp((mm - near_mm) / span_mm, 0.0, 1.0);
      grey.at<std::uint8_t>(v, u) = static_cast<std::uint8_t>(std::lround(255.0 * (1.0 - f)));
    }
  }
  cv::Mat colour;
  cv::applyColorMap(grey, colour, cv::COLORMAP_TURBO);
  std::vector<std::uint8_t> bgr(colour.data, colour.data + colour.total() * 3);
  for (std::size_t i = 0; i < depth.mm.size(); ++i) {
    if (depth.mm[i] == 0) std::fill_n(bgr.begin() + static_cast<std::ptrdiff_t>(3 * i), 3, 0);
  }
  return bgr;
}

cv::Mat DepthPreviewWithColourBar(const vehicle::DepthImage& depth, double near_m, double far_m) {
  std::vector<std::uint8_t> preview = DepthPreview(depth, near_m, far_m);
  cv::Mat out(depth.height, depth.width + kColourBarPanelWidthPx, CV_8UC3, cv::Scalar(40, 40, 40));
  cv::Mat(depth.height, depth.width, CV_8UC3, preview.data())
      .copyTo(out(cv::Rect(0, 0, depth.width, depth.height)));
  // the bar: the preview's own mapping of each row's depth, near at the top
  const int bar_x = depth.width + 10, bar_w = 22, top = 30, bottom = depth.height - 60;
  vehicle::DepthImage ramp;
  ramp.width = 1;
  ramp.height = bottom - top + 1;
  for (int r = 0; r < ramp.height; ++r) {
    const double m = near_m + (far_m - near_m) * r / std::max(1, ramp.height - 1);
    ramp.mm.push_back(static_cast<std::uint16_t>(std::lround(1000.0 * m)));
  }
  const std::vector<std::uint8_t> colours = DepthPreview(ramp, near_m, far_m);
  for (int r = 0; r < ramp.height; ++r) {
    const cv::Vec3b c(colours[3 * r], colours[3 * r + 1], colours[3 * r + 2]);
    out(cv::Rect(bar_x, top + r, bar_w, 1)).setTo(cv::Scalar(c[0], c[1], c[2]));
  }
  const cv::Scalar white(255, 255, 255);
  const int font = cv::FONT_HERSHEY_SIMPLEX;
  cv::putText(out, "depth (m)", {depth.width + 6, 18}, font, 0.45, white, 1, cv::LINE_AA);
  // ticks every metre (every 0.5 m under 3 m of range), and the clip limits
  const double step = far_m - near_m < 3.0 ? 0.5 : 1.0;
  auto tick = [&](double m) {
    const int y =
        top + static_cast<int>(std::lround((m - near_m) / (far_m - near_m) * (bottom - top)));
    cv::line(out, {bar_x + bar_w, y}, {bar_x + bar_w + 5, y}, white, 1);
    cv::putText(out, fmt::format("{:g}", m), {bar_x + bar_w + 8, y + 4}, font, 0.4, white, 1,
                cv::LINE_AA);
  };
  tick(near_m);
  for (double m = std::ceil(near_m / step) * step; m < far_m - 0.5 * step; m += step) {
    if (m > near_m + 0.5 * step) tick(m);  // not crowding the limits
  }
  tick(far_m);
  // no return
  out(cv::Rect(bar_x, depth.height - 40, bar_w, 14)).setTo(cv::Scalar(0, 0, 0));
  cv::rectangle(out, cv::Rect(bar_x, depth.height - 40, bar_w, 14), white, 1);
  cv::putText(out, "no return", {bar_x + bar_w + 6, depth.height - 29}, font, 0.4, white, 1,
              cv::LINE_AA);
  return out;
}

void WriteRenderFolder(const std::vector<RenderedCamera>& cameras, Time t, int car_id,
                       const fs::path& out_dir, bool force) {
  WriteRenderFolder({RenderedInstant{t, cameras, nullptr}}, car_id, {}, out_dir, force);
}

std::string InstantFolderName(Time t) { return fmt::format("t_{:08.3f}", ToSeconds(t)); }

void WriteRenderFolder(const std::vector<RenderedInstant>& instants, int car_id,
                       const std::vector<std::string>& class_names, const fs::path& out_dir,
                       bool force) {
  WriteFolderAtomically(
      out_dir,
      [&](const fs::path& partial) {
        for (const RenderedInstant& instant : instants) {
          const fs::path root =
              instants.size() == 1 ? partial : partial / InstantFolderName(instant.t);
          fs::create_directories(root);
          const Time t = instant.t;
          bool labelled = false;
          for (const RenderedCamera& camera : instant.cameras) {
            const fs::path dir = root / camera.name;
            fs::create_directory(dir);
            // OpenCV only reads through the Mats: the const_casts lend it our buffers
            if (camera.has_color) {
              WritePng(dir / "color.png",
                       cv::Mat(camera.color.height, camera.color.width, CV_8UC3,
                               const_cast<std::uint8_t*>(camera.color.bgr.data())));
            }
            if (camera.has_depth) {
              WritePng(dir / "depth.png",
                       cv::Mat(camera.depth.height, camera.depth.width, CV_16UC1,
                               const_cast<std::uint16_t*>(camera.depth.mm.data())));
              WritePng(dir / "depth_preview.png",
                       DepthPreviewWithColourBar(camera.depth, camera.params.clip_near_m,
                                                 camera.params.clip_far_m));
            }
            if (!camera.classes.empty()) {
              labelled = true;
              const int w = camera.params.width_px, h = camera.params.height_px;
              WritePng(dir / "labels.png",
                       cv::Mat(h, w, CV_8UC1, const_cast<std::uint8_t*>(camera.classes.data())));
              WritePng(dir / "instances.png",
                       cv::Mat(h, w, CV_8UC1, const_cast<std::uint8_t*>(camera.instances.data())));
            }
            WriteFile(dir / "camera_info.json", CameraInfoJson(camera, t, car_id).dump(2) + "\n");
          }
          if (labelled) {
            const nlohmann::json legend = {
                {"t_s", ToSeconds(t)},
                {"car", car_id},
                {"images",
                 "<camera>/labels.png: each pixel's class id (mono8); <camera>/instances.png: "
                 "each pixel's instance id, 0 for none (mono8); ground truth from the scene's "
                 "geometry"},
                {"classes", class_names},
                {"instances", instant.instances}};
            WriteFile(root / "labels.json", legend.dump(2) + "\n");
          }
        }
      },
      force, OutputKind::kRender);
}

}  // namespace autonomsim::sim
