// Nav2-style 2D costmaps for the planner and the controller (reference §6): a uint8 grid with
// Nav2's cost values, and the three layers the real car's costmaps used:
//   static     the map the car is given (world::OccupancyMap), as Galactic's StaticLayer reads it;
//   obstacle   marks from the obstacle-grid layer (reference §4): LETHAL or FREE per cell centre;
//   inflation  Nav2's InflationLayer: LETHAL at an obstacle cell, INSCRIBED within the footprint's
//              inscribed radius, 252·exp(−scale·(d − r_inscribed)) out to the inflation radius.
// The global costmap (static + inflation over the whole map) and the rolling local costmap
// (obstacle + inflation in a window centred on the robot) are small classes around these layers.
//
// Layer composition follows nav2_costmap_2d: the master grid starts as a copy of the static layer
// (StaticLayer with use_maximum false overwrites), or FREE without one; the obstacle layer is
// merged with Costmap2D::updateWithMax (a layer's NO_INFORMATION is skipped; otherwise the larger
// cost wins, and a known cost replaces an unknown master cell); then inflation raises the costs
// around every LETHAL cell. So clearing a cell (a FREE mark) only erases what the obstacle layer
// marked there: a cell of the static map stays LETHAL, in the master grid and its inflation.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <vector>

#include "world/geometry.h"
#include "world/occupancy_map.h"

namespace autonomsim::stack {

// nav2_costmap_2d/cost_values.hpp.
inline constexpr std::uint8_t kFreeSpace = 0;
inline constexpr std::uint8_t kInscribedInflatedObstacle = 253;
inline constexpr std::uint8_t kLethalObstacle = 254;
inline constexpr std::uint8_t kNoInformation = 255;
// The largest cost of a cell that is neither inscribed nor lethal (Nav2's "INSCRIBED - 1").
inline constexpr std::uint8_t kMaxNonInscribedCost = 252;

struct CellIndex {
  int mx{0};  // column, +x
  int my{0};  // row, +y (row 0 is the south edge, as in ROS maps)
  bool operator==(const CellIndex&) const = default;
};

// A grid of costs over an axis-aligned rectangle of the costmap's frame. Cell (mx, my) covers
// [origin + (mx, my)·resolution, origin + (mx + 1, my + 1)·resolution); storage is row-major from
// row 0. Every cell accessor is bounds-checked (std::out_of_range).
// The origin is kept as an anchor point plus a whole number of cells (only a RollingWindow moves
// the latter), and a point is binned against the anchor: a point exactly on a cell edge falls in
// the same world cell wherever the window has rolled.
class Costmap2D {
 public:
  Costmap2D() = default;
  // Throws std::invalid_argument on a non-positive size or resolution.
  Costmap2D(int size_x_cells, int size_y_cells, double resolution_m, const world::Vec2& origin_m,
            std::uint8_t fill = kFreeSpace);

  int size_x_cells() const { return size_x_; }
  int size_y_cells() const { return size_y_; }
  double resolution_m() const { return resolution_m_; }
  world::Vec2 origin_m() const;  // lower-left corner of cell (0, 0)
  // Same size, resolution, anchor and origin: cell (mx, my) of both is the same square.
  bool SameGeometry(const Costmap2D& other) const;

  bool Contains(int mx, int my) const { return mx >= 0 && mx < size_x_ && my >= 0 && my < size_y_; }
  // The cell containing p (half-open cells), or nullopt outside the grid.
  std::optional<CellIndex> WorldToMap(const world::Vec2& p) const;
  world::Vec2 MapToWorld(int mx, int my) const;  // the cell's centre; any (mx, my), not checked
  std::size_t Index(int mx, int my) const;       // throws outside
  CellIndex Cell(std::size_t index) const;       // throws outside

