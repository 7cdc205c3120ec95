// The video's steps that need no encoder (video.h's WriteVideo strings them together): the options
// checked against the run, the instant of each frame, who holds each intersection when, and the
// frames themselves, drawn one after another. In autonomsim_results, so that they are tested
// without OpenCV's videoio (FFmpeg).
#pragma once

#include <cstddef>
#include <map>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "sim/core/random.h"
#include "sim/results/camera_views.h"
#include "sim/results/expectations.h"
#include "sim/results/finished_run.h"
#include "sim/results/scene_views.h"
#include "sim/results/track_figure.h"
#include "sim/results/video.h"

namespace autonomsim::sim::detail {

// std::invalid_argument for options that do not fit the run, as WriteVideo documents.
void CheckVideoOptions(const FinishedRun& run, const VideoOptions& options);

// The instant frame k shows: from_s + k · speed / fps.
Time VideoFrameTime(const VideoOptions& options, std::size_t k);

// Who holds an intersection and who waits at it, from the server's and the cars' events.
struct IntersectionState {
  int holder{-1};
  std::vector<int> queue;
};
struct IntersectionTimeline {
  std::vector<Time> since;
  std::vector<IntersectionState> states;
  const IntersectionState& At(Time t) const;
};
std::map<int, IntersectionTimeline> IntersectionTimelines(const FinishedRun& run);

// The faults of a run (fault_begin and fault_end events) and, at an instant, a line for each one
// that strikes then: "v2i_partition, car 1 (since 7.6 s)".
struct FaultTimeline {
  std::vector<FaultSpan> spans;
  std::vector<std::string> ActiveAt(Time t) const;
};
FaultTimeline FaultsOfRun(const FinishedRun& run);

// `text` in lines that each fit `max_width_px` in the video's font at `scale` and `thickness`,
// broken at spaces (a single word wider than that stays whole).
std::vector<std::string> WrapToWidth(const std::string& text, int max_width_px, double scale,
                                     int thickness);

// Each car's samples in time order, and a cursor that moves forward with the frames.
struct CarTrack {
  int id{0};
  cv::Scalar colour;
  double length_m{0.0}, width_m{0.0};
  std::vector<const TrajectorySample*> samples;
  std::size_t now{0};  // the last sample at or before the frame's time
  void Advance(Time t);
};

// The frames of one video. What stays the same from frame to frame (the track figure, the cars'
// samples, the intersections' timelines, the renderers of the camera and 3D views) is made once;
// Draw draws the frame at t over it. Frames are drawn in time order (the cars' cursors and the
// collisions so far only move forward).
class VideoFrames {
 public:
  // Options as CheckVideoOptions accepts them. vehicle::GlUnavailable where a 3D view is asked for
  // and no OpenGL ES context can be made.
  VideoFrames(const FinishedRun& run, const VideoOptions& options);

  // Even sides (encoders want them): the figure, then the camera panel, then the 3D panel.
  cv::Size size() const { return background_.size(); }
  // The frame at t, valid until the next Draw.
  const cv::Mat& Draw(Time t);

 private:
  void DrawIntersections(Time t);
  void DrawTrailsAndCollisions(Time t);
  std::vector<world::Pose2> DrawCars();
  void DrawClock(Time t);
  void DrawFaults(Time t);
  void DrawCameraPanel(const std::vector<world::Pose2>& poses, Time t);
  void DrawScenePanel(const std::vector<world::Pose2>& poses, Time t);

  const FinishedRun& run_;      // must outlive this
  const VideoOptions options_;  // a copy: a caller may pass a temporary
  std::optional<CarCameraViewer> viewer_;
  std::optional<SceneViews> scene_;
  RngStreams streams_;
  TrackFigureLayout at_;
  int figure_cols_{0};
  int legend_x_{0}, legend_end_{0};
  cv::Mat background_;
  std::vector<CarTrack> cars_;
  std::map<int, IntersectionTimeline> timelines_;
  std::vector<std::pair<Time, int>> collisions_;  // (t, car)
  FaultTimeline faults_;
  std::size_t next_collision_{0};
  std::vector<cv::Point> collision_points_;
  cv::Mat frame_;
};

}  // namespace autonomsim::sim::detail
