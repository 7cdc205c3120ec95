// The ROS 2 messages a run is recorded as (sim/results/mcap_recording.h): their definitions, as
// MCAP's ros2 profile stores them (schema encoding "ros2msg": the type's .msg text, then each type
// it uses after a line of 80 '=' and "MSG: pkg/Type"), and their CDR encoders (sim/mcap/cdr.h).
//
// The definitions are ROS 2's (common_interfaces and rcl_interfaces as in Humble and later, the
// fields and constants without the comments); visualization_msgs/Marker has Humble's texture and
// mesh-file fields, which Galactic's lacks, so that `ros2 bag play` on a current distribution
// decodes it. iceoryx_msg/LanePoints is the lab's own (code/ros_ws/src/iceoryx_msg/msg/
// LanePoints.msg and LanePoint.msg: `uint64 valid`, `LanePoint[30] points`; `float32 x`,
// `float32 y`).
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "sim/mcap/cdr.h"

namespace autonomsim::mcap::ros2 {

// The message types, with their names as MCAP's ros2 profile writes them ("pkg/msg/Type").
enum class Type {
  kTFMessage,        // tf2_msgs/msg/TFMessage
  kPoseStamped,      // geometry_msgs/msg/PoseStamped
  kTwist,            // geometry_msgs/msg/Twist
  kImage,            // sensor_msgs/msg/Image
  kCompressedImage,  // sensor_msgs/msg/CompressedImage
  kCameraInfo,       // sensor_msgs/msg/CameraInfo
  kOccupancyGrid,    // nav_msgs/msg/OccupancyGrid
  kPath,             // nav_msgs/msg/Path
  kString,           // std_msgs/msg/String
  kBool,             // std_msgs/msg/Bool
  kFloat64,          // std_msgs/msg/Float64
  kLog,              // rcl_interfaces/msg/Log
  kMarkerArray,      // visualization_msgs/msg/MarkerArray
  kLanePoints,       // iceoryx_msg/msg/LanePoints (the lab's)
};

// The schema's name and its ros2msg text (the type's definition and its dependencies').
std::string_view SchemaName(Type type);
std::string SchemaText(Type type);

// builtin_interfaces/Time of a time in nanoseconds (simulated time since the run's start).
struct Time {
  std::int32_t sec{0};
  std::uint32_t nanosec{0};
};
Time TimeOfNs(std::int64_t ns);

struct Header {
  Time stamp;
  std::string frame_id;
};
struct Vector3 {  // also geometry_msgs/Point: the same three float64
  double x{0.0};
  double y{0.0};
  double z{0.0};
};
struct Quaternion {
  double x{0.0};
  double y{0.0};
  double z{0.0};
  double w{1.0};
};
Quaternion YawQuaternion(double yaw_rad);
struct Pose {
  Vector3 position;
  Quaternion orientation;
};
struct TransformStamped {
  Header header;
  std::string child_frame_id;
  Vector3 translation;
  Quaternion rotation;
};
struct ColorRGBA {
  float r{0.0F};
  float g{0.0F};
  float b{0.0F};
  float a{1.0F};
};
// visualization_msgs/Marker, the fields a recording sets (the others are written empty).
struct Marker {
  static constexpr std::int32_t kCube = 1;
  static constexpr std::int32_t kLineStrip = 4;
  static constexpr std::int32_t kTextViewFacing = 9;
  Header header;
  std::string ns;
  std::int32_t id{0};
  std::int32_t type{kLineStrip};
  Pose pose;
  Vector3 scale;
  ColorRGBA color;
  bool frame_locked{false};
  std::vector<Vector3> points;
  std::string text;
};
// rcl_interfaces/Log's levels.
enum class LogLevel : std::uint8_t {
  kDebug = 10,
  kInfo = 20,
  kWarn = 30,
  kError = 40,
  kFatal = 50
};
struct Log {
  Time stamp;
  LogLevel level{LogLevel::kInfo};
  std::string name;  // the logger
  std::string msg;
  std::string file;
  std::string function;
  std::uint32_t line{0};
};
struct CameraInfo {
  std::uint32_t height{0};
  std::uint32_t width{0};
  std::string distortion_model;
  std::vector<double> d;
  std::array<double, 9> k{};
  std::array<double, 9> r{};
  std::array<double, 12> p{};
};
struct LanePoint {
  float x{0.0F};
  float y{0.0F};
};
// iceoryx_msg/LanePoints' fixed array: `LanePoint[30] points` (the lab's LanePoints.msg).
inline constexpr std::size_t kLanePointsCount = 30;

// The encoders: each writes one whole message into `w` (after Reset, or a fresh writer).
void EncodeTFMessage(CdrWriter& w, std::span<const TransformStamped> transforms);
void EncodePoseStamped(CdrWriter& w, const Header& header, const Pose& pose);
void EncodeTwist(CdrWriter& w, const Vector3& linear, const Vector3& angular);
// `encoding`: "bgr8", "16UC1", ...; `step`: bytes per row; little-endian data.
void EncodeImage(CdrWriter& w, const Header& header, std::uint32_t height, std::uint32_t width,
                 std::string_view encoding, std::uint32_t step, std::span<const std::uint8_t> data);
void EncodeCompressedImage(CdrWriter& w, const Header& header, std::string_view format,
                           std::span<const std::uint8_t> data);
void EncodeCameraInfo(CdrWriter& w, const Header& header, const CameraInfo& info);
// `data`: row-major from the origin's cell, -1 unknown, 0..100 occupancy.
void EncodeOccupancyGrid(CdrWriter& w, const Header& header, float resolution_m,
                         std::uint32_t width, std::uint32_t height, const Pose& origin,
                         std::span<const std::int8_t> data);
// Each pose carries the path's header.
void EncodePath(CdrWriter& w, const Header& header, std::span<const Pose> poses);
void EncodeString(CdrWriter& w, std::string_view data);
void EncodeBool(CdrWriter& w, bool data);
void EncodeFloat64(CdrWriter& w, double data);
void EncodeLog(CdrWriter& w, const Log& log);
void EncodeMarkerArray(CdrWriter& w, std::span<const Marker> markers);
void EncodeLanePoints(CdrWriter& w, std::uint64_t valid,
                      std::span<const LanePoint, kLanePointsCount> points);

}  // namespace autonomsim::mcap::ros2
