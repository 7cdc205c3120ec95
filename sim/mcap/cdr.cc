#include "sim/mcap/cdr.h"

#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

namespace autonomsim::mcap {
namespace {
// The encapsulation header: representation identifier CDR_LE (0x0001, big-endian as RTPS writes
// it), then the options, 0.
constexpr std::uint8_t kCdrLeHeader[] = {0x00, 0x01, 0x00, 0x00};
constexpr std::size_t kCdrHeaderSize = sizeof(kCdrLeHeader);

// The uint32 that counts `size` (plus `extra`), or std::length_error: CDR cannot say more.
std::uint32_t CdrCount(std::size_t size, std::size_t extra, const char* what) {
  if (size > std::numeric_limits<std::uint32_t>::max() - extra) {
    throw std::length_error(std::string("CdrWriter: ") + what + " longer than a uint32 counts");
  }
  return static_cast<std::uint32_t>(size + extra);
}
}  // namespace

CdrWriter::CdrWriter() { Reset(); }

void CdrWriter::Reset() { buffer_.assign(std::begin(kCdrLeHeader), std::end(kCdrLeHeader)); }

std::vector<std::uint8_t> CdrWriter::Take() {
  std::vector<std::uint8_t> message = std::move(buffer_);
  buffer_ = {};
  Reset();
  return message;
}

std::uint8_t* CdrWriter::Grow(std::size_t alignment, std::size_t size) {
  // alignment counts from the end of the header
  const std::size_t position = buffer_.size() - kCdrHeaderSize;
  const std::size_t padding = (alignment - position % alignment) % alignment;
  const std::size_t start = buffer_.size() + padding;
  buffer_.resize(start + size);  // the padding bytes value-initialized: zeros
  return buffer_.data() + start;
}

void CdrWriter::String(std::string_view value) {
  U32(CdrCount(value.size(), 1, "a string"));
  std::uint8_t* out = Grow(1, value.size() + 1);
  if (!value.empty()) std::memcpy(out, value.data(), value.size());
  out[value.size()] = 0;
}

void CdrWriter::Bytes(std::span<const std::uint8_t> bytes) {
  SequenceLength(CdrCount(bytes.size(), 0, "a byte sequence"));
  Array(bytes);
}

}  // namespace autonomsim::mcap
