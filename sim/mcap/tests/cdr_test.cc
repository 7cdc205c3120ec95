// CdrWriter's bytes worked out by hand from the rules in cdr.h's opening comment. Offsets in the
// comments count from the end of the 4-byte encapsulation header, where alignment starts.
#include "sim/mcap/cdr.h"

#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <span>
#include <vector>

namespace autonomsim::mcap {
namespace {

using Bytes = std::vector<std::uint8_t>;

Bytes Of(const CdrWriter& cdr) { return {cdr.data().begin(), cdr.data().end()}; }

TEST(CdrWriter, StartsWithTheLittleEndianEncapsulationHeader) {
  CdrWriter cdr;
  EXPECT_EQ(Of(cdr), (Bytes{0x00, 0x01, 0x00, 0x00}));
}

TEST(CdrWriter, AU8ThenAF64PadsSevenBytes) {
  CdrWriter cdr;
  cdr.U8(0xAB);  // offset 0
  cdr.F64(1.0);  // offset 8: 1.0 is 0x3FF0000000000000

  EXPECT_EQ(Of(cdr), (Bytes{0,    1, 0, 0,                 //
                            0xAB, 0, 0, 0, 0, 0, 0,    0,  //
                            0,    0, 0, 0, 0, 0, 0xF0, 0x3F}));
}

TEST(CdrWriter, EachPrimitiveAlignsToItsOwnSize) {
  CdrWriter cdr;
  cdr.Bool(true);               // 0
  cdr.I16(-2);                  // 2
  cdr.I8(-1);                   // 4
  cdr.U32(0x01020304);          // 8
  cdr.U16(0xBEEF);              // 12
  cdr.F32(-2.0F);               // 16: 0xC0000000
  cdr.I64(-3);                  // 24
  cdr.U64(0x1122334455667788);  // 32

  EXPECT_EQ(Of(cdr), (Bytes{0,    1,    0,    0,                             //
                            1,    0,    0xFE, 0xFF, 0xFF, 0,    0,    0,     //
                            0x04, 0x03, 0x02, 0x01, 0xEF, 0xBE, 0,    0,     //
                            0,    0,    0,    0xC0, 0,    0,    0,    0,     //
                            0xFD, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF,  //
                            0x88, 0x77, 0x66, 0x55, 0x44, 0x33, 0x22, 0x11}));
}

TEST(CdrWriter, AStringsLengthCountsItsNul) {
  CdrWriter cdr;
  cdr.U8(7);         // 0
  cdr.String("hi");  // length at 4: 3 ("h", "i", NUL), bytes at 8
  cdr.String("");    // length at 12 (after 3 bytes, aligned): 1, then the NUL alone

  EXPECT_EQ(Of(cdr), (Bytes{0,   1,   0, 0,              //
                            7,   0,   0, 0, 3, 0, 0, 0,  //
                            'h', 'i', 0, 0,              //
                            1,   0,   0, 0, 0}));
}

TEST(CdrWriter, BytesAreACountAndTheRawBytes) {
  CdrWriter cdr;
  cdr.U8(9);
  const std::array<std::uint8_t, 3> blob{0xA, 0xB, 0xC};
  cdr.Bytes(blob);
  cdr.Bytes({});

  EXPECT_EQ(Of(cdr), (Bytes{0, 1, 0, 0, 9, 0, 0, 0, 3, 0, 0, 0, 0xA, 0xB, 0xC, 0, 0, 0, 0, 0}));
}

TEST(CdrWriter, ArraysAlignOnceAndAnEmptySequenceHasNoPadding) {
  CdrWriter cdr;
  const std::array<double, 2> pair{0.0, -0.0};
  cdr.SequenceLength(2);                     // 0
  cdr.Array(std::span<const double>(pair));  // 8 and 16; -0.0 is the sign bit
  cdr.U8(1);                                 // 24
  cdr.SequenceLength(0);                     // 28
  cdr.Array(std::span<const double>());      // nothing, not even padding to 8
  cdr.U8(2);                                 // 32
  Bytes expected{0, 1, 0, 0, 2, 0, 0, 0, 0, 0, 0, 0};
  expected.insert(expected.end(), {0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0x80});
  expected.insert(expected.end(), {1, 0, 0, 0, 0, 0, 0, 0, 2});
  EXPECT_EQ(Of(cdr), expected);
}

// A ROS 2 geometry_msgs/msg/TransformStamped, field by field: header (stamp sec, nanosec,
// frame_id), child_frame_id, translation x y z, rotation x y z w.
TEST(CdrWriter, ATransformStampedHasTheLayoutRosbag2Records) {
  CdrWriter cdr;
  cdr.I32(5);
  cdr.U32(6);
  cdr.String("map");   // 8: length 4, "map\0" at 12
  cdr.String("base");  // 16: length 5, "base\0" at 20..24
  for (double v : {1.0, 2.0, 3.0, 0.0, 0.0, 0.0, 1.0}) cdr.F64(v);  // from 32 (NUL at 24, 7 pad)
  ASSERT_EQ(cdr.size(), 4U + 32 + 7 * 8);
  const Bytes bytes = Of(cdr);
  EXPECT_EQ(Bytes(bytes.begin() + 4, bytes.begin() + 36),
            (Bytes{5, 0, 0, 0, 6,   0,   0,   0,   4, 0, 0, 0, 'm', 'a', 'p', 0,  //
                   5, 0, 0, 0, 'b', 'a', 's', 'e', 0, 0, 0, 0, 0,   0,   0,   0}));
  EXPECT_EQ(bytes[4 + 32 + 7], 0x3F);  // translation.x = 1.0's top byte
}

TEST(CdrWriter, ResetKeepsTheBufferAndTakeHandsItOver) {
  CdrWriter cdr;
  cdr.String("a longer message than the next");
  const std::uint8_t* memory = cdr.data().data();
  cdr.Reset();
  cdr.U8(1);
  EXPECT_EQ(cdr.data().data(), memory);  // no allocation for the next message
  EXPECT_EQ(Of(cdr), (Bytes{0, 1, 0, 0, 1}));
  const Bytes taken = cdr.Take();
  EXPECT_EQ(taken, (Bytes{0, 1, 0, 0, 1}));
  EXPECT_EQ(Of(cdr), (Bytes{0, 1, 0, 0}));
}

}  // namespace
}  // namespace autonomsim::mcap
