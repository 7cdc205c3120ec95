// A car's `sensors:` entry (e.g. `cars[0].sensors`): each sensor's model parameters, rate and
// topic, as plain structs with one Validate each. Kept apart from the sensors in time
// (sim/car/sensors.h: kernel, timers, renderers) so that a scenario can name them without the
// simulator's machinery, as Drake keeps a camera's config apart from the camera system.
#pragma once

#include <optional>
#include <string>

#include "vehicle/camera_model.h"
#include "vehicle/imu.h"
#include "vehicle/ray_caster.h"
#include "vehicle/ultrasonic.h"
#include "vehicle/wheel_encoder.h"
#include "world/enum_names.h"

namespace autonomsim::sim {

struct CameraStreamParams {
  vehicle::CameraParams camera;
  double rate_hz{30.0};  // reference §2: both cameras run at 30 fps
  // The topic the real car publishes the frame on (code/reconros_ws/carcontrol/build.cfg and the
  // camera drivers): the colour camera's driver publishes "/image", the depth camera's
  // "/depth/image_raw" and "/depth/camera_info".
  std::string topic;
  std::string info_topic;     // CameraInfo; empty: none (the colour camera's driver sends none)
  bool publish_color{false};  // which image the topic carries
  bool publish_depth{false};
  vehicle::CameraNoiseParams noise;

  template <class V>
  void Describe(V& v) {
    v("camera", camera, "the camera's model");
    v("rate_hz", rate_hz, "frames per second");
    v("topic", topic, "the topic its images go out on");
    v("info_topic", info_topic, "the topic of its CameraInfo; empty: none");
    v("publish_color", publish_color, "the topic carries the colour image");
    v("publish_depth", publish_depth, "the topic carries the depth image");
    v("noise", noise, "seeded image noise");
  }
  void Validate() const;
};
CameraStreamParams ColorCameraStream();  // See3CAM CU30 on /image (bgr8)
CameraStreamParams DepthCameraStream();  // Astra Pro depth on /depth/image_raw (mono16, mm)

struct ImuStreamParams {
  vehicle::ImuParams imu;
  double rate_hz{100.0};  // reference §2
  // the EKF's imu0 input (code/ros_ws/src/localization/params/ekf.yaml)
  std::string topic{"/bno055/imu"};

  template <class V>
  void Describe(V& v) {
    v("imu", imu, "the IMU's model (BNO055)");
    v("rate_hz", rate_hz, "messages per second");
    v("topic", topic, "the topic its messages go out on");
  }
  void Validate() const;
};

struct WheelSpeedStreamParams {
  vehicle::WheelEncoderParams encoder;
  double rate_hz{10.0};  // reference §2
  // the Hall sensor node's publisher (build.cfg), the EKF's twist0 input
  std::string topic{"/modelcar/speed"};

  template <class V>
  void Describe(V& v) {
    v("encoder", encoder, "the Hall encoder's model");
    v("rate_hz", rate_hz, "messages per second");
    v("topic", topic, "the topic its speed goes out on");
  }
  void Validate() const;
};

struct UltrasonicStreamParams {
  vehicle::UltrasonicParams sensor;
  double rate_hz{10.0};                        // reference §2
  std::string topic{"/modelcar/front_range"};  // the ultrasound node's publisher (build.cfg)

  template <class V>
  void Describe(V& v) {
    v("sensor", sensor, "the ranger's model");
    v("rate_hz", rate_hz, "readings per second");
    v("topic", topic, "the topic its range goes out on");
  }
  void Validate() const;
};

// One car's sensors, as a scenario file would set them (e.g. `cars[0].sensors`).
struct SensorSuiteParams {
  CameraStreamParams color_camera{ColorCameraStream()};
  CameraStreamParams depth_camera{DepthCameraStream()};
  ImuStreamParams imu;
  WheelSpeedStreamParams wheel_speed;
  UltrasonicStreamParams ultrasonic;

  template <class V>
  void Describe(V& v) {
    v("color_camera", color_camera, "the colour camera (See3CAM), for lane detection");
    v("depth_camera", depth_camera, "the depth camera (Astra), for obstacles");
    v("imu", imu, "the IMU");
    v("wheel_speed", wheel_speed, "the wheel-speed sensor");
    v("ultrasonic", ultrasonic, "the front ultrasonic ranger");
  }
  void Validate() const;  // each part, and the two cameras' names differ
};

// Which renderer makes the cameras' images: the ray caster (vehicle/ray_caster.h) or the
// rasteriser in an offscreen OpenGL ES context (vehicle/gl_camera.h). A scenario names it
// `camera_backend: raycast | gl`.
enum class CameraBackend { kRayCast, kGl };
// The backend a name means, std::invalid_argument naming the choices for any other (a command
// line's --backend; a scenario's camera_backend is read as the enum).
CameraBackend ParseCameraBackend(const std::string& name);

}  // namespace autonomsim::sim

namespace autonomsim {
template <>
struct NameTable<sim::CameraBackend> {
  static constexpr std::array<std::pair<sim::CameraBackend, std::string_view>, 2> kEntries{
      {{sim::CameraBackend::kRayCast, "raycast"}, {sim::CameraBackend::kGl, "gl"}}};
};
}  // namespace autonomsim
