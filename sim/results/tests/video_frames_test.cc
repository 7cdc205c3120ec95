// The video's steps without an encoder: the options it refuses, the instant of each frame, who
// holds an intersection when, and the frames drawn from a hand-made run (a car seen where its
// samples put it, an intersection tinted while it is held). The encoder itself is tested through
// the `autonomsim video` command (tools/tests/report_test.cc).
#include "sim/results/video_frames.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <string>

namespace autonomsim::sim::detail {
namespace {

using ::testing::HasSubstr;

// Car 0 of the obstacle scenario at (0, -2) facing east until 1 s, then at (1, -2): two samples,
// a run of 2 s; car 1 has no samples. The box obstacle is there from 5 s on, after the run.
FinishedRun TwoSampleRun() {
  const LoadedScenario loaded = LoadScenario("scenarios/static_obstacle.yaml");
  FinishedRun run{"run", {}, loaded.scenario, loaded.track, {}};
  run.summary.sim_seconds = 2.0;
  TrajectorySample first, second;
  first.car = second.car = 0;
  first.x_m = 0.0;
  second.x_m = 1.0;
  first.y_m = second.y_m = -2.0;
  second.t = FromSeconds(1.0);
  run.record.trajectory = {first, second};
  return run;
}

Event At(double t_s, EventKind type, int car, int intersection) {
  Event e;
  e.t = FromSeconds(t_s);
  e.type = type;
  e.car = car;
  e.intersection = intersection;
  return e;
}

void ExpectRefused(const FinishedRun& run, const VideoOptions& options, const std::string& what) {
  try {
    CheckVideoOptions(run, options);
    FAIL() << "accepted options that should name " << what;
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr(what));
  }
}

TEST(VideoFramesTest, OptionsThatDoNotFitTheRunAreRefusedByName) {
  const FinishedRun run = TwoSampleRun();
  EXPECT_NO_THROW(CheckVideoOptions(run, {}));
  VideoOptions fps;
  fps.fps = 0.0;
  ExpectRefused(run, fps, "--fps 0: must be > 0");
  VideoOptions speed;
  speed.speed = -1.0;
  ExpectRefused(run, speed, "--speed -1");
  VideoOptions past_end;
  past_end.to_s = 3.0;
  ExpectRefused(run, past_end, "--from 0 --to 3");
  VideoOptions backwards;
  backwards.from_s = 1.5;
  backwards.to_s = 1.0;
  ExpectRefused(run, backwards, "0 <= from <= to <= 2");
  VideoOptions camera;
  camera.camera_car = 7;
  ExpectRefused(run, camera, "--cameras 7: the run has no car 7 with a board");
  VideoOptions chase;
  chase.chase_car = 7;
  ExpectRefused(run, chase, "--chase 7: the run has no car 7");
}

TEST(VideoFramesTest, FramesAreEvenlySpacedInSimulatedTime) {
  const FinishedRun run = TwoSampleRun();
  VideoOptions options;
  options.fps = 10.0;
  options.speed = 2.0;  // 0.2 s of the run per frame
  options.from_s = 0.4;
  EXPECT_EQ(VideoFrameTime(options, 0), FromSeconds(0.4));
  EXPECT_EQ(VideoFrameTime(options, 3), FromSeconds(0.4 + 3 * 0.2));
  EXPECT_EQ(VideoFrameCount(run, options), 9u);  // 0.4, 0.6, ..., 2.0 s
}

TEST(VideoFramesTest, TheTimelineFollowsGrantsQueuesAndFrees) {
  FinishedRun run = TwoSampleRun();
  run.record.events = {At(1.0, EventKind::kWait, 1, 0),  At(2.0, EventKind::kGrant, 0, 0),
                       At(3.0, EventKind::kFree, 0, 0),  At(3.5, EventKind::kGo, 1, 0),
                       At(4.0, EventKind::kGrant, 1, 1), At(5.0, EventKind::kLeaseExpired, 1, 1)};
  const auto timelines = IntersectionTimelines(run);
  ASSERT_EQ(timelines.size(), 2u);
  const IntersectionTimeline& right = timelines.at(0);
  EXPECT_EQ(right.At(FromSeconds(0.5)).holder, -1);
  EXPECT_TRUE(right.At(FromSeconds(0.5)).queue.empty());
  EXPECT_THAT(right.At(FromSeconds(1.5)).queue, ::testing::ElementsAre(1));
  EXPECT_EQ(right.At(FromSeconds(2.0)).holder, 0);  // from the instant of the grant on
  EXPECT_THAT(right.At(FromSeconds(2.5)).queue, ::testing::ElementsAre(1));
  EXPECT_EQ(right.At(FromSeconds(3.0)).holder, -1);
  EXPECT_TRUE(right.At(FromSeconds(3.5)).queue.empty());
  const IntersectionTimeline& left = timelines.at(1);
  EXPECT_EQ(left.At(FromSeconds(4.5)).holder, 1);
  EXPECT_EQ(left.At(FromSeconds(5.0)).holder, -1);
}

TEST(VideoFramesTest, EachFrameShowsTheCarAtItsLastSample) {
  const FinishedRun run = TwoSampleRun();
  VideoOptions options;
  options.trail_s = 0.0;  // no trail over the old place
  VideoFrames frames(run, options);
  EXPECT_EQ(frames.size().width % 2, 0);
  EXPECT_EQ(frames.size().height % 2, 0);
  const TrackFigureLayout at = DrawTrackFigureBase(run.scenario, run.track, false).layout;
  const CarConfig& car = *run.scenario.FindCar(0);
  const double behind_m = car.vehicle.length_m / 4;  // behind the centre: clear of arrow and label
  const cv::Point first = at.ToPixel(0.0 - behind_m, -2.0),
                  second = at.ToPixel(1.0 - behind_m, -2.0);
  const cv::Scalar colour = CarColourBgr(run.scenario, 0);
  const auto is_car = [&](const cv::Mat& frame, cv::Point p) {
    const cv::Vec3b bgr = frame.at<cv::Vec3b>(p);
    return bgr[0] == colour[0] && bgr[1] == colour[1] && bgr[2] == colour[2];
  };
  const cv::Mat before = frames.Draw(FromSeconds(0.5)).clone();
  ASSERT_EQ(before.size(), frames.size());
  EXPECT_TRUE(is_car(before, first));
  EXPECT_FALSE(is_car(before, second));
  const cv::Mat after = frames.Draw(FromSeconds(1.5));
  EXPECT_FALSE(is_car(after, first));
  EXPECT_TRUE(is_car(after, second));
}

TEST(VideoFramesTest, AHeldIntersectionIsTintedOnlyWhileHeld) {
  FinishedRun run = TwoSampleRun();
  run.record.events = {At(1.0, EventKind::kGrant, 1, 1), At(1.5, EventKind::kFree, 1, 1)};
  VideoFrames frames(run, {});
  const TrackFigureLayout at = DrawTrackFigureBase(run.scenario, run.track, false).layout;
  const cv::Point centre = at.ToPixel(-1.75, -0.3);  // inside intersection 1, off its labels
  const cv::Vec3b free_before = frames.Draw(FromSeconds(0.5)).at<cv::Vec3b>(centre);
  const cv::Vec3b held = frames.Draw(FromSeconds(1.2)).at<cv::Vec3b>(centre);
  const cv::Vec3b free_after = frames.Draw(FromSeconds(1.8)).at<cv::Vec3b>(centre);
  EXPECT_NE(held, free_before);
  EXPECT_EQ(free_after, free_before);
}

// Issue 34: the video showed no faults. A fault is named under the clock while it strikes.
TEST(VideoFramesTest, AFaultIsNamedWhileItStrikes) {
  FinishedRun run = TwoSampleRun();
  Event begin = At(0.5, EventKind::kFaultBegin, 1, -1);
  begin.fault = FaultKind::kV2iPartition;
  Event end = At(1.5, EventKind::kFaultEnd, 1, -1);
  end.fault = FaultKind::kV2iPartition;
  Event stall = At(1.2, EventKind::kFaultBegin, -1, -1);
  stall.fault = FaultKind::kBrokerOutage;
  run.record.events = {begin, stall, end};
  const FaultTimeline faults = FaultsOfRun(run);
  EXPECT_TRUE(faults.ActiveAt(FromSeconds(0.4)).empty());
  EXPECT_THAT(faults.ActiveAt(FromSeconds(1.0)),
              ::testing::ElementsAre("v2i_partition, car 1 (since 0.5 s)"));
  EXPECT_THAT(faults.ActiveAt(FromSeconds(1.6)),
              ::testing::ElementsAre("broker_outage (since 1.2 s)"));  // to the run's end

  VideoFrames with(run, {});
  run.record.events.clear();
  VideoFrames without(run, {});
  const cv::Mat drawn = with.Draw(FromSeconds(1.0)).clone();
  EXPECT_GT(cv::norm(drawn, without.Draw(FromSeconds(1.0)), cv::NORM_L1), 0.0);
}

// Issue 34: the camera caption ran off the frame's right edge. Wrapped, every line fits and
// nothing is lost.
TEST(VideoFramesTest, ACaptionIsWrappedToFitItsWidth) {
  const std::string caption =
      "lane detection: yellow line (yellow 123456 px, white 654321 px), invalid (no trajectory)";
  const std::vector<std::string> lines = WrapToWidth(caption, 300, 0.42, 1);
  EXPECT_GE(lines.size(), 2u);
  std::string joined;
  for (const std::string& line : lines) {
    int baseline = 0;
    EXPECT_LE(cv::getTextSize(line, cv::FONT_HERSHEY_SIMPLEX, 0.42, 1, &baseline).width, 300)
        << line;
    joined += (joined.empty() ? "" : " ") + line;
  }
  EXPECT_EQ(joined, caption);
  EXPECT_EQ(WrapToWidth("short", 300, 0.42, 1), std::vector<std::string>{"short"});
}

}  // namespace
}  // namespace autonomsim::sim::detail
