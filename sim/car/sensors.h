// A car's sensors in the closed loop: when each one samples (rates, per-car phases), what it
// publishes (the real topic names and message sizes) and the seeded noise streams. The sensor
// models themselves are pure (vehicle/); this file wraps them in time, Drake-style: a sample is a
// pure function of the world at the sample instant.
//
// Cameras are lazy. A frame is published as a CameraFrame: its stamp, the car's pose and the
// prisms it could see at that instant, and a noise seed; the pixels are rendered only when a node
// that takes the frame calls Render. A frame no node processes (dropped from a keep-last queue,
// or no subscriber at all) is never rendered, and because rendering depends on nothing but the
// frame, results are identical whether it is or not.
//
// Random streams (all derived from the scenario seed, sim/core/random.h), for car N:
//   carN/<camera name>/phase, carN/<camera name>/noise (one seed drawn per frame, rendered or not),
//   carN/imu/phase, carN/imu/bias, carN/imu/noise, carN/wheel_speed/phase, carN/ultrasonic/phase,
//   carN/ultrasonic/noise; and one for the run, not the car: lab/magnetic_field (the field that
//   distorts every car's magnetometer heading, vehicle/imu.h).
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "sim/car/sensor_config.h"
#include "sim/core/built_once.h"
#include "sim/core/kernel.h"
#include "sim/core/priorities.h"
#include "sim/core/random.h"
#include "vehicle/camera_model.h"
#include "vehicle/gl_camera.h"
#include "vehicle/imu.h"
#include "vehicle/physics_world.h"
#include "vehicle/ray_caster.h"
#include "vehicle/ultrasonic.h"
#include "vehicle/wheel_encoder.h"
#include "world/floor_raster.h"
#include "world/time.h"

namespace autonomsim::sim {

// Priorities: sim/core/priorities.h (kPrioritySensorIntegrate, kPrioritySensor).
// The sensors' parameters (SensorSuiteParams and its streams): sim/car/sensor_config.h.

// The message types the sensors publish, with their sizes on the wire. Images: reference §8. The
// others are not in the reference; their sizes are the ROS 2 messages' fixed fields (header stamp,
// no frame_id string, no CDR padding): ours, for the transport model.
struct SensorMessageType {
  std::string name;
  std::int64_t bytes{0};
};
SensorMessageType ColorImageType();  // Image640rgb, 921,600 B (reference §8)
SensorMessageType DepthImageType();  // Image640mono, 614,400 B (reference §8; mono16 640×480)
SensorMessageType ImuType();         // sensor_msgs/Imu, 304 B
SensorMessageType WheelSpeedType();  // geometry_msgs/TwistWithCovarianceStamped, 344 B
SensorMessageType RangeType();       // sensor_msgs/Range, 25 B

// What the sensors of every car share: the world they look at, the floor's texture, the scene's
// colours, the per-pixel ray tables (one per distinct camera, however many cars carry it), and,
// with the GL backend, the scene in an OpenGL ES context.
class SensorEnvironment {
 public:
  // `physics` is not owned and must outlive the environment and every suite and frame using it.
  // `backend`: kGl, the cameras render with the rasteriser (vehicle/gl_camera.h) instead of the
  // ray caster; vehicle::GlUnavailable if no OpenGL ES context can be made here.
  SensorEnvironment(const vehicle::PhysicsWorld* physics, const world::FloorRaster& floor,
                    const vehicle::SceneAppearance& appearance,
                    CameraBackend backend = CameraBackend::kRayCast);

  const vehicle::PhysicsWorld& physics() const { return *physics_; }
  const vehicle::SceneAppearance& appearance() const { return appearance_; }
  const std::shared_ptr<const vehicle::FloorTexture>& floor() const { return floor_; }
  // The GL backend's scene; null with the ray caster.
  const std::shared_ptr<vehicle::GlScene>& gl_scene() const { return gl_scene_; }
  // Built on first use for these params, then shared.
  std::shared_ptr<const vehicle::CameraRays> Rays(const vehicle::CameraParams& camera);
  // Every other car and every enabled obstacle, now.
  std::vector<vehicle::Prism> PrismsSeenBy(int car_id) const;

