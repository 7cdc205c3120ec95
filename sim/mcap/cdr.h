// CdrWriter: ROS 2 messages encoded as CDR, the way rosbag2 records them (MCAP message encoding
// "cdr"): plain XCDR1, little-endian (OMG DDS-XTypes 1.3 §7.4.3.5 "PLAIN_CDR"; the framing is
// DDSI-RTPS 2.5 §10.5's SerializedPayload header).
//
// The layout:
// - a 4-byte encapsulation header 00 01 00 00 (representation CDR_LE, options 0);
// - every primitive aligned to its own size, counted from the end of that header (not from the
//   start of the buffer), with zero bytes as padding; 8-byte values to 8 (XCDR1; XCDR2 would use
//   4); bool and (u)int8 unaligned;
// - a string: a uint32 length that counts the terminating NUL, the bytes, the NUL;
// - a sequence: a uint32 element count, then the elements; a fixed array: the elements alone;
// - an empty sequence of primitives is the count alone: no padding for elements that are not
//   there.
// Checked against foxglove/cdr (commit 233fc65): src/CdrWriter.ts writes the header and sets its
// alignment origin to 4, align() pads with zeros to (offset - origin) % size, 64-bit values use
// eightByteAlignment = 8 for CDR1, string() writes length + 1 and a 0 byte; src/CdrReader.ts's
// typedArray() returns an empty array before aligning when the count is 0. And against eProsima
// Fast-CDR (commit 00e324d), the encoder of rmw_fastrtps whose bytes rosbag2 records:
// src/cpp/Cdr.cpp's serialize_encapsulation() ends with reset_alignment() (origin after the
// header), align64_ is 8 for XCDR1, Cdr::alignment() is (size - (offset - origin) % size) &
// (size - 1), and serialize_array() returns before aligning when num_elements is 0.
//
// A message is encoded by calling the methods in the order of the message definition's fields,
// depth first (a nested message's fields in place, no header of its own). The writer keeps its
// buffer: Reset() starts the next message in the same memory, so a recorder that encodes one
// message at a time allocates only while its largest message grows.
#pragma once

#include <bit>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>
#include <string_view>
#include <type_traits>
#include <vector>

namespace autonomsim::mcap {

// The host's byte order is CDR_LE's: values are copied as they are in memory.
static_assert(std::endian::native == std::endian::little, "CdrWriter assumes a little-endian host");

class CdrWriter {
 public:
  // Starts a message: the encapsulation header and nothing else.
  CdrWriter();

  void Bool(bool value) { U8(value ? 1 : 0); }
  void U8(std::uint8_t value) { Put(value); }
  void I8(std::int8_t value) { Put(value); }
  void U16(std::uint16_t value) { Put(value); }
  void I16(std::int16_t value) { Put(value); }
  void U32(std::uint32_t value) { Put(value); }
  void I32(std::int32_t value) { Put(value); }
  void U64(std::uint64_t value) { Put(value); }
  void I64(std::int64_t value) { Put(value); }
  void F32(float value) { Put(value); }
  void F64(double value) { Put(value); }

  // A string: its uint32 length counting the terminating NUL, the bytes, the NUL. (A ROS 2
  // string holds no NUL of its own; one in `value` is written as it is.)
  void String(std::string_view value);
  // The element count that opens a sequence (the elements follow, written by the caller).
  void SequenceLength(std::uint32_t count) { U32(count); }
  // A uint8[] sequence (an image's data, a serialized blob): the count, then the bytes in one copy.
  void Bytes(std::span<const std::uint8_t> bytes);
  // A fixed array of primitives (float64[9], ...): the elements, aligned once, in one copy. For a
  // sequence, call SequenceLength first. Nothing at all for an empty span.
  template <typename T>
  void Array(std::span<const T> values) {
    static_assert(std::is_arithmetic_v<T> && !std::is_same_v<T, bool>,
                  "Array: numbers only (a bool[] is written one Bool at a time)");
    if (values.empty()) return;
    std::uint8_t* out = Grow(sizeof(T), values.size_bytes());
    std::memcpy(out, values.data(), values.size_bytes());
  }

  // The message so far, header included.
  std::span<const std::uint8_t> data() const { return buffer_; }
  std::size_t size() const { return buffer_.size(); }
  // Starts the next message in the same buffer (its capacity kept).
  void Reset();
  // Hands the buffer over and starts the next message in an empty one.
  std::vector<std::uint8_t> Take();

 private:
  template <typename T>
  void Put(T value) {
    std::memcpy(Grow(sizeof(T), sizeof(T)), &value, sizeof(T));
  }
  // Pads to `alignment` (zeros) and appends `size` bytes; returns where they start.
  std::uint8_t* Grow(std::size_t alignment, std::size_t size);

  std::vector<std::uint8_t> buffer_;
};

}  // namespace autonomsim::mcap
