#include "world/floor_raster.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "world/track.h"
#include "world/validation.h"

namespace autonomsim::world {
namespace {

std::array<std::uint8_t, 3> ToBgr(const Rgb& rgb) {
  return {static_cast<std::uint8_t>(rgb[2]), static_cast<std::uint8_t>(rgb[1]),
          static_cast<std::uint8_t>(rgb[0])};
}

}  // namespace

Vec2 FloorRaster::PixelCentre(int col, int row) const {
  return {origin_m.x() + (col + 0.5) * m_per_px, origin_m.y() - (row + 0.5) * m_per_px};
}

std::optional<std::array<int, 2>> FloorRaster::PixelAt(const Vec2& p_map) const {
  const double col = std::floor((p_map.x() - origin_m.x()) / m_per_px);
  const double row = std::floor((origin_m.y() - p_map.y()) / m_per_px);
  if (!(col >= 0.0 && col < width_px && row >= 0.0 && row < height_px)) return std::nullopt;
  return std::array<int, 2>{static_cast<int>(col), static_cast<int>(row)};
}

std::array<std::uint8_t, 3> FloorRaster::ColorAt(const Vec2& p_map) const {
  const auto pixel = PixelAt(p_map);
  if (!pixel) return floor_bgr;
  const std::size_t i =
      3 * (static_cast<std::size_t>((*pixel)[1]) * static_cast<std::size_t>(width_px) +
           static_cast<std::size_t>((*pixel)[0]));
  return {bgr[i], bgr[i + 1], bgr[i + 2]};
}

FloorRaster RasterizeFloor(const Track& track, double m_per_px) {
  if (!(std::isfinite(m_per_px) && m_per_px > 0.0)) {
    throw std::invalid_argument("m_per_px must be > 0, got " + Num(m_per_px));
  }
  const TrackSpec& spec = track.spec();
  FloorRaster raster;
  raster.m_per_px = m_per_px;
  // 1e-9 absorbs the rounding of size / m_per_px so that 5 m at 5 mm is 1000 px, not 1001.
  const int side_px = static_cast<int>(std::ceil(spec.size_m / m_per_px - 1e-9));
  raster.width_px = side_px;
  raster.height_px = side_px;
  raster.origin_m = Vec2(-0.5 * side_px * m_per_px, 0.5 * side_px * m_per_px);
  raster.floor_bgr = ToBgr(spec.floor_rgb);
  const std::size_t pixel_count = static_cast<std::size_t>(side_px) * side_px;
  const std::size_t row_bytes = 3 * static_cast<std::size_t>(side_px);
  raster.bgr.resize(3 * pixel_count);
  for (std::size_t i = 0; i < row_bytes; i += 3) {
    std::copy(raster.floor_bgr.begin(), raster.floor_bgr.end(), raster.bgr.begin() + i);
  }
  for (int row = 1; row < side_px; ++row) {
    std::copy_n(raster.bgr.begin(), row_bytes, raster.bgr.begin() + row * row_bytes);
  }

  // Pixel centres x_c = origin.x + (col + 0.5) m within [lo, hi] (sign -1: rows, counted from
  // the north edge), clamped to the image; a hair wider so that rounding never drops a pixel the
  // distance test would take.
  auto first = [&](double lo_m, double origin, double sign) {
    const double index = std::ceil(sign * (lo_m - origin) / m_per_px - 0.5 - 1e-6);
    return static_cast<int>(std::clamp(index, 0.0, static_cast<double>(side_px)));
  };
  auto last = [&](double hi_m, double origin, double sign) {
    const double index = std::floor(sign * (hi_m - origin) / m_per_px - 0.5 + 1e-6);
    return static_cast<int>(std::clamp(index, -1.0, static_cast<double>(side_px - 1)));
  };
  // Each chord stamps the pixels of its bounding box grown by half the width whose centres lie
  // within half the width of it.
  for (std::size_t l = 0; l < spec.lines.size(); ++l) {
    const TrackLineSpec& line = spec.lines[l];
    const std::array<std::uint8_t, 3> color = ToBgr(spec.colors_rgb.at(line.color));
    const double half_width = 0.5 * line.width_m;
    const double half_width_sq = half_width * half_width;
    const std::vector<Vec2>& points = track.line_paths()[l].points();
    for (std::size_t i = 0; i + 1 < points.size(); ++i) {
      const Vec2& a = points[i];
      const Vec2& b = points[i + 1];
      const int col_lo = first(std::min(a.x(), b.x()) - half_width, raster.origin_m.x(), 1.0);
      const int col_hi = last(std::max(a.x(), b.x()) + half_width, raster.origin_m.x(), 1.0);
      const int row_lo = first(std::max(a.y(), b.y()) + half_width, raster.origin_m.y(), -1.0);
      const int row_hi = last(std::min(a.y(), b.y()) - half_width, raster.origin_m.y(), -1.0);
      const double ab_x = b.x() - a.x();
      const double ab_y = b.y() - a.y();
      const double inverse_length_sq = 1.0 / (ab_x * ab_x + ab_y * ab_y);
      for (int row = row_lo; row <= row_hi; ++row) {
        const double d_y = raster.origin_m.y() - (row + 0.5) * m_per_px - a.y();
        std::uint8_t* pixel = raster.bgr.data() + row * row_bytes + 3 * col_lo;
        for (int col = col_lo; col <= col_hi; ++col, pixel += 3) {
          const double d_x = raster.origin_m.x() + (col + 0.5) * m_per_px - a.x();
          const double t = std::clamp((d_x * ab_x + d_y * ab_y) * inverse_length_sq, 0.0, 1.0);
          const double e_x = d_x - ab_x * t;
          const double e_y = d_y - ab_y * t;
          if (e_x * e_x + e_y * e_y <= half_width_sq) {
            pixel[0] = color[0];
            pixel[1] = color[1];
            pixel[2] = color[2];
          }
        }
      }
    }
  }
  return raster;
}

}  // namespace autonomsim::world
