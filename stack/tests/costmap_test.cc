#include "stack/costmap.h"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include "sim/core/track_loader.h"
#include "world/occupancy_map.h"

namespace autonomsim::stack {
namespace {

using world::Vec2;

// 252·exp(−scale·(d − r)), truncated as Nav2's InflationLayer::computeCost does.
int Nav2Cost(double distance_m, double scale, double inscribed_m) {
  return static_cast<int>(252.0 * std::exp(-scale * (distance_m - inscribed_m)));
}

// --- Costmap2D ---------------------------------------------------------------------------------

TEST(Costmap2DTest, WorldToMapAndBack) {
  const Costmap2D map(40, 20, 0.05, Vec2(-1.0, -0.5));
  EXPECT_EQ(map.WorldToMap(Vec2(-1.0, -0.5)), (CellIndex{0, 0}));
  EXPECT_EQ(map.WorldToMap(Vec2(-0.951, -0.451)), (CellIndex{0, 0}));
  EXPECT_EQ(map.WorldToMap(Vec2(-0.949, -0.449)), (CellIndex{1, 1}));
  EXPECT_EQ(map.WorldToMap(Vec2(0.99, 0.49)), (CellIndex{39, 19}));
  EXPECT_FALSE(map.WorldToMap(Vec2(1.0, 0.0)));  // the east edge is outside (half-open cells)
  EXPECT_FALSE(map.WorldToMap(Vec2(0.0, -0.5001)));
  EXPECT_FALSE(map.WorldToMap(Vec2(std::nan(""), 0.0)));
  for (int mx : {0, 7, 39}) {
    for (int my : {0, 11, 19}) {
      const Vec2 centre = map.MapToWorld(mx, my);
      EXPECT_NEAR(centre.x(), -1.0 + (mx + 0.5) * 0.05, 1e-12);
      EXPECT_NEAR(centre.y(), -0.5 + (my + 0.5) * 0.05, 1e-12);
      EXPECT_EQ(map.WorldToMap(centre), (CellIndex{mx, my}));
      EXPECT_EQ(map.Cell(map.Index(mx, my)), (CellIndex{mx, my}));
    }
  }
  EXPECT_EQ(map.Index(3, 2), 2u * 40u + 3u);
}

TEST(Costmap2DTest, BoundsChecked) {
  Costmap2D map(4, 3, 0.1, Vec2::Zero());
  EXPECT_THROW(map.Cost(4, 0), std::out_of_range);
  EXPECT_THROW(map.Cost(0, -1), std::out_of_range);
  EXPECT_THROW(map.SetCost(-1, 0, kLethalObstacle), std::out_of_range);
  EXPECT_THROW(map.Cell(12), std::out_of_range);
  EXPECT_FALSE(map.CostAt(Vec2(0.45, 0.1)));
  map.SetCost(3, 2, kLethalObstacle);
  EXPECT_EQ(map.CostAt(Vec2(0.35, 0.25)), kLethalObstacle);
  EXPECT_THROW(Costmap2D(0, 3, 0.1, Vec2::Zero()), std::invalid_argument);
  EXPECT_THROW(Costmap2D(3, 3, 0.0, Vec2::Zero()), std::invalid_argument);
}

// --- footprint and inflation -------------------------------------------------------------------

TEST(CostmapInflationTest, InscribedRadiusOfTheCarFootprint) {
  EXPECT_DOUBLE_EQ(InscribedRadius_m(FootprintParams{}.Polygon()), 0.135);  // reference §2
  const FootprintParams square{.half_length_m = 0.2, .half_width_m = 0.2};
  EXPECT_DOUBLE_EQ(InscribedRadius_m(square.Polygon()), 0.2);
  EXPECT_THROW(InscribedRadius_m({Vec2(0, 0), Vec2(1, 0)}), std::invalid_argument);
}

TEST(CostmapInflationTest, CostAtDistanceFollowsNav2Formula) {
  const Inflation inflation(InflationParams{}, 0.135, 0.05);
  EXPECT_EQ(inflation.cell_inflation_radius(), 8);  // ceil(0.4 / 0.05)
  EXPECT_EQ(inflation.CostAtCellDistance(0.0), kLethalObstacle);
  EXPECT_EQ(inflation.CostAtCellDistance(1.0), kInscribedInflatedObstacle);  // 0.05 m
  EXPECT_EQ(inflation.CostAtCellDistance(2.0), kInscribedInflatedObstacle);  // 0.10 m
  EXPECT_EQ(inflation.CostAtCellDistance(2.7), kInscribedInflatedObstacle);  // 0.135 m, on it
  for (double d_cells : {2.8, 3.0, std::sqrt(10.0), 4.0, 5.0, std::sqrt(50.0), 8.0}) {
    SCOPED_TRACE(d_cells);
    EXPECT_EQ(inflation.CostAtCellDistance(d_cells), Nav2Cost(d_cells * 0.05, 5.0, 0.135));
  }
  // Spot values: 0.15 m -> 252·e^-0.075 = 233.8; 0.3 m -> 252·e^-0.825 = 110.4; 0.4 m -> 66.98.
  EXPECT_EQ(inflation.CostAtCellDistance(3.0), 233);
  EXPECT_EQ(inflation.CostAtCellDistance(6.0), 110);
  EXPECT_EQ(inflation.CostAtCellDistance(8.0), 66);
  EXPECT_EQ(Inflation({.inflation_radius_m = 0.3}, 0.135, 0.05).cell_inflation_radius(), 6);
}

TEST(CostmapInflationTest, InflatedGridMatchesFormulaAroundOneObstacle) {
  Costmap2D grid(41, 41, 0.05, Vec2::Zero());
  grid.SetCost(20, 20, kLethalObstacle);
  const Inflation inflation(InflationParams{}, 0.135, 0.05);
  inflation.Apply(&grid);
  for (int my = 0; my < 41; ++my) {
    for (int mx = 0; mx < 41; ++mx) {
      const double d_cells = std::hypot(mx - 20, my - 20);
      const int expected = d_cells == 0.0  ? kLethalObstacle
                           : d_cells > 8.0 ? kFreeSpace
                                           : inflation.CostAtCellDistance(d_cells);
      ASSERT_EQ(grid.Cost(mx, my), expected) << mx << ", " << my;
    }
  }
  EXPECT_EQ(grid.Cost(20, 22), kInscribedInflatedObstacle);  // 0.10 m
  EXPECT_EQ(grid.Cost(23, 20), Nav2Cost(0.15, 5.0, 0.135));  // 0.15 m
  EXPECT_EQ(grid.Cost(24, 23), Nav2Cost(0.25, 5.0, 0.135));  // 0.25 m (3-4-5)
  EXPECT_EQ(grid.Cost(28, 20), Nav2Cost(0.40, 5.0, 0.135));  // 0.40 m, the edge
  EXPECT_EQ(grid.Cost(28, 21), kFreeSpace);                  // 0.403 m
}

// The exact distance transform against brute force on a scattered grid: every cell takes the
// cost of its nearest LETHAL cell, never less than it had, and unknown cells only go INSCRIBED.
// Apply on a grid with `lethal` obstacles scattered over its lower-left nx_obstacles × ny_obstacles
// cells (and some lower costs and unknown cells anywhere) equals the nearest obstacle found by
// brute force at every cell.
void ExpectInflationEqualsBruteForce(int nx, int ny, int nx_obstacles, int ny_obstacles,
                                     int lethal) {
  Costmap2D grid(nx, ny, 0.05, Vec2::Zero());
  unsigned state = 12345u;  // a fixed LCG: the same scattered pattern every run
  auto next = [&state] { return (state = state * 1103515245u + 12345u) >> 16; };
  for (int k = 0; k < lethal; ++k) {
    grid.SetCost(next() % nx_obstacles, next() % ny_obstacles, kLethalObstacle);
  }
  for (int k = 0; k < 40; ++k) grid.SetCost(next() % nx, next() % ny, 40);
  for (int k = 0; k < 40; ++k) grid.SetCost(next() % nx, next() % ny, kNoInformation);
  const Costmap2D before = grid;
  const Inflation inflation(InflationParams{}, 0.135, 0.05);
  inflation.Apply(&grid);
  for (int my = 0; my < ny; ++my) {
    for (int mx = 0; mx < nx; ++mx) {
      double nearest = 1e9;
      for (int oy = 0; oy < ny; ++oy) {
        for (int ox = 0; ox < nx; ++ox) {
          if (before.Cost(ox, oy) == kLethalObstacle) {
            nearest = std::min(nearest, std::hypot(mx - ox, my - oy));
          }
        }
      }
      const int old_cost = before.Cost(mx, my);
      const int inflated = nearest <= 8.0 ? inflation.CostAtCellDistance(nearest) : 0;
      const int expected = old_cost == kNoInformation
                               ? (inflated >= kInscribedInflatedObstacle ? inflated : old_cost)
                               : std::max(old_cost, inflated);
      ASSERT_EQ(grid.Cost(mx, my), expected) << mx << ", " << my;
    }
  }
}

TEST(CostmapInflationTest, InflationEqualsBruteForceNearestObstacle) {
  ExpectInflationEqualsBruteForce(37, 29, 37, 29, 25);
}

TEST(CostmapInflationTest, InflationOfASparseWindowEqualsBruteForce) {
  // a rolling window's case: obstacles in one corner, most rows and columns free of them
  ExpectInflationEqualsBruteForce(100, 100, 20, 12, 6);
}

TEST(CostmapInflationTest, AGridWithoutALethalCellIsLeftAsItIs) {
  // lower costs and unknown cells only: nothing inflates (Apply returns early on such a grid)
  ExpectInflationEqualsBruteForce(40, 30, 40, 30, 0);
}

// --- obstacle layer ----------------------------------------------------------------------------

TEST(CostmapObstacleLayerTest, MarksLethalAndClearFree) {
  Costmap2D layer(20, 20, 0.05, Vec2(-0.5, -0.5));
  const int landed = ApplyMarks({{Vec2(0.01, 0.01), true},
                                 {Vec2(0.11, 0.01), true},
                                 {Vec2(3.0, 0.0), true},  // outside: ignored
                                 {Vec2(0.11, 0.01), false}},
                                &layer);
  EXPECT_EQ(landed, 3);
  EXPECT_EQ(layer.CostAt(Vec2(0.01, 0.01)), kLethalObstacle);
  EXPECT_EQ(layer.CostAt(Vec2(0.11, 0.01)), kFreeSpace);  // the later mark of the cell wins
}

TEST(CostmapObstacleLayerTest, CombineMaxFollowsNav2UpdateWithMax) {
  Costmap2D master(3, 1, 0.05, Vec2::Zero());
  Costmap2D layer = master;
  master.mutable_costs() = {kNoInformation, 100, kLethalObstacle};
  layer.mutable_costs() = {kFreeSpace, kNoInformation, kFreeSpace};
  CombineMax(layer, &master);
  // A known layer cost replaces unknown; the layer's unknown is skipped; FREE never lowers.
  EXPECT_EQ(master.costs(), (std::vector<std::uint8_t>{kFreeSpace, 100, kLethalObstacle}));
  EXPECT_THROW(CombineMax(Costmap2D(2, 1, 0.05, Vec2::Zero()), &master), std::invalid_argument);
}

// --- the global costmap on the lab track -------------------------------------------------------

class CostmapLabTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    map_ = new world::OccupancyMap(world::BuildStaticMap(
        sim::LoadTrack("scenarios/tracks/lab.yaml"), world::kLabMapResolution_m));
  }
  static void TearDownTestSuite() {
    delete map_;
    map_ = nullptr;
  }
  static world::OccupancyMap* map_;
};
world::OccupancyMap* CostmapLabTest::map_ = nullptr;

