#include "world/occupancy_map.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "world/track.h"
#include "world/validation.h"

namespace autonomsim::world {
namespace {

double PointSegmentDistanceSq(const Vec2& p, const Vec2& a, const Vec2& b) {
  const Vec2 ab = b - a;
  const double t = std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
  return (p - (a + ab * t)).squaredNorm();
}

double PointBoxDistanceSq(const Vec2& p, const Vec2& lo, const Vec2& hi) {
  const double dx = std::max({lo.x() - p.x(), 0.0, p.x() - hi.x()});
  const double dy = std::max({lo.y() - p.y(), 0.0, p.y() - hi.y()});
  return dx * dx + dy * dy;
}

// Liang-Barsky: does the segment a-b meet the closed box [lo, hi]?
bool SegmentMeetsBox(const Vec2& a, const Vec2& b, const Vec2& lo, const Vec2& hi) {
  double t0 = 0.0;
  double t1 = 1.0;
  const Vec2 d = b - a;
  for (int axis = 0; axis < 2; ++axis) {
    if (d[axis] == 0.0) {
      if (a[axis] < lo[axis] || a[axis] > hi[axis]) return false;
      continue;
    }
    double enter = (lo[axis] - a[axis]) / d[axis];
    double leave = (hi[axis] - a[axis]) / d[axis];
    if (enter > leave) std::swap(enter, leave);
    t0 = std::max(t0, enter);
    t1 = std::min(t1, leave);
    if (t0 > t1) return false;
  }
  return true;
}

// Between a segment and a box that it does not meet, the nearest pair has an end of the segment
// or a corner of the box in it (both are convex).
double SegmentBoxDistanceSq(const Vec2& a, const Vec2& b, const Vec2& lo, const Vec2& hi) {
  if (SegmentMeetsBox(a, b, lo, hi)) return 0.0;
  double d = std::min(PointBoxDistanceSq(a, lo, hi), PointBoxDistanceSq(b, lo, hi));
  for (const Vec2& corner : {lo, Vec2(hi.x(), lo.y()), hi, Vec2(lo.x(), hi.y())}) {
    d = std::min(d, PointSegmentDistanceSq(corner, a, b));
  }
  return d;
}

}  // namespace

bool OccupancyMap::Occupied(const Vec2& p_map) const {
  const auto cell = CellAt(p_map);
  if (!cell) return true;
  return At((*cell)[0], (*cell)[1]) != kFree;
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
  // 1e-9 absorbs the rounding of size / resolution so that 5 m at 5 cm is 100 cells, not 101.
  const double map_size_m = spec.planner_map_size_m.value_or(spec.size_m);
  const int side = static_cast<int>(std::ceil(map_size_m / resolution_m - 1e-9));
  map.width_cells = side;
  map.height_cells = side;
  map.origin_m = Vec2(-0.5 * side * resolution_m, -0.5 * side * resolution_m);
  map.cells.assign(static_cast<std::size_t>(side) * side, OccupancyMap::kFree);
  return map;
}

void Occupy(OccupancyMap* map, int col, int row) {
  map->cells[static_cast<std::size_t>(row) * map->width_cells + col] = OccupancyMap::kOccupied;
}

// Index range of the cells meeting [lo, hi] along one axis, clamped to the (square) map.
std::array<int, 2> CellRange(const OccupancyMap& map, double lo_m, double hi_m, double origin) {
  const int side = map.width_cells;
  const double first = std::floor((lo_m - origin) / map.resolution_m);
  const double last = std::floor((hi_m - origin) / map.resolution_m);
  return std::array<int, 2>{static_cast<int>(std::clamp(first, 0.0, double(side))),
                            static_cast<int>(std::clamp(last, -1.0, double(side - 1)))};
}

// The painted stroke: cells it overlaps with positive area, chord by chord.
void OccupyStroke(const std::vector<Vec2>& points, double width_m, OccupancyMap* map) {
  const double resolution_m = map->resolution_m;
  const double half_width = 0.5 * width_m;
  const double half_width_sq = half_width * half_width;
  for (std::size_t i = 0; i + 1 < points.size(); ++i) {
    const Vec2& a = points[i];
    const Vec2& b = points[i + 1];
    const auto cols = CellRange(*map, std::min(a.x(), b.x()) - half_width,
                                std::max(a.x(), b.x()) + half_width, map->origin_m.x());
    const auto rows = CellRange(*map, std::min(a.y(), b.y()) - half_width,
                                std::max(a.y(), b.y()) + half_width, map->origin_m.y());
    for (int row = rows[0]; row <= rows[1]; ++row) {
      for (int col = cols[0]; col <= cols[1]; ++col) {
        const Vec2 lo = map->origin_m + Vec2(col, row) * resolution_m;
        const Vec2 hi = lo + Vec2(resolution_m, resolution_m);
        if (SegmentBoxDistanceSq(a, b, lo, hi) < half_width_sq) Occupy(map, col, row);
      }
    }
  }
}

// The inside of a filled outline: cell centres inside the sampled outline, row by row (even-odd
// rule on the crossings of the row's centre line).
void OccupyInside(const std::vector<Vec2>& points, OccupancyMap* map) {
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
      for (int col = col_lo; col <= col_hi; ++col) Occupy(map, col, row);
    }
  }
}

}  // namespace

OccupancyMap BuildStaticMap(const Track& track, double resolution_m) {
  Require(std::isfinite(resolution_m) && resolution_m > 0.0,
          [&] { return "resolution_m must be > 0, got " + Num(resolution_m); });
  const TrackSpec& spec = track.spec();
  OccupancyMap map = EmptyMap(spec, resolution_m);
  for (std::size_t l = 0; l < spec.lines.size(); ++l) {
    const TrackLineSpec& line = spec.lines[l];
    if (line.planner == "none") continue;
    const std::vector<Vec2>& points = track.line_paths()[l].points();
    OccupyStroke(points, line.width_m, &map);
    if (line.planner == "filled") OccupyInside(points, &map);
  }
  return map;
}

}  // namespace autonomsim::world
