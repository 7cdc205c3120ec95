// The planner's static map: what the real car is given as its map, not ground truth. Reference §1:
// it holds the yellow lines and the islands' outlines as obstacles, and the outer white boundary
// is missing. The lab's map is a picture (nav2_local/maps/final_map.png) that map_server loads in
// `mode: scale` (nav2_local/maps/simplestreet3.yaml:20-24); ours is drawn from the track file in
// the grey levels the lab's picture uses (measured, see TrackLineSpec::planner_grey) and turned
// into OccupancyGrid values the way Galactic's map_server does (nav2_map_server/src/map_io.cpp:
// 196-243): 0 free, 100 occupied, 1..99 graded, -1 unknown.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <vector>

#include "world/geometry.h"

namespace autonomsim::world {

class Track;

struct OccupancyMap {
  static constexpr std::int8_t kFree = 0;  // ROS OccupancyGrid values
  static constexpr std::int8_t kOccupied = 100;

  int width_cells{0};
  int height_cells{0};
  double resolution_m{0.05};
  // Map coordinates of the lower-left corner of cell (0,0) (ROS map_server convention: row 0 is
  // the south edge).
  Vec2 origin_m{0.0, 0.0};
  std::vector<std::int8_t> cells;  // row-major from row 0; 0 free, 100 occupied, -1 unknown

  // Outside the map, unknown cells and occupied (100) cells count as occupied; graded cells
  // (1..99) do not (Galactic's StaticLayer makes them FREE, see stack/costmap.h).
  bool Occupied(const Vec2& p_map) const;
  std::int8_t At(int col, int row) const;  // throws std::out_of_range outside the map
  bool Contains(int col, int row) const {
    return col >= 0 && col < width_cells && row >= 0 && row < height_cells;
  }
  std::optional<std::array<int, 2>> CellAt(const Vec2& p_map) const;  // {col,row}, nullopt outside
  Vec2 CellCentre(int col, int row) const;                            // map coords
};

// How map_server turns a picture's grey into an OccupancyGrid value (`mode: scale`,
// nav2_map_server/src/map_io.cpp:212-243): occ = 1 - grey/255 (negate 0); occ > occupied_thresh:
// 100; occ < free_thresh: 0; else rint(100 (occ - free) / (occupied - free)). All pixels of the
// lab's picture are opaque (alpha 255, measured), so none is unknown.
struct MapServerParams {
  double occupied_thresh{0.60};  // simplestreet3.yaml:22
  double free_thresh{0.196};     // simplestreet3.yaml:23
  void Validate() const;
  std::int8_t ValueOfGrey(int grey) const;  // grey 0 (black) .. 255 (white)
};

// The lab's map's resolution: simplestreet3.yaml:18 (0.00517063 m/px, 1934 px for 10 m).
inline constexpr double kLabMapResolution_m = 0.00517063;

// Covers a square of side spec.planner_map_size_m (absent: spec.size_m) centred on the origin
// (rounded up to whole cells). Each line with planner "line" or "filled" is drawn as an
// anti-aliased stroke of width_m in its planner_grey: a cell whose centre lies d from the sampled
// centreline is covered by c = clamp((width/2 - d)/resolution + 1/2, 0, 1) (a straight edge's
// share of the cell: one graded cell at each edge, as in the lab's picture) and gets grey
// 255 - (255 - planner_grey) c; round joins, and flat ends at an open line's end points (the
// lab's picture, measured). "filled": every cell whose centre is inside the closed outline is
// occupied too; "none": ignored. Where strokes meet, the darker grey wins. Throws
// std::invalid_argument if the resolution is not positive.
OccupancyMap BuildStaticMap(const Track& track, double resolution_m = kLabMapResolution_m,
                            const MapServerParams& map_server = {});

}  // namespace autonomsim::world
