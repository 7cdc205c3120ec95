// The painted floor as an image, for the cameras and for track.png.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <vector>

#include "world/geometry.h"

namespace autonomsim::world {

class Track;

// The floor raster's texel: 5 mm (the cameras' texture and track.png).
inline constexpr double kFloorTexel_m = 0.005;

struct FloorRaster {
  int width_px{0};
  int height_px{0};
  double m_per_px{kFloorTexel_m};
  // Map coordinates of the top-left corner of pixel (0,0); image row 0 is the north edge (y max),
  // column 0 the west edge.
  Vec2 origin_m{0.0, 0.0};
  std::vector<std::uint8_t> bgr;  // row-major, 3 bytes per pixel, B,G,R (OpenCV order)
  std::array<std::uint8_t, 3> floor_bgr{0, 0, 0};  // the bare floor, also reported outside

  Vec2 PixelCentre(int col, int row) const;  // map coords
  // {col,row} of the pixel containing p (its top and left edges included), or nullopt outside.
  std::optional<std::array<int, 2>> PixelAt(const Vec2& p_map) const;
  // BGR; floor_bgr outside.
  std::array<std::uint8_t, 3> ColorAt(const Vec2& p_map) const;
};

// Covers spec.size_m × size_m centred on the origin (rounded up to whole pixels). A pixel takes a
// line's colour when its centre is within width/2 of the line's sampled centreline (inclusive; so
// an open line's ends are round); later lines paint over earlier ones. Cost: proportional to the
// painted area, not to the image times the lines (lab, 5 mm/px: ~2 ms). Throws
// std::invalid_argument if m_per_px is not positive.
FloorRaster RasterizeFloor(const Track& track, double m_per_px = kFloorTexel_m);

}  // namespace autonomsim::world
