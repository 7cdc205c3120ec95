#include "stack/costmap.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "world/validation.h"

namespace autonomsim::stack {
namespace {

// Whole cells in `length_m` at `resolution_m`; 1e-9 absorbs the rounding of 5.0 / 0.05.
int CellsIn(double length_m, double resolution_m) {
  return static_cast<int>(std::ceil(length_m / resolution_m - 1e-9));
}

void RequireSameGeometry(const Costmap2D& a, const Costmap2D& b) {
  Require(a.SameGeometry(b), [&] {
    return "costmap layers differ in geometry: " + Num(a.size_x_cells()) + " x " +
           Num(a.size_y_cells()) + " at " + Num(a.resolution_m()) + " m vs " +
           Num(b.size_x_cells()) + " x " + Num(b.size_y_cells()) + " at " + Num(b.resolution_m()) +
           " m";
  });
}

// The lower envelope of the parabolas (x - q)² + g(q)² of one row's columns q with g(q) < far
// (Felzenszwalb & Huttenlocher, "Distance Transforms of Sampled Functions", 2012, algorithm 1),
// so every cell's least squared distance costs O(1) instead of a scan over the radius. The
// parabolas' crossings are fractions compared by cross-multiplication in 64-bit integers: no
// rounding, the same distances as the scan on every machine.
class RowEnvelope {
 public:
  void Build(const int* g, int n, int far) {
    apex_.clear();
    from_.clear();
    for (int q = 0; q < n; ++q) {
      if (g[q] >= far) continue;
      const std::int64_t height = static_cast<std::int64_t>(g[q]) * g[q];
      while (!apex_.empty()) {
        const Fraction s = Crossing(apex_.back(), {q, height});
        if (Less(from_.back(), s)) {
          apex_.push_back({q, height});
          from_.push_back(s);
          break;
        }
        apex_.pop_back();
        from_.pop_back();
      }
      if (apex_.empty()) {
        apex_.push_back({q, height});
        from_.push_back({-(std::int64_t{1} << 40), 1});  // before every cell
      }
    }
    // the first whole x of each parabola's stretch: ceil(num / den), den > 0
    first_x_.clear();
    for (const Fraction& f : from_) {
      first_x_.push_back(f.num >= 0 ? (f.num + f.den - 1) / f.den : -((-f.num) / f.den));
    }
  }
  bool empty() const { return apex_.empty(); }
  // f(x, d²) for every x in [0, n) whose least squared distance d² is at most radius².
  template <class F>
  void ForEachWithin(int n, int radius, F&& f) const {
    const std::int64_t limit_sq = static_cast<std::int64_t>(radius) * radius;
    std::size_t k = 0;
    const int end = std::min(n, apex_.back().q + radius + 1);
    for (int x = std::max(0, apex_.front().q - radius); x < end; ++x) {
      while (k + 1 < apex_.size() && first_x_[k + 1] <= x) ++k;
      const std::int64_t dx = x - apex_[k].q;
      const std::int64_t d2 = dx * dx + apex_[k].height;
      if (d2 <= limit_sq) f(x, static_cast<int>(d2));
    }
  }

