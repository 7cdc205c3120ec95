// Bit masks of 64-bit words, for the row bitmaps of the renderer and the lane detector.
#pragma once

#include <cstdint>

namespace autonomsim::world {

// Bits [lo, hi) of a 64-bit word set, the others clear (0 <= lo <= hi <= 64).
constexpr std::uint64_t BitRange(int lo, int hi) {
  return (hi == 64 ? ~std::uint64_t{0} : (std::uint64_t{1} << hi) - 1) & (~std::uint64_t{0} << lo);
}

}  // namespace autonomsim::world
