#include "sim/mcap/ros2_messages.h"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <utility>

namespace autonomsim::mcap::ros2 {
namespace {

// Each type's own .msg text (fields and constants; nested types named as in the .msg file).
struct Definition {
  std::string_view name;  // "pkg/Type", as a dependency's "MSG:" line names it
  std::string_view text;
};
constexpr Definition kDefinitions[] = {
    {"builtin_interfaces/Time", "int32 sec\nuint32 nanosec\n"},
    {"builtin_interfaces/Duration", "int32 sec\nuint32 nanosec\n"},
    {"std_msgs/Header", "builtin_interfaces/Time stamp\nstring frame_id\n"},
    {"std_msgs/String", "string data\n"},
    {"std_msgs/Bool", "bool data\n"},
    {"std_msgs/Float64", "float64 data\n"},
    {"std_msgs/ColorRGBA", "float32 r\nfloat32 g\nfloat32 b\nfloat32 a\n"},
    {"geometry_msgs/Vector3", "float64 x\nfloat64 y\nfloat64 z\n"},
    {"geometry_msgs/Point", "float64 x\nfloat64 y\nfloat64 z\n"},
    {"geometry_msgs/Quaternion", "float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n"},
    {"geometry_msgs/Pose", "Point position\nQuaternion orientation\n"},
    {"geometry_msgs/PoseStamped", "std_msgs/Header header\nPose pose\n"},
    {"geometry_msgs/Transform", "Vector3 translation\nQuaternion rotation\n"},
    {"geometry_msgs/TransformStamped",
     "std_msgs/Header header\nstring child_frame_id\nTransform transform\n"},
    {"geometry_msgs/Twist", "Vector3 linear\nVector3 angular\n"},
    {"tf2_msgs/TFMessage", "geometry_msgs/TransformStamped[] transforms\n"},
    {"sensor_msgs/Image",
     "std_msgs/Header header\nuint32 height\nuint32 width\nstring encoding\nuint8 is_bigendian\n"
     "uint32 step\nuint8[] data\n"},
    {"sensor_msgs/CompressedImage", "std_msgs/Header header\nstring format\nuint8[] data\n"},
    {"sensor_msgs/RegionOfInterest",
     "uint32 x_offset\nuint32 y_offset\nuint32 height\nuint32 width\nbool do_rectify\n"},
    {"sensor_msgs/CameraInfo",
     "std_msgs/Header header\nuint32 height\nuint32 width\nstring distortion_model\n"
     "float64[] d\nfloat64[9] k\nfloat64[9] r\nfloat64[12] p\nuint32 binning_x\n"
     "uint32 binning_y\nRegionOfInterest roi\n"},
    {"nav_msgs/MapMetaData",
     "builtin_interfaces/Time map_load_time\nfloat32 resolution\nuint32 width\nuint32 height\n"
     "geometry_msgs/Pose origin\n"},
    {"nav_msgs/OccupancyGrid", "std_msgs/Header header\nMapMetaData info\nint8[] data\n"},
    {"nav_msgs/Path", "std_msgs/Header header\ngeometry_msgs/PoseStamped[] poses\n"},
    {"rcl_interfaces/Log",
     "byte DEBUG=10\nbyte INFO=20\nbyte WARN=30\nbyte ERROR=40\nbyte FATAL=50\n"
     "builtin_interfaces/Time stamp\nuint8 level\nstring name\nstring msg\nstring file\n"
     "string function\nuint32 line\n"},
    {"visualization_msgs/UVCoordinate", "float32 u\nfloat32 v\n"},
    {"visualization_msgs/MeshFile", "string filename\nuint8[] data\n"},
    {"visualization_msgs/Marker",
     "int32 ARROW=0\nint32 CUBE=1\nint32 SPHERE=2\nint32 CYLINDER=3\nint32 LINE_STRIP=4\n"
     "int32 LINE_LIST=5\nint32 CUBE_LIST=6\nint32 SPHERE_LIST=7\nint32 POINTS=8\n"
     "int32 TEXT_VIEW_FACING=9\nint32 MESH_RESOURCE=10\nint32 TRIANGLE_LIST=11\nint32 ADD=0\n"
     "int32 MODIFY=0\nint32 DELETE=2\nint32 DELETEALL=3\n"
     "std_msgs/Header header\nstring ns\nint32 id\nint32 type\nint32 action\n"
     "geometry_msgs/Pose pose\ngeometry_msgs/Vector3 scale\nstd_msgs/ColorRGBA color\n"
     "builtin_interfaces/Duration lifetime\nbool frame_locked\ngeometry_msgs/Point[] points\n"
     "std_msgs/ColorRGBA[] colors\nstring texture_resource\n"
     "sensor_msgs/CompressedImage texture\nUVCoordinate[] uv_coordinates\nstring text\n"
     "string mesh_resource\nMeshFile mesh_file\nbool mesh_use_embedded_materials\n"},
    {"visualization_msgs/MarkerArray", "Marker[] markers\n"},
    {"iceoryx_msg/LanePoint", "float32 x\nfloat32 y\n"},
    {"iceoryx_msg/LanePoints", "uint64 valid\nLanePoint[30] points\n"},
};

std::string_view TextOf(std::string_view name) {
  for (const Definition& d : kDefinitions) {
    if (d.name == name) return d.text;
  }
  throw std::logic_error("ros2 message definition missing: " + std::string(name));
}

// Per type: its own definition's name, then every type it uses, each once.
struct Composition {
  Type type;
  std::string_view schema_name;
  std::vector<std::string_view> parts;
};
const std::vector<Composition>& Compositions() {
  static const std::vector<Composition> kCompositions = {
      {Type::kTFMessage,
       "tf2_msgs/msg/TFMessage",
       {"tf2_msgs/TFMessage", "geometry_msgs/TransformStamped", "std_msgs/Header",
        "builtin_interfaces/Time", "geometry_msgs/Transform", "geometry_msgs/Vector3",
        "geometry_msgs/Quaternion"}},
      {Type::kPoseStamped,
       "geometry_msgs/msg/PoseStamped",
       {"geometry_msgs/PoseStamped", "std_msgs/Header", "builtin_interfaces/Time",
        "geometry_msgs/Pose", "geometry_msgs/Point", "geometry_msgs/Quaternion"}},
      {Type::kTwist, "geometry_msgs/msg/Twist", {"geometry_msgs/Twist", "geometry_msgs/Vector3"}},
      {Type::kImage,
       "sensor_msgs/msg/Image",
       {"sensor_msgs/Image", "std_msgs/Header", "builtin_interfaces/Time"}},
      {Type::kCompressedImage,
       "sensor_msgs/msg/CompressedImage",
       {"sensor_msgs/CompressedImage", "std_msgs/Header", "builtin_interfaces/Time"}},
      {Type::kCameraInfo,
       "sensor_msgs/msg/CameraInfo",
       {"sensor_msgs/CameraInfo", "std_msgs/Header", "builtin_interfaces/Time",
        "sensor_msgs/RegionOfInterest"}},
      {Type::kOccupancyGrid,
       "nav_msgs/msg/OccupancyGrid",
       {"nav_msgs/OccupancyGrid", "std_msgs/Header", "builtin_interfaces/Time",
        "nav_msgs/MapMetaData", "geometry_msgs/Pose", "geometry_msgs/Point",
        "geometry_msgs/Quaternion"}},
      {Type::kPath,
       "nav_msgs/msg/Path",
       {"nav_msgs/Path", "std_msgs/Header", "builtin_interfaces/Time", "geometry_msgs/PoseStamped",
        "geometry_msgs/Pose", "geometry_msgs/Point", "geometry_msgs/Quaternion"}},
      {Type::kString, "std_msgs/msg/String", {"std_msgs/String"}},
      {Type::kBool, "std_msgs/msg/Bool", {"std_msgs/Bool"}},
      {Type::kFloat64, "std_msgs/msg/Float64", {"std_msgs/Float64"}},
      {Type::kLog, "rcl_interfaces/msg/Log", {"rcl_interfaces/Log", "builtin_interfaces/Time"}},
      {Type::kMarkerArray,
       "visualization_msgs/msg/MarkerArray",
       {"visualization_msgs/MarkerArray", "visualization_msgs/Marker", "std_msgs/Header",
        "builtin_interfaces/Time", "geometry_msgs/Pose", "geometry_msgs/Point",
        "geometry_msgs/Quaternion", "geometry_msgs/Vector3", "std_msgs/ColorRGBA",
        "builtin_interfaces/Duration", "sensor_msgs/CompressedImage",
        "visualization_msgs/UVCoordinate", "visualization_msgs/MeshFile"}},
      {Type::kLanePoints,
       "iceoryx_msg/msg/LanePoints",
       {"iceoryx_msg/LanePoints", "iceoryx_msg/LanePoint"}},
  };
  return kCompositions;
}

const Composition& CompositionOf(Type type) {
  for (const Composition& c : Compositions()) {
    if (c.type == type) return c;
  }
  throw std::logic_error("ros2 message type without a composition");
}

// A sequence's element count as CDR's uint32 (std::length_error beyond it).
void Count(CdrWriter& w, std::size_t n) {
  if (n > std::numeric_limits<std::uint32_t>::max()) {
    throw std::length_error("a ROS 2 sequence of more than 2^32 - 1 elements");
  }
  w.SequenceLength(static_cast<std::uint32_t>(n));
}

void Put(CdrWriter& w, const Time& t) {
  w.I32(t.sec);
  w.U32(t.nanosec);
}
void Put(CdrWriter& w, const Header& h) {
  Put(w, h.stamp);
  w.String(h.frame_id);
}
void Put(CdrWriter& w, const Vector3& v) {
  w.F64(v.x);
  w.F64(v.y);
  w.F64(v.z);
}
void Put(CdrWriter& w, const Quaternion& q) {
  w.F64(q.x);
  w.F64(q.y);
  w.F64(q.z);
  w.F64(q.w);
}
void Put(CdrWriter& w, const Pose& p) {
  Put(w, p.position);
  Put(w, p.orientation);
}
void Put(CdrWriter& w, const ColorRGBA& c) {
  w.F32(c.r);
  w.F32(c.g);
  w.F32(c.b);
  w.F32(c.a);
}

void PutMarker(CdrWriter& w, const Marker& m) {
  Put(w, m.header);
  w.String(m.ns);
  w.I32(m.id);
  w.I32(m.type);
  w.I32(0);  // action ADD
  Put(w, m.pose);
  Put(w, m.scale);
  Put(w, m.color);
  Put(w, Time{});  // lifetime 0: for ever
  w.Bool(m.frame_locked);
  Count(w, m.points.size());
  for (const Vector3& p : m.points) Put(w, p);
  w.SequenceLength(0);  // colors
  w.String("");         // texture_resource
  Put(w, Header{});     // texture: CompressedImage header, format, data
  w.String("");
  w.Bytes({});
  w.SequenceLength(0);  // uv_coordinates
  w.String(m.text);
  w.String("");  // mesh_resource
  w.String("");  // mesh_file: filename, data
  w.Bytes({});
  w.Bool(false);  // mesh_use_embedded_materials
}

}  // namespace

std::string_view SchemaName(Type type) { return CompositionOf(type).schema_name; }

std::string SchemaText(Type type) {
  const Composition& c = CompositionOf(type);
  std::string text(TextOf(c.parts.front()));
  for (std::size_t i = 1; i < c.parts.size(); ++i) {
    text += std::string(80, '=') + "\nMSG: " + std::string(c.parts[i]) + "\n";
    text += TextOf(c.parts[i]);
  }
  return text;
}

Time TimeOfNs(std::int64_t ns) {
  constexpr std::int64_t kMaxSeconds = std::numeric_limits<std::int32_t>::max();
  if (ns < 0 || ns / 1'000'000'000 > kMaxSeconds) {
    throw std::invalid_argument("TimeOfNs: outside builtin_interfaces/Time's [0, 2^31) s");
  }
  return Time{.sec = static_cast<std::int32_t>(ns / 1'000'000'000),
              .nanosec = static_cast<std::uint32_t>(ns % 1'000'000'000)};
}

Quaternion YawQuaternion(double yaw_rad) {
  return Quaternion{.x = 0.0, .y = 0.0, .z = std::sin(yaw_rad / 2.0), .w = std::cos(yaw_rad / 2.0)};
}

void EncodeTFMessage(CdrWriter& w, std::span<const TransformStamped> transforms) {
  Count(w, transforms.size());
  for (const TransformStamped& t : transforms) {
    Put(w, t.header);
    w.String(t.child_frame_id);
    Put(w, t.translation);
    Put(w, t.rotation);
  }
}

void EncodePoseStamped(CdrWriter& w, const Header& header, const Pose& pose) {
  Put(w, header);
  Put(w, pose);
}

void EncodeTwist(CdrWriter& w, const Vector3& linear, const Vector3& angular) {
  Put(w, linear);
  Put(w, angular);
}

void EncodeImage(CdrWriter& w, const Header& header, std::uint32_t height, std::uint32_t width,
                 std::string_view encoding, std::uint32_t step,
                 std::span<const std::uint8_t> data) {
  Put(w, header);
  w.U32(height);
  w.U32(width);
  w.String(encoding);
  w.U8(0);  // is_bigendian: little-endian
  w.U32(step);
  w.Bytes(data);
}

void EncodeCompressedImage(CdrWriter& w, const Header& header, std::string_view format,
                           std::span<const std::uint8_t> data) {
  Put(w, header);
  w.String(format);
  w.Bytes(data);
}

void EncodeCameraInfo(CdrWriter& w, const Header& header, const CameraInfo& info) {
  Put(w, header);
  w.U32(info.height);
  w.U32(info.width);
  w.String(info.distortion_model);
  Count(w, info.d.size());
  w.Array(std::span<const double>(info.d));
  w.Array(std::span<const double>(info.k));
  w.Array(std::span<const double>(info.r));
  w.Array(std::span<const double>(info.p));
  w.U32(0);  // binning_x, binning_y: none
  w.U32(0);
  for (int i = 0; i < 4; ++i) w.U32(0);  // roi: x_offset, y_offset, height, width (the full image)
  w.Bool(false);                         // do_rectify
}

void EncodeOccupancyGrid(CdrWriter& w, const Header& header, float resolution_m,
                         std::uint32_t width, std::uint32_t height, const Pose& origin,
                         std::span<const std::int8_t> data) {
  if (data.size() != static_cast<std::size_t>(width) * height) {
    throw std::invalid_argument("EncodeOccupancyGrid: data is not width x height cells");
  }
  Put(w, header);
  Put(w, header.stamp);  // map_load_time
  w.F32(resolution_m);
  w.U32(width);
  w.U32(height);
  Put(w, origin);
  Count(w, data.size());
  w.Array(data);
}

void EncodePath(CdrWriter& w, const Header& header, std::span<const Pose> poses) {
  Put(w, header);
  Count(w, poses.size());
  for (const Pose& pose : poses) {
    Put(w, header);
    Put(w, pose);
  }
}

void EncodeString(CdrWriter& w, std::string_view data) { w.String(data); }
void EncodeBool(CdrWriter& w, bool data) { w.Bool(data); }
void EncodeFloat64(CdrWriter& w, double data) { w.F64(data); }

void EncodeLog(CdrWriter& w, const Log& log) {
  Put(w, log.stamp);
  w.U8(static_cast<std::uint8_t>(log.level));
  w.String(log.name);
  w.String(log.msg);
  w.String(log.file);
  w.String(log.function);
  w.U32(log.line);
}

void EncodeMarkerArray(CdrWriter& w, std::span<const Marker> markers) {
  Count(w, markers.size());
  for (const Marker& m : markers) PutMarker(w, m);
}

void EncodeLanePoints(CdrWriter& w, std::uint64_t valid,
                      std::span<const LanePoint, kLanePointsCount> points) {
  w.U64(valid);
  for (const LanePoint& p : points) {
    w.F32(p.x);
    w.F32(p.y);
  }
}

}  // namespace autonomsim::mcap::ros2
