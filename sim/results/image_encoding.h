// PNG and JPEG bytes from OpenCV images, written with libpng and libjpeg directly instead of
// OpenCV's imgcodecs. The bytes are those cv::imencode gives (OpenCV 4.6, the same libpng, zlib
// and libjpeg; tests/image_encoding_test.cc compares them): the same settings, set here.
//
// Why not imgcodecs: Debian's libopencv_imgcodecs brings GDAL, GDCM, OpenEXR, HEIF and the like,
// some 130 shared libraries, whose loading and relocation (and GDCM's dictionary, built as the
// process starts) cost every process ~45 ms before main, a fifth of a short run's time
// (issue 38), for the two formats we write. Tests and tools that read images still link it.
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

namespace autonomsim::sim {

// `image` as PNG: 8-bit grey, BGR or BGRA, or 16-bit grey, BGR or BGRA (continuous or not), with
// OpenCV's default settings (the Sub filter, zlib level 1, run-length strategy). Throws
// std::runtime_error for another type or when libpng fails.
std::vector<std::uint8_t> EncodePng(const cv::Mat& image);

// `image` (8-bit grey or BGR) as baseline JPEG at `quality` (1-100), as cv::imencode with
// IMWRITE_JPEG_QUALITY `quality` and nothing else. Throws std::runtime_error for another type or
// when libjpeg fails.
std::vector<std::uint8_t> EncodeJpeg(const cv::Mat& image, int quality);

}  // namespace autonomsim::sim
