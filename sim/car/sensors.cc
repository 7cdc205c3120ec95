#include "sim/car/sensors.h"

#include <cmath>
#include <cstring>
#include <numbers>
#include <stdexcept>
#include <string>
#include <utility>

#include "world/validation.h"

namespace autonomsim::sim {
namespace {

Duration PeriodOf(double rate_hz) { return Duration{std::llround(1e9 / rate_hz)}; }

// A per-car phase in [0, period): whole milliseconds when the period is at least one, so that
// phases read well in traces (as the closed loop's own timers do).
Time PhaseOf(const RngStreams& streams, const std::string& name, Duration period) {
  Rng rng = streams.Stream(name);
  const double u = rng.Uniform01();
  const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(period).count();
  if (ms >= 1) {
    return std::chrono::milliseconds(static_cast<std::int64_t>(u * static_cast<double>(ms)));
  }
  return Duration{static_cast<std::int64_t>(u * static_cast<double>(period.count()))};
}

std::int64_t ImageBytes(const CameraStreamParams& p) {
  const std::int64_t pixels = static_cast<std::int64_t>(p.camera.width_px) * p.camera.height_px;
  return pixels * (p.publish_color ? 3 : 2);
}

SensorMessageType CameraMessageType(const CameraStreamParams& p) {
  const bool vga = p.camera.width_px == 640 && p.camera.height_px == 480;
  if (p.publish_color) return vga ? ColorImageType() : SensorMessageType{"Image", ImageBytes(p)};
  return vga ? DepthImageType() : SensorMessageType{"Image", ImageBytes(p)};
}

}  // namespace

SensorMessageType ColorImageType() { return {"Image640rgb", 640 * 480 * 3}; }
SensorMessageType DepthImageType() { return {"Image640mono", 640 * 480 * 2}; }
// stamp 8 + orientation 4·8 + 3 covariances 3·72 + angular velocity 3·8 + acceleration 3·8
SensorMessageType ImuType() { return {"sensor_msgs/Imu", 8 + 32 + 216 + 24 + 24}; }
// stamp 8 + twist 6·8 + covariance 36·8
SensorMessageType WheelSpeedType() {
  return {"geometry_msgs/TwistWithCovarianceStamped", 8 + 48 + 288};
}
// stamp 8 + radiation_type 1 + field_of_view, min_range, max_range, range 4·4
SensorMessageType RangeType() { return {"sensor_msgs/Range", 8 + 1 + 16}; }

SensorEnvironment::SensorEnvironment(const vehicle::PhysicsWorld* physics,
                                     const world::FloorRaster& floor,
                                     const vehicle::SceneAppearance& appearance,
                                     CameraBackend backend)
    : physics_(physics),
      appearance_(appearance),
      floor_(std::make_shared<const vehicle::FloorTexture>(floor)) {
  Require(physics_ != nullptr, "SensorEnvironment needs a physics world");
  appearance_.Validate();
  if (backend == CameraBackend::kGl) {
    gl_scene_ = std::make_shared<vehicle::GlScene>(vehicle::GlContext::Create(), *floor_,
                                                   appearance_.surround());
  }
}

std::shared_ptr<const vehicle::CameraRays> SensorEnvironment::Rays(
    const vehicle::CameraParams& camera) {
  return rays_.Get(camera, [&] {
    return std::make_shared<const vehicle::CameraRays>(vehicle::CameraModel(camera));
  });
}

std::vector<vehicle::Prism> SensorEnvironment::PrismsSeenBy(int car_id) const {
  std::vector<CarBody> cars;
  for (const int id : physics_->car_ids()) {
    const vehicle::Car& car = physics_->car(id);
    cars.push_back(CarBody{id, car.pose(), car.params().length_m, car.params().width_m,
                           car.params().height_m});
  }
  std::vector<vehicle::ObstacleBox> obstacles;
  for (std::size_t i = 0; i < physics_->obstacle_count(); ++i) {
    if (physics_->obstacle_enabled(i)) obstacles.push_back(physics_->obstacle(i));
  }
  return ScenePrisms(cars, obstacles, appearance_, car_id);
}

std::vector<vehicle::Prism> ScenePrisms(const std::vector<CarBody>& cars,
                                        const std::vector<vehicle::ObstacleBox>& obstacles,
                                        const vehicle::SceneAppearance& appearance,
                                        int exclude_car_id) {
  std::vector<vehicle::Prism> prisms;
  prisms.reserve(cars.size() + obstacles.size());
  for (const CarBody& car : cars) {
    if (car.id == exclude_car_id) continue;
    prisms.push_back(vehicle::Prism{world::OrientedBox{car.pose, car.length_m, car.width_m},
                                    car.height_m, appearance.car_body(car.id)});
  }
  for (const vehicle::ObstacleBox& box : obstacles) {
    prisms.push_back(vehicle::Prism{world::OrientedBox{box.pose, box.length_m, box.width_m},
                                    box.height_m, appearance.obstacle()});
  }
  return prisms;
}

namespace {
const CameraSensor& CameraOf(const CameraFrame& frame) {
  if (frame.camera == nullptr) {
    throw std::logic_error("CameraFrame::Render: the frame has no camera");
  }
  return *frame.camera;
}
}  // namespace

void CameraFrame::Render(vehicle::ColorImage* color, vehicle::DepthImage* depth) const {
  CameraOf(*this).Render(*this, color, depth);
}

void CameraFrame::Render(vehicle::ColorImage* color, vehicle::DepthImage* depth,
                         const vehicle::RowSpans& color_region) const {
  CameraOf(*this).Render(*this, color, depth, &color_region);
}

void CameraFrame::RenderDepth(vehicle::DepthImage* depth, vehicle::DepthRowHistory* history,
                              const vehicle::DepthInterest* interest) const {
  CameraOf(*this).RenderDepth(*this, depth, history, interest);
}

bool CameraFrame::RenderLabels(const vehicle::RowSpans& region, const vehicle::ColourLabel& label,
                               vehicle::LabelView out) const {
  return CameraOf(*this).RenderLabels(*this, region, label, out);
}

const std::string& CameraFrame::topic() const { return camera->params().topic; }

std::int64_t CameraFrame::bytes() const { return ImageBytes(camera->params()); }

CameraSensor::CameraSensor(SensorEnvironment* environment, const CameraStreamParams& params)
    : params_(params),
      renderer_(environment->Rays(params.camera), environment->floor(),
                environment->appearance().surround()) {
  params_.Validate();
  if (environment->gl_scene() != nullptr) {
    gl_ = std::make_unique<vehicle::GlCameraRenderer>(environment->gl_scene(),
                                                      environment->Rays(params.camera));
  }
}

void CameraSensor::Render(const CameraFrame& frame, vehicle::ColorImage* color,
                          vehicle::DepthImage* depth, const vehicle::RowSpans* color_region) const {
  if (frame.blackout) {
    const vehicle::CameraInfo info = Info();
    if (color != nullptr) {
      color->width = info.width;
      color->height = info.height;
      color->bgr.assign(static_cast<std::size_t>(info.width) * info.height * 3, 0);
    }
    if (depth != nullptr) {
      depth->width = info.width;
      depth->height = info.height;
      depth->mm.assign(static_cast<std::size_t>(info.width) * info.height, 0);
    }
    ++frames_rendered_;
    return;
  }
  if (gl_ != nullptr) {
    gl_->Render(frame.X_map_car, frame.prisms, color, depth);
  } else if (color_region != nullptr) {
    renderer_.Render(frame.X_map_car, frame.prisms, color, depth, *color_region);
  } else {
    renderer_.Render(frame.X_map_car, frame.prisms, color, depth);
  }
  vehicle::AddCameraNoise(params_.noise, params_.camera, frame.noise_seed, color, depth);
  ++frames_rendered_;
}

bool CameraFrame::LabelsFromScene() const { return CameraOf(*this).LabelsFromScene(); }

bool CameraFrame::DepthFromScene() const { return CameraOf(*this).DepthFromScene(); }

bool CameraFrame::MaySee(const vehicle::Prism& prism,
                         const vehicle::DepthInterest* interest) const {
  return CameraOf(*this).MaySee(*this, prism, interest);
}

bool CameraSensor::RenderLabels(const CameraFrame& frame, const vehicle::RowSpans& region,
                                const vehicle::ColourLabel& label, vehicle::LabelView out) const {
  if (!LabelsFromScene()) return false;
  if (frame.blackout) {  // every pixel black
    const std::uint8_t black = label(vehicle::Bgr{0, 0, 0});
    if (out.nonzero_columns != nullptr) {
      if (black != 0) {
        *out.nonzero_columns = region.columns;
      } else {
        out.nonzero_columns->assign(region.columns.size(), {0, 0});
      }
    }
    for (std::size_t v = 0; v < region.columns.size(); ++v) {
      const auto [begin, end] = region.columns[v];
      if (begin < end) {
        std::memset(out.origin + static_cast<std::ptrdiff_t>(v) * out.stride + begin, black,
                    static_cast<std::size_t>(end - begin));
      }
    }
  } else {
    renderer_.RenderLabels(frame.X_map_car, frame.prisms, region, label, out);
  }
  ++frames_rendered_;
  return true;
}

void CameraSensor::RenderDepth(const CameraFrame& frame, vehicle::DepthImage* depth,
                               vehicle::DepthRowHistory* history,
                               const vehicle::DepthInterest* interest) const {
  // not the bare floor plus prisms, or not rendered row by row
  if (frame.blackout || !DepthFromScene()) {
    Render(frame, nullptr, depth);
    history->Forget();
    return;
  }
  renderer_.RenderDepth(frame.X_map_car, frame.prisms, depth, history, interest);
  ++frames_rendered_;
}

SensorSuite::SensorSuite(Kernel* kernel, SensorEnvironment* environment, int car_id,
                         const SensorSuiteParams& params, const RngStreams& streams,
                         Duration physics_step, SensorSuiteOptions options)
    : kernel_(kernel),
      environment_(environment),
      car_id_(car_id),
      params_(params),
      physics_step_(physics_step),
      color_state_{streams.Stream("car" + std::to_string(car_id) + "/" +
                                  params.color_camera.camera.name + "/noise")},
      depth_state_{streams.Stream("car" + std::to_string(car_id) + "/" +
                                  params.depth_camera.camera.name + "/noise")},
      imu_noise_(streams.Stream("car" + std::to_string(car_id) + "/imu/noise")),
      range_noise_(streams.Stream("car" + std::to_string(car_id) + "/ultrasonic/noise")) {
  Require(kernel_ != nullptr && environment_ != nullptr, "SensorSuite needs a kernel and a world");
  Require(physics_step_ > Duration::zero(), "SensorSuite: physics_step must be > 0");
  params_.Validate();
  environment_->physics().car(car_id_);  // std::out_of_range for an unknown car
  color_ = std::make_unique<CameraSensor>(environment_, params_.color_camera);
  depth_ = std::make_unique<CameraSensor>(environment_, params_.depth_camera);

  const std::string car = "car" + std::to_string(car_id_) + "/";
  auto stream = [&](const std::string& name, const std::string& topic,
                    const SensorMessageType& type, double rate_hz) {
    const Duration period = PeriodOf(rate_hz);
    return SensorStream{topic, type,
                        kernel_->Now() + PhaseOf(streams, car + name + "/phase", period), period};
  };
  const CameraStreamParams& c = params_.color_camera;
  const CameraStreamParams& d = params_.depth_camera;
  color_stream_ = stream(c.camera.name, c.topic, CameraMessageType(c), c.rate_hz);
  depth_stream_ = stream(d.camera.name, d.topic, CameraMessageType(d), d.rate_hz);
  imu_stream_ = stream("imu", params_.imu.topic, ImuType(), params_.imu.rate_hz);
  wheel_speed_stream_ = stream("wheel_speed", params_.wheel_speed.topic, WheelSpeedType(),
                               params_.wheel_speed.rate_hz);
  range_stream_ =
      stream("ultrasonic", params_.ultrasonic.topic, RangeType(), params_.ultrasonic.rate_hz);

  Rng bias = streams.Stream(car + "imu/bias");
  const double gyro = bias.Normal(0.0, 1.0);
  const double accel_x = bias.Normal(0.0, 1.0);
  const double accel_y = bias.Normal(0.0, 1.0);
  // the lab's magnetic field: one per run, every car in it (no car prefix in the stream's name)
  Rng field = streams.Stream("lab/magnetic_field");
  const double phase_x = field.Uniform(0.0, 2.0 * std::numbers::pi);
  const double phase_y = field.Uniform(0.0, 2.0 * std::numbers::pi);
  imu_state_ =
      vehicle::InitialImuState(params_.imu.imu, {gyro, accel_x, accel_y}, {phase_x, phase_y});

  if (options.camera_timers) {
    timers_.push_back(kernel_->SchedulePeriodic(
        color_stream_.first, color_stream_.period,
        [this] { SampleCamera(*color_, &color_state_, on_color_); }, kPrioritySensor));
    timers_.push_back(kernel_->SchedulePeriodic(
        depth_stream_.first, depth_stream_.period,
        [this] { SampleCamera(*depth_, &depth_state_, on_depth_); }, kPrioritySensor));
  }
  timers_.push_back(kernel_->SchedulePeriodic(
      imu_stream_.first, imu_stream_.period, [this] { SampleImu(); }, kPrioritySensor));
  // the physics steps end at whole multiples of the step
  const Time first_step_end{(kernel_->Now().count() / physics_step_.count() + 1) *
                            physics_step_.count()};
  timers_.push_back(kernel_->SchedulePeriodic(
      first_step_end, physics_step_, [this] { IntegrateWheel(); }, kPrioritySensorIntegrate));
  timers_.push_back(kernel_->SchedulePeriodic(
      wheel_speed_stream_.first, wheel_speed_stream_.period, [this] { SampleWheelSpeed(); },
      kPrioritySensor));
  timers_.push_back(kernel_->SchedulePeriodic(
      range_stream_.first, range_stream_.period, [this] { SampleRange(); }, kPrioritySensor));
}

SensorSuite::~SensorSuite() {
  for (const EventId id : timers_) kernel_->Cancel(id);
}

void SensorSuite::OnColorFrame(std::function<void(const CameraFrame&)> callback) {
  on_color_.push_back(std::move(callback));
}
void SensorSuite::OnDepthFrame(std::function<void(const CameraFrame&)> callback) {
  on_depth_.push_back(std::move(callback));
}
void SensorSuite::OnImu(std::function<void(const vehicle::ImuReading&)> callback) {
  on_imu_.push_back(std::move(callback));
}
void SensorSuite::OnWheelSpeed(std::function<void(const WheelSpeedMessage&)> callback) {
  on_wheel_speed_.push_back(std::move(callback));
}
void SensorSuite::OnRange(std::function<void(const RangeMessage&)> callback) {
  on_range_.push_back(std::move(callback));
}

CameraFrame SensorSuite::Capture(const CameraSensor& camera, CameraState* state, bool scene) {
  CameraFrame frame;
  frame.camera = &camera;
  frame.car_id = car_id_;
  frame.sequence = state->sequence++;
  frame.stamp = kernel_->Now();
  // drawn for every frame, rendered or not, so that no frame's noise depends on which were
  frame.noise_seed = state->noise.NextU64();
  if (!scene) return frame;
  if (state->fault == CameraFault::kFreeze && state->last) {
    CameraFrame frozen = *state->last;  // the old picture, under the new header
    frozen.sequence = frame.sequence;
    frozen.stamp = frame.stamp;
    return frozen;
  }
  frame.X_map_car = environment_->physics().car(car_id_).pose();
  frame.prisms = environment_->PrismsSeenBy(car_id_);
  frame.blackout = state->fault == CameraFault::kBlackout;
  if (!frame.blackout) state->last = frame;
  return frame;
}

CameraFrame SensorSuite::CaptureColorFrame() { return Capture(*color_, &color_state_, true); }
CameraFrame SensorSuite::CaptureDepthFrame() { return Capture(*depth_, &depth_state_, true); }

void SensorSuite::SampleCamera(
    const CameraSensor& camera, CameraState* state,
    const std::vector<std::function<void(const CameraFrame&)>>& callbacks) {
  const CameraFrame frame = Capture(camera, state, !callbacks.empty());
  for (const auto& callback : callbacks) callback(frame);
}

void SensorSuite::SampleImu() {
  const vehicle::Car& car = environment_->physics().car(car_id_);
  const vehicle::ImuTruth truth{.t = kernel_->Now(),
                                .X_map_car = car.pose(),
                                .yaw_rate_rad_per_s = car.yaw_rate_rad_per_s(),
                                .accel_body_mps2 = car.acceleration_body_mps2()};
  vehicle::ImuNoiseDraws noise;
  noise.gyro = imu_noise_.Normal(0.0, 1.0);
  noise.accel_x = imu_noise_.Normal(0.0, 1.0);
  noise.accel_y = imu_noise_.Normal(0.0, 1.0);
  noise.accel_z = imu_noise_.Normal(0.0, 1.0);
  noise.yaw = imu_noise_.Normal(0.0, 1.0);
  const vehicle::ImuReading reading = vehicle::StepImu(params_.imu.imu, truth, noise, &imu_state_);
  for (const auto& callback : on_imu_) callback(reading);
}

void SensorSuite::StepGyroBias(double rad_per_s) {
  vehicle::StepGyroBias(kernel_->Now(), rad_per_s, &imu_state_);
}

void SensorSuite::IntegrateWheel() {
  const vehicle::Car& car = environment_->physics().car(car_id_);
  vehicle::AdvanceWheelEncoder(params_.wheel_speed.encoder, kernel_->Now(), physics_step_,
                               car.forward_speed_mps(), &wheel_state_);
}

void SensorSuite::SampleWheelSpeed() {
  const WheelSpeedMessage message{
      kernel_->Now(),
      vehicle::WheelSpeedReading(params_.wheel_speed.encoder, wheel_state_, kernel_->Now())};
  for (const auto& callback : on_wheel_speed_) callback(message);
}

void SensorSuite::SampleRange() {
  const vehicle::UltrasonicParams& sensor = params_.ultrasonic.sensor;
  const double draw = range_noise_.Normal(0.0, 1.0);
  if (on_range_.empty()) return;
  const RangeMessage message{
      .stamp = kernel_->Now(),
      .range_m = vehicle::UltrasonicRange(sensor, environment_->physics().car(car_id_).pose(),
                                          environment_->PrismsSeenBy(car_id_), draw),
      .min_range_m = sensor.min_range_m,
      .max_range_m = sensor.max_range_m,
      .field_of_view_rad = sensor.field_of_view_deg * std::numbers::pi / 180.0};
  for (const auto& callback : on_range_) callback(message);
}

}  // namespace autonomsim::sim
