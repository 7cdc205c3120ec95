// The ROS 2 definitions and encoders of sim/mcap/ros2_messages.h: byte layouts computed by hand
// from the CDR rules (sim/mcap/cdr.h), and every schema complete (each type a definition uses is
// in it once). Foxglove's own decoder reads them in tools/tests/mcap_run_check.mjs.
#include "sim/mcap/ros2_messages.h"

#include <gtest/gtest.h>

#include <cstring>
#include <set>
#include <sstream>
#include <string>
#include <vector>

namespace autonomsim::mcap::ros2 {
namespace {

std::vector<std::uint8_t> Bytes(const CdrWriter& w) { return {w.data().begin(), w.data().end()}; }

template <class T>
T At(const CdrWriter& w, std::size_t offset_after_header) {
  T value;
  std::memcpy(&value, w.data().data() + 4 + offset_after_header, sizeof(T));
  return value;
}

TEST(Ros2Messages, AStringIsItsLengthWithTheNulThenTheBytes) {
  CdrWriter w;
  EncodeString(w, "hi");
  EXPECT_EQ(Bytes(w), (std::vector<std::uint8_t>{0, 1, 0, 0, 3, 0, 0, 0, 'h', 'i', 0}));
}

TEST(Ros2Messages, APoseStampedAlignsItsFirstDoubleAfterTheFrameId) {
  // stamp sec 0-3, nanosec 4-7, frame_id length 8-11 ("map" + NUL = 4), bytes 12-15; the
  // position's x at 16 (already 8-aligned), then y, z and the quaternion: 16 + 7 * 8 = 72
  CdrWriter w;
  EncodePoseStamped(w, Header{.stamp = TimeOfNs(2'500'000'000), .frame_id = "map"},
                    Pose{.position = {1.5, -2.0, 0.0}, .orientation = YawQuaternion(0.0)});
  ASSERT_EQ(w.size(), 4u + 72u);
  EXPECT_EQ(At<std::int32_t>(w, 0), 2);
  EXPECT_EQ(At<std::uint32_t>(w, 4), 500'000'000u);
  EXPECT_EQ(At<std::uint32_t>(w, 8), 4u);
  EXPECT_EQ(std::string(reinterpret_cast<const char*>(w.data().data()) + 16), "map");
  EXPECT_EQ(At<double>(w, 16), 1.5);
  EXPECT_EQ(At<double>(w, 24), -2.0);
  EXPECT_EQ(At<double>(w, 64), 1.0);  // w of the identity
}

TEST(Ros2Messages, AFrameIdOfOddLengthIsPaddedBeforeTheNextDouble) {
  // frame_id "odom" + NUL = 5 bytes at 12-16: the translation's x pads to 24
  CdrWriter w;
  const TransformStamped t{.header = {.stamp = {}, .frame_id = "odom"},
                           .child_frame_id = "b",
                           .translation = {3.0, 0.0, 0.0}};
  EncodeTFMessage(w, std::span(&t, 1));
  EXPECT_EQ(At<std::uint32_t>(w, 0), 1u);  // one transform
  // count 0-3, sec 4-7, nanosec 8-11, "odom" length 12-15, bytes 16-20, "b" length at 24
  // (4-aligned)
  EXPECT_EQ(At<std::uint32_t>(w, 24), 2u);
  // "b\0" at 28-29, the translation's x at 32
  EXPECT_EQ(At<double>(w, 32), 3.0);
}

TEST(Ros2Messages, LanePointsAreTheLabsLayoutValidFirst) {
  std::array<LanePoint, 30> points{};
  points[0] = {0.5F, -0.25F};
  points[29] = {1.0F, 2.0F};
  CdrWriter w;
  EncodeLanePoints(w, 7, points);
  ASSERT_EQ(w.size(), 4u + 8u + 30u * 8u);  // uint64 valid, then 30 × two float32
  EXPECT_EQ(At<std::uint64_t>(w, 0), 7u);
  EXPECT_EQ(At<float>(w, 8), 0.5F);
  EXPECT_EQ(At<float>(w, 12), -0.25F);
  EXPECT_EQ(At<float>(w, 8 + 29 * 8 + 4), 2.0F);
}

TEST(Ros2Messages, AnOccupancyGridNeedsWidthTimesHeightCells) {
  CdrWriter w;
  const std::vector<std::int8_t> cells(6, 0);
  EXPECT_THROW(EncodeOccupancyGrid(w, Header{}, 0.05F, 4, 2, Pose{}, cells), std::invalid_argument);
  w.Reset();
  EncodeOccupancyGrid(w, Header{}, 0.05F, 3, 2, Pose{}, cells);
  // header: stamp 0-7, "" length 8-11 (1: the NUL) at 12; map_load_time 16-23, resolution 24,
  // width 28, height 32, origin 40-95 (8-aligned), data count at 96
  EXPECT_EQ(At<float>(w, 24), 0.05F);
  EXPECT_EQ(At<std::uint32_t>(w, 28), 3u);
  EXPECT_EQ(At<std::uint32_t>(w, 96), 6u);
  EXPECT_EQ(w.size(), 4u + 100u + 6u);
}

// Every field type a schema's definitions use, other than a primitive, is the section of one of
// them (resolved in the using definition's package when it names none), and each section comes
// once: what a ros2msg reader needs to decode.
TEST(Ros2Messages, EverySchemaDefinesEachTypeItUsesOnce) {
  const std::set<std::string> primitives = {"bool",   "byte",    "char",    "int8",   "uint8",
                                            "int16",  "uint16",  "int32",   "uint32", "int64",
                                            "uint64", "float32", "float64", "string", "wstring"};
  for (Type type :
       {Type::kTFMessage, Type::kPoseStamped, Type::kTwist, Type::kImage, Type::kCompressedImage,
        Type::kCameraInfo, Type::kOccupancyGrid, Type::kPath, Type::kString, Type::kBool,
        Type::kFloat64, Type::kLog, Type::kMarkerArray, Type::kLanePoints}) {
    const std::string name(SchemaName(type));
    const std::string top = name.substr(0, name.find('/')) + "/" + name.substr(name.rfind('/') + 1);
    std::istringstream text(SchemaText(type));
    std::set<std::string> defined = {top};
    std::vector<std::string> used;
    std::string package = top.substr(0, top.find('/'));
    for (std::string line; std::getline(text, line);) {
      if (line == std::string(80, '=')) continue;
      if (line.rfind("MSG: ", 0) == 0) {
        const std::string section = line.substr(5);
        EXPECT_TRUE(defined.insert(section).second) << name << ": " << section << " twice";
        package = section.substr(0, section.find('/'));
        continue;
      }
      std::string field_type = line.substr(0, line.find(' '));
      field_type = field_type.substr(0, field_type.find('['));
      if (line.find('=') != std::string::npos || primitives.count(field_type) > 0) continue;
      used.push_back(field_type.find('/') == std::string::npos ? package + "/" + field_type
                                                               : field_type);
    }
    for (const std::string& u : used) EXPECT_TRUE(defined.count(u) > 0) << name << " uses " << u;
  }
}

}  // namespace
}  // namespace autonomsim::mcap::ros2
