// The lane-detection judge against hand-made detections on the lab track's outer loop.
#include "sim/loop/lane_judge.h"

#include <gtest/gtest.h>

#include <optional>

#include "sim/core/track_loader.h"

namespace autonomsim::sim {
namespace {

// A detection whose lane centre runs parallel to the car's heading, `y_m` to its left, from 0.9 m
// to 0.3 m ahead (far to near, as the real node sends it).
stack::LanePoints StraightDetection(float y_m) {
  stack::LanePoints lanes;
  for (int i = 0; i < stack::LanePoints::kCount; ++i) {
    const float x = 0.9F - 0.6F * static_cast<float>(i) / (stack::LanePoints::kCount - 1);
    lanes.points[static_cast<std::size_t>(i)] = {x, y_m};
  }
  lanes.valid = 1;
  return lanes;
}

class LaneJudgeTest : public ::testing::Test {
 protected:
  LaneJudgeTest()
      : track_(LoadTrack("scenarios/tracks/lab.yaml")), route_(track_.RouteByName("outer_loop")) {}

  world::Pose2 OnRoute(double s_m) const {
    const world::Vec2 p = route_.path.PointAt(s_m);
    return {p.x(), p.y(), route_.path.HeadingAt(s_m)};
  }
  // The first place along the route where a centred detection is judged.
  std::optional<double> FirstJudgedS() const {
    for (double s = 0.0; s < route_.path.length_m(); s += 0.05) {
      if (LaneDetectionError({}, track_, route_.path, OnRoute(s), StraightDetection(0.0F))) {
        return s;
      }
    }
    return std::nullopt;
  }

  world::Track track_;
  world::Route route_;
};

TEST_F(LaneJudgeTest, OnAStraightTheErrorIsTheDetectionsOffsetFromTheLaneCentre) {
  const std::optional<double> s = FirstJudgedS();
  ASSERT_TRUE(s.has_value());
  const world::Pose2 car = OnRoute(*s);
  EXPECT_NEAR(*LaneDetectionError({}, track_, route_.path, car, StraightDetection(0.0F)), 0.0,
              1e-6);
  EXPECT_NEAR(*LaneDetectionError({}, track_, route_.path, car, StraightDetection(0.05F)), 0.05,
              1e-6);
  EXPECT_NEAR(*LaneDetectionError({}, track_, route_.path, car, StraightDetection(-0.08F)), 0.08,
              1e-6);
}

TEST_F(LaneJudgeTest, InvalidShortOrMisplacedDetectionsAreNotJudged) {
  const std::optional<double> s = FirstJudgedS();
  ASSERT_TRUE(s.has_value());
  const world::Pose2 car = OnRoute(*s);
  stack::LanePoints invalid = StraightDetection(0.0F);
  invalid.valid = 0;
  EXPECT_FALSE(LaneDetectionError({}, track_, route_.path, car, invalid));
  // points that end before the judged distance (0.5 m ahead)
  stack::LanePoints short_reach = StraightDetection(0.0F);
  for (stack::LanePoint& p : short_reach.points) p.x_m *= 0.4F;
  EXPECT_FALSE(LaneDetectionError({}, track_, route_.path, car, short_reach));
  // in an intersection area FollowPath steers, not the lanes
  const world::Box& area = track_.spec().intersections.front().area;
  const world::Pose2 in_area{0.5 * (area.x_min_m + area.x_max_m),
                             0.5 * (area.y_min_m + area.y_max_m), car.yaw_rad};
  EXPECT_FALSE(LaneDetectionError({}, track_, route_.path, in_area, StraightDetection(0.0F)));
}

TEST_F(LaneJudgeTest, InACornerNothingIsJudged) {
  // the route's corners are arcs: every pose whose surroundings curve is left out
  int judged_in_corners = 0;
  for (double s = 0.0; s < route_.path.length_m(); s += 0.05) {
    if (std::abs(route_.path.CurvatureAt(s)) < 0.5) continue;
    if (LaneDetectionError({}, track_, route_.path, OnRoute(s), StraightDetection(0.0F))) {
      ++judged_in_corners;
    }
  }
  EXPECT_EQ(judged_in_corners, 0);
}

}  // namespace
}  // namespace autonomsim::sim