 private:
  const vehicle::PhysicsWorld* physics_;
  vehicle::SceneAppearance appearance_;
  std::shared_ptr<const vehicle::FloorTexture> floor_;
  BuiltOnce<vehicle::CameraParams, vehicle::CameraRays> rays_;
  std::shared_ptr<vehicle::GlScene> gl_scene_;
};

// A car body or obstacle box as the sensors see it.
struct CarBody {
  int id{0};
  world::Pose2 pose;
  double length_m{0.0};
  double width_m{0.0};
  double height_m{0.0};
};
// The prisms of a scene: the cars other than `exclude_car_id` (their body colours from
// `appearance`), then the obstacles (all of those given: pass only the present ones).
std::vector<vehicle::Prism> ScenePrisms(const std::vector<CarBody>& cars,
                                        const std::vector<vehicle::ObstacleBox>& obstacles,
                                        const vehicle::SceneAppearance& appearance,
                                        int exclude_car_id);

class CameraSensor;

// One published camera frame: cheap to copy; its pixels are rendered on demand.
struct CameraFrame {
  const CameraSensor* camera{nullptr};  // the suite's; the frame must not outlive the suite
  int car_id{0};
  std::uint64_t sequence{0};  // 0, 1, 2, ... per camera
  Time stamp{};               // the sample instant (header.stamp)
  world::Pose2 X_map_car;
  std::vector<vehicle::Prism> prisms;  // what the camera could see then
  std::uint64_t noise_seed{0};
  bool blackout{false};  // a camera_blackout fault: every pixel 0 (depth 0: no return), no noise

  // The frame's images (either may be null), noise included when it is on; the buffers are
  // reused (no allocation once they have their size). Identical for the same frame every time.
  void Render(vehicle::ColorImage* color, vehicle::DepthImage* depth) const;
  // The same with the colour computed only where a consumer reads it (vehicle::RowSpans): those
  // pixels are Render's, bit for bit; the others are left as the buffer held them.
  void Render(vehicle::ColorImage* color, vehicle::DepthImage* depth,
              const vehicle::RowSpans& color_region) const;
  // The depth image alone, into a buffer `history` describes (vehicle::DepthRowHistory): Render's
  // image, with only the rows that can have changed since the buffer's last frame rewritten;
  // exact within `interest`'s bounds (null: everywhere), as vehicle::CameraRenderer::RenderDepth.
  void RenderDepth(vehicle::DepthImage* depth, vehicle::DepthRowHistory* history,
                   const vehicle::DepthInterest* interest = nullptr) const;
  // label(colour) of each `region` pixel (vehicle::CameraRenderer::RenderLabels), without the
  // colour image. False, and nothing written, where a pixel's colour is not the scene's own (the
  // colour noise is on): render the colour then.
  bool RenderLabels(const vehicle::RowSpans& region, const vehicle::ColourLabel& label,
                    vehicle::LabelView out) const;
  // Whether RenderLabels renders from the scene alone (false: it would return false), and
  // whether `prism` may cover a pixel of this frame (vehicle::CameraRenderer::MaySee): two such
  // frames with the same pose, blackout and prisms it may see have the same labels.
  bool LabelsFromScene() const;
  bool MaySee(const vehicle::Prism& prism, const vehicle::DepthInterest* interest = nullptr) const;
  // The same for RenderDepth: false where its image is not the scene's alone (depth noise, the GL
  // backend).
  bool DepthFromScene() const;
  const std::string& topic() const;
  std::int64_t bytes() const;  // of the message on the topic
};

// A camera of one car: its model, its renderer and its stream. With the GL backend its images
// come whole from the rasteriser: a colour region is rendered with the rest of the image, labels
// are not rendered on their own (RenderLabels is false: the consumer labels the colour image),
// and a depth buffer's history is forgotten each frame.
class CameraSensor {
 public:
  CameraSensor(SensorEnvironment* environment, const CameraStreamParams& params);

  const CameraStreamParams& params() const { return params_; }
  const vehicle::CameraModel& model() const { return renderer_.camera(); }
  vehicle::CameraInfo Info() const { return model().Info(); }
  std::uint64_t frames_rendered() const { return frames_rendered_; }
  const vehicle::CameraRays& rays() const { return renderer_.rays(); }

  void Render(const CameraFrame& frame, vehicle::ColorImage* color, vehicle::DepthImage* depth,
              const vehicle::RowSpans* color_region = nullptr) const;
  void RenderDepth(const CameraFrame& frame, vehicle::DepthImage* depth,
                   vehicle::DepthRowHistory* history, const vehicle::DepthInterest* interest) const;
  bool RenderLabels(const CameraFrame& frame, const vehicle::RowSpans& region,
                    const vehicle::ColourLabel& label, vehicle::LabelView out) const;
  bool LabelsFromScene() const { return !params_.noise.AltersColor() && gl_ == nullptr; }
  bool DepthFromScene() const { return !params_.noise.AltersDepth() && gl_ == nullptr; }
  bool MaySee(const CameraFrame& frame, const vehicle::Prism& prism,
              const vehicle::DepthInterest* interest) const {
    return renderer_.MaySee(frame.X_map_car, prism, interest);
  }