  std::uint8_t Cost(int mx, int my) const { return costs_[Index(mx, my)]; }
  void SetCost(int mx, int my, std::uint8_t cost) { costs_[Index(mx, my)] = cost; }
  // The cost at p; nullopt outside the grid.
  std::optional<std::uint8_t> CostAt(const world::Vec2& p) const;

  const std::vector<std::uint8_t>& costs() const { return costs_; }
  std::vector<std::uint8_t>& mutable_costs() { return costs_; }

 private:
  friend class RollingWindow;
  int size_x_{0};
  int size_y_{0};
  double resolution_m_{0.05};
  world::Vec2 anchor_m_{0.0, 0.0};
  int origin_cx_{0};  // origin_m() == anchor_m_ + origin_c · resolution_m_
  int origin_cy_{0};
  std::vector<std::uint8_t> costs_;
};

// The car's footprint, a rectangle centred on base_link (reference §2).
struct FootprintParams {
  double half_length_m{0.265};  // reference §2: planner footprint ±0.265 × ±0.135 m
  double half_width_m{0.135};   // reference §2

  template <class V>
  void Describe(V& v) {
    v("half_length_m", half_length_m, "half the footprint's length, from base_link");
    v("half_width_m", half_width_m, "half the footprint's width");
  }
  void Validate() const;
  bool operator==(const FootprintParams&) const = default;
  std::vector<world::Vec2> Polygon() const;  // counter-clockwise, base_link frame
};

// Nav2's inscribed radius (nav2_costmap_2d::calculateMinAndMaxDistances): the least distance from
// base_link to an edge of the footprint polygon; 0.135 m for the car. Throws on < 3 points.
double InscribedRadius_m(const std::vector<world::Vec2>& footprint);

struct InflationParams {
  double inflation_radius_m{0.4};   // reference §6: global costmap inflation radius 0.4 m
  double cost_scaling_factor{5.0};  // reference §6: scale 5.0 (1/m), both costmaps

  template <class V>
  void Describe(V& v) {
    v("inflation_radius_m", inflation_radius_m, "how far from an obstacle its cost spreads");
    v("cost_scaling_factor", cost_scaling_factor,
      "how fast the inflated cost falls off with distance (1/m)");
  }
  void Validate() const;
  bool operator==(const InflationParams&) const = default;
};

// Nav2's InflationLayer on a grid of one resolution, with its costs cached per cell distance (as
// Nav2's cached_costs_). Cell distances are exact Euclidean distances between cell centres, from
// an exact distance transform (see costmap.cc), where Nav2 propagates a brushfire from the
// obstacle cells; both give the distance to the nearest LETHAL cell.
class Inflation {
 public:
  // Validates params; throws if the inscribed radius is negative or the resolution not positive.
  Inflation(const InflationParams& params, double inscribed_radius_m, double resolution_m);

  // Nav2's InflationLayer::computeCost for a distance in cells: LETHAL at 0, INSCRIBED while
  // distance·resolution <= inscribed radius, else uint8(252·exp(−scale·(d − r_inscribed))).
  std::uint8_t CostAtCellDistance(double distance_cells) const;
  // Nav2 inflates cells within ceil(inflation_radius / resolution) cells of an obstacle
  // (Costmap2D::cellDistance); beyond that they keep their cost.
  int cell_inflation_radius() const { return cell_radius_; }

  // Raises every cell within the inflation radius of a LETHAL cell of *grid to the inflated cost,
  // as Nav2's updateCosts: new = max(old, inflated), except that an unknown cell only takes an
  // inflated cost of INSCRIBED or more (inflate_unknown false). Deterministic; O(cells · radius)
  // where obstacles are near, O(cells) elsewhere.
  void Apply(Costmap2D* grid) const;

