// `autonomsim video RUN_DIR --out FILE.mp4`: the top-down replay of a finished run as a video
// (sim/results/video.h). Built into the `autonomsim-video` helper, which `autonomsim video`
// runs (tools/autonomsim_video.cc says why).
#include <fmt/format.h>
#include <unistd.h>

#include <cstdio>

#include "sim/core/config.h"
#include "sim/core/files.h"
#include "sim/results/video.h"
#include "tools/cli_common.h"

namespace autonomsim::cli {
namespace {

namespace fs = std::filesystem;

struct VideoArgs {
  std::string run_dir;
  std::string out;
  std::optional<int> cameras;
  std::optional<int> chase;
  bool overview{false};
  double fps{20.0};
  double speed{1.0};
  double from_s{0.0};
  std::optional<double> to_s;
  double trail_s{10.0};
  bool quiet{false};
  bool force{false};
};

int VideoCommand(const VideoArgs& a) {
  std::optional<sim::FinishedRun> run;
  fs::path out;
  try {
    run.emplace(sim::ReadFinishedRun(a.run_dir));
    out = sim::CheckOutputFile(
        a.out.empty() ? (fs::path(a.run_dir) / "replay.mp4").string() : a.out, a.force);
  } catch (const sim::ConfigError& e) {
    fmt::print(stderr, "error: {}\n", e.what());
    return kExitUnusableInput;
  }
  sim::VideoOptions options{.fps = a.fps,
                            .speed = a.speed,
                            .from_s = a.from_s,
                            .to_s = a.to_s,
                            .trail_s = a.trail_s,
                            .camera_car = a.cameras,
                            .chase_car = a.chase,
                            .overview = a.overview};
  const bool tty = ::isatty(STDERR_FILENO) != 0;
  std::size_t last_decile = 0;
  if (!a.quiet) {
    options.progress = [&](std::size_t done, std::size_t total) {
      if (tty) {
        fmt::print(stderr, "\r  frame {} / {}", done, total);
        if (done == total) fmt::print(stderr, "\n");
      } else if (done * 10 / total > last_decile) {
        last_decile = done * 10 / total;
        fmt::print(stderr, "  frame {} / {}\n", done, total);
      }
    };
  }
  const auto start = std::chrono::steady_clock::now();
  try {
    sim::WriteVideo(*run, options, out);
  } catch (const std::invalid_argument& e) {
    fmt::print(stderr, "error: {}\n", e.what());
    return kExitUnusableInput;
  } catch (const vehicle::GlUnavailable& e) {
    fmt::print(stderr, "error: --chase/--overview: {}\n", e.what());
    return kExitUnusableInput;
  }
  fmt::print("video: {} ({} frames at {:g} fps, {:g}x real time; {:.1f} MB, made in {:.1f} s)\n",
             out.string(), sim::VideoFrameCount(*run, options), a.fps, a.speed,
             static_cast<double>(fs::file_size(out)) / 1e6, WallSecondsSince(start));
  return kExitOk;
}

}  // namespace

Command AddVideoCommand(CLI::App& parent) {
  auto a = std::make_shared<VideoArgs>();
  CLI::App* video = parent.add_subcommand("video", kVideoDescription);
  video->add_option("RUN_DIR", a->run_dir, "A run's result folder")->required();
  video
      ->add_option("--out", a->out,
                   "The video file (.mp4; default RUN_DIR/replay.mp4); an existing file is "
                   "replaced only inside a folder this program wrote (else refused: see --force)")
      ->type_name("FILE.mp4");
  video->add_option("--cameras", a->cameras, "Show this car's camera views (a car with a board)")
      ->type_name("ID");
  video
      ->add_option("--chase", a->chase,
                   "Show the run in 3D from a chase camera behind this car (OpenGL ES, offscreen)")
      ->type_name("ID");
  video->add_flag("--overview", a->overview,
                  "Show the run in 3D from above one side of the track (OpenGL ES, offscreen)");
  video->add_option("--fps", a->fps, "Frames per second of the video (default 20)")
      ->check(CLI::PositiveNumber);
  video->add_option("--speed", a->speed, "Simulated seconds per second of video (default 1)")
      ->check(CLI::PositiveNumber);
  video->add_option("--from", a->from_s, "Start, seconds of the run (default 0)")->type_name("T");
  video->add_option("--to", a->to_s, "End, seconds of the run (default: its end)")->type_name("T");
  video->add_option("--trail", a->trail_s, "Seconds of path drawn behind each car (default 10)")
      ->type_name("S");
  video->add_flag("--force", a->force, "Replace --out even if this program did not write it");
  video->add_flag("--quiet,-q", a->quiet, "No progress output");
  return {video, [a] { return VideoCommand(*a); }};
}

}  // namespace autonomsim::cli