 private:
  struct Apex {
    int q;
    std::int64_t height;  // g(q)²
  };
  struct Fraction {
    std::int64_t num, den;  // den > 0
  };
  static bool Less(const Fraction& a, const Fraction& b) { return a.num * b.den < b.num * a.den; }
  // Where the parabolas of a and b (a.q < b.q) cross: the x with equal values.
  static Fraction Crossing(const Apex& a, const Apex& b) {
    return {b.height + static_cast<std::int64_t>(b.q) * b.q - a.height -
                static_cast<std::int64_t>(a.q) * a.q,
            2 * static_cast<std::int64_t>(b.q - a.q)};
  }
  std::vector<Apex> apex_;
  std::vector<Fraction> from_;  // from_[k]: where apex_[k]'s parabola becomes the least
  std::vector<std::int64_t> first_x_;
};

// Per cell, the distance in cells to the nearest LETHAL cell of its column, capped at `far`: a pass
// down and a pass up each column, run a row at a time for all columns together, so that both read
// and write the grid in memory order (column by column, each step strides a whole row: that was
// most of the global costmap's inflation at start, issue 38). The same integers either way.
std::vector<int> ColumnDistances(const std::vector<std::uint8_t>& costs, int nx, int ny, int far) {
  std::vector<int> distance(costs.size(), far);
  std::vector<int> running(static_cast<std::size_t>(nx));
  // one pass over the rows in `step`'s direction, each cell keeping the least distance so far
  const auto pass = [&](int y_first, int y_end, int step) {
    std::fill(running.begin(), running.end(), far);
    for (int y = y_first; y != y_end; y += step) {
      const std::uint8_t* row_costs = costs.data() + static_cast<std::size_t>(y) * nx;
      int* row_distance = distance.data() + static_cast<std::size_t>(y) * nx;
      for (int x = 0; x < nx; ++x) {
        int& d = running[static_cast<std::size_t>(x)];
        d = row_costs[x] == kLethalObstacle ? 0 : std::min(d + 1, far);
        row_distance[x] = std::min(row_distance[x], d);
      }
    }
  };
  pass(0, ny, 1);        // down each column
  pass(ny - 1, -1, -1);  // and up
  return distance;
}

}  // namespace

// --- Costmap2D ---------------------------------------------------------------------------------

Costmap2D::Costmap2D(int size_x_cells, int size_y_cells, double resolution_m,
                     const world::Vec2& origin_m, std::uint8_t fill)
    : size_x_(size_x_cells),
      size_y_(size_y_cells),
      resolution_m_(resolution_m),
      anchor_m_(origin_m) {
  Require(size_x_cells > 0 && size_y_cells > 0, [&] {
    return "costmap size must be > 0 cells, got " + Num(size_x_cells) + " x " + Num(size_y_cells);
  });
  Require(std::isfinite(resolution_m) && resolution_m > 0.0,
          [&] { return "costmap resolution_m must be > 0, got " + Num(resolution_m); });
  Require(origin_m.allFinite(), "costmap origin must be finite");
  costs_.assign(static_cast<std::size_t>(size_x_cells) * size_y_cells, fill);
}

world::Vec2 Costmap2D::origin_m() const {
  return {anchor_m_.x() + origin_cx_ * resolution_m_, anchor_m_.y() + origin_cy_ * resolution_m_};
}

bool Costmap2D::SameGeometry(const Costmap2D& other) const {
  return size_x_ == other.size_x_ && size_y_ == other.size_y_ &&
         resolution_m_ == other.resolution_m_ && anchor_m_ == other.anchor_m_ &&
         origin_cx_ == other.origin_cx_ && origin_cy_ == other.origin_cy_;
}

std::optional<CellIndex> Costmap2D::WorldToMap(const world::Vec2& p) const {
  const double mx = std::floor((p.x() - anchor_m_.x()) / resolution_m_) - origin_cx_;
  const double my = std::floor((p.y() - anchor_m_.y()) / resolution_m_) - origin_cy_;
  if (!(mx >= 0.0 && mx < size_x_ && my >= 0.0 && my < size_y_)) return std::nullopt;
  return CellIndex{static_cast<int>(mx), static_cast<int>(my)};
}

world::Vec2 Costmap2D::MapToWorld(int mx, int my) const {
  return {anchor_m_.x() + (origin_cx_ + mx + 0.5) * resolution_m_,
          anchor_m_.y() + (origin_cy_ + my + 0.5) * resolution_m_};
}

std::size_t Costmap2D::Index(int mx, int my) const {
  if (!Contains(mx, my)) {
    throw std::out_of_range("cell (" + std::to_string(mx) + ", " + std::to_string(my) +
                            ") outside the " + std::to_string(size_x_) + " x " +
                            std::to_string(size_y_) + " costmap");
  }
  return static_cast<std::size_t>(my) * size_x_ + mx;
}

CellIndex Costmap2D::Cell(std::size_t index) const {
  if (index >= costs_.size()) {
    throw std::out_of_range("cell index " + std::to_string(index) + " outside the " +
                            std::to_string(costs_.size()) + "-cell costmap");
  }
  return {static_cast<int>(index % size_x_), static_cast<int>(index / size_x_)};
}

std::optional<std::uint8_t> Costmap2D::CostAt(const world::Vec2& p) const {
  const auto cell = WorldToMap(p);
  if (!cell) return std::nullopt;
  return Cost(cell->mx, cell->my);
}

// --- footprint and inflation -------------------------------------------------------------------

void FootprintParams::Validate() const {
  Require(std::isfinite(half_length_m) && half_length_m > 0.0,
          [&] { return "half_length_m must be > 0, got " + Num(half_length_m); });
  Require(std::isfinite(half_width_m) && half_width_m > 0.0,
          [&] { return "half_width_m must be > 0, got " + Num(half_width_m); });
}

std::vector<world::Vec2> FootprintParams::Polygon() const {
  return {{half_length_m, -half_width_m},
          {half_length_m, half_width_m},
          {-half_length_m, half_width_m},
          {-half_length_m, -half_width_m}};
}

double InscribedRadius_m(const std::vector<world::Vec2>& footprint) {
  Require(footprint.size() >= 3,
          [&] { return "a footprint needs at least 3 points, got " + Num(footprint.size()); });
  double radius = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < footprint.size(); ++i) {
    const world::Vec2& a = footprint[i];
    const world::Vec2& b = footprint[(i + 1) % footprint.size()];
    const world::Vec2 ab = b - a;
    const double t =
        ab.squaredNorm() > 0.0 ? std::clamp(-a.dot(ab) / ab.squaredNorm(), 0.0, 1.0) : 0.0;
    radius = std::min(radius, (a + ab * t).norm());
  }
  return radius;
}