TEST_F(CostmapLabTest, StaticLayerAndInflationOfTheLabMap) {
  const GlobalCostmap global(GlobalCostmapParams{}, *map_);
  const Costmap2D& costmap = global.costmap();
  // the 10 m map at its own 0.00517063 m (simplestreet3.yaml:18; Galactic's StaticLayer resizes
  // the global costmap to it, static_layer.cpp:180-197)
  EXPECT_EQ(costmap.size_x_cells(), 1934);
  EXPECT_EQ(costmap.size_y_cells(), 1934);
  int lethal = 0;
  for (std::size_t i = 0; i < map_->cells.size(); ++i) {
    const bool occupied = map_->cells[i] == world::OccupancyMap::kOccupied;
    EXPECT_EQ(global.static_layer().costs()[i] == kLethalObstacle, occupied);
    EXPECT_EQ(costmap.costs()[i] == kLethalObstacle, occupied);
    lethal += occupied;
  }
  EXPECT_GT(lethal, 30000);  // ≈ 27 m of 7-cell-wide lines
  // The yellow south loop at y = −1.86 is lethal with an inscribed halo; the outer south lane
  // centre (0.31 m away) is inflated but traversable; the outer boundary is not in the map.
  EXPECT_EQ(costmap.CostAt(Vec2(0.0, -1.86)), kLethalObstacle);
  EXPECT_EQ(costmap.CostAt(Vec2(0.0, -1.96)), kInscribedInflatedObstacle);
  const std::uint8_t lane = *costmap.CostAt(Vec2(0.0, -2.17));
  EXPECT_GT(lane, 50);
  EXPECT_LT(lane, kInscribedInflatedObstacle);
  EXPECT_EQ(costmap.CostAt(Vec2(0.0, -2.45)), kFreeSpace);
  EXPECT_EQ(costmap.CostAt(Vec2(0.0, -2.6)), kFreeSpace);  // beyond the floor, on the map
  // Inside an island: its outlines' inflation only (the lab's map draws hollow outlines), at
  // 0.325 m from both long sides: 252 exp(-5 (0.325 - 0.018 - 0.135)) ≈ 107.
  const std::uint8_t inside = *costmap.CostAt(Vec2(0.0, 0.9335));
  EXPECT_GT(inside, 90);
  EXPECT_LT(inside, 120);
  // The obstacle layer is not kept until a mark comes: two grids of 1934² bytes.
  EXPECT_EQ(global.bytes(), 2u * 1934 * 1934);
}

