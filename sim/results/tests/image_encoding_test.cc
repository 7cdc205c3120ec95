// Our PNG and JPEG encoders give cv::imencode's bytes (the files a run writes are unchanged by
// leaving OpenCV's imgcodecs out of the simulator): every image type the simulator writes, of
// noise and of smooth content, whole and as a view into a larger image (rows not contiguous).
#include "sim/results/image_encoding.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <vector>

namespace autonomsim::sim {
namespace {

// Noise in the top half (what compresses worst), gradients and a filled circle below.
cv::Mat TestImage(int rows, int cols, int type) {
  cv::Mat image(rows, cols, type);
  cv::RNG rng(38);
  rng.fill(image, cv::RNG::UNIFORM, 0, CV_MAT_DEPTH(type) == CV_16U ? 65536 : 256);
  cv::Mat lower = image.rowRange(rows / 2, rows);
  for (int v = 0; v < lower.rows; ++v) {
    for (int u = 0; u < lower.cols * lower.channels(); ++u) {
      const int value = (v * 7 + u * 3) % 256;
      if (CV_MAT_DEPTH(type) == CV_16U) {
        lower.ptr<std::uint16_t>(v)[u] = static_cast<std::uint16_t>(value * 257);
      } else {
        lower.ptr<std::uint8_t>(v)[u] = static_cast<std::uint8_t>(value);
      }
    }
  }
  cv::circle(lower, {cols / 2, lower.rows / 2}, rows / 5, cv::Scalar::all(1000), cv::FILLED);
  return image;
}

std::vector<std::uint8_t> OpenCvBytes(const cv::Mat& image, const char* extension,
                                      const std::vector<int>& params = {}) {
  std::vector<std::uint8_t> bytes;
  EXPECT_TRUE(cv::imencode(extension, image, bytes, params));
  return bytes;
}

TEST(ImageEncoding, PngBytesAreOpenCvs) {
  for (const int type : {CV_8UC1, CV_8UC3, CV_8UC4, CV_16UC1, CV_16UC3, CV_16UC4}) {
    SCOPED_TRACE(cv::typeToString(type));
    const cv::Mat image = TestImage(240, 320, type);
    EXPECT_EQ(EncodePng(image), OpenCvBytes(image, ".png"));
    const cv::Mat view = image(cv::Rect(3, 5, 101, 77));
    ASSERT_FALSE(view.isContinuous());
    EXPECT_EQ(EncodePng(view), OpenCvBytes(view, ".png"));
    const cv::Mat pixel = image(cv::Rect(0, 0, 1, 1));
    EXPECT_EQ(EncodePng(pixel), OpenCvBytes(pixel, ".png"));
  }
}

TEST(ImageEncoding, JpegBytesAreOpenCvs) {
  for (const int type : {CV_8UC1, CV_8UC3}) {
    for (const int quality : {88, 95}) {
      SCOPED_TRACE(cv::typeToString(type) + " quality " + std::to_string(quality));
      const std::vector<int> params{cv::IMWRITE_JPEG_QUALITY, quality};
      const cv::Mat image = TestImage(240, 320, type);
      EXPECT_EQ(EncodeJpeg(image, quality), OpenCvBytes(image, ".jpg", params));
      const cv::Mat view = image(cv::Rect(3, 5, 101, 77));
      EXPECT_EQ(EncodeJpeg(view, quality), OpenCvBytes(view, ".jpg", params));
    }
  }
}

TEST(ImageEncoding, OtherTypesAreErrors) {
  EXPECT_THROW(EncodePng(cv::Mat(2, 2, CV_32FC1)), std::runtime_error);
  EXPECT_THROW(EncodePng(cv::Mat(2, 2, CV_8UC2)), std::runtime_error);
  EXPECT_THROW(EncodePng(cv::Mat()), std::runtime_error);
  EXPECT_THROW(EncodeJpeg(cv::Mat(2, 2, CV_16UC1), 88), std::runtime_error);
  EXPECT_THROW(EncodeJpeg(cv::Mat(2, 2, CV_8UC4), 88), std::runtime_error);
}

}  // namespace
}  // namespace autonomsim::sim