void InflationParams::Validate() const {
  Require(std::isfinite(inflation_radius_m) && inflation_radius_m >= 0.0,
          [&] { return "inflation_radius_m must be >= 0, got " + Num(inflation_radius_m); });
  Require(std::isfinite(cost_scaling_factor) && cost_scaling_factor >= 0.0,
          [&] { return "cost_scaling_factor must be >= 0, got " + Num(cost_scaling_factor); });
}

Inflation::Inflation(const InflationParams& params, double inscribed_radius_m, double resolution_m)
    : resolution_m_(resolution_m),
      inscribed_radius_m_(inscribed_radius_m),
      cost_scaling_factor_(params.cost_scaling_factor) {
  params.Validate();
  Require(std::isfinite(inscribed_radius_m) && inscribed_radius_m >= 0.0,
          [&] { return "inscribed radius must be >= 0 m, got " + Num(inscribed_radius_m); });
  Require(std::isfinite(resolution_m) && resolution_m > 0.0,
          [&] { return "resolution_m must be > 0, got " + Num(resolution_m); });
  // Nav2 Costmap2D::cellDistance: ceil, without a tolerance (0.4 / 0.05 -> 8, 0.3 / 0.05 -> 6).
  cell_radius_ = static_cast<int>(std::ceil(params.inflation_radius_m / resolution_m));
  cost_by_distance_sq_.resize(static_cast<std::size_t>(cell_radius_) * cell_radius_ + 1);
  for (std::size_t d2 = 0; d2 < cost_by_distance_sq_.size(); ++d2) {
    cost_by_distance_sq_[d2] = CostAtCellDistance(std::sqrt(static_cast<double>(d2)));
  }
}

std::uint8_t Inflation::CostAtCellDistance(double distance_cells) const {
  if (distance_cells == 0.0) return kLethalObstacle;
  const double distance_m = distance_cells * resolution_m_;
  if (distance_m <= inscribed_radius_m_) return kInscribedInflatedObstacle;
  const double factor = std::exp(-cost_scaling_factor_ * (distance_m - inscribed_radius_m_));
  return static_cast<std::uint8_t>(kMaxNonInscribedCost * factor);
}

// Exact Euclidean distance transform, bounded to the inflation radius, in two separable passes
// (Saito-Toriwaki / Meijster): first each cell's distance along its column to the nearest LETHAL
// cell, then, along each row, min over dx of dx² + column_distance(x + dx)². All integer, so the
// result is exact and the same on every machine. Nav2 reaches the same distances with a brushfire
// ordered by distance (a cell takes the distance to the obstacle whose wave reached it first); an
// exact transform is simpler, has no queue and cannot be off where two waves meet. OpenCV's
// cv::distanceTransform (DIST_MASK_PRECISE) would give the same distances as float32; the integer
// squared distances here index the cost cache directly.
void Inflation::Apply(Costmap2D* grid) const {
  if (cell_radius_ == 0) return;
  const int nx = grid->size_x_cells();
  const int ny = grid->size_y_cells();
  std::vector<std::uint8_t>& costs = grid->mutable_costs();
  // Only LETHAL cells inflate: a grid without one (a rolling window with nothing in it, most of
  // the time) is left as it is.
  if (std::find(costs.begin(), costs.end(), kLethalObstacle) == costs.end()) return;
  const int far = cell_radius_ + 1;  // "no obstacle within the radius"

  const std::vector<int> column_distance = ColumnDistances(costs, nx, ny, far);

  // Per row, only the columns with an obstacle within the radius along their column count (most
  // of a rolling window is free): the least dx² + g² over them, by their parabolas' lower envelope.
  RowEnvelope envelope;
  for (int y = 0; y < ny; ++y) {
    const int* row_distance = column_distance.data() + static_cast<std::size_t>(y) * nx;
    std::uint8_t* row_costs = costs.data() + static_cast<std::size_t>(y) * nx;
    envelope.Build(row_distance, nx, far);
    if (envelope.empty()) continue;
    envelope.ForEachWithin(nx, cell_radius_, [&](int x, int distance_sq) {
      if (row_distance[x] == 0) return;  // the obstacle itself
      const std::uint8_t inflated = cost_by_distance_sq_[distance_sq];
      std::uint8_t& cell = row_costs[x];
      if (cell == kNoInformation) {
        if (inflated >= kInscribedInflatedObstacle) cell = inflated;
      } else {
        cell = std::max(cell, inflated);
      }
    });
  }
}

