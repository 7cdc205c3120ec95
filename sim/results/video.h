// `autonomsim video RUN_DIR --out FILE.mp4`: the top-down replay of a finished run as a video
// (the track figure's floor, zone boxes, axes and legend; the cars as boxes with their heading,
// trails, each intersection tinted by its holder, collisions, the clock), and on request one car's
// colour camera with the detected lane drawn in and its depth camera beside it, and the run in 3D:
// a chase camera behind a car and an overview of the track (scene_views.h, rendered with OpenGL
// ES offscreen). Written with OpenCV's VideoWriter.
#pragma once

#include <filesystem>
#include <functional>
#include <optional>
#include <string>

#include "sim/results/finished_run.h"

namespace autonomsim::sim {

struct VideoOptions {
  double fps{20.0};               // frames per second of the video
  double speed{1.0};              // simulated seconds per second of video
  double from_s{0.0};             // the run's part to show
  std::optional<double> to_s;     // default: the run's end
  double trail_s{10.0};           // how much of each car's path is drawn behind it
  std::optional<int> camera_car;  // add this car's camera views (a car with a board)
  std::optional<int> chase_car;   // add a 3D chase view behind this car
  bool overview{false};           // add a 3D overview of the track
  // Called after each frame with (frames written, frames in all).
  std::function<void(std::size_t, std::size_t)> progress;
};

// The instants shown, from_s + k · speed / fps for k = 0, 1, ... up to to_s: the frame count.
std::size_t VideoFrameCount(const FinishedRun& run, const VideoOptions& options);

// Writes the video (MPEG-4: H.264 where OpenCV's FFmpeg has an encoder for it, else MPEG-4 Part
// 2) through a temporary file renamed when complete. std::invalid_argument for options that do
// not fit the run (fps or speed not positive, a range outside it, a camera car that is not
// there or has no board, a chase car that is not there); std::runtime_error when no encoder
// opens; vehicle::GlUnavailable when a 3D view is asked for and no OpenGL ES context can be made.
void WriteVideo(const FinishedRun& run, const VideoOptions& options,
                const std::filesystem::path& out);

}  // namespace autonomsim::sim
