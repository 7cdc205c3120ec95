// The one PNG writer: what it writes reads back as the same pixels; a file it cannot write is an
// error that names it.
#include "sim/results/png.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <stdexcept>
#include <string>

namespace autonomsim::sim {
namespace {

namespace fs = std::filesystem;

TEST(Png, WhatIsWrittenReadsBackTheSame) {
  const fs::path dir =
      fs::temp_directory_path() / ("autonomsim_png_test_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  cv::Mat depth_mm(3, 4, CV_16UC1);
  cv::Mat bgr(3, 4, CV_8UC3);
  for (int v = 0; v < 3; ++v) {
    for (int u = 0; u < 4; ++u) {
      depth_mm.at<std::uint16_t>(v, u) = static_cast<std::uint16_t>(1000 * v + u);
      bgr.at<cv::Vec3b>(v, u) =
          cv::Vec3b(static_cast<std::uint8_t>(u), 2, static_cast<std::uint8_t>(v));
    }
  }
  WritePng(dir / "depth.png", depth_mm);
  WritePng(dir / "color.png", bgr);
  const cv::Mat depth_back = cv::imread((dir / "depth.png").string(), cv::IMREAD_UNCHANGED);
  const cv::Mat bgr_back = cv::imread((dir / "color.png").string(), cv::IMREAD_COLOR);
  fs::remove_all(dir);
  ASSERT_EQ(depth_back.type(), CV_16UC1);
  EXPECT_EQ(cv::countNonZero(depth_back != depth_mm), 0);
  ASSERT_EQ(bgr_back.type(), CV_8UC3);
  EXPECT_EQ(cv::norm(bgr_back, bgr, cv::NORM_INF), 0.0);
}

TEST(Png, AFileThatCannotBeWrittenIsAnErrorNamingIt) {
  const fs::path file = "/nonexistent-autonomsim-folder/track.png";
  try {
    WritePng(file, cv::Mat(2, 2, CV_8UC3, cv::Scalar(0, 0, 0)));
    FAIL() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(file.string()), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace autonomsim::sim
