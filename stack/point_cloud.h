// Point cloud generation (reference §3; paper §IV-B, code/reconros_ws/pointcloud): a mono16 depth
// image and the camera's projection matrix P in, one point per pixel out (PointCloud640), in the
// camera's forward/left/up frame.
//
// The arithmetic is the real node's, in float, step by step: for pixel (col, row) of depth d (mm)
//   u = col·d, v = row·d,  x = (u − cx·d)/fx,  y = (v − cy·d)/fy          (the paper's equations)
//   point = (d·s, −x·s, −y·s)                       (forward, left, up; s = metres per millimetre)
// Tx and Ty of P are not used, as in the real code; a monocular camera's are 0 and anything else
// is rejected. The cloud is dense and ordered: point i is pixel i in row-major order, and a pixel
// without a return (depth 0) becomes the point (0, −0, −0), the camera's origin, as in the real
// code; downstream filters (the obstacle box) drop it by position.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

// The row kernels below (and the grid's) are built twice on x86-64, for AVX2 and for the
// baseline, and the loader picks one for the host (function multiversioning). Both compute the
// same bits: plain IEEE float operations, contraction off (no FMA), and the vector width changes
// nothing of what one lane computes. The AVX2 build is ~1.25x faster (bench_perception).
#if defined(__x86_64__) && defined(__has_attribute)
#if __has_attribute(target_clones)
#define AUTONOMSIM_ROW_KERNEL __attribute__((target_clones("avx2", "default")))
#endif
#endif
#ifndef AUTONOMSIM_ROW_KERNEL
#define AUTONOMSIM_ROW_KERNEL
#endif

namespace autonomsim::stack {

// A mono16 depth image as the stack receives it (reference §2: 640×480, millimetres, 0 = no
// return). A view: the stack never copies a frame it only reads.
struct DepthImageView {
  int width_px{0};
  int height_px{0};
  std::span<const std::uint16_t> mm;  // row-major
};

// One point of PointCloud640: 16 bytes (reference §3). The fourth word is the real code's
// `_padding`: its packing writes 0 there (x|y in one 64-bit word, z zero-extended in the next);
// their PointCloud2 converter labels the word "rgb", but nothing fills it.
struct CloudPoint {
  float x_m{0.0f};  // forward
  float y_m{0.0f};  // left
  float z_m{0.0f};  // up
  std::uint32_t padding{0};
};
static_assert(sizeof(CloudPoint) == 16);

// The fixed-size Iceoryx message (reference §3: uint8[4915200] data).
struct PointCloud640 {
  static constexpr int kWidth = 640;
  static constexpr int kHeight = 480;
  static constexpr int kPoints = kWidth * kHeight;
  static constexpr std::size_t kPointBytes = sizeof(CloudPoint);
  // What the message weighs on the modeled transport, whether or not a path materializes it.
  static constexpr std::size_t kModeledBytes = kPoints * kPointBytes;
  static_assert(kModeledBytes == 4'915'200);  // reference §3, §8

  std::vector<CloudPoint> points;  // kPoints once filled; row-major
};

struct PointCloudParams {
  // reference §3: the software node scales millimetres by 0.001f; the hardware implementation by
  // 1.0/1024 (a quirk of the real HLS code: its points come out 2.3 % short). Set by the node's
  // mapping (SW or HW slot).
  bool hardware_scale{false};

  template <class V>
  void Describe(V& v) {
    v("hardware_scale", hardware_scale);
  }
  void Validate() const {}  // every value is valid
  friend bool operator==(const PointCloudParams&, const PointCloudParams&) = default;

  // The scale as the real code's float: 0.001f or 1.0f/1024.
  float m_per_mm() const { return hardware_scale ? 1.0f / 1024.0f : 0.001f; }
};

// Fills *cloud (resized to kPoints; reuses its memory). Throws std::invalid_argument if the depth
// image is not 640×480 or P is not a monocular projection [fx 0 cx 0; 0 fy cy 0; 0 0 1 0] with
// fx, fy > 0.
void StepPointCloud(const PointCloudParams& params, const DepthImageView& depth,
                    const std::array<double, 12>& P, PointCloud640* cloud);

namespace detail {

// P's entries as the real code holds them (floats), validated.
struct CloudConstants {
  float fx, fy, cx, cy;
  float m_per_mm;
};
CloudConstants MakeCloudConstants(const PointCloudParams& params, const std::array<double, 12>& P);
void CheckDepthImage(const DepthImageView& depth);  // 640×480 with a matching buffer

// The camera-frame points of one image row (PointCloud640::kWidth pixels), as separate x, y, z
// arrays. The cloud's arithmetic lives in one place, which this and CameraPointsOfSegment share:
// the cloud and the fused depth→grid path (obstacle_grid.h) call them, so they compute the same
// bits.
void CameraPointsOfRow(const CloudConstants& k, int row, const std::uint16_t* mm, float* x_m,
                       float* y_m, float* z_m);

// The same for kSegmentWidth pixels of a row, columns [col0, col0 + kSegmentWidth), `mm` pointing
// at the first: each pixel's point is the one CameraPointsOfRow gives it. The grid's memo counts a
// row in such segments (obstacle_grid.h: DepthGridMemo); col0 is a multiple of kSegmentWidth.
// Measured on the 10-car fleet: 64 spends as little in the memo as 32 does, 128 a little more.
inline constexpr int kSegmentWidth = 64;
static_assert(PointCloud640::kWidth % kSegmentWidth == 0 && kSegmentWidth % 8 == 0);
void CameraPointsOfSegment(const CloudConstants& k, int row, int col0, const std::uint16_t* mm,
                           float* x_m, float* y_m, float* z_m);

}  // namespace detail
}  // namespace autonomsim::stack
