#include "world/track.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <numbers>
#include <stdexcept>
#include <string>

namespace autonomsim::world {
namespace {

using ::testing::HasSubstr;

std::string ErrorOf(const auto& action) {
  try {
    action();
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "(no exception)";
}

TrackLineSpec Line(std::string name, std::string color, PointList points, bool closed,
                   double corner_radius_m, std::string planner) {
  TrackLineSpec line;
  line.name = std::move(name);
  line.color = std::move(color);
  line.points_m = std::move(points);
  line.closed = closed;
  line.corner_radius_m = corner_radius_m;
  line.planner = std::move(planner);
  return line;
}

LaneSegmentSpec Lane(std::string name, PointList points) {
  LaneSegmentSpec lane;
  lane.name = std::move(name);
  lane.points_m = std::move(points);
  return lane;
}

// A 4 m floor with a ring lane (clockwise at ±1.5 m, in two halves), a border, a middle line and
// an island, two intersections on the east side.
TrackSpec MiniSpec() {
  TrackSpec spec;
  spec.name = "mini";
  spec.size_m = 4.0;
  spec.colors_rgb = {{"white", {255, 255, 255}}, {"yellow", {235, 235, 0}}};
  spec.lines = {
      Line("border", "white", {{1.9, -1.9}, {1.9, 1.9}, {-1.9, 1.9}, {-1.9, -1.9}}, true, 0.3,
           "none"),
      Line("middle", "yellow", {{-1.0, 0.0}, {1.0, 0.0}}, false, 0.0, "line"),
      Line("island", "white", {{0.5, 0.6}, {0.5, 1.2}, {-0.5, 1.2}, {-0.5, 0.6}}, true, 0.1,
           "filled"),
  };
  spec.lanes = {
      Lane("east", {{0.0, 1.5}, {1.5, 1.5}, {1.5, -1.5}, {0.0, -1.5}}),
      Lane("west", {{0.0, -1.5}, {-1.5, -1.5}, {-1.5, 1.5}, {0.0, 1.5}}),
  };
  spec.routes = {{"ring", {"east", "west"}}};
  IntersectionSpec north;
  north.id = 3;
  north.name = "north";
  north.area = {1.0, 2.0, 0.0, 1.0};
  north.stop_zones = {{1.2, 1.8, 1.0, 1.4}, {1.0, 1.2, 0.2, 0.8}};
  IntersectionSpec south;
  south.id = 4;
  south.name = "south";
  south.area = {1.0, 2.0, -1.0, 0.0};
  south.stop_zones = {{1.2, 1.8, -1.4, -1.0}};
  spec.intersections = {north, south};
  spec.start_poses = {{"east_side", {1.5, 0.2, -90.0}}};
  return spec;
}

TEST(TrackTest, DerivesLinesGraphAndRoutes) {
  const Track track(MiniSpec());
  EXPECT_EQ(track.spec().name, "mini");
  ASSERT_EQ(track.line_paths().size(), 3u);
  EXPECT_TRUE(track.line_paths()[0].cyclic());
  EXPECT_FALSE(track.line_paths()[1].cyclic());
  EXPECT_DOUBLE_EQ(track.line_paths()[1].length_m(), 2.0);
  // Chords sampling a 0.1 m arc to 0.1 mm are 0.2 mm shorter than it over a full turn.
  EXPECT_NEAR(track.line_paths()[2].length_m(),
              2.0 * (1.0 + 0.6) - 8.0 * 0.1 + 2.0 * std::numbers::pi * 0.1, 3e-4);
  EXPECT_EQ(track.road_graph().segment_count(), 2u);
  const Route ring = track.RouteByName("ring");
  EXPECT_TRUE(ring.cyclic);
  EXPECT_EQ(ring.segments.size(), 2u);
  EXPECT_NEAR(ring.path.Project({1.6, 0.0}).lateral_m, 0.1, 1e-9);  // east side runs south
  const std::string error = ErrorOf([&] { track.RouteByName("square"); });
  EXPECT_THAT(error, HasSubstr("unknown route 'square'"));
  EXPECT_THAT(error, HasSubstr("known routes: ring"));
}

TEST(TrackTest, IntersectionAndStopZoneLookUps) {
  const Track track(MiniSpec());
  const IntersectionSpec* north = track.IntersectionAt({1.5, 0.5});
  ASSERT_NE(north, nullptr);
  EXPECT_EQ(north->id, 3);
  EXPECT_EQ(track.IntersectionAt({1.5, -0.5})->id, 4);
  EXPECT_EQ(track.IntersectionAt({0.5, 0.5}), nullptr);
  EXPECT_EQ(track.IntersectionAt({1.5, 0.0}),
            nullptr);  // on the shared edge: strict, like the cars

  const auto zone = track.StopZoneAt({1.1, 0.5});
  ASSERT_TRUE(zone.has_value());
  EXPECT_EQ(zone->intersection_id, 3);
  EXPECT_EQ(zone->zone_index, 1);
  EXPECT_EQ(track.StopZoneAt({1.5, -1.2})->intersection_id, 4);
  EXPECT_EQ(track.StopZoneAt({1.5, -1.2})->zone_index, 0);
  EXPECT_FALSE(track.StopZoneAt({1.5, 0.5}).has_value());
  EXPECT_FALSE(track.StopZoneAt({1.2, 1.2}).has_value());  // on a zone's edge
}

TEST(TrackTest, StartPoses) {
  const Track track(MiniSpec());
  const auto pose = track.StartPose("east_side");
  ASSERT_TRUE(pose.has_value());
  EXPECT_DOUBLE_EQ(pose->x_m, 1.5);
  EXPECT_DOUBLE_EQ(pose->y_m, 0.2);
  EXPECT_DOUBLE_EQ(pose->yaw_rad, -std::numbers::pi / 2);
  EXPECT_FALSE(track.StartPose("nowhere").has_value());
}

TEST(TrackTest, BadGeometryIsNamed) {
  TrackSpec tight = MiniSpec();
  tight.lines[2].corner_radius_m = 0.31;  // the island is 0.6 m tall: two 0.31 m arcs do not fit
  EXPECT_THAT(ErrorOf([&] { Track{tight}; }), HasSubstr("line 'island'"));
  tight.lines[2].corner_radius_m = 0.3;  // exactly half its height: a stadium, fine
  EXPECT_NO_THROW(Track{tight});

  TrackSpec lane = MiniSpec();
  lane.lanes[1].points_m = {{0.0, -1.5}, {-1.5, -1.5}, {-1.5, -1.5}, {0.0, 1.5}};
  EXPECT_THAT(ErrorOf([&] { Track{lane}; }), HasSubstr("lane 'west'"));

  TrackSpec broken = MiniSpec();
  broken.lanes[1].points_m = {{0.0, -1.5}, {-1.5, -1.5}, {-1.5, 1.5}, {0.0, 1.6}};
  broken.routes["ring"] = {"east", "west", "east"};
  const std::string error = ErrorOf([&] { Track{broken}; });
  EXPECT_THAT(error, HasSubstr("route 'ring'"));
  EXPECT_THAT(error, HasSubstr("lane 'west' does not lead into lane 'east'"));

  TrackSpec planner = MiniSpec();
  planner.lines[1].planner = "filled";  // an open line cannot be filled
  EXPECT_THAT(ErrorOf([&] { Track{planner}; }), HasSubstr("line 'middle'"));

  TrackSpec width = MiniSpec();
  width.lines[0].width_m = 0.0;
  EXPECT_THAT(ErrorOf([&] { Track{width}; }), HasSubstr("line 'border'"));

  TrackSpec zones = MiniSpec();
  zones.intersections[1].stop_zones.clear();
  EXPECT_THAT(ErrorOf([&] { Track{zones}; }), HasSubstr("intersection 4"));

  TrackSpec color = MiniSpec();
  color.lines[1].color = "blue";
  EXPECT_THAT(ErrorOf([&] { Track{color}; }), HasSubstr("unknown color 'blue'"));
}

}  // namespace
}  // namespace autonomsim::world
