#include "sim/car/sensor_config.h"

#include <cmath>
#include <stdexcept>
#include <string>

#include "world/validation.h"

namespace autonomsim::sim {
namespace {

constexpr double kMaxRate_hz = 1e6;  // a sample every microsecond at most

void RequireRate(double rate_hz) {
  Require(std::isfinite(rate_hz) && rate_hz > 0.0 && rate_hz <= kMaxRate_hz,
          [&] { return "rate_hz must be in (0, 1e6], got " + Num(rate_hz); });
}

// Rethrows a nested struct's error with its key in front, as the config reader expects paths.
template <class F>
void Within(const std::string& key, F&& validate) {
  try {
    validate();
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(key + "." + e.what());
  }
}

}  // namespace

void CameraStreamParams::Validate() const {
  Within("camera", [&] { camera.Validate(); });
  RequireRate(rate_hz);
  Require(!topic.empty(), "topic must not be empty");
  Require(publish_color != publish_depth,
          "exactly one of publish_color and publish_depth must be true (a topic carries one "
          "image)");
  Within("noise", [&] { noise.Validate(); });
}

CameraStreamParams ColorCameraStream() {
  CameraStreamParams p;
  p.camera = vehicle::ColorCameraParams();
  p.topic = "/image";  // cam2image → the lane planner (build.cfg: camera_image_sub)
  p.publish_color = true;
  return p;
}

CameraStreamParams DepthCameraStream() {
  CameraStreamParams p;
  p.camera = vehicle::DepthCameraParams();
  p.topic = "/depth/image_raw";  // astra_pro_publisher → the point cloud (build.cfg)
  p.info_topic = "/depth/camera_info";
  p.publish_depth = true;
  return p;
}

void ImuStreamParams::Validate() const {
  Within("imu", [&] { imu.Validate(); });
  RequireRate(rate_hz);
  Require(!topic.empty(), "topic must not be empty");
}

void WheelSpeedStreamParams::Validate() const {
  Within("encoder", [&] { encoder.Validate(); });
  RequireRate(rate_hz);
  Require(!topic.empty(), "topic must not be empty");
}

void UltrasonicStreamParams::Validate() const {
  Within("sensor", [&] { sensor.Validate(); });
  RequireRate(rate_hz);
  Require(!topic.empty(), "topic must not be empty");
}

void SensorSuiteParams::Validate() const {
  Within("color_camera", [&] { color_camera.Validate(); });
  Within("depth_camera", [&] { depth_camera.Validate(); });
  Within("imu", [&] { imu.Validate(); });
  Within("wheel_speed", [&] { wheel_speed.Validate(); });
  Within("ultrasonic", [&] { ultrasonic.Validate(); });
  Require(color_camera.camera.name != depth_camera.camera.name, [&] {
    return "color_camera.camera.name and depth_camera.camera.name must differ, both are '" +
           color_camera.camera.name + "'";
  });
}

CameraBackend ParseCameraBackend(const std::string& name) {
  const std::optional<CameraBackend> backend = FromName<CameraBackend>(name);
  Require(backend.has_value(), [&] {
    return "camera_backend must be 'raycast' (the ray caster) or 'gl' (OpenGL ES through EGL), "
           "got '" +
           name + "'";
  });
  return *backend;
}

}  // namespace autonomsim::sim