 private:
  double resolution_m_;
  double inscribed_radius_m_;
  double cost_scaling_factor_;
  int cell_radius_;
  std::vector<std::uint8_t> cost_by_distance_sq_;  // index dx² + dy² <= cell_radius²
};

// How Galactic's StaticLayer reads the map's values (nav2_costmap_2d/plugins/static_layer.cpp:
// 252-267, StaticLayer::interpretValue), with the global costmap's parameters.
struct StaticLayerParams {
  // Galactic's default (costmap_2d_ros.cpp:112; nav2_car_params.yaml:221-240 does not set it):
  // every value below lethal_cost_threshold becomes FREE, so the graded greys of the lab's
  // `mode: scale` map never reach the planner.
  bool trinary_costmap{true};
  int lethal_cost_threshold{100};  // Galactic's default (costmap_2d_ros.cpp:96), not set

  template <class V>
  void Describe(V& v) {
    v("trinary_costmap", trinary_costmap,
      "map values below the threshold are free, above it lethal (false: graded costs)");
    v("lethal_cost_threshold", lethal_cost_threshold,
      "the map value from which a cell is lethal (0..100)");
  }
  void Validate() const;  // threshold in [0, 100] (Galactic clamps it, static_layer.cpp:160)
  bool operator==(const StaticLayerParams&) const = default;
};

// The static layer (Nav2 StaticLayer, track_unknown_space true, nav2_car_params.yaml:231):
// unknown (-1) -> NO_INFORMATION; value >= lethal_cost_threshold -> LETHAL; otherwise FREE when
// trinary, else value / threshold · LETHAL (truncated); same geometry as the map.
Costmap2D StaticLayer(const world::OccupancyMap& map, const StaticLayerParams& params = {});

// A mark of the obstacle layer: the obstacle-grid layer writes each of its cell centres as LETHAL
// (count above its threshold) or FREE (reference §4). p is in the costmap's frame.
struct CostmapMark {
  world::Vec2 p{world::Vec2::Zero()};
  bool lethal{false};
};

// Writes each mark into the obstacle layer grid in order (a later mark of the same cell wins):
// LETHAL, or FREE to clear. Marks outside the grid are ignored. Returns how many landed.
int ApplyMarks(const std::vector<CostmapMark>& marks, Costmap2D* obstacle_layer);

// Nav2's Costmap2D updateWithMax: for each cell where the layer is not NO_INFORMATION, master
// takes the layer's cost if master is NO_INFORMATION or lower. Grids must have equal geometry
// (std::invalid_argument otherwise).
void CombineMax(const Costmap2D& layer, Costmap2D* master);

struct GlobalCostmapParams {
  // The map's resolution (simplestreet3.yaml:18, 0.00517063 m): the yaml's `resolution: 0.05`
  // (nav2_car_params.yaml:230) does not hold, because Galactic's StaticLayer::processMap resizes a
  // non-rolling costmap to the map's size, resolution and origin (static_layer.cpp:180-197;
  // reference §6). The world map handed in must have this resolution
  // (world::BuildStaticMap(track, resolution_m)).
  double resolution_m{world::kLabMapResolution_m};
  StaticLayerParams static_layer{};
  InflationParams inflation{};  // reference §6: static + inflation (scale 5.0, radius 0.4)
  FootprintParams footprint{};  // reference §2

  template <class V>
  void Describe(V& v) {
    v("resolution_m", resolution_m, "the planner map's cell size (the lab's map's)");
    v("static_layer", static_layer, "how the track's static map becomes costs");
    v("inflation", inflation, "the cost around obstacles");
    v("footprint", footprint, "the car's outline for the costs");
  }
  void Validate() const;
  bool operator==(const GlobalCostmapParams&) const = default;
};

// The planner's costmap over the whole static map: static + obstacle + inflation. The real car's
// global costmap had no obstacle layer (reference §6): Update with no marks reproduces it; marks
// are for a stack that wants obstacles in its plans.
class GlobalCostmap {
 public:
  // Validates params; throws std::invalid_argument when the map's resolution differs from
  // params.resolution_m.
  GlobalCostmap(const GlobalCostmapParams& params, const world::OccupancyMap& map);

