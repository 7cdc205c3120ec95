#include "sim/results/mcap_recording.h"

#include <fmt/format.h>
#include <fnmatch.h>

#include <Eigen/Geometry>
#include <array>
#include <utility>

#include "sim/car/perception_config.h"
#include "sim/car/stack_config.h"
#include "sim/car/stack_messages.h"
#include "sim/results/image_encoding.h"
#include "stack/controller_server.h"
#include "stack/lane_detection.h"
#include "stack/localization_ekf.h"
#include "vehicle/car.h"
#include "world/enum_names.h"

namespace autonomsim::sim {

namespace ros2 = mcap::ros2;
using ros2::Type;
static_assert(stack::LanePoints::kCount == ros2::kLanePointsCount,
              "the stack's lane points are the lab's message's");

namespace {

std::uint64_t Ns(Time t) { return static_cast<std::uint64_t>(t.count()); }

ros2::Header HeaderAt(Time stamp, std::string frame_id) {
  return ros2::Header{.stamp = ros2::TimeOfNs(stamp.count()), .frame_id = std::move(frame_id)};
}

ros2::Pose PoseOf(const world::Pose2& p) {
  return ros2::Pose{.position = {p.x_m, p.y_m, 0.0}, .orientation = ros2::YawQuaternion(p.yaw_rad)};
}

ros2::TransformStamped TransformOf(Time stamp, std::string parent, std::string child,
                                   const world::Pose2& p) {
  return ros2::TransformStamped{.header = HeaderAt(stamp, std::move(parent)),
                                .child_frame_id = std::move(child),
                                .translation = {p.x_m, p.y_m, 0.0},
                                .rotation = ros2::YawQuaternion(p.yaw_rad)};
}

ros2::TransformStamped TransformOf(Time stamp, std::string parent, std::string child,
                                   const Eigen::Isometry3d& X) {
  const Eigen::Quaterniond q(X.rotation());
  const Eigen::Vector3d t = X.translation();
  return ros2::TransformStamped{.header = HeaderAt(stamp, std::move(parent)),
                                .child_frame_id = std::move(child),
                                .translation = {t.x(), t.y(), t.z()},
                                .rotation = {q.x(), q.y(), q.z(), q.w()}};
}

// Nav2's costmap → OccupancyGrid translation (nav2_costmap_2d costmap_2d_publisher.cpp): free 0,
// inscribed 99, lethal 100, unknown -1, the costs between scaled into 1..98; a table by cost.
const std::array<std::int8_t, 256>& OccupancyOfCost() {
  static const std::array<std::int8_t, 256> kTable = [] {
    std::array<std::int8_t, 256> table{};
    for (int cost = 1; cost < 253; ++cost) {
      table[static_cast<std::size_t>(cost)] = static_cast<std::int8_t>(1 + (97 * (cost - 1)) / 251);
    }
    table[253] = 99;
    table[254] = 100;
    table[255] = -1;
    return table;
  }();
  return kTable;
}

// rosbag2's channel metadata: the QoS the recorded publisher offered, which `ros2 bag play`
// offers again (rmw enums: history 1 keep last, reliability 1 reliable, durability 1 transient
// local / 2 volatile, liveliness 1 automatic; unset durations as rosbag2 writes them).
std::map<std::string, std::string> Qos(bool latched) {
  return {{"offered_qos_profiles",
           std::string("- history: 1\n  depth: ") + (latched ? "1" : "10") +
               "\n  reliability: 1\n  durability: " + (latched ? "1" : "2") +
               "\n  deadline:\n    sec: 2147483647\n    nsec: 4294967295\n  lifespan:\n    sec: "
               "2147483647\n    nsec: 4294967295\n  liveliness: 1\n  liveliness_lease_duration:\n"
               "    sec: 2147483647\n    nsec: 4294967295\n  avoid_ros_namespace_conventions: "
               "false\n"}};
}

// /tf_static and /track: transient local, as a latched topic (late subscribers get them).
std::map<std::string, std::string> LatchedQos() { return Qos(true); }

ros2::LogLevel LevelOf(EventKind kind) {
  switch (kind) {
    case EventKind::kCollision:
      return ros2::LogLevel::kError;
    case EventKind::kDenied:
    case EventKind::kLeaseExpired:
    case EventKind::kQueueDrop:
    case EventKind::kV2iLost:
    case EventKind::kV2iMalformed:
    case EventKind::kFaultBegin:
    case EventKind::kFaultEnd:
      return ros2::LogLevel::kWarn;
    default:
      return ros2::LogLevel::kInfo;
  }
}

std::string DescribeEvent(const Event& e) {
  std::string text(ToName(e.type));
  if (e.fault) text += fmt::format(" {}", ToName(*e.fault));
  if (e.car >= 0) text += fmt::format(" car {}", e.car);
  if (e.intersection >= 0) text += fmt::format(" intersection {}", e.intersection);
  if (e.other_car >= 0) text += fmt::format(" other car {}", e.other_car);
  if (!e.obstacle.empty()) text += " obstacle " + e.obstacle;
  if (e.granted) text += *e.granted ? " granted" : " not granted";
  if (e.lap > 0) text += fmt::format(" lap {}", e.lap);
  if (!e.detail.empty()) text += ": " + e.detail;
  return text;
}

ros2::CameraInfo InfoOf(const vehicle::CameraInfo& info) {
  return ros2::CameraInfo{.height = static_cast<std::uint32_t>(info.height),
                          .width = static_cast<std::uint32_t>(info.width),
                          .distortion_model = info.distortion_model,
                          .d = {info.D.begin(), info.D.end()},
                          .k = info.K,
                          .r = info.R,
                          .p = info.P};
}

// The camera_info topic beside an image topic: the camera's own, else the sibling of the image
// topic (image_transport's convention; the lab's colour driver publishes none).
std::string InfoTopicOf(const CameraStreamParams& stream) {
  if (!stream.info_topic.empty()) return stream.info_topic;
  const auto slash = stream.topic.rfind('/');
  return stream.topic.substr(0, slash == std::string::npos ? 0 : slash) + "/camera_info";
}

}  // namespace

struct McapRecording::Slot {
  std::string topic;
  Type type{Type::kString};
  std::map<std::string, std::string> metadata;
  std::optional<bool> wanted;
  std::uint16_t channel{0};  // 0: not opened yet
  std::uint64_t messages{0};
  std::uint64_t bytes{0};
};

struct McapRecording::CarTaps {
  int id{0};
  std::size_t index{0};  // in the scenario's cars
  std::string prefix;    // "/car0": its topics' namespace
  std::string frame;     // "car0/": its frames' prefix
  Board* board{nullptr};
  // the slots of what every sample writes, made once (cpu_load once the car has a board)
  Slot* ground_truth{nullptr};
  Slot* tf{nullptr};
  Slot* cpu_load{nullptr};
  double last_busy_core_s{0.0};
  Time last_sample{kZeroTime};
  vehicle::ColorImage color;  // the image buffers, reused frame after frame
  vehicle::DepthImage depth;
  std::vector<std::uint8_t> png;
};

std::string McapFileSignature() {
  const mcap::WriterOptions defaults;
  std::string signature;
  for (const std::string& field : {defaults.profile, defaults.library}) {
    const auto n = static_cast<std::uint32_t>(field.size());  // a string: uint32 length, bytes
    for (int i = 0; i < 4; ++i) signature += static_cast<char>((n >> (8 * i)) & 0xFFU);
    signature += field;
  }
  return signature;
}

bool DefaultMcapTopic(const std::string& /*topic*/, Type type) {
  return type != Type::kImage && type != Type::kCompressedImage;
}

McapRecording::McapRecording(const LoadedScenario& loaded, const std::filesystem::path& file,
                             McapRecordingOptions options)
    : loaded_(loaded),
      options_(std::move(options)),
      writer_(file, options_.writer),
      pattern_matched_(options_.topics.size(), false) {
  for (std::size_t i = 0; i < loaded_.cars.size(); ++i) {
    auto car = std::make_unique<CarTaps>();
    car->id = loaded_.cars[i].config->id;
    car->index = i;
    car->prefix = fmt::format("/car{}", car->id);
    car->frame = fmt::format("car{}/", car->id);
    car->ground_truth = &SlotFor(car->prefix + "/ground_truth/pose", Type::kPoseStamped);
    car->tf = &SlotFor(car->prefix + "/tf", Type::kTFMessage);
    car_of_id_[car->id] = car.get();
    cars_.push_back(std::move(car));
  }
  rosout_ = &SlotFor("/rosout", Type::kLog);
  WriteTrack();
}

McapRecording::~McapRecording() = default;

McapRecording::Slot& McapRecording::SlotFor(const std::string& topic, Type type,
                                            std::map<std::string, std::string> metadata) {
  if (const auto it = slot_of_topic_.find(topic); it != slot_of_topic_.end()) return *it->second;
  if (metadata.empty()) metadata = Qos(false);
  Slot& slot =
      slots_.emplace_back(Slot{.topic = topic, .type = type, .metadata = std::move(metadata)});
  slot_of_topic_[topic] = &slot;
  for (std::size_t i = 0; i < options_.topics.size(); ++i) {  // a topic of the run, recorded or not
    if (fnmatch(options_.topics[i].c_str(), topic.c_str(), 0) == 0) pattern_matched_[i] = true;
  }
  return slot;
}

bool McapRecording::Wanted(Slot& slot) {
  if (!slot.wanted) {
    if (options_.topics.empty()) {
      slot.wanted = DefaultMcapTopic(slot.topic, slot.type);
    } else {
      slot.wanted = false;
      for (const std::string& pattern : options_.topics) {
        if (fnmatch(pattern.c_str(), slot.topic.c_str(), 0) == 0) slot.wanted = true;
      }
    }
  }
  return *slot.wanted;
}

void McapRecording::OpenChannel(Slot& slot) {
  const auto [schema, added] = schema_ids_.try_emplace(slot.type, 0);
  if (added) {
    schema->second =
        writer_.AddSchema(ros2::SchemaName(slot.type), "ros2msg", ros2::SchemaText(slot.type));
  }
  slot.channel = writer_.AddChannel(schema->second, slot.topic, "cdr", slot.metadata);
  opened_.push_back(&slot);
}

template <class Encode>
void McapRecording::Write(Slot& slot, Time t, const Encode& encode) {
  if (closed_ || !Wanted(slot)) return;
  if (slot.channel == 0) OpenChannel(slot);
  cdr_.Reset();
  encode(cdr_);
  writer_.Write(slot.channel, Ns(t), Ns(t), cdr_.data());
  ++slot.messages;
  slot.bytes += cdr_.size();
}

void McapRecording::OnBoard(int car_id, Board& board, const SensorSuite& sensors) {
  CarTaps& car = *car_of_id_.at(car_id);
  car.board = &board;
  car.cpu_load = &SlotFor(car.prefix + "/cpu_load", Type::kFloat64);
  WriteStatics(car, sensors);
  TapCameras(car, board.graph(), sensors);
  TapStack(car, board.graph());
}

void McapRecording::WriteStatics(const CarTaps& car, const SensorSuite& sensors) {
  std::vector<ros2::TransformStamped> statics;
  const LoadedCar& loaded_car = loaded_.cars[car.index];
  if (loaded_car.config->drives_by_stack()) {  // the static map→odom: the start pose (§6)
    statics.push_back(TransformOf(kZeroTime, "map", car.frame + "odom", loaded_car.start_pose));
  }
  for (const CameraSensor* camera : {&sensors.color_camera(), &sensors.depth_camera()}) {
    statics.push_back(TransformOf(kZeroTime, car.frame + "base_link",
                                  car.frame + camera->params().camera.name + "_optical_frame",
                                  camera->model().X_base_camera()));
  }
  Write(SlotFor(car.prefix + "/tf_static", Type::kTFMessage, LatchedQos()), kZeroTime,
        [&](mcap::CdrWriter& w) { ros2::EncodeTFMessage(w, statics); });
}

void McapRecording::TapCameras(CarTaps& car, NodeGraph& graph, const SensorSuite& sensors) {
  for (const CameraSensor* camera : {&sensors.color_camera(), &sensors.depth_camera()}) {
    const CameraStreamParams& stream = camera->params();
    const bool color = stream.publish_color;
    const Type image_type = options_.png_images ? Type::kCompressedImage : Type::kImage;
    Slot* image = &SlotFor(car.prefix + stream.topic, image_type);
    Slot* info = &SlotFor(car.prefix + InfoTopicOf(stream), Type::kCameraInfo);
    const ros2::CameraInfo calibration = InfoOf(camera->Info());
    const std::string frame_id = car.frame + stream.camera.name + "_optical_frame";
    graph.Tap<CameraFrame>(stream.topic, [this, &car, image, info, calibration, frame_id, color](
                                             const CameraFrame& frame, Time stamp, Time now) {
      const ros2::Header header = HeaderAt(stamp, frame_id);
      Write(*info, now,
            [&](mcap::CdrWriter& w) { ros2::EncodeCameraInfo(w, header, calibration); });
      if (!Wanted(*image)) return;
      cv::Mat mat;
      if (color) {
        frame.Render(&car.color, nullptr);
        mat = cv::Mat(car.color.height, car.color.width, CV_8UC3, car.color.bgr.data());
      } else {
        frame.Render(nullptr, &car.depth);
        mat = cv::Mat(car.depth.height, car.depth.width, CV_16UC1, car.depth.mm.data());
      }
      if (options_.png_images) {
        car.png = EncodePng(mat);
        Write(*image, now,
              [&](mcap::CdrWriter& w) { ros2::EncodeCompressedImage(w, header, "png", car.png); });
        return;
      }
      const auto step = static_cast<std::uint32_t>(mat.step[0]);
      Write(*image, now, [&](mcap::CdrWriter& w) {
        ros2::EncodeImage(w, header, static_cast<std::uint32_t>(mat.rows),
                          static_cast<std::uint32_t>(mat.cols), color ? "bgr8" : "16UC1", step,
                          {mat.data, step * static_cast<std::size_t>(mat.rows)});
      });
    });
  }
}

void McapRecording::TapStack(CarTaps& car, NodeGraph& graph) {
  const std::string& p = car.prefix;
  const std::string odom = car.frame + "odom";
  Slot* tf = &SlotFor(p + "/tf", Type::kTFMessage);
  graph.Tap<stack::LocalizationEkfOutput>(
      "/odometry/filtered", [this, tf, odom, base = car.frame + "base_link"](
                                const stack::LocalizationEkfOutput& e, Time stamp, Time now) {
        Write(*tf, now, [&](mcap::CdrWriter& w) {
          const std::array transforms{TransformOf(stamp, odom, base, e.X_odom_base)};
          ros2::EncodeTFMessage(w, transforms);
        });
      });
  Slot* lanes = &SlotFor(p + kLanePointsTopic, Type::kLanePoints);
  graph.Tap<stack::LanePoints>(kLanePointsTopic,
                               [this, lanes](const stack::LanePoints& l, Time, Time now) {
                                 Write(*lanes, now, [&](mcap::CdrWriter& w) {
                                   std::array<ros2::LanePoint, ros2::kLanePointsCount> points;
                                   for (std::size_t i = 0; i < points.size(); ++i) {
                                     points[i] = {l.points[i].x_m, l.points[i].y_m};
                                   }
                                   ros2::EncodeLanePoints(w, l.valid, points);
                                 });
                               });
  Slot* costmap = &SlotFor(p + "/local_costmap/costmap", Type::kOccupancyGrid);
  graph.Tap<CostmapMessage>("/local_costmap/costmap_raw",
                            [this, costmap, odom](const CostmapMessage& m, Time stamp, Time now) {
                              if (!m.costmap || !Wanted(*costmap)) return;
                              const stack::Costmap2D& c = *m.costmap;
                              std::vector<std::int8_t> cells(c.costs().size());
                              const auto& occupancy = OccupancyOfCost();
                              for (std::size_t i = 0; i < cells.size(); ++i) {
                                cells[i] = occupancy[c.costs()[i]];
                              }
                              const world::Vec2 origin = c.origin_m();
                              Write(*costmap, now, [&](mcap::CdrWriter& w) {
                                ros2::EncodeOccupancyGrid(
                                    w, HeaderAt(stamp, odom), static_cast<float>(c.resolution_m()),
                                    static_cast<std::uint32_t>(c.size_x_cells()),
                                    static_cast<std::uint32_t>(c.size_y_cells()),
                                    ros2::Pose{.position = {origin.x(), origin.y(), 0.0}}, cells);
                              });
                            });
  Slot* plan = &SlotFor(p + "/plan", Type::kPath);
  graph.Tap<PathMessage>("/plan", [this, plan](const PathMessage& m, Time stamp, Time now) {
    if (!m.ok || !m.path) return;  // Nav2 publishes a plan only when it found one
    std::vector<ros2::Pose> poses;
    poses.reserve(m.path->size());
    for (const world::Vec2& q : *m.path) poses.push_back({.position = {q.x(), q.y(), 0.0}});
    Write(*plan, now,
          [&](mcap::CdrWriter& w) { ros2::EncodePath(w, HeaderAt(stamp, "map"), poses); });
  });
  TapCommands(car, graph);
}

void McapRecording::TapCommands(CarTaps& car, NodeGraph& graph) {
  const std::string& p = car.prefix;
  Slot* cmd_vel = &SlotFor(p + "/cmd_vel", Type::kTwist);
  graph.Tap<stack::Twist>("/cmd_vel", [this, cmd_vel](const stack::Twist& t, Time, Time now) {
    Write(*cmd_vel, now, [&](mcap::CdrWriter& w) {
      ros2::EncodeTwist(w, {t.speed_mps, 0.0, 0.0}, {0.0, 0.0, t.yaw_rate_rad_per_s});
    });
  });
  // the carcontroller's output as the lab's topic and type: linear.x the throttle in [-1, 1],
  // angular.z the curvature ω / v (code/ros_ws/src/carcontroller/src/carcontroller.cpp:37,91-93)
  Slot* drive = &SlotFor(p + "/modelcar/drive_cmd", Type::kTwist);
  graph.Tap<vehicle::ActuatorCommand>(
      kCarCommandTopic, [this, drive](const vehicle::ActuatorCommand& c, Time, Time now) {
        Write(*drive, now, [&](mcap::CdrWriter& w) {
          ros2::EncodeTwist(w, {c.throttle, 0.0, 0.0}, {0.0, 0.0, c.curvature_per_m});
        });
      });
  Slot* check = &SlotFor(p + "/intersection_check", Type::kBool);
  graph.Tap<IntersectionFree>(
      "/intersection_free", [this, check](const IntersectionFree& f, Time, Time now) {
        Write(*check, now, [&](mcap::CdrWriter& w) { ros2::EncodeBool(w, f.free); });
      });
  Slot* selector = &SlotFor(p + "/controller_selector", Type::kString);
  graph.Tap<stack::ControllerStatus>(
      "/controller/status", [this, selector](const stack::ControllerStatus& s, Time, Time now) {
        Write(*selector, now, [&](mcap::CdrWriter& w) {
          ros2::EncodeString(w, s.follow_path ? "FollowPath" : "LaneController");
        });
      });
}

void McapRecording::OnV2iPublished(Time t, std::optional<int> /*car_id*/,
                                   const world::V2IMessage& message) {
  Write(SlotFor(message.topic, Type::kString), t,
        [&](mcap::CdrWriter& w) { ros2::EncodeString(w, message.payload); });
}

void McapRecording::OnSample(const TrajectorySample& s) {
  CarTaps& car = *car_of_id_.at(s.car);
  const world::Pose2 pose{s.x_m, s.y_m, s.yaw_rad};
  Write(*car.ground_truth, s.t, [&](mcap::CdrWriter& w) {
    ros2::EncodePoseStamped(w, HeaderAt(s.t, "map"), PoseOf(pose));
  });
  Write(*car.tf, s.t, [&](mcap::CdrWriter& w) {
    const std::array transforms{TransformOf(s.t, "map", car.frame + "ground_truth", pose)};
    ros2::EncodeTFMessage(w, transforms);
  });
  if (car.board && s.t > car.last_sample) {
    // the board's mean load since the last sample, in % of one core (400: the ZCU104's four)
    const double busy = car.board->platform().cpu().BusyCoreSecondsAt(s.t);
    const double percent = 100.0 * (busy - car.last_busy_core_s) / ToSeconds(s.t - car.last_sample);
    car.last_busy_core_s = busy;
    car.last_sample = s.t;
    Write(*car.cpu_load, s.t, [&](mcap::CdrWriter& w) { ros2::EncodeFloat64(w, percent); });
  }
}

void McapRecording::OnEvent(const Event& e) {
  Write(*rosout_, e.t, [&](mcap::CdrWriter& w) {
    ros2::EncodeLog(w, ros2::Log{.stamp = ros2::TimeOfNs(e.t.count()),
                                 .level = LevelOf(e.type),
                                 .name = e.car >= 0 ? fmt::format("car{}", e.car) : "autonomsim",
                                 .msg = DescribeEvent(e),
                                 .file = "events.jsonl",
                                 .function = std::string(ToName(e.type)),
                                 .line = 0});
  });
}

namespace {

ros2::ColorRGBA ColorOf(const world::Rgb& rgb, float alpha = 1.0F) {
  return {static_cast<float>(rgb[0]) / 255.0F, static_cast<float>(rgb[1]) / 255.0F,
          static_cast<float>(rgb[2]) / 255.0F, alpha};
}

ros2::Marker Outline(const world::Box& b, std::string ns, int id, ros2::ColorRGBA color) {
  ros2::Marker m{.header = HeaderAt(kZeroTime, "map"), .ns = std::move(ns), .id = id};
  m.scale.x = 0.02;  // line width, m
  m.color = color;
  m.points = {{b.x_min_m, b.y_min_m, 0.0},
              {b.x_max_m, b.y_min_m, 0.0},
              {b.x_max_m, b.y_max_m, 0.0},
              {b.x_min_m, b.y_max_m, 0.0},
              {b.x_min_m, b.y_min_m, 0.0}};
  return m;
}

// A car's body: a box locked to its frame (it moves with the frame's transform).
ros2::Marker Body(const CarConfig& car, std::string frame, std::string ns, ros2::ColorRGBA color) {
  ros2::Marker m{.header = HeaderAt(kZeroTime, std::move(frame)),
                 .ns = std::move(ns),
                 .id = car.id,
                 .type = ros2::Marker::kCube,
                 .frame_locked = true};
  m.pose.position.z = car.vehicle.height_m / 2.0;
  m.scale = {car.vehicle.length_m, car.vehicle.width_m, car.vehicle.height_m};
  m.color = color;
  return m;
}

}  // namespace

// /track at time 0: the floor (its colour, and its edge), the painted lines (every 5 cm of the 1 cm
// samples), the intersections' areas and stop zones, and each car's body on its ground truth and
// its estimate.
void McapRecording::WriteTrack() {
  const world::TrackSpec& spec = loaded_.track.spec();
  std::vector<ros2::Marker> markers;
  const double h = spec.size_m / 2.0;
  ros2::Marker floor{
      .header = HeaderAt(kZeroTime, "map"), .ns = "floor", .id = 0, .type = ros2::Marker::kCube};
  floor.pose.position.z = -0.007;  // its top 2 mm below the lines
  floor.scale = {spec.size_m, spec.size_m, 0.01};
  floor.color = ColorOf(spec.floor_rgb);
  markers.push_back(std::move(floor));
  markers.push_back(Outline({-h, h, -h, h}, "floor", 1, {0.5F, 0.5F, 0.5F, 1.0F}));
  for (std::size_t i = 0; i < spec.lines.size(); ++i) {
    ros2::Marker m{.header = HeaderAt(kZeroTime, "map"), .ns = "lines", .id = static_cast<int>(i)};
    m.scale.x = spec.lines[i].width_m;
    m.color = ColorOf(spec.colors_rgb.at(spec.lines[i].color));
    const auto& points = loaded_.track.line_paths()[i].points();
    for (std::size_t k = 0; k < points.size(); k += 5) {
      m.points.push_back({points[k].x(), points[k].y(), 0.0});
    }
    m.points.push_back({points.back().x(), points.back().y(), 0.0});
    markers.push_back(std::move(m));
  }
  int zone = 0;
  for (const world::IntersectionSpec& x : spec.intersections) {
    markers.push_back(Outline(x.area, "intersection_areas", x.id, {1.0F, 0.2F, 0.2F, 1.0F}));
    for (const world::Box& b : x.stop_zones) {
      markers.push_back(Outline(b, "stop_zones", zone++, {1.0F, 0.6F, 0.0F, 1.0F}));
    }
  }
  for (const LoadedCar& car : loaded_.cars) {
    const std::string frame = fmt::format("car{}/", car.config->id);
    markers.push_back(
        Body(*car.config, frame + "ground_truth", "cars_ground_truth", {0.2F, 0.6F, 1.0F, 0.8F}));
    if (car.config->drives_by_stack()) {
      markers.push_back(
          Body(*car.config, frame + "base_link", "cars_estimate", {1.0F, 1.0F, 1.0F, 0.35F}));
    }
  }
  Write(SlotFor("/track", Type::kMarkerArray, LatchedQos()), kZeroTime,
        [&](mcap::CdrWriter& w) { ros2::EncodeMarkerArray(w, markers); });
}

void McapRecording::Close(const std::vector<ExpectationResult>& expectations,
                          const std::string& result_sha256) {
  if (closed_) return;
  const Time end = loaded_.scenario.duration;
  for (const ExpectationResult& e : expectations) {
    if (e.passed) continue;
    const Time at = e.at_s ? FromSeconds(*e.at_s) : end;
    const ros2::Log log{.stamp = ros2::TimeOfNs(at.count()),
                        .level = ros2::LogLevel::kError,
                        .name = "expectations",
                        .msg = "failed: " + e.name + ": " + e.detail,
                        .file = "summary.json",
                        .function = "expect"};
    Write(*rosout_, at, [&](mcap::CdrWriter& w) { ros2::EncodeLog(w, log); });
  }
  writer_.AddMetadata("autonomsim", {{"scenario", loaded_.scenario.name},
                                     {"seed", std::to_string(loaded_.scenario.seed)},
                                     {"duration_s", fmt::format("{}", ToSeconds(end))},
                                     {"scenario_sha256", loaded_.sha256},
                                     {"result_sha256", result_sha256}});
  closed_ = true;
  writer_.Close();
}

std::vector<McapRecording::ChannelCount> McapRecording::channels() const {
  std::vector<ChannelCount> out;
  for (const Slot* slot : opened_) {
    out.push_back(
        {slot->topic, std::string(ros2::SchemaName(slot->type)), slot->messages, slot->bytes});
  }
  return out;
}

std::vector<std::string> McapRecording::unmatched_patterns() const {
  std::vector<std::string> out;
  for (std::size_t i = 0; i < options_.topics.size(); ++i) {
    if (!pattern_matched_[i]) out.push_back(options_.topics[i]);
  }
  return out;
}

}  // namespace autonomsim::sim
