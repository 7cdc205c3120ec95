#include "world/occupancy_map.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "world/track.h"
#include "world/validation.h"

namespace autonomsim::world {

bool OccupancyMap::Occupied(const Vec2& p_map) const {
  const auto cell = CellAt(p_map);
  if (!cell) return true;
  const std::int8_t value = At((*cell)[0], (*cell)[1]);
  return value < 0 || value >= kOccupied;
}

void MapServerParams::Validate() const {
  Require(std::isfinite(free_thresh) && std::isfinite(occupied_thresh) && free_thresh >= 0.0 &&
              free_thresh < occupied_thresh && occupied_thresh <= 1.0,
          [&] {
            return "map_server thresholds must satisfy 0 <= free_thresh < occupied_thresh <= 1, "
                   "got " +
                   Num(free_thresh) + " and " + Num(occupied_thresh);
          });
}

std::int8_t MapServerParams::ValueOfGrey(int grey) const {
  const double occ = 1.0 - static_cast<double>(grey) / 255.0;
  if (occupied_thresh < occ) return OccupancyMap::kOccupied;
  if (occ < free_thresh) return OccupancyMap::kFree;
  return static_cast<std::int8_t>(
      std::rint((occ - free_thresh) / (occupied_thresh - free_thresh) * 100.0));
}

std::int8_t OccupancyMap::At(int col, int row) const {
  if (!Contains(col, row)) {
    throw std::out_of_range("cell (" + std::to_string(col) + ", " + std::to_string(row) +
                            ") outside the " + std::to_string(width_cells) + " x " +
                            std::to_string(height_cells) + " map");
  }
  return cells[static_cast<std::size_t>(row) * width_cells + col];
}

std::optional<std::array<int, 2>> OccupancyMap::CellAt(const Vec2& p_map) const {
  const double col = std::floor((p_map.x() - origin_m.x()) / resolution_m);
  const double row = std::floor((p_map.y() - origin_m.y()) / resolution_m);
  if (!(col >= 0.0 && col < width_cells && row >= 0.0 && row < height_cells)) return std::nullopt;
  return std::array<int, 2>{static_cast<int>(col), static_cast<int>(row)};
}

Vec2 OccupancyMap::CellCentre(int col, int row) const {
  return {origin_m.x() + (col + 0.5) * resolution_m, origin_m.y() + (row + 0.5) * resolution_m};
}

namespace {

// A square map of free cells, centred on the track's origin.
OccupancyMap EmptyMap(const TrackSpec& spec, double resolution_m) {
  OccupancyMap map;
  map.resolution_m = resolution_m;
  // A thousandth of a cell absorbs the rounding of size / resolution: 5 m at 5 cm is 100 cells,
  // not 101, and 10 m at the lab's 0.00517063 m its picture's 1934 px (9.999998 m), not 1935.
  const double map_size_m = spec.planner_map_size_m.value_or(spec.size_m);
  const int side = static_cast<int>(std::ceil(map_size_m / resolution_m - 1e-3));
  map.width_cells = side;
  map.height_cells = side;
  map.origin_m = Vec2(-0.5 * side * resolution_m, -0.5 * side * resolution_m);
  map.cells.assign(static_cast<std::size_t>(side) * side, OccupancyMap::kFree);
  return map;
}

// The picture being drawn: a grey per cell (255 white, 0 black), row-major from row 0.
struct Canvas {
  const OccupancyMap& map;
  std::vector<std::uint8_t> grey;
  void Darken(int col, int row, double grey_value) {
    const auto g = static_cast<std::uint8_t>(std::lround(grey_value));
    std::uint8_t& cell = grey[static_cast<std::size_t>(row) * map.width_cells + col];
    cell = std::min(cell, g);
  }
};

// Index range of the cells meeting [lo, hi] along one axis, clamped to the (square) map.
std::array<int, 2> CellRange(const OccupancyMap& map, double lo_m, double hi_m, double origin) {
  const int side = map.width_cells;
  const double first = std::floor((lo_m - origin) / map.resolution_m);
  const double last = std::floor((hi_m - origin) / map.resolution_m);
  return std::array<int, 2>{static_cast<int>(std::clamp(first, 0.0, double(side))),
                            static_cast<int>(std::clamp(last, -1.0, double(side - 1)))};
}

// A straight edge's share of a cell whose centre lies `inside_m` inside it (negative: outside).
double EdgeCoverage(double inside_m, double resolution_m) {
  return std::clamp(inside_m / resolution_m + 0.5, 0.0, 1.0);
}

// An open line's flat end: the stroke stops square at `point`, `outward` pointing away from it.
struct FlatEnd {
  Vec2 point;
  Vec2 outward;  // unit
};

// One chord a-b of a stroke of half width h in grey `core`; a cell beyond the chord's ends is
// measured to the end point (a round join with the next chord), except past an open line's ends,
// where every chord's stroke stops square at the flat ends.
struct Chord {
  Vec2 a, b;
  double half_width_m;
  int core;
  const FlatEnd* ends;  // two, or nullptr for a closed line
};

void DrawChord(const Chord& chord, Canvas* canvas) {
  const OccupancyMap& map = canvas->map;
  const double res = map.resolution_m;
  const Vec2 ab = chord.b - chord.a;
  const double length = ab.norm();
  if (length <= 0.0) return;
  const Vec2 u = ab / length;
  const double reach = chord.half_width_m + res;
  const auto cols = CellRange(map, std::min(chord.a.x(), chord.b.x()) - reach,
                              std::max(chord.a.x(), chord.b.x()) + reach, map.origin_m.x());
  const auto rows = CellRange(map, std::min(chord.a.y(), chord.b.y()) - reach,
                              std::max(chord.a.y(), chord.b.y()) + reach, map.origin_m.y());
  for (int row = rows[0]; row <= rows[1]; ++row) {
    for (int col = cols[0]; col <= cols[1]; ++col) {
      const Vec2 c = map.CellCentre(col, row);
      const Vec2 p = c - chord.a;
      const double t = p.dot(u);
      double d = std::abs(u.x() * p.y() - u.y() * p.x());
      if (t < 0.0 && !(chord.ends && chord.a == chord.ends[0].point)) d = p.norm();
      if (t > length && !(chord.ends && chord.b == chord.ends[1].point)) d = (p - ab).norm();
      double coverage = EdgeCoverage(chord.half_width_m - d, res);
      if (chord.ends != nullptr) {
        for (int e = 0; e < 2; ++e) {  // the square cap: the end's chord, and others near it
          const Vec2 from_end = c - chord.ends[e].point;
          const bool own = (e == 0 ? chord.a : chord.b) == chord.ends[e].point;
          if (!own && from_end.norm() > 1.5 * reach) continue;
          coverage *= EdgeCoverage(-from_end.dot(chord.ends[e].outward), res);
        }
      }
      if (coverage <= 0.0) continue;
      canvas->Darken(col, row, 255.0 - (255.0 - chord.core) * coverage);
    }
  }
}

// The painted stroke, chord by chord.
void DrawStroke(const std::vector<Vec2>& points, const TrackLineSpec& line, Canvas* canvas) {
  const std::size_t n = points.size();
  const FlatEnd ends[2] = {{points[0], (points[0] - points[1]).normalized()},
                           {points[n - 1], (points[n - 1] - points[n - 2]).normalized()}};
  for (std::size_t i = 0; i + 1 < n; ++i) {
    DrawChord({points[i], points[i + 1], 0.5 * line.width_m, line.planner_grey,
               line.closed ? nullptr : ends},
              canvas);
  }
}

// The inside of a filled outline: cell centres inside the sampled outline, row by row (even-odd
// rule on the crossings of the row's centre line), in grey `core`.
void FillInside(const std::vector<Vec2>& points, int core, Canvas* canvas) {
  const OccupancyMap* map = &canvas->map;
  const double resolution_m = map->resolution_m;
  const int side = map->width_cells;
  double y_min = points[0].y();
  double y_max = points[0].y();
  for (const Vec2& p : points) {
    y_min = std::min(y_min, p.y());
    y_max = std::max(y_max, p.y());
  }
  const auto rows = CellRange(*map, y_min, y_max, map->origin_m.y());
  std::vector<double> crossings;
  for (int row = rows[0]; row <= rows[1]; ++row) {
    const double y = map->CellCentre(0, row).y();
    crossings.clear();
    for (std::size_t i = 0; i + 1 < points.size(); ++i) {
      const Vec2& a = points[i];
      const Vec2& b = points[i + 1];
      if ((a.y() > y) != (b.y() > y)) {
        crossings.push_back(a.x() + (y - a.y()) * (b.x() - a.x()) / (b.y() - a.y()));
      }
    }
    std::sort(crossings.begin(), crossings.end());
    for (std::size_t k = 0; k + 1 < crossings.size(); k += 2) {
      // Cell centres x_c = origin.x + (col + 0.5) res within [crossings[k], crossings[k+1]].
      const double first = std::ceil((crossings[k] - map->origin_m.x()) / resolution_m - 0.5);
      const double last = std::floor((crossings[k + 1] - map->origin_m.x()) / resolution_m - 0.5);
      const int col_lo = static_cast<int>(std::clamp(first, 0.0, double(side)));
      const int col_hi = static_cast<int>(std::clamp(last, -1.0, double(side - 1)));
      for (int col = col_lo; col <= col_hi; ++col) canvas->Darken(col, row, core);
    }
  }
}

}  // namespace

OccupancyMap BuildStaticMap(const Track& track, double resolution_m,
                            const MapServerParams& map_server) {
  Require(std::isfinite(resolution_m) && resolution_m > 0.0,
          [&] { return "resolution_m must be > 0, got " + Num(resolution_m); });
  map_server.Validate();
  const TrackSpec& spec = track.spec();
  OccupancyMap map = EmptyMap(spec, resolution_m);
  Canvas canvas{map, std::vector<std::uint8_t>(map.cells.size(), 255)};
  for (std::size_t l = 0; l < spec.lines.size(); ++l) {
    const TrackLineSpec& line = spec.lines[l];
    if (line.planner == "none") continue;
    const std::vector<Vec2>& points = track.line_paths()[l].points();
    DrawStroke(points, line, &canvas);
    if (line.planner == "filled") FillInside(points, line.planner_grey, &canvas);
  }
  // Each of the 256 greys' value once, rather than a division and a rint per cell (of nearly a
  // million for the lab's map at the global costmap's 5 mm: a few ms of every start, issue 38).
  std::array<std::int8_t, 256> value_of_grey;
  for (int grey = 0; grey < 256; ++grey) {
    value_of_grey[static_cast<std::size_t>(grey)] = map_server.ValueOfGrey(grey);
  }
  for (std::size_t i = 0; i < map.cells.size(); ++i) map.cells[i] = value_of_grey[canvas.grey[i]];
  return map;
}

}  // namespace autonomsim::world
