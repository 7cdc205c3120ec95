#include "sim/results/image_encoding.h"

// clang-format off
#include <cstdio>  // before jpeglib.h, which needs FILE and size_t
// clang-format on
#include <jpeglib.h>
#include <png.h>
#include <zlib.h>

#include <bit>
#include <csetjmp>
#include <cstdlib>
#include <new>
#include <stdexcept>

namespace autonomsim::sim {
namespace {

// libpng is told the samples are little-endian (png_set_swap), as OpenCV does on such machines.
static_assert(std::endian::native == std::endian::little);

// Where libpng's output goes. A failed allocation is remembered and reported once libpng has
// returned, rather than thrown through libpng's C frames.
struct PngSink {
  std::vector<std::uint8_t>* bytes;
  bool out_of_memory = false;
};

void AppendPng(png_structp png, png_bytep data, png_size_t size) {
  auto* sink = static_cast<PngSink*>(png_get_io_ptr(png));
  if (sink->out_of_memory) return;
  try {
    sink->bytes->insert(sink->bytes->end(), data, data + size);
  } catch (const std::bad_alloc&) {
    sink->out_of_memory = true;
  }
}

void FlushNothing(png_structp) {}

// OpenCV's PngEncoder::write with no parameters, step by step. libpng reports an error by a
// longjmp to the setjmp here: this frame holds nothing with a destructor.
bool WritePngImage(png_structp png, png_infop info, const cv::Mat& image) {
  if (setjmp(png_jmpbuf(png)) != 0) return false;
  png_set_filter(png, PNG_FILTER_TYPE_BASE, PNG_FILTER_SUB);
  png_set_compression_level(png, Z_BEST_SPEED);
  png_set_compression_strategy(png, Z_RLE);
  const int channels = image.channels();
  const int colour_type = channels == 1   ? PNG_COLOR_TYPE_GRAY
                          : channels == 3 ? PNG_COLOR_TYPE_RGB
                                          : PNG_COLOR_TYPE_RGBA;
  png_set_IHDR(png, info, static_cast<png_uint_32>(image.cols),
               static_cast<png_uint_32>(image.rows), image.depth() == CV_8U ? 8 : 16, colour_type,
               PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  png_set_bgr(png);
  png_set_swap(png);
  for (int v = 0; v < image.rows; ++v) png_write_row(png, image.ptr<png_byte>(v));
  png_write_end(png, info);
  return true;
}

struct JpegErrorJump {
  jpeg_error_mgr manager;  // first: libjpeg hands its address back as cinfo->err
  std::jmp_buf jump;
};

// Instead of libjpeg's default, which ends the process.
[[noreturn]] void JumpOnJpegError(j_common_ptr cinfo) {
  std::longjmp(reinterpret_cast<JpegErrorJump*>(cinfo->err)->jump, 1);
}

// OpenCV's JpegEncoder::write with IMWRITE_JPEG_QUALITY only, into a buffer libjpeg allocates
// (*out, *size: ours to free). As WritePngImage, this frame holds nothing with a destructor for
// libjpeg's error longjmp to skip.
bool WriteJpegImage(jpeg_compress_struct* cinfo, JpegErrorJump* error, const cv::Mat& image,
                    int quality, unsigned char** out,
                    unsigned long* size) {  // NOLINT(runtime/int): libjpeg's type
  if (setjmp(error->jump) != 0) return false;
  jpeg_create_compress(cinfo);
  jpeg_mem_dest(cinfo, out, size);
  cinfo->image_width = static_cast<JDIMENSION>(image.cols);
  cinfo->image_height = static_cast<JDIMENSION>(image.rows);
  cinfo->input_components = image.channels();
  cinfo->in_color_space = image.channels() == 3 ? JCS_EXT_BGR : JCS_GRAYSCALE;
  jpeg_set_defaults(cinfo);
  jpeg_set_quality(cinfo, quality, TRUE);  // TRUE: baseline quantisation tables, as OpenCV
  jpeg_start_compress(cinfo, TRUE);
  for (int v = 0; v < image.rows; ++v) {
    JSAMPROW row = const_cast<JSAMPROW>(image.ptr<JSAMPLE>(v));  // libjpeg only reads it
    jpeg_write_scanlines(cinfo, &row, 1);
  }
  jpeg_finish_compress(cinfo);
  return true;
}

}  // namespace

std::vector<std::uint8_t> EncodePng(const cv::Mat& image) {
  const int channels = image.channels();
  if ((image.depth() != CV_8U && image.depth() != CV_16U) ||
      (channels != 1 && channels != 3 && channels != 4) || image.empty()) {
    throw std::runtime_error("PNG: an image of type " + cv::typeToString(image.type()) +
                             " cannot be encoded");
  }
  std::vector<std::uint8_t> bytes;
  PngSink sink{&bytes};
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png != nullptr ? png_create_info_struct(png) : nullptr;
  bool written = false;
  if (info != nullptr) {
    png_set_write_fn(png, &sink, AppendPng, FlushNothing);
    written = WritePngImage(png, info, image);
  }
  png_destroy_write_struct(&png, &info);
  if (!written || sink.out_of_memory) throw std::runtime_error("PNG encoding failed");
  return bytes;
}

std::vector<std::uint8_t> EncodeJpeg(const cv::Mat& image, int quality) {
  if ((image.type() != CV_8UC1 && image.type() != CV_8UC3) || image.empty()) {
    throw std::runtime_error("JPEG: an image of type " + cv::typeToString(image.type()) +
                             " cannot be encoded");
  }
  jpeg_compress_struct cinfo{};
  JpegErrorJump error{};
  cinfo.err = jpeg_std_error(&error.manager);
  error.manager.error_exit = JumpOnJpegError;
  unsigned char* out = nullptr;
  unsigned long size = 0;  // NOLINT(runtime/int): libjpeg's type
  const bool written = WriteJpegImage(&cinfo, &error, image, quality, &out, &size);
  jpeg_destroy_compress(&cinfo);  // also after a failed jpeg_create_compress: it checks

  std::vector<std::uint8_t> bytes;
  if (written) bytes.assign(out, out + size);
  std::free(out);
  if (!written) throw std::runtime_error("JPEG encoding failed");
  return bytes;
}

}  // namespace autonomsim::sim
