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
                   std::string planner) {
  TrackLineSpec line;
  line.name = std::move(name);
  line.color = "white";
  line.width_m = 0.04;
  line.points_m = std::move(points);
  line.closed = closed;
  line.corner_radius_m = corner_radius_m;
  line.planner = std::move(planner);
  return line;
}

// A 4 m floor: a border the planner does not see, a middle line, and a filled island.
Track MakeTrack() {
  TrackSpec spec;
  spec.size_m = 4.0;
  spec.colors_rgb = {{"white", {255, 255, 255}}};
  spec.lines = {
      Line("border", {{1.9, -1.9}, {1.9, 1.9}, {-1.9, 1.9}, {-1.9, -1.9}}, true, 0.4, "none"),
      Line("middle", {{-1.0, 0.0}, {1.0, 0.0}}, false, 0.0, "line"),
      Line("island", {{0.5, 0.6}, {0.5, 1.2}, {-0.5, 1.2}, {-0.5, 0.6}}, true, 0.3, "filled"),
      Line("ghost", {{0.2, -1.0}, {0.2, -0.2}}, false, 0.0, "none"),
  };
  LaneSegmentSpec lane;
  lane.name = "ring";
  lane.points_m = {{1.5, 0.0}, {1.5, -1.5}, {-1.5, -1.5}, {-1.5, 1.5}, {1.5, 1.5}, {1.5, 0.0}};
  spec.lanes = {lane};
  return Track(spec);
}

TEST(OccupancyMapTest, GeometryFollowsMapServer) {
  const OccupancyMap map = BuildStaticMap(MakeTrack());
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
}

TEST(OccupancyMapTest, APlannerMapLargerThanTheFloorIsFreeBeyondIt) {
  TrackSpec spec = MakeTrack().spec();
  spec.planner_map_size_m = 6.0;
  const Track track(spec);
  const OccupancyMap map = BuildStaticMap(track);
  EXPECT_EQ(map.width_cells, 120);
  EXPECT_TRUE(map.origin_m.isApprox(Vec2(-3.0, -3.0)));
  EXPECT_FALSE(map.Occupied({2.5, 0.0}));  // beyond the 4 m floor, on the map: free
  EXPECT_TRUE(map.Occupied({0.0, 0.01}));  // the middle line where it was
  EXPECT_TRUE(map.Occupied({0.0, 0.9}));   // inside the filled island, as on the floor's map
  EXPECT_TRUE(map.Occupied({3.01, 0.0}));  // outside the map
  spec.planner_map_size_m = 3.0;           // smaller than the floor
  EXPECT_THROW(spec.Validate(), std::invalid_argument);
}

TEST(OccupancyMapTest, LinesFilledOutlinesAndIgnoredLines) {
  const Track track = MakeTrack();
  const OccupancyMap map = BuildStaticMap(track);
  // The middle line lies on a cell boundary (y = 0): the rows either side are occupied, the
  // next ones free; its 2 cm round cap reaches into the next column only.
  EXPECT_TRUE(map.Occupied({0.0, 0.01}));
  EXPECT_TRUE(map.Occupied({0.0, -0.01}));
  EXPECT_TRUE(map.Occupied({-0.97, 0.04}));
  EXPECT_FALSE(map.Occupied({0.0, 0.06}));
  EXPECT_FALSE(map.Occupied({0.0, -0.06}));
  EXPECT_TRUE(map.Occupied({1.01, 0.01}));
  EXPECT_FALSE(map.Occupied({1.06, 0.01}));
  EXPECT_EQ(map.At(60, 40), OccupancyMap::kOccupied);  // x in [1.0, 1.05): the cap
  EXPECT_EQ(map.At(61, 40), OccupancyMap::kFree);
  // Inside the island, and its outline.
  EXPECT_TRUE(map.Occupied({0.0, 0.9}));
  EXPECT_TRUE(map.Occupied({-0.3, 0.7}));
  EXPECT_TRUE(map.Occupied({0.5, 0.9}));
  EXPECT_FALSE(map.Occupied({0.0, 0.5}));
  EXPECT_FALSE(map.Occupied({0.6, 0.9}));
  // Lines with planner: none are not there.
  EXPECT_FALSE(map.Occupied({1.9, 0.5}));
  EXPECT_FALSE(map.Occupied({0.2, -0.6}));
  // The lane is free all along.
  for (const Vec2& p : track.road_graph().path(0).points()) EXPECT_FALSE(map.Occupied(p)) << p;
}

// Cell by cell, against an independent reckoning: the stroke's distance to each cell found by
// walking the centreline in 1 mm steps (so within 0.5 mm of the truth), and the cell centre's
// inside-ness by ray casting.
TEST(OccupancyMapTest, MatchesBruteForce) {
  const Track track = MakeTrack();
  const OccupancyMap map = BuildStaticMap(track, 0.1);
  ASSERT_EQ(map.width_cells, 40);
  const TrackSpec& spec = track.spec();
  const double half_width = 0.02;
  const double res = map.resolution_m;
  std::vector<double> stroke_distance(map.cells.size(), 1e9);
  std::vector<bool> inside(map.cells.size(), false);
  for (std::size_t l = 0; l < spec.lines.size(); ++l) {
    if (spec.lines[l].planner == "none") continue;
    const std::vector<Vec2>& p = track.line_paths()[l].points();
    for (std::size_t i = 0; i + 1 < p.size(); ++i) {
      const int steps = static_cast<int>(std::ceil((p[i + 1] - p[i]).norm() / 1e-3));
      for (int k = 0; k <= steps; ++k) {
        const Vec2 q = p[i] + (p[i + 1] - p[i]) * (static_cast<double>(k) / steps);
        // The cells within reach of q.
        const Vec2 cell = (q - map.origin_m) / res;
        for (int row = static_cast<int>(cell.y()) - 1; row <= static_cast<int>(cell.y()) + 1;
             ++row) {
          for (int col = static_cast<int>(cell.x()) - 1; col <= static_cast<int>(cell.x()) + 1;
               ++col) {
            if (!map.Contains(col, row)) continue;
            const Vec2 lo = map.origin_m + Vec2(col, row) * res;
            const Vec2 hi = lo + Vec2(res, res);
            double& d = stroke_distance[row * map.width_cells + col];
            d = std::min(d, (q - q.cwiseMax(lo).cwiseMin(hi)).norm());
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
      const bool actual = map.At(col, row) == OccupancyMap::kOccupied;
      occupied += actual;
      if (inside[k] || stroke_distance[k] < half_width - 1e-3) {
        EXPECT_TRUE(actual) << "cell " << col << ", " << row;
      } else if (stroke_distance[k] > half_width + 1e-3) {
        EXPECT_FALSE(actual) << "cell " << col << ", " << row;
      }
    }
  }
  EXPECT_GT(occupied, 40);
}

}  // namespace
}  // namespace autonomsim::world
