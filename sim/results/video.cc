#include "sim/results/video.h"

#include <unistd.h>

#include <opencv2/videoio.hpp>
#include <stdexcept>
#include <string>

#include "sim/results/video_frames.h"

namespace autonomsim::sim {
namespace {

namespace fs = std::filesystem;

// The encoder, writing to a temporary name beside `out`: Finish renames it to `out`; a file not
// finished (an exception on the way) is removed.
class VideoFile {
 public:
  // std::runtime_error when no encoder opens.
  VideoFile(const fs::path& out, double fps, cv::Size size)
      : out_(out),
        partial_(out.parent_path() / (out.stem().string() + ".partial-" +
                                      std::to_string(::getpid()) + out.extension().string())) {
    for (const char* codec : {"avc1", "mp4v"}) {
      if (writer_.open(partial_.string(), cv::CAP_FFMPEG,
                       cv::VideoWriter::fourcc(codec[0], codec[1], codec[2], codec[3]), fps,
                       size)) {
        break;
      }
    }
    if (!writer_.isOpened()) {
      throw std::runtime_error(out.string() +
                               ": OpenCV's video writer (FFmpeg) opens no MPEG-4 encoder");
    }
  }
  VideoFile(const VideoFile&) = delete;
  VideoFile& operator=(const VideoFile&) = delete;
  ~VideoFile() {
    if (finished_) return;
    writer_.release();
    std::error_code ignored;
    fs::remove(partial_, ignored);
  }

  void Write(const cv::Mat& frame) { writer_.write(frame); }
  void Finish() {
    writer_.release();
    fs::rename(partial_, out_);
    finished_ = true;
  }

 private:
  fs::path out_, partial_;
  cv::VideoWriter writer_;
  bool finished_{false};
};

}  // namespace

void WriteVideo(const FinishedRun& run, const VideoOptions& options, const fs::path& out) {
  detail::CheckVideoOptions(run, options);
  detail::VideoFrames frames(run, options);
  VideoFile file(out, options.fps, frames.size());
  const std::size_t count = VideoFrameCount(run, options);
  for (std::size_t k = 0; k < count; ++k) {
    file.Write(frames.Draw(detail::VideoFrameTime(options, k)));
    if (options.progress) options.progress(k + 1, count);
  }
  file.Finish();
}

}  // namespace autonomsim::sim
