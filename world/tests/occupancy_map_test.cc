#include "world/occupancy_map.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "world/track.h"

namespace autonomsim::world {
namespace {

TrackLineSpec Line(std::string name, PointList points, bool closed, double corner_radius_m,
                   std::string planner, int grey = 0) {
  TrackLineSpec line;
  line.planner_grey = grey;
  line.name = std::move(name);
  line.color = "white";
  line.width_m = 0.04;
  line.points_m = std::move(points);
  line.closed = closed;
  line.corner_radius_m = corner_radius_m;
  line.planner = std::move(planner);
  return line;
}

// A 4 m floor: a border the planner does not see, a middle line, a filled island and a hollow one.
Track MakeTrack() {
  TrackSpec spec;
  spec.size_m = 4.0;
  spec.colors_rgb = {{"white", {255, 255, 255}}};
  spec.lines = {
      Line("border", {{1.9, -1.9}, {1.9, 1.9}, {-1.9, 1.9}, {-1.9, -1.9}}, true, 0.4, "none"),
      Line("middle", {{-1.0, 0.0}, {1.0, 0.0}}, false, 0.0, "line"),
      Line("island", {{0.5, 0.6}, {0.5, 1.2}, {-0.5, 1.2}, {-0.5, 0.6}}, true, 0.3, "filled"),
      Line("ghost", {{0.2, -1.0}, {0.2, -0.2}}, false, 0.0, "none"),
      Line("ring", {{0.5, -1.2}, {0.5, -0.6}, {-0.5, -0.6}, {-0.5, -1.2}}, true, 0.3, "line"),
  };
  LaneSegmentSpec lane;
  lane.name = "ring";
  lane.points_m = {{1.5, 0.0}, {1.5, -1.5}, {-1.5, -1.5}, {-1.5, 1.5}, {1.5, 1.5}, {1.5, 0.0}};
  spec.lanes = {lane};
  return Track(spec);
}

TEST(OccupancyMapTest, GeometryFollowsMapServer) {
  const OccupancyMap map = BuildStaticMap(MakeTrack(), 0.05);
  EXPECT_EQ(map.width_cells, 80);
  EXPECT_EQ(map.height_cells, 80);
  EXPECT_DOUBLE_EQ(map.resolution_m, 0.05);
  EXPECT_EQ(map.cells.size(), 6400u);
  EXPECT_TRUE(map.origin_m.isApprox(Vec2(-2.0, -2.0)));
  // Row 0 is the south edge.
  EXPECT_EQ(map.CellAt({-1.99, -1.99}), (std::array<int, 2>{0, 0}));
  EXPECT_EQ(map.CellAt({-1.99, 1.99}), (std::array<int, 2>{0, 79}));
  EXPECT_TRUE(map.CellCentre(0, 0).isApprox(Vec2(-1.975, -1.975)));
  EXPECT_FALSE(map.CellAt({2.0, 0.0}).has_value());
  EXPECT_TRUE(map.Occupied({2.5, 0.0}));  // outside counts as occupied
  EXPECT_TRUE(map.Occupied({0.0, -2.01}));
  EXPECT_THROW(map.At(80, 0), std::out_of_range);
  EXPECT_THROW(map.At(0, -1), std::out_of_range);
  EXPECT_THROW(BuildStaticMap(MakeTrack(), -0.05), std::invalid_argument);
  // The lab's map: 10 m at simplestreet3.yaml:18's 0.00517063 m is the picture's 1934 px.
  TrackSpec lab = MakeTrack().spec();
  lab.planner_map_size_m = 10.0;
  EXPECT_EQ(BuildStaticMap(Track(lab)).width_cells, 1934);
}

TEST(OccupancyMapTest, APlannerMapLargerThanTheFloorIsFreeBeyondIt) {
  TrackSpec spec = MakeTrack().spec();
  spec.planner_map_size_m = 6.0;
  const Track track(spec);
  const OccupancyMap map = BuildStaticMap(track, 0.01);
  EXPECT_EQ(map.width_cells, 600);
  EXPECT_TRUE(map.origin_m.isApprox(Vec2(-3.0, -3.0)));
  EXPECT_FALSE(map.Occupied({2.5, 0.0}));  // beyond the 4 m floor, on the map: free
  EXPECT_TRUE(map.Occupied({0.0, 0.01}));  // the middle line where it was
  EXPECT_TRUE(map.Occupied({0.0, 0.9}));   // inside the filled island, as on the floor's map
  EXPECT_TRUE(map.Occupied({3.01, 0.0}));  // outside the map
  spec.planner_map_size_m = 3.0;           // smaller than the floor
  EXPECT_THROW(spec.Validate(), std::invalid_argument);
}

// Galactic map_io.cpp:212-243 (`mode: scale`) with simplestreet3.yaml:22-23's thresholds.
TEST(OccupancyMapTest, MapServerScaleModeTurnsGreyIntoValues) {
  const MapServerParams lab;
  EXPECT_EQ(lab.ValueOfGrey(0), 100);
  EXPECT_EQ(lab.ValueOfGrey(77), 100);   // the yellow lines' grey: occ 0.698 > 0.60
  EXPECT_EQ(lab.ValueOfGrey(102), 100);  // occ 0.600: rint(100 · 0.404 / 0.404)
  EXPECT_EQ(lab.ValueOfGrey(103), 99);   // occ 0.596
  EXPECT_EQ(lab.ValueOfGrey(204), 1);    // occ 0.200: rint(0.99)
  EXPECT_EQ(lab.ValueOfGrey(205), 0);    // occ 0.196 1: rint(0.02)
  EXPECT_EQ(lab.ValueOfGrey(255), 0);
  EXPECT_THROW((MapServerParams{.occupied_thresh = 0.1, .free_thresh = 0.2}.Validate()),
               std::invalid_argument);
}

// A stroke in its grey with one graded cell at each edge and flat ends (the lab's picture,
// measured): worked by hand for a 0.04 m line along y = 0.003 from x = -1 to 1.003, in grey 77,
// at 0.01 m.
TEST(OccupancyMapTest, AStrokeIsDrawnInItsGreyWithOneGradedCellAtEachEdgeAndFlatEnds) {
  TrackSpec spec = MakeTrack().spec();
  spec.lines = {Line("middle", {{-1.0, 0.003}, {1.003, 0.003}}, false, 0.0, "line", 77)};
  const Track track(spec);
  const OccupancyMap map = BuildStaticMap(track, 0.01);
  const auto value = [&](double x, double y) {
    const auto cell = map.CellAt({x, y});
    return map.At((*cell)[0], (*cell)[1]);
  };
  // Cell centres at y = 0.005 ... 0.015 (d <= 0.012): covered, grey 77 -> 100.
  EXPECT_EQ(value(0.0, 0.015), 100);
  EXPECT_EQ(value(0.0, -0.005), 100);
  // y = 0.025: d 0.022, coverage (0.02 - 0.022) / 0.01 + 0.5 = 0.3, grey 255 - 178 · 0.3 = 202,
  // occ 0.208: rint(100 · 0.012 / 0.404) = 3.
  EXPECT_EQ(value(0.0, 0.025), 3);
  // y = -0.015: d 0.018, coverage 0.7, grey 130, occ 0.490: rint(72.8) = 73.
  EXPECT_EQ(value(0.0, -0.015), 73);
  EXPECT_EQ(value(0.0, 0.035), 0);
  EXPECT_EQ(value(0.0, -0.025), 0);
  // The flat end at x = 1.003: the cell centred 0.002 beyond it is covered 0.3 (grey 202, 3);
  // the next one not at all.
  EXPECT_EQ(value(0.995, 0.005), 100);
  EXPECT_EQ(value(1.005, 0.005), 3);
  EXPECT_EQ(value(1.015, 0.005), 0);
  EXPECT_TRUE(map.Occupied({0.0, 0.0}));
  EXPECT_FALSE(map.Occupied({0.0, -0.015}));  // graded cells are not occupied
  // A U whose ends lie at different heights, as the lab's yellow loop (y = 0.63 on the right,
  // 0.68 on the left): each end's square cap clips the stroke only near that end.
  spec.lines = {Line("u", {{1.0, 0.5}, {1.0, 1.5}, {-1.0, 1.5}, {-1.0, 0.8}}, false, 0.2, "line")};
  const OccupancyMap u = BuildStaticMap(Track(spec), 0.01);
  EXPECT_TRUE(u.Occupied({1.0, 0.6}));  // below the other end's 0.8
  EXPECT_TRUE(u.Occupied({-1.0, 0.805}));
  EXPECT_FALSE(u.Occupied({-1.0, 0.78}));
  EXPECT_FALSE(u.Occupied({1.0, 0.48}));
}

TEST(OccupancyMapTest, HollowAndFilledOutlinesAndIgnoredLines) {
  const Track track = MakeTrack();
  const OccupancyMap map = BuildStaticMap(track, 0.01);
  // The filled island: inside and its outline.
  EXPECT_TRUE(map.Occupied({0.0, 0.9}));
  EXPECT_TRUE(map.Occupied({-0.3, 0.7}));
  EXPECT_TRUE(map.Occupied({0.5, 0.9}));
  EXPECT_FALSE(map.Occupied({0.0, 0.5}));
  EXPECT_FALSE(map.Occupied({0.6, 0.9}));
  // The hollow one (planner: line): its outline, and free inside.
  EXPECT_TRUE(map.Occupied({0.0, -0.601}));
  EXPECT_TRUE(map.Occupied({0.5, -0.9}));
  // A 0.04 m line along a cell boundary at 0.05 m covers 0.4 of each cell beside it: graded
  // (value 50), so it is not in a map that coarse at all.
  EXPECT_FALSE(BuildStaticMap(track, 0.05).Occupied({0.0, -0.601}));
  EXPECT_FALSE(map.Occupied({0.0, -0.9}));
  EXPECT_FALSE(map.Occupied({0.3, -0.8}));
  // Lines with planner: none are not there.
  EXPECT_FALSE(map.Occupied({1.9, 0.5}));
  EXPECT_FALSE(map.Occupied({0.2, -0.3}));
  // The lane is free all along.
  for (const Vec2& p : track.road_graph().path(0).points()) EXPECT_FALSE(map.Occupied(p)) << p;
}

// Cell by cell, against an independent reckoning: each cell centre's distance to the stroke found
// by walking the centreline in 0.2 mm steps, and its inside-ness by ray casting. Cells clearly
// inside the stroke (or a filled outline) are occupied, cells clearly outside it are free.
TEST(OccupancyMapTest, MatchesBruteForce) {
  const Track track = MakeTrack();
  const OccupancyMap map = BuildStaticMap(track, 0.1);
  ASSERT_EQ(map.width_cells, 40);
  const TrackSpec& spec = track.spec();
  const double half_width = 0.02;
  const double res = map.resolution_m;
  std::vector<double> distance(map.cells.size(), 1e9);
  std::vector<bool> inside(map.cells.size(), false);
  for (std::size_t l = 0; l < spec.lines.size(); ++l) {
    if (spec.lines[l].planner == "none") continue;
    const std::vector<Vec2>& p = track.line_paths()[l].points();
    for (std::size_t i = 0; i + 1 < p.size(); ++i) {
      const int steps = static_cast<int>(std::ceil((p[i + 1] - p[i]).norm() / 2e-4));
      for (int k = 0; k <= steps; ++k) {
        const Vec2 q = p[i] + (p[i + 1] - p[i]) * (static_cast<double>(k) / steps);
        const Vec2 cell = (q - map.origin_m) / res;
        for (int row = static_cast<int>(cell.y()) - 1; row <= static_cast<int>(cell.y()) + 1;
             ++row) {
          for (int col = static_cast<int>(cell.x()) - 1; col <= static_cast<int>(cell.x()) + 1;
               ++col) {
            if (!map.Contains(col, row)) continue;
            double& d = distance[row * map.width_cells + col];
            d = std::min(d, (q - map.CellCentre(col, row)).norm());
          }
        }
      }
    }
    if (spec.lines[l].planner != "filled") continue;
    for (int row = 0; row < map.height_cells; ++row) {
      for (int col = 0; col < map.width_cells; ++col) {
        const Vec2 c = map.CellCentre(col, row);
        for (std::size_t i = 0; i + 1 < p.size(); ++i) {
          if ((p[i].y() > c.y()) != (p[i + 1].y() > c.y()) &&
              c.x() < p[i].x() + (c.y() - p[i].y()) * (p[i + 1].x() - p[i].x()) /
                                     (p[i + 1].y() - p[i].y())) {
            inside[row * map.width_cells + col] = !inside[row * map.width_cells + col];
          }
        }
      }
    }
  }
  int occupied = 0;
  for (int row = 0; row < map.height_cells; ++row) {
    for (int col = 0; col < map.width_cells; ++col) {
      const std::size_t k = row * map.width_cells + col;
      const std::int8_t value = map.At(col, row);
      occupied += value == OccupancyMap::kOccupied;
      // Black lines: occupied where the coverage (half_width - d) / res + 1/2 reaches 0.6.
      if (inside[k] || distance[k] < half_width - 0.1 * res - 1e-3) {
        EXPECT_EQ(value, OccupancyMap::kOccupied) << "cell " << col << ", " << row;
      } else if (distance[k] > half_width + 0.5 * res + 1e-3) {
        EXPECT_EQ(value, OccupancyMap::kFree) << "cell " << col << ", " << row;
      }
    }
  }
  EXPECT_GT(occupied, 10);
}

}  // namespace
}  // namespace autonomsim::world
