// track.png as a reader uses it: the floor placed by its layout, and the collisions marked where
// the car was when it collided.
#include "sim/results/track_figure.h"

#include <gtest/gtest.h>

#include "sim/scenario/scenario.h"

namespace autonomsim::sim {
namespace {

// Car 0 drives 2 m east along the outer south lane, 0.5 m per second; it collides at 2.5 s.
RunRecord StraightRunWithACollision() {
  RunRecord record;
  for (int k = 0; k <= 40; ++k) {
    TrajectorySample s;
    s.t = Milliseconds(100 * k);
    s.car = 0;
    s.x_m = -1.0 + 0.05 * k;
    s.y_m = -2.17;
    record.trajectory.push_back(s);
  }
  Event collision;
  collision.t = Milliseconds(2500);
  collision.type = EventKind::kCollision;
  collision.car = 0;
  collision.other_car = 1;
  record.events.push_back(collision);
  return record;
}

TEST(TrackFigureTest, TheFloorSitsInMarginsAndMetresMapToItsPixels) {
  const LoadedScenario loaded = LoadScenario("scenarios/lab_two_cars_oracle.yaml");
  const TrackFigureLayout at = TrackFigureLayoutOf(loaded);
  const cv::Mat image = DrawTrackFigure(loaded, RunRecord{});
  const int floor_px = static_cast<int>(std::lround(loaded.track.spec().size_m / at.m_per_px));
  EXPECT_GT(at.left_px, 0);
  EXPECT_GT(at.top_px, 0);
  EXPECT_GT(image.cols, at.left_px + floor_px);  // room for the legend
  EXPECT_GT(image.rows, at.top_px + floor_px);   // and for the x axis
  // the centre of the floor's top-left pixel, and the floor's centre
  EXPECT_EQ(at.ToPixel(at.x0_m + 0.5 * at.m_per_px, at.y0_m - 0.5 * at.m_per_px),
            cv::Point(at.left_px, at.top_px));
  EXPECT_EQ(at.ToPixel(0.0, 0.0), cv::Point(at.left_px + floor_px / 2, at.top_px + floor_px / 2));
  // the yellow loop crosses y = 0 at x = -1.86 (reference §1): drawn there, on the figure
  const cv::Vec3b yellow = image.at<cv::Vec3b>(at.ToPixel(-1.86, 1.2));
  EXPECT_GT(yellow[1], 150);
  EXPECT_GT(yellow[2], 150);
  EXPECT_LT(yellow[0], 100);
}

TEST(TrackFigureTest, ACollisionIsMarkedWhereTheCarWas) {
  const LoadedScenario loaded = LoadScenario("scenarios/lab_two_cars_oracle.yaml");
  const TrackFigureLayout at = TrackFigureLayoutOf(loaded);
  const cv::Mat image = DrawTrackFigure(loaded, StraightRunWithACollision());
  const cv::Vec3b red(static_cast<std::uint8_t>(kCollisionMarkerBgr[0]),
                      static_cast<std::uint8_t>(kCollisionMarkerBgr[1]),
                      static_cast<std::uint8_t>(kCollisionMarkerBgr[2]));
  EXPECT_EQ(image.at<cv::Vec3b>(at.ToPixel(0.25, -2.17)), red);  // x at 2.5 s
  EXPECT_NE(image.at<cv::Vec3b>(at.ToPixel(-0.5, -2.17)), red);  // no marker elsewhere on the path
  // without the event, no marker there
  RunRecord quiet = StraightRunWithACollision();
  quiet.events.clear();
  EXPECT_NE(DrawTrackFigure(loaded, quiet).at<cv::Vec3b>(at.ToPixel(0.25, -2.17)), red);
}

}  // namespace
}  // namespace autonomsim::sim