// --- layers ------------------------------------------------------------------------------------

void StaticLayerParams::Validate() const {
  Require(lethal_cost_threshold >= 0 && lethal_cost_threshold <= 100, [&] {
    return "lethal_cost_threshold must be in [0, 100], got " + Num(lethal_cost_threshold);
  });
}

Costmap2D StaticLayer(const world::OccupancyMap& map, const StaticLayerParams& params) {
  Require(map.width_cells > 0 && map.height_cells > 0 &&
              map.cells.size() == static_cast<std::size_t>(map.width_cells) * map.height_cells,
          [&] {
            return "static map: " + Num(map.cells.size()) + " cells for " + Num(map.width_cells) +
                   " x " + Num(map.height_cells);
          });
  Costmap2D layer(map.width_cells, map.height_cells, map.resolution_m, map.origin_m);
  std::vector<std::uint8_t>& costs = layer.mutable_costs();
  const int threshold = params.lethal_cost_threshold;
  for (std::size_t i = 0; i < map.cells.size(); ++i) {
    const int value = map.cells[i];
    if (value < 0) {
      costs[i] = kNoInformation;  // OccupancyGrid -1 is 255 = unknown_cost_value
    } else if (value >= threshold) {
      costs[i] = kLethalObstacle;
    } else if (params.trinary_costmap) {
      costs[i] = kFreeSpace;
    } else {
      costs[i] =
          static_cast<std::uint8_t>(static_cast<double>(value) / threshold * kLethalObstacle);
    }
  }
  return layer;
}

int ApplyMarks(const std::vector<CostmapMark>& marks, Costmap2D* obstacle_layer) {
  int landed = 0;
  for (const CostmapMark& mark : marks) {
    const auto cell = obstacle_layer->WorldToMap(mark.p);
    if (!cell) continue;
    obstacle_layer->SetCost(cell->mx, cell->my, mark.lethal ? kLethalObstacle : kFreeSpace);
    ++landed;
  }
  return landed;
}

void CombineMax(const Costmap2D& layer, Costmap2D* master) {
  RequireSameGeometry(layer, *master);
  const std::vector<std::uint8_t>& from = layer.costs();
  std::vector<std::uint8_t>& to = master->mutable_costs();
  for (std::size_t i = 0; i < from.size(); ++i) {
    if (from[i] == kNoInformation) continue;
    if (to[i] == kNoInformation || to[i] < from[i]) to[i] = from[i];
  }
}

// --- global costmap ----------------------------------------------------------------------------

void GlobalCostmapParams::Validate() const {
  Require(std::isfinite(resolution_m) && resolution_m > 0.0,
          [&] { return "resolution_m must be > 0, got " + Num(resolution_m); });
  static_layer.Validate();
  inflation.Validate();
  footprint.Validate();
}

namespace {

const GlobalCostmapParams& Validated(const GlobalCostmapParams& params) {
  params.Validate();
  return params;
}

const LocalCostmapParams& Validated(const LocalCostmapParams& params) {
  params.Validate();
  return params;
}

}  // namespace

GlobalCostmap::GlobalCostmap(const GlobalCostmapParams& params, const world::OccupancyMap& map)
    : params_(params),
      inflation_(Validated(params).inflation, InscribedRadius_m(params.footprint.Polygon()),
                 params.resolution_m),
      static_(StaticLayer(map, params.static_layer)) {
  Require(map.resolution_m == params.resolution_m, [&] {
    return "resolution_m: the static map is at " + Num(map.resolution_m) +
           " m, the global costmap at " + Num(params.resolution_m) + " m";
  });
  Update();
}