// Galactic's StaticLayer::interpretValue (static_layer.cpp:252-267) with the costmap's defaults,
// which nav2_car_params.yaml:221-240 leaves: trinary_costmap true (costmap_2d_ros.cpp:112),
// lethal_cost_threshold 100 (:96), and track_unknown_space true (yaml:231). So the `mode: scale`
// map's graded values become FREE; only 100 is LETHAL.
TEST(CostmapStaticLayerTest, GradedValuesAreFreeUnderGalacticsTrinaryDefault) {
  world::OccupancyMap map;
  map.width_cells = 5;
  map.height_cells = 1;
  map.cells = {0, 50, 99, 100, -1};
  EXPECT_EQ(StaticLayer(map).costs(), (std::vector<std::uint8_t>{kFreeSpace, kFreeSpace, kFreeSpace,
                                                                 kLethalObstacle, kNoInformation}));
  // Not trinary: value / threshold · 254, truncated.
  EXPECT_EQ(StaticLayer(map, {.trinary_costmap = false}).costs(),
            (std::vector<std::uint8_t>{0, 127, 251, kLethalObstacle, kNoInformation}));
  EXPECT_THROW(StaticLayerParams{.lethal_cost_threshold = 101}.Validate(), std::invalid_argument);
}

TEST_F(CostmapLabTest, ClearingMarksKeepsTheStaticMap) {
  GlobalCostmap global(GlobalCostmapParams{}, *map_);
  const Costmap2D reference = global.costmap();
  const Vec2 on_yellow(0.0, -1.86);
  const Vec2 on_lane(0.5, -2.3);
  global.Update({{on_lane, true}});
  EXPECT_EQ(global.costmap().CostAt(on_lane), kLethalObstacle);
  EXPECT_EQ(global.costmap().CostAt(on_lane + Vec2(0.1, 0.0)), kInscribedInflatedObstacle);
  // Clearing both cells: the mark goes, the static line stays.
  global.Update({{on_lane, false}, {on_yellow, false}});
  EXPECT_EQ(global.costmap().CostAt(on_yellow), kLethalObstacle);
  EXPECT_EQ(global.costmap().costs(), reference.costs());
}

