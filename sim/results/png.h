// PNG files from OpenCV images: one encoder call and one error path for every picture the
// simulator writes (a run's track.png, the render command's camera images, a sweep's plots).
//
// It lives here, not beside WriteFile in sim/core, because sim/core does not depend on OpenCV and
// should not for one encoder call: sim/results is the lowest module that draws pictures and links
// OpenCV, and sim/study (the plots) sits above it.
#pragma once

#include <filesystem>
#include <opencv2/core.hpp>

namespace autonomsim::sim {

// Writes `image` (8-bit grey or BGR, or 16-bit grey) to `file` as PNG, with OpenCV's default
// compression; std::runtime_error naming the file when it cannot be encoded or written. Not
// atomic: write into a folder made by WriteFolderAtomically (sim/core/files.h) where a reader must
// never see half a picture.
void WritePng(const std::filesystem::path& file, const cv::Mat& image);

}  // namespace autonomsim::sim