const Costmap2D& GlobalCostmap::Update(const std::vector<CostmapMark>& marks) {
  if (!marks.empty() && obstacles_.costs().empty()) {
    obstacles_ = Costmap2D(static_.size_x_cells(), static_.size_y_cells(), static_.resolution_m(),
                           static_.origin_m(), kFreeSpace);
  }
  ApplyMarks(marks, &obstacles_);
  // The static layer overwrites the master grid (Nav2 StaticLayer, use_maximum false).
  master_ = static_;
  if (!obstacles_.costs().empty()) CombineMax(obstacles_, &master_);
  inflation_.Apply(&master_);
  return master_;
}

std::size_t GlobalCostmap::bytes() const {
  return static_.costs().size() + obstacles_.costs().size() + master_.costs().size();
}

// --- rolling window and local costmap ----------------------------------------------------------

RollingWindow::RollingWindow(int size_x_cells, int size_y_cells, double resolution_m,
                             std::uint8_t fill)
    : grid_(size_x_cells, size_y_cells, resolution_m, world::Vec2::Zero(), fill), fill_(fill) {
  grid_.origin_cx_ = -(size_x_cells / 2);
  grid_.origin_cy_ = -(size_y_cells / 2);
}

void RollingWindow::Recentre(const world::Vec2& p) {
  Require(p.allFinite(), "rolling window: non-finite robot position");
  const int nx = grid_.size_x_;
  const int ny = grid_.size_y_;
  const int new_cx = static_cast<int>(std::floor(p.x() / grid_.resolution_m_)) - nx / 2;
  const int new_cy = static_cast<int>(std::floor(p.y() / grid_.resolution_m_)) - ny / 2;
  const int shift_x = new_cx - grid_.origin_cx_;
  const int shift_y = new_cy - grid_.origin_cy_;
  if (shift_x == 0 && shift_y == 0) return;

  // New cell (mx, my) is old cell (mx + shift_x, my + shift_y): copy the overlap row by row.
  std::vector<std::uint8_t> moved(grid_.costs_.size(), fill_);
  const int x_lo = std::max(0, -shift_x);
  const int x_hi = std::min(nx, nx - shift_x);  // exclusive
  for (int my = std::max(0, -shift_y); my < std::min(ny, ny - shift_y) && x_lo < x_hi; ++my) {
    const std::size_t from = static_cast<std::size_t>(my + shift_y) * nx + (x_lo + shift_x);
    const std::size_t to = static_cast<std::size_t>(my) * nx + x_lo;
    std::copy_n(grid_.costs_.begin() + from, x_hi - x_lo, moved.begin() + to);
  }
  grid_.costs_ = std::move(moved);
  grid_.origin_cx_ = new_cx;
  grid_.origin_cy_ = new_cy;
}

void LocalCostmapParams::Validate() const {
  Require(std::isfinite(resolution_m) && resolution_m > 0.0,
          [&] { return "resolution_m must be > 0, got " + Num(resolution_m); });
  Require(std::isfinite(width_m) && width_m >= resolution_m,
          [&] { return "width_m must be >= resolution_m, got " + Num(width_m); });
  Require(std::isfinite(height_m) && height_m >= resolution_m,
          [&] { return "height_m must be >= resolution_m, got " + Num(height_m); });
  Require(std::isfinite(update_rate_hz) && update_rate_hz > 0.0,
          [&] { return "update_rate_hz must be > 0, got " + Num(update_rate_hz); });
  inflation.Validate();
  footprint.Validate();
}

LocalCostmap::LocalCostmap(const LocalCostmapParams& params)
    : inflation_(Validated(params).inflation, InscribedRadius_m(params.footprint.Polygon()),
                 params.resolution_m),
      obstacles_(CellsIn(params.width_m, params.resolution_m),
                 CellsIn(params.height_m, params.resolution_m), params.resolution_m, kFreeSpace),
      master_(obstacles_.grid()) {}

const Costmap2D& LocalCostmap::Step(const LocalCostmapInput& input) {
  obstacles_.Recentre(input.p_robot);
  ApplyMarks(input.marks, &obstacles_.mutable_grid());
  const Costmap2D& layer = obstacles_.grid();
  master_ = layer;  // the geometry; the master grid restarts FREE (no static layer here)
  std::fill(master_.mutable_costs().begin(), master_.mutable_costs().end(), kFreeSpace);
  CombineMax(layer, &master_);
  inflation_.Apply(&master_);
  return master_;
}

}  // namespace autonomsim::stack