TEST_F(CostmapLabTest, RejectsAMapOfAnotherResolution) {
  EXPECT_THROW(GlobalCostmap(GlobalCostmapParams{.resolution_m = 0.1}, *map_),
               std::invalid_argument);
}

// --- rolling window and local costmap ----------------------------------------------------------

TEST(CostmapRollingWindowTest, RecentreKeepsWorldAnchoredCells) {
  RollingWindow window(100, 100, 0.05);
  EXPECT_EQ(window.grid().origin_m(), Vec2(-2.5, -2.5));  // centred on the frame's origin
  window.Recentre(Vec2(0.96, -2.18));
  const Costmap2D& grid = window.grid();
  EXPECT_EQ(grid.WorldToMap(Vec2(0.96, -2.18)), (CellIndex{50, 50}));
  EXPECT_NEAR(grid.origin_m().x(), 19 * 0.05 - 2.5, 1e-12);
  EXPECT_NEAR(grid.origin_m().y(), -44 * 0.05 - 2.5, 1e-12);

  const Vec2 stays(1.5, -1.0);    // inside both windows
  const Vec2 leaves(-1.4, -2.0);  // falls out after the move
  ApplyMarks({{stays, true}, {leaves, true}}, &window.mutable_grid());
  window.Recentre(Vec2(2.43, -1.62));  // a diagonal move of many cells
  EXPECT_EQ(window.grid().WorldToMap(Vec2(2.43, -1.62)), (CellIndex{50, 50}));
  EXPECT_EQ(window.grid().CostAt(stays), kLethalObstacle);
  EXPECT_FALSE(window.grid().CostAt(leaves));
  int lethal = 0;
  for (std::uint8_t c : window.grid().costs()) lethal += c == kLethalObstacle;
  EXPECT_EQ(lethal, 1);
  // Back again: the cell that left comes back as new (FREE), the one that stayed is still there.
  window.Recentre(Vec2(0.96, -2.18));
  EXPECT_EQ(window.grid().CostAt(stays), kLethalObstacle);
  EXPECT_EQ(window.grid().CostAt(leaves), kFreeSpace);
  // A move within the same cell changes nothing.
  const Costmap2D same = window.grid();
  window.Recentre(Vec2(0.97, -2.16));
  EXPECT_EQ(window.grid().origin_m(), same.origin_m());
}

