#include "stack/point_cloud.h"

#include <cmath>

#include "world/validation.h"

namespace autonomsim::stack {
namespace detail {

CloudConstants MakeCloudConstants(const PointCloudParams& params, const std::array<double, 12>& P) {
  params.Validate();
  const auto finite = [&P] {
    for (double e : P) {
      if (!std::isfinite(e)) return false;
    }
    return true;
  };
  Require(finite(), "point cloud: P has a non-finite entry");
  Require(P[0] > 0.0 && P[5] > 0.0, [&] {
    return "point cloud: P needs fx, fy > 0, got fx = " + Num(P[0]) + ", fy = " + Num(P[5]);
  });
  Require(P[1] == 0.0 && P[4] == 0.0 && P[8] == 0.0 && P[9] == 0.0 && P[10] == 1.0 && P[11] == 0.0,
          "point cloud: P must be [fx 0 cx Tx; 0 fy cy Ty; 0 0 1 0]");
  // The real code reads fx, cx, fy, cy only; a stereo camera's Tx/Ty would be silently ignored.
  Require(P[3] == 0.0 && P[7] == 0.0, [&] {
    return "point cloud: P has Tx = " + Num(P[3]) + ", Ty = " + Num(P[7]) +
           "; only a monocular camera (0, 0) is modeled";
  });
  return CloudConstants{.fx = static_cast<float>(P[0]),
                        .fy = static_cast<float>(P[5]),
                        .cx = static_cast<float>(P[2]),
                        .cy = static_cast<float>(P[6]),
                        .m_per_mm = params.m_per_mm()};
}

void CheckDepthImage(const DepthImageView& depth) {
  Require(depth.width_px == PointCloud640::kWidth && depth.height_px == PointCloud640::kHeight,
          [&] {
            return "point cloud: the depth image must be 640x480, got " + Num(depth.width_px) +
                   "x" + Num(depth.height_px);
          });
  Require(depth.mm.size() == static_cast<std::size_t>(PointCloud640::kPoints), [&] {
    return "point cloud: the depth buffer holds " + Num(depth.mm.size()) + " pixels, not 640x480";
  });
}

namespace {
// Pixels [col0, col0 + kCount) of a row: written so that the compiler vectorizes it (a fixed trip
// count, no aliasing); each lane does exactly the real code's float operations, in its order, so
// the result is the same bits whichever of the row's pixels a call covers.
template <int kCount>
[[gnu::always_inline]] inline void CameraPoints(const CloudConstants& k, int row, int col0,
                                                const std::uint16_t* __restrict mm,
                                                float* __restrict x_m, float* __restrict y_m,
                                                float* __restrict z_m) {
  const float row_f = static_cast<float>(row);
  for (int i = 0; i < kCount; ++i) {
    const float d = static_cast<float>(mm[i]);
    const float u = static_cast<float>(col0 + i) * d;
    const float v = row_f * d;
    const float x = (u - k.cx * d) / k.fx;
    const float y = (v - k.cy * d) / k.fy;
    x_m[i] = d * k.m_per_mm;
    y_m[i] = -x * k.m_per_mm;
    z_m[i] = -y * k.m_per_mm;
  }
}
}  // namespace

AUTONOMSIM_ROW_KERNEL void CameraPointsOfRow(const CloudConstants& k, int row,
                                             const std::uint16_t* __restrict mm,
                                             float* __restrict x_m, float* __restrict y_m,
                                             float* __restrict z_m) {
  CameraPoints<PointCloud640::kWidth>(k, row, 0, mm, x_m, y_m, z_m);
}

AUTONOMSIM_ROW_KERNEL void CameraPointsOfSegment(const CloudConstants& k, int row, int col0,
                                                 const std::uint16_t* __restrict mm,
                                                 float* __restrict x_m, float* __restrict y_m,
                                                 float* __restrict z_m) {
  CameraPoints<kSegmentWidth>(k, row, col0, mm, x_m, y_m, z_m);
}

}  // namespace detail

void StepPointCloud(const PointCloudParams& params, const DepthImageView& depth,
                    const std::array<double, 12>& P, PointCloud640* cloud) {
  const detail::CloudConstants k = detail::MakeCloudConstants(params, P);
  detail::CheckDepthImage(depth);
  cloud->points.resize(PointCloud640::kPoints);
  constexpr int kWidth = PointCloud640::kWidth;
  alignas(64) float x[kWidth], y[kWidth], z[kWidth];
  for (int row = 0; row < PointCloud640::kHeight; ++row) {
    detail::CameraPointsOfRow(k, row, depth.mm.data() + row * kWidth, x, y, z);
    CloudPoint* out = cloud->points.data() + row * kWidth;
    for (int col = 0; col < kWidth; ++col) out[col] = CloudPoint{x[col], y[col], z[col], 0};
  }
}

}  // namespace autonomsim::stack
