// Test helper: a producer's line classes for a detector, from a whole colour frame (ClassOf of
// each pixel the detector reads), as the renderer writes them in the loop.
#pragma once

#include <cstddef>
#include <cstdint>

#include "stack/lane_detection.h"
#include "vehicle/ray_caster.h"

namespace autonomsim::stack::testing {

inline void WriteLineClasses(LaneDetector& detector, const vehicle::ColorImage& color) {
  const ClassImageRegion classes = detector.MutableClassRegion();
  for (const LaneDetector::SourceSpan& span : classes.spans) {
    for (int c = span.col_begin; c < span.col_end; ++c) {
      const std::uint8_t* px = color.bgr.data() + 3 * (span.row * color.width + c);
      classes.pixels[static_cast<std::size_t>(span.row * classes.stride + c)] =
          detector.ClassOf(px[0], px[1], px[2]);
    }
  }
}

}  // namespace autonomsim::stack::testing
