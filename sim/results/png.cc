#include "sim/results/png.h"

#include <cstdint>
#include <opencv2/imgcodecs.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "sim/core/files.h"

namespace autonomsim::sim {

void WritePng(const std::filesystem::path& file, const cv::Mat& image) {
  std::vector<std::uint8_t> png;
  bool encoded = false;
  try {
    encoded = cv::imencode(".png", image, png);
  } catch (const cv::Exception& e) {
    throw OutputError("cannot write " + file.string() + ": " + e.what());
  }
  if (!encoded) throw OutputError("cannot write " + file.string() + ": PNG encoding failed");
  WriteFile(file, std::string(png.begin(), png.end()));
}

}  // namespace autonomsim::sim