  // Applies the marks to the (persistent) obstacle layer and rebuilds static + obstacle +
  // inflation into costmap().
  const Costmap2D& Update(const std::vector<CostmapMark>& marks = {});

  const Costmap2D& costmap() const { return master_; }
  const Costmap2D& static_layer() const { return static_; }
  const GlobalCostmapParams& params() const { return params_; }
  // Empty (0 cells) until the first marks arrive: at the map's resolution a layer is 3.7 MB.
  const Costmap2D& obstacle_layer() const { return obstacles_; }
  // The grids' bytes (static, obstacle and master layers).
  std::size_t bytes() const;

 private:
  GlobalCostmapParams params_;
  Inflation inflation_;
  Costmap2D static_;
  Costmap2D obstacles_;
  Costmap2D master_;
};

struct LocalCostmapParams {
  double width_m{5.0};        // reference §6: local costmap rolling 5 × 5 m
  double height_m{5.0};       // reference §6
  double resolution_m{0.05};  // reference §6
  // reference §6: obstacle layer + inflation (scale 5.0, radius 0.3)
  InflationParams inflation{.inflation_radius_m = 0.3, .cost_scaling_factor = 5.0};
  FootprintParams footprint{};  // reference §2
  // reference §6: the local costmap updates at 5 Hz (for the node that runs it).
  double update_rate_hz{5.0};

  template <class V>
  void Describe(V& v) {
    v("width_m", width_m, "the rolling window's size along x");
    v("height_m", height_m, "the rolling window's size along y");
    v("resolution_m", resolution_m, "its cell size");
    v("inflation", inflation, "the cost around obstacles");
    v("footprint", footprint, "the car's outline for the costs");
    v("update_rate_hz", update_rate_hz, "how often it is updated");
  }
  void Validate() const;
};

// A rolling window (Nav2 rolling_window: true): a grid whose origin moves by whole cells so that
// the robot stays at its centre. Cells are world-anchored: the origin is always an integer number
// of cells from the frame's origin, so cell (mx, my) covers the same square of the frame while it
// stays in the window, and a re-centre copies the overlap and fills the rest.
class RollingWindow {
 public:
  RollingWindow(int size_x_cells, int size_y_cells, double resolution_m,
                std::uint8_t fill = kFreeSpace);
  // Moves the window so that the cell containing p (costmap frame) becomes cell
  // (size_x / 2, size_y / 2); cells still inside keep their cost, new ones get the fill value.
  // A new window is centred on the frame's origin in the same way.
  void Recentre(const world::Vec2& p);
  const Costmap2D& grid() const { return grid_; }
  Costmap2D& mutable_grid() { return grid_; }
  // The window's cell (0, 0) as a cell of the frame's grid (anchored at the frame's origin).
  CellIndex origin_cell() const { return {grid_.origin_cx_, grid_.origin_cy_}; }

 private:
  Costmap2D grid_;
  std::uint8_t fill_;
};

struct LocalCostmapInput {
  world::Vec2 p_robot{world::Vec2::Zero()};  // base_link's position in the costmap frame
  std::vector<CostmapMark> marks;            // this update's obstacle-grid cells
};

// The controller's costmap: a rolling window centred on the robot, with a persistent obstacle
// layer (marks stay until cleared or rolled out of the window) and inflation. One Step per update
// (5 Hz in the real stack): re-centre, mark/clear, rebuild the master grid from FREE, inflate.
class LocalCostmap {
 public:
  explicit LocalCostmap(const LocalCostmapParams& params);  // validates
  const Costmap2D& Step(const LocalCostmapInput& input);
  const Costmap2D& costmap() const { return master_; }
  const Costmap2D& obstacle_layer() const { return obstacles_.grid(); }

 private:
  Inflation inflation_;
  RollingWindow obstacles_;
  Costmap2D master_;
};

}  // namespace autonomsim::stack