TEST(CostmapLocalTest, StepMarksInflatesAndRolls) {
  LocalCostmap local(LocalCostmapParams{});
  const Vec2 robot(0.96, -2.18);
  const Vec2 obstacle(1.51, -2.16);  // 0.55 m ahead on the lane
  const Costmap2D& costmap = local.Step({.p_robot = robot, .marks = {{obstacle, true}}});
  EXPECT_EQ(costmap.size_x_cells(), 100);
  EXPECT_EQ(costmap.CostAt(obstacle), kLethalObstacle);
  // Local inflation radius 0.3 m (reference §6): 6 cells.
  const CellIndex o = *costmap.WorldToMap(obstacle);
  EXPECT_EQ(costmap.Cost(o.mx + 6, o.my), Nav2Cost(0.30, 5.0, 0.135));
  EXPECT_EQ(costmap.Cost(o.mx + 7, o.my), kFreeSpace);
  EXPECT_EQ(costmap.Cost(o.mx, o.my + 2), kInscribedInflatedObstacle);
  // The mark persists while the robot drives on (no marks this step), then is cleared.
  const Vec2 later(1.31, -2.18);
  EXPECT_EQ(local.Step({.p_robot = later}).CostAt(obstacle), kLethalObstacle);
  EXPECT_EQ(local.Step({.p_robot = later, .marks = {{obstacle, false}}}).CostAt(obstacle),
            kFreeSpace);
  for (std::uint8_t c : local.costmap().costs()) ASSERT_EQ(c, kFreeSpace);
}

TEST(CostmapLocalTest, ParamsValidate) {
  EXPECT_THROW(LocalCostmap(LocalCostmapParams{.resolution_m = 0.0}), std::invalid_argument);
  EXPECT_THROW(LocalCostmap(LocalCostmapParams{.inflation = {.inflation_radius_m = -1.0}}),
               std::invalid_argument);
  EXPECT_THROW(LocalCostmap(LocalCostmapParams{.footprint = {.half_width_m = 0.0}}),
               std::invalid_argument);
}

}  // namespace
}  // namespace autonomsim::stack
