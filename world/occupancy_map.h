// The planner's static map: what the real car is given as its map, not ground truth. Reference §1:
// it holds the yellow lines and the islands as obstacles, and the outer white boundary is missing.
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

  // Outside the map, and unknown cells, count as occupied: anything but kFree is.
  bool Occupied(const Vec2& p_map) const;
  std::int8_t At(int col, int row) const;  // throws std::out_of_range outside the map
  bool Contains(int col, int row) const {
    return col >= 0 && col < width_cells && row >= 0 && row < height_cells;
  }
  std::optional<std::array<int, 2>> CellAt(const Vec2& p_map) const;  // {col,row}, nullopt outside
  Vec2 CellCentre(int col, int row) const;                            // map coords
};

// Covers a square of side spec.planner_map_size_m (absent: spec.size_m) centred on the origin
// (rounded up to whole cells). Lines with planner
// "line": every cell the painted stroke overlaps with positive area (some point of the sampled
// centreline closer than width/2 to the cell; round ends) is occupied; "filled": also every cell
// whose centre is inside the closed outline; "none": ignored. Throws std::invalid_argument if the
// resolution is not positive.
OccupancyMap BuildStaticMap(const Track& track, double resolution_m = 0.05);

}  // namespace autonomsim::world