 private:
  CameraStreamParams params_;
  mutable vehicle::CameraRenderer renderer_;               // scratch memory only: rendering is pure
  mutable std::unique_ptr<vehicle::GlCameraRenderer> gl_;  // the GL backend's, or null
  mutable std::uint64_t frames_rendered_{0};
};

struct WheelSpeedMessage {
  Time stamp{};
  double speed_mps{0.0};  // twist.twist.linear.x, >= 0 (a Hall sensor has no direction)
};

struct RangeMessage {
  Time stamp{};
  double range_m{0.0};  // REP-117: +inf nothing within max_range_m, -inf nearer than min_range_m
  double min_range_m{0.0};
  double max_range_m{0.0};
  double field_of_view_rad{0.0};
};

// When and where a sensor publishes.
struct SensorStream {
  std::string topic;
  SensorMessageType type;
  Time first{};  // the first sample: the per-car phase
  Duration period{};
};

struct SensorSuiteOptions {
  // false: the cameras do not sample on their own timers; whoever drives them (e.g. a node
  // graph's source node, ticking at color_stream().first + k · period) calls CaptureColorFrame /
  // CaptureDepthFrame at those instants instead. The other sensors always run on their timers.
  bool camera_timers{true};
};

// All sensors of one car, sampling on `kernel` from construction on. Subscribe before running the
// kernel; a callback runs in the sample's event, at the sample instant. The kernel, the
// environment and the physics world must outlive the suite, and the suite every CameraFrame.
class SensorSuite {
 public:
  // `physics_step`: the physics world's step, which the wheel encoder integrates over.
  SensorSuite(Kernel* kernel, SensorEnvironment* environment, int car_id,
              const SensorSuiteParams& params, const RngStreams& streams, Duration physics_step,
              SensorSuiteOptions options = {});
  SensorSuite(const SensorSuite&) = delete;
  SensorSuite& operator=(const SensorSuite&) = delete;
  ~SensorSuite();

  void OnColorFrame(std::function<void(const CameraFrame&)> callback);
  void OnDepthFrame(std::function<void(const CameraFrame&)> callback);
  void OnImu(std::function<void(const vehicle::ImuReading&)> callback);
  void OnWheelSpeed(std::function<void(const WheelSpeedMessage&)> callback);
  void OnRange(std::function<void(const RangeMessage&)> callback);

  // A camera frame of the world now (stamp = the kernel's Now()), the next in its camera's
  // sequence; what the camera timers publish. Each call draws the frame's noise seed.
  CameraFrame CaptureColorFrame();
  CameraFrame CaptureDepthFrame();

  // Faults (sim/loop/faults.h). A frozen camera publishes its last frame again (same pixels, pose
  // and scene) with each new stamp; a blacked-out one publishes black frames. kNone ends either.
  // Stamps, sequences and noise seeds go on as without the fault.
  enum class CameraFault { kNone, kFreeze, kBlackout };
  void SetColorCameraFault(CameraFault fault) { color_state_.fault = fault; }
  void SetDepthCameraFault(CameraFault fault) { depth_state_.fault = fault; }
  // From now on the gyro reads `rad_per_s` more (vehicle::StepGyroBias); steps add up.
  void StepGyroBias(double rad_per_s);

  int car_id() const { return car_id_; }
  const SensorSuiteParams& params() const { return params_; }
  const CameraSensor& color_camera() const { return *color_; }
  const CameraSensor& depth_camera() const { return *depth_; }
  const SensorStream& color_stream() const { return color_stream_; }
  const SensorStream& depth_stream() const { return depth_stream_; }
  const SensorStream& imu_stream() const { return imu_stream_; }
  const SensorStream& wheel_speed_stream() const { return wheel_speed_stream_; }
  const SensorStream& range_stream() const { return range_stream_; }

 private:
  struct CameraState {
    Rng noise;
    std::uint64_t sequence{0};
    CameraFault fault{CameraFault::kNone};
    std::optional<CameraFrame> last;  // the last frame with a scene, for a freeze
  };
  // The frame's header (sequence, stamp, noise seed), and with `scene` its world.
  CameraFrame Capture(const CameraSensor& camera, CameraState* state, bool scene);
  void SampleCamera(const CameraSensor& camera, CameraState* state,
                    const std::vector<std::function<void(const CameraFrame&)>>& callbacks);
  void SampleImu();
  void IntegrateWheel();
  void SampleWheelSpeed();
  void SampleRange();

  Kernel* kernel_;
  SensorEnvironment* environment_;
  int car_id_;
  SensorSuiteParams params_;
  Duration physics_step_;
  std::unique_ptr<CameraSensor> color_;
  std::unique_ptr<CameraSensor> depth_;
  SensorStream color_stream_, depth_stream_, imu_stream_, wheel_speed_stream_, range_stream_;
  CameraState color_state_;
  CameraState depth_state_;
  Rng imu_noise_;
  vehicle::ImuState imu_state_;
  vehicle::WheelEncoderState wheel_state_;
  Rng range_noise_;
  std::vector<EventId> timers_;
  std::vector<std::function<void(const CameraFrame&)>> on_color_, on_depth_;
  std::vector<std::function<void(const vehicle::ImuReading&)>> on_imu_;
  std::vector<std::function<void(const WheelSpeedMessage&)>> on_wheel_speed_;
  std::vector<std::function<void(const RangeMessage&)>> on_range_;
};

}  // namespace autonomsim::sim
