#include "world/floor_raster.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "world/track.h"

namespace autonomsim::world {
namespace {

using Bgr = std::array<std::uint8_t, 3>;

constexpr Bgr kFloor{40, 30, 20};
constexpr Bgr kWhite{255, 255, 255};
constexpr Bgr kYellow{0, 235, 235};
constexpr Bgr kRed{0, 0, 200};

TrackLineSpec Line(std::string name, std::string color, double width_m, PointList points,
                   bool closed, double corner_radius_m) {
  TrackLineSpec line;
  line.name = std::move(name);
  line.color = std::move(color);
  line.width_m = width_m;
  line.points_m = std::move(points);
  line.closed = closed;
  line.corner_radius_m = corner_radius_m;
  return line;
}

// A 4 m floor: a rounded white border, a 4 cm yellow middle line, a red line drawn over it.
Track MakeTrack() {
  TrackSpec spec;
  spec.size_m = 4.0;
  spec.floor_rgb = {20, 30, 40};
  spec.colors_rgb = {{"white", {255, 255, 255}}, {"yellow", {235, 235, 0}}, {"red", {200, 0, 0}}};
  spec.lines = {
      Line("border", "white", 0.036, {{1.9, -1.9}, {1.9, 1.9}, {-1.9, 1.9}, {-1.9, -1.9}}, true,
           0.4),
      Line("middle", "yellow", 0.04, {{-1.0, 0.0}, {1.0, 0.0}}, false, 0.0),
      Line("crossing", "red", 0.02, {{0.0, -0.3}, {0.0, 0.3}}, false, 0.0),
  };
  return Track(spec);
}

TEST(FloorRasterTest, GeometryAndPixelLookUps) {
  const FloorRaster raster = RasterizeFloor(MakeTrack());
  EXPECT_EQ(raster.width_px, 800);
  EXPECT_EQ(raster.height_px, 800);
  EXPECT_DOUBLE_EQ(raster.m_per_px, 0.005);
  EXPECT_EQ(raster.bgr.size(), 800u * 800u * 3u);
  EXPECT_TRUE(raster.origin_m.isApprox(Vec2(-2.0, 2.0)));
  // Row 0 is the north edge, column 0 the west edge.
  EXPECT_TRUE(raster.PixelCentre(0, 0).isApprox(Vec2(-1.9975, 1.9975)));
  EXPECT_TRUE(raster.PixelCentre(799, 799).isApprox(Vec2(1.9975, -1.9975)));
  EXPECT_EQ(raster.PixelAt({-2.0, 2.0}), (std::array<int, 2>{0, 0}));
  EXPECT_EQ(raster.PixelAt({1.9999, -1.9999}), (std::array<int, 2>{799, 799}));
  EXPECT_EQ(raster.PixelAt({0.0126, 1.0}), (std::array<int, 2>{402, 200}));
  EXPECT_FALSE(raster.PixelAt({2.0, 0.0}).has_value());
  EXPECT_FALSE(raster.PixelAt({0.0, -2.0}).has_value());
  EXPECT_FALSE(raster.PixelAt({-2.1, 0.0}).has_value());
  EXPECT_FALSE(raster.PixelAt({std::numeric_limits<double>::quiet_NaN(), 0.0}).has_value());
  EXPECT_THROW(RasterizeFloor(MakeTrack(), 0.0), std::invalid_argument);
}

TEST(FloorRasterTest, ColoursAtKnownPoints) {
  const FloorRaster raster = RasterizeFloor(MakeTrack());
  EXPECT_EQ(raster.floor_bgr, kFloor);
  EXPECT_EQ(raster.ColorAt({0.5, 0.0}), kYellow);  // on the middle line
  EXPECT_EQ(raster.ColorAt({1.9, 0.0}), kWhite);   // on the border's straight side
  EXPECT_EQ(raster.ColorAt({-1.9, -1.0}), kWhite);
  EXPECT_EQ(raster.ColorAt({0.5, 0.5}), kFloor);           // between lines
  EXPECT_EQ(raster.ColorAt({1.8, 1.8}), kFloor);           // cut off by the rounded corner
  const double corner = 1.9 - 0.4 + 0.4 / std::sqrt(2.0);  // the arc's middle
  EXPECT_EQ(raster.ColorAt({corner, corner}), kWhite);
  EXPECT_EQ(raster.ColorAt({0.0, 0.0}), kRed);    // a later line paints over an earlier one
  EXPECT_EQ(raster.ColorAt({3.0, 3.0}), kFloor);  // outside the raster
  // Pixel centres at 17.5 mm and 22.5 mm from the 40 mm line's centreline.
  EXPECT_EQ(raster.ColorAt({0.3025, 0.0175}), kYellow);
  EXPECT_EQ(raster.ColorAt({0.3025, -0.0175}), kYellow);
  EXPECT_EQ(raster.ColorAt({0.3025, 0.0225}), kFloor);
  EXPECT_EQ(raster.ColorAt({1.0175, 0.0025}), kYellow);  // round cap past the end
  EXPECT_EQ(raster.ColorAt({1.0225, 0.0025}), kFloor);
}

// Stamping chord by chord gives what the definition says: a pixel takes the colour of the last
// line whose centreline is within half its width of the pixel centre (the distance from
// Polyline::Project, itself checked against an exhaustive search). At a pixel size that does not
// divide the floor: 4 m / 4.5 cm -> 89 px.
TEST(FloorRasterTest, MatchesDefinition) {
  const Track track = MakeTrack();
  const FloorRaster raster = RasterizeFloor(track, 0.045);
  ASSERT_EQ(raster.width_px, 89);
  EXPECT_NEAR(raster.origin_m.x(), -2.0025, 1e-12);
  const TrackSpec& spec = track.spec();
  int painted = 0;
  for (int row = 0; row < raster.height_px; ++row) {
    for (int col = 0; col < raster.width_px; ++col) {
      const Vec2 c = raster.PixelCentre(col, row);
      Bgr expected = kFloor;
      for (std::size_t l = 0; l < spec.lines.size(); ++l) {
        if (track.line_paths()[l].Project(c).distance_m <= 0.5 * spec.lines[l].width_m) {
          const Rgb& rgb = spec.colors_rgb.at(spec.lines[l].color);
          expected = {static_cast<std::uint8_t>(rgb[2]), static_cast<std::uint8_t>(rgb[1]),
                      static_cast<std::uint8_t>(rgb[0])};
        }
      }
      const std::size_t k = 3 * (static_cast<std::size_t>(row) * raster.width_px + col);
      const Bgr actual{raster.bgr[k], raster.bgr[k + 1], raster.bgr[k + 2]};
      ASSERT_EQ(actual, expected) << "pixel " << col << ", " << row;
      painted += expected != kFloor;
    }
  }
  EXPECT_GT(painted, 150);
}

}  // namespace
}  // namespace autonomsim::world
