#include "world/road_graph.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

namespace autonomsim::world {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;

std::string ErrorOf(const auto& action) {
  try {
    action();
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "(no exception)";
}

LaneSegmentSpec Lane(std::string name, PointList points, double corner_radius_m = 0.9) {
  LaneSegmentSpec lane;
  lane.name = std::move(name);
  lane.points_m = std::move(points);
  lane.corner_radius_m = corner_radius_m;
  return lane;
}

// start -> detour -> goal has fewer segments, and detour has the lower index, so a search that
// stops at the first path it finds returns it; start -> short_a -> short_b -> goal is shorter.
std::vector<LaneSegmentSpec> DetourLanes() {
  return {
      Lane("start", {{0.0, 0.0}, {1.0, 0.0}}),
      Lane("detour", {{1.0, 0.0}, {1.0, 5.0}, {3.0, 5.0}, {3.0, 0.0}}),
      Lane("short_a", {{1.0, 0.0}, {2.0, 0.0}}),
      Lane("short_b", {{2.0, 0.0}, {3.0, 0.0}}),
      Lane("goal", {{3.0, 0.0}, {4.0, 0.0}}),
      Lane("near_end", {{4.0005, 0.0}, {5.0, 0.0}}),  // 0.5 mm from goal's end: joined
      Lane("far_end", {{4.002, 0.0}, {5.0, 1.0}}),    // 2 mm: not joined
  };
}

TEST(RoadGraphTest, SuccessorsAreSegmentsStartingWhereOneEnds) {
  const RoadGraph graph(DetourLanes());
  ASSERT_EQ(graph.segment_count(), 7u);
  EXPECT_EQ(graph.SegmentIndex("short_a"), 2);
  EXPECT_EQ(graph.name(1), "detour");
  EXPECT_THAT(graph.Successors(graph.SegmentIndex("start")), ElementsAre(1, 2));
  EXPECT_THAT(graph.Successors(graph.SegmentIndex("detour")), ElementsAre(4));
  EXPECT_THAT(graph.Successors(graph.SegmentIndex("short_a")), ElementsAre(3));
  EXPECT_THAT(graph.Successors(graph.SegmentIndex("goal")), ElementsAre(5));
  EXPECT_TRUE(graph.Successors(graph.SegmentIndex("far_end")).empty());
  EXPECT_NEAR(graph.path(1).length_m(), 12.0 - 4.0 * 0.9 + std::numbers::pi * 0.9, 1e-3);
}

TEST(RoadGraphTest, UnknownNameListsTheKnownOnes) {
  const RoadGraph graph(DetourLanes());
  const std::string error = ErrorOf([&] { graph.SegmentIndex("nowhere"); });
  EXPECT_THAT(error, HasSubstr("'nowhere'"));
  EXPECT_THAT(error, HasSubstr("detour, far_end, goal, near_end, short_a, short_b, start"));
  EXPECT_THROW(graph.Successors(7), std::out_of_range);
  EXPECT_THROW(graph.path(-1), std::out_of_range);
}

TEST(RoadGraphTest, ShortestPathIsShortestNotFirstFound) {
  const RoadGraph graph(DetourLanes());
  const int start = graph.SegmentIndex("start");
  const int goal = graph.SegmentIndex("goal");
  const auto path = graph.ShortestPath(start, goal);
  ASSERT_TRUE(path.has_value());
  EXPECT_THAT(*path, ElementsAre(start, graph.SegmentIndex("short_a"),
                                 graph.SegmentIndex("short_b"), goal));
  EXPECT_THAT(*graph.ShortestPath(start, graph.SegmentIndex("near_end")),
              ElementsAre(start, 2, 3, goal, 5));
  EXPECT_THAT(*graph.ShortestPath(goal, goal), ElementsAre(goal));
  EXPECT_FALSE(graph.ShortestPath(goal, start).has_value());
  EXPECT_FALSE(graph.ShortestPath(start, graph.SegmentIndex("far_end")).has_value());
}

TEST(RoadGraphTest, BadLaneIsNamed) {
  // Sides of 1 m cannot hold two 0.9 m arcs.
  const std::string error = ErrorOf([] {
    RoadGraph({Lane("fine", {{0.0, 0.0}, {1.0, 0.0}}),
               Lane("zigzag", {{0.0, 0.0}, {1.0, 0.0}, {1.0, 1.0}, {2.0, 1.0}})});
  });
  EXPECT_THAT(error, HasSubstr("lane 'zigzag'"));
  EXPECT_THAT(error, HasSubstr("does not fit"));
  EXPECT_THAT(ErrorOf([] {
                RoadGraph({Lane("twice", {{0.0, 0.0}, {1.0, 0.0}}),
                           Lane("twice", {{1.0, 0.0}, {2.0, 0.0}})});
              }),
              HasSubstr("duplicate lane name 'twice'"));
  EXPECT_THAT(ErrorOf([] { RoadGraph({Lane("dot", {{0.0, 0.0}})}); }), HasSubstr("lane 'dot'"));
}

TEST(MakeRouteTest, JoinsSegmentsDroppingJunctionDuplicates) {
  const RoadGraph graph(DetourLanes());
  const Route route = MakeRoute(graph, "straight", {"start", "short_a", "short_b", "goal"});
  EXPECT_EQ(route.name, "straight");
  EXPECT_FALSE(route.cyclic);
  EXPECT_FALSE(route.path.cyclic());
  EXPECT_THAT(route.segments, ElementsAre(0, 2, 3, 4));
  EXPECT_DOUBLE_EQ(route.path.length_m(), 4.0);
  ASSERT_EQ(route.segment_start_s_m.size(), 4u);
  for (int k = 0; k < 4; ++k) EXPECT_NEAR(route.segment_start_s_m[k], k, 1e-12);
  std::size_t points = 0;
  for (int segment : route.segments) points += graph.path(segment).points().size();
  EXPECT_EQ(route.path.points().size(), points - 3);
  // Across a 0.5 mm junction: the earlier end point is kept.
  const Route gap = MakeRoute(graph, "gap", {"goal", "near_end"});
  EXPECT_NEAR(gap.path.length_m(), 2.0, 1e-12);
  EXPECT_NEAR(gap.segment_start_s_m[1], 1.0, 1e-12);
}

TEST(MakeRouteTest, DisconnectedPairIsNamed) {
  const RoadGraph graph(DetourLanes());
  const std::string error = ErrorOf([&] {
    MakeRoute(graph, "broken", {"start", "short_a", "goal"});
  });
  EXPECT_THAT(error, HasSubstr("route 'broken'"));
  EXPECT_THAT(error, HasSubstr("lane 'short_a' does not lead into lane 'goal'"));
  EXPECT_THAT(ErrorOf([&] {
                MakeRoute(graph, "far", {"goal", "far_end"});
              }),
              HasSubstr("lane 'goal' does not lead into lane 'far_end'"));
  EXPECT_THAT(ErrorOf([&] {
                MakeRoute(graph, "typo", {"start", "shrot_a"});
              }),
              HasSubstr("unknown lane 'shrot_a'"));
  EXPECT_THROW(MakeRoute(graph, "empty", {}), std::invalid_argument);
}

TEST(MakeRouteTest, LoopIsCyclic) {
  const RoadGraph graph({
      Lane("east_half", {{0.0, -2.0}, {2.0, -2.0}, {2.0, 2.0}, {0.0, 2.0}}),
      Lane("west_half", {{0.0, 2.0}, {-2.0, 2.0}, {-2.0, -2.0}, {0.0, -2.0}}),
      Lane("ring", {{1.0, 0.0}, {1.0, -1.0}, {-1.0, -1.0}, {-1.0, 1.0}, {1.0, 1.0}, {1.0, 0.0}},
           0.5),
  });
  const Route loop = MakeRoute(graph, "loop", {"east_half", "west_half"});
  EXPECT_TRUE(loop.cyclic);
  EXPECT_TRUE(loop.path.cyclic());
  EXPECT_NEAR(loop.path.length_m(), graph.path(0).length_m() + graph.path(1).length_m(), 1e-9);
  EXPECT_NEAR(loop.segment_start_s_m[1], graph.path(0).length_m(), 1e-9);
  // The seam is smooth: the headings either side of s = 0 agree.
  EXPECT_NEAR(WrapAngle(loop.path.HeadingAt(-1e-3) - loop.path.HeadingAt(1e-3)), 0.0, 1e-9);
  EXPECT_TRUE(loop.path.PointAt(loop.path.length_m() + 0.5).isApprox(loop.path.PointAt(0.5)));

  // A segment that ends where it starts is its own successor and a cyclic route alone.
  EXPECT_THAT(graph.Successors(2), ElementsAre(2));
  const Route ring = MakeRoute(graph, "ring", {"ring"});
  EXPECT_TRUE(ring.cyclic);
  EXPECT_NEAR(ring.path.length_m(), graph.path(2).length_m(), 1e-12);
  EXPECT_FALSE(MakeRoute(graph, "half", {"east_half"}).cyclic);
}

}  // namespace
}  // namespace autonomsim::world
