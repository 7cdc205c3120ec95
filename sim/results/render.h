// `autonomsim render SCENARIO --car ID --at T --out DIR`: what one car's cameras see at one
// instant of a scenario, written as DIR/<camera name>/{color.png, depth.png, depth_preview.png,
// camera_info.json}.
//
// The world at T comes from running the scenario's closed loop up to T. The seam is WorldSnapshot,
// a plain struct: anything that can say where the cars are and which obstacles stand at T can
// feed the renderer (today SnapshotAt below; later a Simulation accessor).
#pragma once

#include <Eigen/Geometry>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "sim/car/sensors.h"
#include "sim/core/random.h"
#include "sim/scenario/scenario.h"
#include "vehicle/camera_model.h"
#include "vehicle/ray_caster.h"
#include "world/time.h"
#include "world/track.h"

namespace autonomsim::sim {

// The world at one instant, as the cameras need it.
struct WorldSnapshot {
  Time t{};
  std::vector<CarBody> cars;                    // every car: id, pose, body size
  std::vector<vehicle::ObstacleBox> obstacles;  // those present at t
};

// Runs `scenario` from 0 to t (0 <= t <= its duration; std::invalid_argument otherwise) and
// returns the world at t, exactly as the full run has it then. Until Simulation offers RunUntil
// and a read-only view of its world, this runs the scenario with its duration cut to t and one
// trajectory sample at t: the sample is taken at t before the (skipped) physics step of t, and
// nothing before t depends on the duration or the sampling period.
WorldSnapshot SnapshotAt(const LoadedScenario& scenario, Time t);
// The world at each of `times` (ascending, each within the scenario's duration, all whole
// milliseconds; std::invalid_argument otherwise), from one run up to the last: its trajectory is
// sampled at the instants' greatest common divisor.
std::vector<WorldSnapshot> SnapshotsAt(const LoadedScenario& scenario,
                                       const std::vector<Time>& times);

// The world at t with the cars (in scenario order) at `poses`: their bodies from the scenario, and
// the obstacles present at t.
WorldSnapshot SnapshotWithPoses(const Scenario& scenario, const std::vector<world::Pose2>& poses,
                                Time t);

// One camera's picture.
struct RenderedCamera {
  std::string name;
  std::string topic;
  bool has_color{false};  // what its stream publishes (CameraStreamParams::publish_color / _depth):
  bool has_depth{false};  // the folder holds only those images
  vehicle::CameraParams params;
  vehicle::CameraInfo info;
  Eigen::Isometry3d X_map_camera{Eigen::Isometry3d::Identity()};  // optical frame
  vehicle::ColorImage color;
  vehicle::DepthImage depth;
  // Ground-truth labels (render --labels), one byte per pixel, row-major, empty unless asked for:
  // the class of the surface each pixel sees (CarCameras::ClassNames) and the object (0: none,
  // k: the k-th of CarCameras::InstancesJson). From the ray caster's geometry whatever made the
  // images: the GL backend's images agree with them except at edges (gl_camera.h).
  std::vector<std::uint8_t> classes;
  std::vector<std::uint8_t> instances;
};

// One car's cameras (the colour and the depth camera of `sensors`) over a track, made once and
// rendered at any number of snapshots (a video's frames).
class CarCameras {
 public:
  // vehicle::GlUnavailable for kGl where no OpenGL ES context can be made.
  CarCameras(const world::Track& track, const SensorSuiteParams& sensors,
             const vehicle::SceneAppearance& appearance,
             CameraBackend backend = CameraBackend::kRayCast);
  // Every camera on car `car_id` in the snapshot (the car's own body is left out). Noise follows
  // each camera's noise params, seeded from the stream "car<id>/<camera name>/render_noise".
  // std::invalid_argument if the car is not in the snapshot.
  std::vector<RenderedCamera> Render(const WorldSnapshot& snapshot, int car_id,
                                     const RngStreams& streams, bool labels = false) const;
  // The label classes by id: "none" (the surround, nothing within the far clip), "floor", then
  // "line:<colour>" for each paint colour of the track (its colors_rgb, by name), "car",
  // "obstacle".
  const std::vector<std::string>& ClassNames() const { return class_names_; }
  // The objects car `car_id`'s cameras can see in the snapshot, instance ids 1, 2, ...: [{id,
  // kind: "car", car} or {id, kind: "obstacle", name}], in the order the renderer takes them.
  nlohmann::json InstancesJson(const WorldSnapshot& snapshot, int car_id) const;

 private:
  std::uint8_t ClassOf(const vehicle::Bgr& floor_colour) const;

  struct Camera {
    const CameraStreamParams* stream;
    std::unique_ptr<vehicle::CameraRenderer> renderer;
    std::unique_ptr<vehicle::GlCameraRenderer> gl;  // the GL backend's, or null
  };
  SensorSuiteParams sensors_;
  vehicle::SceneAppearance appearance_;
  std::vector<Camera> cameras_;
  std::vector<std::string> class_names_;
  std::vector<std::pair<vehicle::Bgr, std::uint8_t>> paint_classes_;  // paint colour -> class
};

// CarCameras(track, sensors, appearance).Render(snapshot, car_id, streams).
std::vector<RenderedCamera> RenderCameras(const world::Track& track, const WorldSnapshot& snapshot,
                                          int car_id, const SensorSuiteParams& sensors,
                                          const vehicle::SceneAppearance& appearance,
                                          const RngStreams& streams,
                                          CameraBackend backend = CameraBackend::kRayCast);

// camera_info.json: width, height, distortion_model, K, D, R, P (row-major) as the camera
// publishes them, and X_map_camera (4×4 row-major, optical frame: z forward, x right, y down).
nlohmann::json CameraInfoJson(const RenderedCamera& camera, Time t, int car_id);

// The depth image in false colour over the camera's clip range (near: red, far: blue); no return
// is black. BGR8, row-major.
std::vector<std::uint8_t> DepthPreview(const vehicle::DepthImage& depth, double near_m,
                                       double far_m);

// DepthPreview with a colour bar on its right: the false colours from near (top) to far
// (bottom) with metre ticks, a black "no return" swatch, and the title "depth (m)". BGR8.
cv::Mat DepthPreviewWithColourBar(const vehicle::DepthImage& depth, double near_m, double far_m);
inline constexpr int kColourBarPanelWidthPx = 110;  // the panel added to the right

// Writes the folder (under a temporary name, renamed when complete; a previous folder there is
// replaced). std::runtime_error if a file cannot be written.
void WriteRenderFolder(const std::vector<RenderedCamera>& cameras, Time t, int car_id,
                       const std::filesystem::path& out_dir, bool force = false);

// One instant's cameras, with their labels' legend where they carry labels.
struct RenderedInstant {
  Time t{};
  std::vector<RenderedCamera> cameras;
  nlohmann::json instances;  // CarCameras::InstancesJson; null without labels
};
// The same for several instants: one instant as above; several, one sub-folder each, named
// t_<seconds, 4 digits . 3 digits> (t_0012.500). Cameras with labels add labels.png (class per
// pixel) and instances.png (object per pixel), and the instant's folder labels.json: the class
// names by id (`class_names`) and the instances.
void WriteRenderFolder(const std::vector<RenderedInstant>& instants, int car_id,
                       const std::vector<std::string>& class_names,
                       const std::filesystem::path& out_dir, bool force = false);
// The sub-folder WriteRenderFolder names an instant by, among several.
std::string InstantFolderName(Time t);

}  // namespace autonomsim::sim
