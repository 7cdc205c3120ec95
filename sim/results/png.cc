#include "sim/results/png.h"

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "sim/core/files.h"
#include "sim/results/image_encoding.h"

namespace autonomsim::sim {

void WritePng(const std::filesystem::path& file, const cv::Mat& image) {
  std::vector<std::uint8_t> png;
  try {
    png = EncodePng(image);
  } catch (const std::runtime_error& e) {
    throw OutputError("cannot write " + file.string() + ": " + e.what());
  }
  WriteFile(file, std::string(png.begin(), png.end()));
}

}  // namespace autonomsim::sim
