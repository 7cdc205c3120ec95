#include "vehicle/ray_caster.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <utility>

#if defined(__x86_64__)
#include <immintrin.h>  // the AVX2 gather (used only in functions compiled for AVX2)
#endif

#include "world/bits.h"
#include "world/validation.h"

namespace autonomsim::vehicle {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

// L lanes of float, int32, int16 or bytes (GCC/Clang vector extensions: SSE2 on x86-64, NEON on
// ARM, scalar code elsewhere; eight lanes are two SSE registers, or one in code compiled for
// AVX2). The arithmetic is IEEE lane by lane, so a lane computes bit for bit what scalar code
// would, whatever the width; a comparison gives -1 (true) or 0 per lane.
template <int L>
struct Lanes {
  // (typedefs: GCC drops the attribute from an alias whose size depends on L)
  typedef float F __attribute__((vector_size(4 * L)));
  typedef std::int32_t I __attribute__((vector_size(4 * L)));
  typedef std::uint16_t U16 __attribute__((vector_size(2 * L)));
  typedef std::int16_t S16 __attribute__((vector_size(2 * L)));
  typedef std::uint8_t U8 __attribute__((vector_size(L)));
  typedef std::int8_t S8 __attribute__((vector_size(L)));
};
constexpr int kLanes = 4;
using F4 = Lanes<kLanes>::F;
using I4 = Lanes<kLanes>::I;

// (always inline, so that they compile for the width and the instruction set of their caller: an
// eight-lane vector never crosses a call, see -Wno-psabi in CMakeLists.txt)
template <class V, class T>
[[gnu::always_inline]] inline V Splat(T x) {
  V v;
  for (std::size_t k = 0; k < sizeof v / sizeof v[0]; ++k) v[k] = x;  // -0 stays -0
  return v;
}
F4 Splat(float x) { return F4{x, x, x, x}; }
I4 SplatInt(std::int32_t x) { return I4{x, x, x, x}; }
// Lanes [0, n) from p (n in 1..L); the others repeat p[0] and must be masked by the caller.
template <class V>
[[gnu::always_inline]] inline V Load(const float* p, int n) {
  constexpr int kWidth = sizeof(V) / sizeof(float);
  V v = Splat<V>(p[0]);
  if (n == kWidth) {
    std::memcpy(&v, p, sizeof v);
  } else {
    for (int k = 1; k < n; ++k) v[k] = p[k];
  }
  return v;
}
// (a function of its own, not Load<F4>: the floor's look-up is faster with GCC's choice of
// where to inline this one, BM_RenderLaneLabels 32 -> 30 us)
F4 Load(const float* p, int n) {
  F4 v = Splat(p[0]);
  if (n == kLanes) {
    std::memcpy(&v, p, sizeof v);
  } else {
    for (int k = 1; k < n; ++k) v[k] = p[k];
  }
  return v;
}
template <class I>
[[gnu::always_inline]] inline I FirstLanes(int n) {
  I lane;
  for (std::size_t k = 0; k < sizeof lane / sizeof lane[0]; ++k) lane[k] = static_cast<int>(k);
  return lane < Splat<I>(n);
}
template <class V>
[[gnu::always_inline]] inline V Min(V a, V b) {
  return a < b ? a : b;
}
template <class V>
[[gnu::always_inline]] inline V Max(V a, V b) {
  return a > b ? a : b;
}
// Whether any lane of a comparison's result is true.
template <class I>
[[gnu::always_inline]] inline bool Any(I mask) {
  if constexpr (sizeof mask > sizeof(I4)) {  // the halves' lanes or-ed
    using Half = typename Lanes<sizeof mask / 8>::I;
    Half lo, hi;
    std::memcpy(&lo, &mask, sizeof lo);
    std::memcpy(&hi, reinterpret_cast<const char*>(&mask) + sizeof lo, sizeof hi);
    return Any(lo | hi);
  } else {
#if defined(__SSE2__)
    return __builtin_ia32_movmskps(reinterpret_cast<F4>(mask)) != 0;  // the lanes' sign bits
#else
    return (mask[0] | mask[1] | mask[2] | mask[3]) != 0;
#endif
  }
}
// Whether this CPU runs AVX2 code (CameraRenderer::set_wide_lanes).
bool CpuHasAvx2() {
#if defined(__x86_64__)
  return __builtin_cpu_supports("avx2");
#else
  return false;
#endif
}

// Face shading, so that a box's faces are told apart: ambient + diffuse · max(0, n · light), one
// fixed light from above (map frame; the lab's ceiling lights are not described).
constexpr double kAmbient = 0.6;
constexpr double kDiffuse = 0.4;
const Eigen::Vector3d kLightDirection = Eigen::Vector3d(0.3, 0.4, 0.866).normalized();

Bgr ToBgr(const std::array<int, 3>& rgb) {
  return {static_cast<std::uint8_t>(rgb[2]), static_cast<std::uint8_t>(rgb[1]),
          static_cast<std::uint8_t>(rgb[0])};
}

void RequireRgb(const std::array<int, 3>& rgb, const std::string& key) {
  for (int c : rgb) {
    Require(c >= 0 && c <= 255,
            [&] { return key + ": channels must be in [0, 255], got " + std::to_string(c); });
  }
}

// SplitMix64's output function (Steele, Lea & Flood 2014): a bijection with full avalanche, used
// as a counter-based generator (its input a seed plus the draw's index).
constexpr std::uint64_t Mix64(std::uint64_t z) {
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}
constexpr std::uint64_t kGolden = 0x9e3779b97f4a7c15ULL;
// Separate the depth and colour draws of one seed.
constexpr std::uint64_t kDepthDomain = 0x6465707468ULL;  // "depth"
constexpr std::uint64_t kColorDomain = 0x636f6c6f72ULL;  // "color"

// An approximately standard normal variate from 64 random bits: the sum of four 16-bit uniforms
// (Irwin–Hall), centred and scaled to unit variance; range ±3.46.
double ApproxNormal(std::uint64_t bits) {
  const double sum = static_cast<double>((bits & 0xffff) + ((bits >> 16) & 0xffff) +
                                         ((bits >> 32) & 0xffff) + (bits >> 48)) +
                     2.0;                             // + 4 × 0.5: the lanes' midpoints
  return (sum / 65536.0 - 2.0) * 1.7320508075688772;  // √3: Var(sum of 4 U(0,1)) = 1/3
}

// An approximately standard normal variate from the low 21 of `bits`: the sum of three 7-bit
// uniforms (Irwin–Hall), centred and scaled to unit variance; range ±3.
float ApproxNormal21(std::uint64_t bits) {
  const auto sum = static_cast<float>((bits & 0x7f) + ((bits >> 7) & 0x7f) + ((bits >> 14) & 0x7f));
  return ((sum + 1.5f) / 128.0f - 1.5f) * 2.0f;  // Var(sum of 3 U(0,1)) = 1/4
}

}  // namespace

void SceneAppearance::Validate() const {
  RequireRgb(surround_rgb, "surround_rgb");
  RequireRgb(obstacle_rgb, "obstacle_rgb");
  Require(!car_body_rgb.empty(), "car_body_rgb must list at least one colour");
  for (std::size_t i = 0; i < car_body_rgb.size(); ++i) {
    RequireRgb(car_body_rgb[i], "car_body_rgb[" + std::to_string(i) + "]");
  }
}

Bgr SceneAppearance::surround() const { return ToBgr(surround_rgb); }
Bgr SceneAppearance::obstacle() const { return ToBgr(obstacle_rgb); }
Bgr SceneAppearance::car_body(int car_id) const {
  const auto n = static_cast<int>(car_body_rgb.size());
  return ToBgr(car_body_rgb[static_cast<std::size_t>(((car_id % n) + n) % n)]);
}

void CameraNoiseParams::Validate() const {
  Require(depth_stddev_per_m >= 0.0 && depth_stddev_per_m <= 0.1,
          [&] { return "depth_stddev_per_m must be in [0, 0.1], got " + Num(depth_stddev_per_m); });
  Require(color_stddev >= 0.0 && color_stddev <= 64.0,
          [&] { return "color_stddev must be in [0, 64], got " + Num(color_stddev); });
}

namespace {

// The cells (kCommonCell texels square, cells_x × cells_y) that hold a texel other than `common`.
std::vector<std::uint8_t> CellsWithOtherColours(const std::vector<std::uint8_t>& index, int width,
                                                int height, std::uint8_t common, int cell,
                                                int cells_x, int cells_y) {
  std::vector<std::uint8_t> other(static_cast<std::size_t>(cells_x) * cells_y, 0);
  for (int row = 0; row < height; ++row) {
    for (int col = 0; col < width; ++col) {
      if (index[static_cast<std::size_t>(row) * width + col] != common) {
        other[static_cast<std::size_t>(row / cell) * cells_x + col / cell] = 1;
      }
    }
  }
  return other;
}

// `marked` grown by one cell (Chebyshev) in every direction.
std::vector<std::uint8_t> GrowByOneCell(const std::vector<std::uint8_t>& marked, int cells_x,
                                        int cells_y) {
  std::vector<std::uint8_t> grown(marked.size());
  for (int y = 0; y < cells_y; ++y) {
    for (int x = 0; x < cells_x; ++x) {
      std::uint8_t any = 0;
      for (int yy = std::max(0, y - 1); yy <= std::min(cells_y - 1, y + 1); ++yy) {
        for (int xx = std::max(0, x - 1); xx <= std::min(cells_x - 1, x + 1); ++xx) {
          any |= marked[static_cast<std::size_t>(yy) * cells_x + xx];
        }
      }
      grown[static_cast<std::size_t>(y) * cells_x + x] = any;
    }
  }
  return grown;
}

}  // namespace

FloorTexture::FloorTexture(const world::FloorRaster& raster)
    : width_(raster.width_px),
      height_(raster.height_px),
      m_per_px_(raster.m_per_px),
      origin_m_(raster.origin_m) {
  Require(width_ > 0 && height_ > 0 && std::isfinite(m_per_px_) && m_per_px_ > 0.0,
          "FloorTexture: the raster needs a positive size and m_per_px");
  const std::size_t n = static_cast<std::size_t>(width_) * static_cast<std::size_t>(height_);
  Require(raster.bgr.size() == 3 * n, "FloorTexture: raster.bgr must hold 3 bytes per pixel");
  IndexColours(raster);
  std::vector<std::size_t> uses(palette_.size(), 0);
  for (std::size_t i = 0; i < n; ++i) ++uses[index_[i]];
  common_index_ =
      static_cast<std::uint8_t>(std::max_element(uses.begin(), uses.end()) - uses.begin());
  IndexCommonCells();
  CountOthers();
}

std::shared_ptr<const std::vector<std::uint8_t>> FloorTexture::LabelTexels(
    const PaletteLabels& labels) const {
  const std::lock_guard<std::mutex> lock(label_texels_mutex_);
  std::shared_ptr<const std::vector<std::uint8_t>>& texels = label_texels_[labels];
  if (!texels) {
    auto made = std::make_shared<std::vector<std::uint8_t>>(index_.size() + kLabelTexelPadding, 0);
    std::transform(index_.begin(), index_.end(), made->begin(),
                   [&](std::uint8_t palette_index) { return labels[palette_index]; });
    texels = std::move(made);
  }
  return texels;
}

void FloorTexture::IndexColours(const world::FloorRaster& raster) {
  const std::size_t n = static_cast<std::size_t>(width_) * static_cast<std::size_t>(height_);
  index_.resize(n + 1);
  std::unordered_map<std::uint32_t, std::uint8_t> seen;
  const auto index_of = [&](const std::uint8_t* bgr) {
    std::uint32_t colour = 0;
    std::memcpy(&colour, bgr, 3);
    const auto [it, added] = seen.try_emplace(colour, static_cast<std::uint8_t>(palette_.size()));
    if (added) {
      Require(palette_.size() < 256, "FloorTexture: the floor raster has more than 256 colours");
      palette_.push_back(colour);
    }
    return it->second;
  };
  // runs of one colour are long: the hash map only where the colour changes
  std::uint32_t last_colour = 0;
  std::uint8_t last_index = 0;
  for (std::size_t i = 0; i < n; ++i) {
    std::uint32_t colour = 0;
    std::memcpy(&colour, &raster.bgr[3 * i], 3);
    if (i == 0 || colour != last_colour) {
      last_colour = colour;
      last_index = index_of(&raster.bgr[3 * i]);
    }
    index_[i] = last_index;
  }
  index_[n] = index_of(raster.floor_bgr.data());
}

void FloorTexture::IndexCommonCells() {
  const int cells_x = (width_ + kCommonCell - 1) / kCommonCell;
  const int cells_y = (height_ + kCommonCell - 1) / kCommonCell;
  cells_y_ = static_cast<std::size_t>(cells_y);
  words_per_row_ = static_cast<std::size_t>((cells_x + 63) / 64);
  // near: the cells with a texel of another colour within d cells, grown by one cell per level
  std::vector<std::uint8_t> near =
      CellsWithOtherColours(index_, width_, height_, common_index_, kCommonCell, cells_x, cells_y);
  common_near_.assign((kMaxReachCells + 1) * cells_y_ * words_per_row_, 0);
  for (int d = 0; d <= kMaxReachCells; ++d) {
    if (d > 0) near = GrowByOneCell(near, cells_x, cells_y);
    for (int y = 0; y < cells_y; ++y) {
      for (int x = 0; x < cells_x; ++x) {
        if (near[static_cast<std::size_t>(y) * cells_x + x] == 0) {
          common_near_[(static_cast<std::size_t>(d) * cells_y_ + y) * words_per_row_ + x / 64] |=
              std::uint64_t{1} << (x % 64);
        }
      }
    }
  }
}

void FloorTexture::CountOthers() {
  const std::size_t stride = static_cast<std::size_t>(width_) + 1;
  others_before_.assign(stride * (static_cast<std::size_t>(height_) + 1), 0);
  for (std::size_t r = 0; r < static_cast<std::size_t>(height_); ++r) {
    std::uint16_t in_row = 0;  // this row's other texels up to column c
    for (std::size_t c = 0; c < static_cast<std::size_t>(width_); ++c) {
      in_row = static_cast<std::uint16_t>(in_row + (index_[r * width_ + c] != common_index_));
      others_before_[(r + 1) * stride + c + 1] =
          static_cast<std::uint16_t>(others_before_[r * stride + c + 1] + in_row);
    }
  }
}

CameraRays::CameraRays(const CameraModel& camera)
    : camera_(camera), width_(camera.width()), height_(camera.height()) {
  origin_base_ = camera_.X_base_camera().translation();
  Require(origin_base_.z() > 0.0, [&] {
    return camera_.params().name + ": the camera must be above the floor (mount.z_m > 0), got " +
           Num(origin_base_.z());
  });
  ComputePixelRays();
  ComputeRuns();
  ComputeFloorBlocks();
  ComputeTiles();
}

void CameraRays::ComputePixelRays() {
  const CameraParams& params = camera_.params();
  const Eigen::Matrix3d R = camera_.X_base_camera().linear();
  const std::size_t n = static_cast<std::size_t>(width_) * static_cast<std::size_t>(height_);
  for (std::vector<float>* v :
       {&dir_x_, &dir_y_, &inv_dir_z_, &floor_x_, &floor_y_, &floor_t_, &ray_x_, &ray_y_}) {
    v->resize(n);
  }
  floor_depth_mm_.resize(n);
  std::vector<std::optional<Eigen::Vector2d>> rays;
  for (int v = 0; v < height_; ++v) {
    camera_.NormalizedRaysOfRow(v, &rays);
    for (int u = 0; u < width_; ++u) {
      const std::size_t i = static_cast<std::size_t>(v) * width_ + u;
      const std::optional<Eigen::Vector2d>& ray = rays[static_cast<std::size_t>(u)];
      Require(ray.has_value(), [&] {
        return params.name + ": the lens distortion D cannot be inverted at pixel (" +
               std::to_string(u) + ", " + std::to_string(v) + ")";
      });
      ray_x_[i] = static_cast<float>(ray->x());
      ray_y_[i] = static_cast<float>(ray->y());
      const Eigen::Vector3d d = R * Eigen::Vector3d(ray->x(), ray->y(), 1.0);
      dir_x_[i] = static_cast<float>(d.x());
      dir_y_[i] = static_cast<float>(d.y());
      inv_dir_z_[i] = 1.0f / static_cast<float>(d.z());
      floor_t_[i] = kInf;
      floor_depth_mm_[i] = 0;
      if (d.z() < 0.0) {
        const double t = -origin_base_.z() / d.z();  // the optical depth, since d's optical z is 1
        if (t <= params.clip_far_m) {
          floor_t_[i] = static_cast<float>(t);
          floor_x_[i] = static_cast<float>(origin_base_.x() + t * d.x());
          floor_y_[i] = static_cast<float>(origin_base_.y() + t * d.y());
          floor_depth_mm_[i] = DepthMillimetres(t, params.clip_near_m, params.clip_far_m);
        }
      }
    }
  }
}

void CameraRays::ComputeRuns() {
  for (int v = 0; v < height_; ++v) {
    const int row = v * width_;
    int u = 0;
    while (u < width_) {
      const bool floor = floor_t_[static_cast<std::size_t>(row + u)] < kInf;
      int end = u + 1;
      while (end < width_ && (floor_t_[static_cast<std::size_t>(row + end)] < kInf) == floor) {
        ++end;
      }
      (floor ? floor_runs_ : surround_runs_).push_back(Run{row + u, row + end});
      u = end;
    }
  }
}

CameraRays::FloorBlock CameraRays::FloorCircle(int u0, int u1, int v0, int v1) const {
  double x_lo = kInf, x_hi = -kInf, y_lo = kInf, y_hi = -kInf;
  for (int v = v0; v < v1; ++v) {
    for (int u = u0; u < u1; ++u) {
      const std::size_t i = static_cast<std::size_t>(v) * width_ + u;
      if (!(floor_t_[i] < kInf)) return FloorBlock{};
      x_lo = std::min(x_lo, double{floor_x_[i]});
      x_hi = std::max(x_hi, double{floor_x_[i]});
      y_lo = std::min(y_lo, double{floor_y_[i]});
      y_hi = std::max(y_hi, double{floor_y_[i]});
    }
  }
  FloorBlock block;
  block.centre_x = static_cast<float>(0.5 * (x_lo + x_hi));
  block.centre_y = static_cast<float>(0.5 * (y_lo + y_hi));
  double radius = 0.0;
  for (int v = v0; v < v1; ++v) {
    for (int u = u0; u < u1; ++u) {
      const std::size_t i = static_cast<std::size_t>(v) * width_ + u;
      radius = std::max(radius, std::hypot(floor_x_[i] - double{block.centre_x},
                                           floor_y_[i] - double{block.centre_y}));
    }
  }
  block.radius = std::nextafter(static_cast<float>(radius), kInf);  // rounded up
  return block;
}

void CameraRays::ComputeFloorBlocks() {
  const int blocks = blocks_per_row();
  floor_blocks_.assign(static_cast<std::size_t>(blocks) * height_, FloorBlock{});
  const int groups_high = (height_ + kGroupRows - 1) / kGroupRows;
  floor_block_groups_.assign(static_cast<std::size_t>(blocks) * groups_high, FloorBlock{});
  for (int k = 0; k < blocks; ++k) {
    const int u0 = k * kBlockSize;
    const int u1 = u0 + kBlockSize;
    if (u1 > width_) continue;
    for (int v = 0; v < height_; ++v) {
      floor_blocks_[static_cast<std::size_t>(v) * blocks + k] = FloorCircle(u0, u1, v, v + 1);
    }
    for (int g = 0; g < groups_high; ++g) {
      floor_block_groups_[static_cast<std::size_t>(g) * blocks + k] =
          FloorCircle(u0, u1, g * kGroupRows, std::min(height_, (g + 1) * kGroupRows));
    }
  }
}

void CameraRays::ComputeTiles() {
  for (int v0 = 0; v0 < height_; v0 += kTileSize) {
    for (int u0 = 0; u0 < width_; u0 += kTileSize) {
      Tile tile{u0,
                v0,
                std::min(u0 + kTileSize, width_),
                std::min(v0 + kTileSize, height_),
                kInf,
                -kInf,
                kInf,
                -kInf};
      for (int v = tile.v0; v < tile.v1; ++v) {
        for (int u = tile.u0; u < tile.u1; ++u) {
          const std::size_t i = static_cast<std::size_t>(v) * width_ + u;
          tile.x_min = std::min(tile.x_min, ray_x_[i]);
          tile.x_max = std::max(tile.x_max, ray_x_[i]);
          tile.y_min = std::min(tile.y_min, ray_y_[i]);
          tile.y_max = std::max(tile.y_max, ray_y_[i]);
        }
      }
      tiles_.push_back(tile);
    }
  }
  for (std::size_t first = 0; first < tiles_.size(); first += tiles_per_row()) {
    Tile row = tiles_[first];
    for (std::size_t k = first; k < first + tiles_per_row(); ++k) {
      row.x_min = std::min(row.x_min, tiles_[k].x_min);
      row.x_max = std::max(row.x_max, tiles_[k].x_max);
      row.y_min = std::min(row.y_min, tiles_[k].y_min);
      row.y_max = std::max(row.y_max, tiles_[k].y_max);
    }
    tile_rows_.push_back(row);
  }
}

CameraRenderer::CameraRenderer(std::shared_ptr<const CameraRays> rays,
                               std::shared_ptr<const FloorTexture> floor, Bgr surround)
    : rays_(std::move(rays)),
      floor_(std::move(floor)),
      surround_(surround),
      wide_lanes_(CpuHasAvx2()) {
  Require(rays_ != nullptr && floor_ != nullptr, "CameraRenderer needs rays and a floor texture");
  nearest_t_.resize(rays_->floor_t().size());
  tile_stamp_.assign(rays_->tiles().size(), 0u);
}

bool CameraRenderer::set_wide_lanes(bool on) {
  if (on && !CpuHasAvx2()) return false;
  wide_lanes_ = on;
  return true;
}

void CameraRenderer::Render(const world::Pose2& X_map_car, std::span<const Prism> prisms,
                            ColorImage* color, DepthImage* depth) {
  RenderImpl(X_map_car, prisms, color, depth, nullptr, nullptr);
}

void CameraRenderer::RenderDepth(const world::Pose2& X_map_car, std::span<const Prism> prisms,
                                 DepthImage* depth, DepthRowHistory* history,
                                 const DepthInterest* interest) {
  Require(depth != nullptr && history != nullptr, "CameraRenderer::RenderDepth needs its outputs");
  CheckInterest(interest);
  RenderImpl(X_map_car, prisms, nullptr, depth, nullptr, history, nullptr, interest);
}

void CameraRenderer::CheckInterest(const DepthInterest* interest) const {
  Require(interest == nullptr ||
              (interest->width() == rays_->width() && interest->height() == rays_->height()),
          [&] {
            return "CameraRenderer: a depth interest of " + std::to_string(interest->width()) +
                   "x" + std::to_string(interest->height()) + " for a camera of " +
                   std::to_string(rays_->width()) + "x" + std::to_string(rays_->height());
          });
}

DepthInterest::DepthInterest(const CameraRays& rays, std::vector<float> farthest_m)
    : width_(rays.width()), height_(rays.height()), pixels_m_(std::move(farthest_m)) {
  const std::size_t n = static_cast<std::size_t>(width_) * static_cast<std::size_t>(height_);
  Require(pixels_m_.size() == n, [&] {
    return "DepthInterest: " + std::to_string(pixels_m_.size()) + " bounds for " +
           std::to_string(n) + " pixels";
  });
  Require(std::none_of(pixels_m_.begin(), pixels_m_.end(), [](float b) { return std::isnan(b); }),
          "DepthInterest: a bound is NaN");
  constexpr float kNone = -std::numeric_limits<float>::infinity();
  tiles_m_.assign(rays.tiles().size(), kNone);
  tile_rows_m_.assign(rays.tile_rows().size(), kNone);
  const auto per_row = static_cast<std::size_t>(rays.tiles_per_row());
  for (std::size_t ti = 0; ti < rays.tiles().size(); ++ti) {
    const CameraRays::Tile& tile = rays.tiles()[ti];
    for (int v = tile.v0; v < tile.v1; ++v) {
      const float* row = pixels_m_.data() + static_cast<std::size_t>(v) * width_;
      tiles_m_[ti] = std::max(tiles_m_[ti], *std::max_element(row + tile.u0, row + tile.u1));
    }
    float& row_m = tile_rows_m_[ti / per_row];
    row_m = std::max(row_m, tiles_m_[ti]);
  }
  farthest_m_ =
      tile_rows_m_.empty() ? kNone : *std::max_element(tile_rows_m_.begin(), tile_rows_m_.end());
}

void CameraRenderer::CheckRegion(const RowSpans& region, const char* what) const {
  if (static_cast<int>(region.columns.size()) != rays_->height()) {
    throw std::invalid_argument(std::string("CameraRenderer: a ") + what + " region of " +
                                std::to_string(region.columns.size()) + " rows for a camera of " +
                                std::to_string(rays_->height()));
  }
}

void CameraRenderer::RenderLabels(const world::Pose2& X_map_car, std::span<const Prism> prisms,
                                  const RowSpans& region, const ColourLabel& label, LabelView out) {
  RenderLabels(X_map_car, prisms, region, label, out, {});
}

void CameraRenderer::RenderLabels(const world::Pose2& X_map_car, std::span<const Prism> prisms,
                                  const RowSpans& region, const ColourLabel& label, LabelView out,
                                  std::span<const std::uint8_t> prism_labels) {
  CheckRegion(region, "label");
  Require(prism_labels.empty() || prism_labels.size() == prisms.size(), [&] {
    return "CameraRenderer::RenderLabels: " + std::to_string(prism_labels.size()) +
           " prism labels for " + std::to_string(prisms.size()) + " prisms";
  });
  Require(out.origin != nullptr && out.stride >= rays_->width() && label != nullptr,
          "CameraRenderer::RenderLabels needs an output of the camera's width and a label");
  LabelOut labels{.view = out, .label = &label, .prism_labels = prism_labels};
  const FloorTexture& tex = *floor_;
  for (int k = 0; k < tex.palette_size(); ++k) {
    Bgr bgr;
    std::memcpy(bgr.data(), &tex.palette()[k], 3);
    labels.palette[static_cast<std::size_t>(k)] = label(bgr);
  }
  labels.surround = label(surround_);
  const std::shared_ptr<const std::vector<std::uint8_t>> texels = tex.LabelTexels(labels.palette);
  // (the eight-lane look-up reads four bytes at a texel's: the padding keeps the last inside)
  Require(texels->size() >= tex.outside_index() + 1 + FloorTexture::kLabelTexelPadding,
          "RenderLabels: the label texels lack their padding");
  labels.texels = texels->data();
  if (out.nonzero_columns != nullptr) {
    if (labels.surround != 0 || labels.palette[tex.common_index()] != 0) {
      *out.nonzero_columns = region.columns;  // the region's every pixel may be
    } else {
      out.nonzero_columns->assign(region.columns.size(), {rays_->width(), 0});
      labels.nonzero = out.nonzero_columns;
    }
  }
  RenderImpl(X_map_car, prisms, nullptr, nullptr, &region, nullptr, &labels);
}

void CameraRenderer::Render(const world::Pose2& X_map_car, std::span<const Prism> prisms,
                            ColorImage* color, DepthImage* depth, const RowSpans& color_region) {
  CheckRegion(color_region, "colour");
  RenderImpl(X_map_car, prisms, color, depth, &color_region, nullptr);
}

namespace {
// The parts of `runs` (pixel index ranges, row-major, width w) inside `region`, into *out.
void Intersect(const std::vector<CameraRays::Run>& runs, const RowSpans& region, int w,
               std::vector<CameraRays::Run>* out) {
  out->clear();
  for (const CameraRays::Run& run : runs) {
    for (int row = run.begin / w; row * w < run.end; ++row) {
      const auto [c0, c1] = region.columns[static_cast<std::size_t>(row)];
      const int begin = std::max(run.begin, row * w + c0);
      const int end = std::min({run.end, (row + 1) * w, row * w + c1});
      if (begin < end) out->push_back({begin, end});
    }
  }
}
}  // namespace

void CameraRenderer::RenderImpl(const world::Pose2& X_map_car, std::span<const Prism> prisms,
                                ColorImage* color, DepthImage* depth, const RowSpans* color_region,
                                DepthRowHistory* history, const LabelOut* labels,
                                const DepthInterest* interest) {
  const int w = rays_->width();
  const int h = rays_->height();
  const std::size_t n = static_cast<std::size_t>(w) * static_cast<std::size_t>(h);
  if (color != nullptr) {
    color->width = w;
    color->height = h;
    color->bgr.resize(3 * n);
  }
  if (depth != nullptr) {
    depth->width = w;
    depth->height = h;
    depth->mm.resize(n);
  }
  if (color == nullptr && depth == nullptr && labels == nullptr) return;
  // A new frame: every tile's nearest_t_ is stale until a prism touches it.
  if (++frame_ == 0) {
    std::fill(tile_stamp_.begin(), tile_stamp_.end(), 0u);
    frame_ = 1;
  }
  depth_columns_hit_.assign(static_cast<std::size_t>(h), {w, 0});
  RenderFloor(X_map_car, color, depth, color_region, history, labels);
  // Without a depth image, only the colour region's pixels of a prism are needed.
  const RowSpans* prism_region = depth == nullptr ? color_region : nullptr;
  for (std::size_t k = 0; k < prisms.size(); ++k) {
    RenderPrism(X_map_car, prisms[k], k, color, depth, prism_region, labels, interest);
  }
  if (history != nullptr) KeepHistory(depth, history);
}

void CameraRenderer::KeepHistory(const DepthImage* depth, DepthRowHistory* history) {
  // RestoreFloorDepth left the last frame's prisms' columns in changed_; this frame's join them:
  // the pixels that differ from the bare floor now or did in the last frame
  for (std::size_t v = 0; v < depth_columns_hit_.size(); ++v) {
    std::pair<int, int>& hit = depth_columns_hit_[v];
    if (hit.first >= hit.second) {
      hit = {0, 0};
      continue;
    }
    std::pair<int, int>& changed = history->changed_[v];
    changed = changed.first < changed.second ? std::pair{std::min(changed.first, hit.first),
                                                         std::max(changed.second, hit.second)}
                                             : hit;
  }
  history->prism_columns_ = depth_columns_hit_;
  history->buffer_ = depth->mm.data();
  history->valid_ = true;
}

namespace ray_caster_internal {

// What a frame's floor look-up reads (CameraRenderer::FloorPass::LookUp): the map from the base
// frame's (x, y) to the texture's continuous (column, row), the texture's extent, the pixels'
// floor points, and the texels' labels (with labels).
struct FloorMap {
  float a00, a01, a02, a10, a11, a12;  // the base frame's (x, y) → the texture's (column, row)
  float cols, rows;                    // the texture's size
  std::int32_t width, outside;         // its width, and FloorTexture::outside_index()
  const float *fx, *fy;                // CameraRays::floor_x(), floor_y()
  const std::uint8_t* label_texels;    // FloorTexture::LabelTexels, padded
};

#if defined(__x86_64__)
// The labelled look-up eight pixels at a time in AVX2 registers, the eight labels read by one
// gather: the same operations per lane as the four-lane look-up, so the same labels (tested).
// Pixels [begin, end) of a row, pixel i's label to label_row[i].
[[gnu::target("avx2")]] void LookUpFloorLabels8(const FloorMap& f, std::uint8_t* label_row,
                                                int begin, int end) {
  using F = Lanes<8>::F;
  using I = Lanes<8>::I;
  const F cols = Splat<F>(f.cols);
  const F rows = Splat<F>(f.rows);
  const F zero = Splat<F>(0.0f);
  const I width = Splat<I>(f.width);
  const I outside = Splat<I>(f.outside);
  for (int i = begin; i < end; i += 8) {
    const int n = std::min(8, end - i);
    const F x = Load<F>(f.fx + i, n);
    const F y = Load<F>(f.fy + i, n);
    const F col = f.a00 * x + f.a01 * y + f.a02;
    const F row = f.a10 * x + f.a11 * y + f.a12;
    const I inside = (col >= zero) & (col < cols) & (row >= zero) & (row < rows);
    const I texel_col = __builtin_convertvector(inside ? col : zero, I);
    const I texel_row = __builtin_convertvector(inside ? row : zero, I);
    const I index = inside ? texel_row * width + texel_col : outside;
    if (n < 8) {
      for (int k = 0; k < n; ++k) label_row[i + k] = f.label_texels[index[k]];
      continue;
    }
    static_assert(FloorTexture::kLabelTexelPadding >= 3);
    // four bytes from each texel's (the padding keeps the last texel's inside), its own the lowest
    // of them: those eight bytes gathered to the low four of each half, the halves' joined
    const __m256i words = _mm256_i32gather_epi32(reinterpret_cast<const int*>(f.label_texels),
                                                 reinterpret_cast<__m256i>(index), 1);
    const __m256i lowest = _mm256_shuffle_epi8(
        words, _mm256_setr_epi8(0, 4, 8, 12, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1,  //
                                0, 4, 8, 12, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1));
    const __m128i bytes =
        _mm_unpacklo_epi32(_mm256_castsi256_si128(lowest), _mm256_extracti128_si256(lowest, 1));
    _mm_storel_epi64(reinterpret_cast<__m128i*>(label_row + i), bytes);
  }
}
#endif

}  // namespace ray_caster_internal

using ray_caster_internal::FloorMap;
#if defined(__x86_64__)
using ray_caster_internal::LookUpFloorLabels8;
#endif

// One frame's colouring of the floor and the surround: where it writes (colour: 3 bytes per pixel
// at out + 3 · i; labels: one byte at LabelRow(v)[i] for pixel i of row v) and the map from the
// base frame's (x, y) to the texture's continuous (column, row): column = (x_map - origin_x) / m,
// row = (origin_y - y_map) / m, with p_map = p_car + R(yaw) · p_base.
struct CameraRenderer::FloorPass {
  FloorPass(const CameraRenderer& renderer, const world::Pose2& X_map_car, ColorImage* color,
            const LabelOut* label_out)
      : rays(*renderer.rays_),
        tex(*renderer.floor_),
        blocks_on(renderer.common_floor_blocks_on_),
        out(color != nullptr ? color->bgr.data() : nullptr),
        labels(label_out),
        wide(renderer.wide_lanes_) {
    const double c = std::cos(X_map_car.yaw_rad);
    const double s = std::sin(X_map_car.yaw_rad);
    const double m = tex.m_per_px();
    map = {.a00 = static_cast<float>(c / m),
           .a01 = static_cast<float>(-s / m),
           .a02 = static_cast<float>((X_map_car.x_m - tex.origin_m().x()) / m),
           .a10 = static_cast<float>(-s / m),
           .a11 = static_cast<float>(-c / m),
           .a12 = static_cast<float>((tex.origin_m().y() - X_map_car.y_m) / m),
           .cols = static_cast<float>(tex.width()),
           .rows = static_cast<float>(tex.height()),
           .width = tex.width(),
           .outside = static_cast<std::int32_t>(tex.outside_index()),
           .fx = rays.floor_x().data(),
           .fy = rays.floor_y().data(),
           .label_texels = labels != nullptr ? labels->texels : nullptr};
    texels_per_m = static_cast<float>(1.0 / m);
    for (int k = 0; k < CameraRays::kBlockSize; ++k) {
      std::memcpy(common_block.data() + 3 * k, &tex.palette()[tex.common_index()], 3);
    }
    if (labels != nullptr) common_label = labels->palette[tex.common_index()];
  }

  std::uint8_t* LabelRow(int v) const {
    const int w = rays.width();
    return labels->Row(v) - static_cast<std::ptrdiff_t>(v) * w;
  }

  // Pixels [begin, end) of row v, each looked up.
  [[gnu::always_inline]] inline void LookUp(int v, int begin, int end) const {
#if defined(__x86_64__)
    if (wide && labels != nullptr) {
      LookUpFloorLabels8(map, LabelRow(v), begin, end);
      return;
    }
#endif
    const F4 cols = Splat(map.cols);
    const F4 rows = Splat(map.rows);
    const F4 zero = Splat(0.0f);
    const I4 width = SplatInt(map.width);
    const I4 outside = SplatInt(map.outside);
    const std::uint8_t* texel_index = tex.palette_index();
    const std::uint32_t* palette = tex.palette();
    const std::uint8_t* label_texels = map.label_texels;
    const float* fx = map.fx;
    const float* fy = map.fy;
    // (the row's start once: the byte stores below may alias anything, so the compiler would
    // compute it again for every chunk)
    std::uint8_t* const label_row = labels != nullptr ? LabelRow(v) : nullptr;
    for (int i = begin; i < end; i += kLanes) {
      const int n = std::min(kLanes, end - i);
      const F4 x = Load(fx + i, n);
      const F4 y = Load(fy + i, n);
      const F4 col = map.a00 * x + map.a01 * y + map.a02;
      const F4 row = map.a10 * x + map.a11 * y + map.a12;
      const I4 inside = (col >= zero) & (col < cols) & (row >= zero) & (row < rows);
      const I4 texel_col = __builtin_convertvector(inside ? col : zero, I4);
      const I4 texel_row = __builtin_convertvector(inside ? row : zero, I4);
      const I4 index = inside ? texel_row * width + texel_col : outside;
      if (labels != nullptr) {
        std::uint8_t* label = label_row + i;
        for (int k = 0; k < n; ++k) label[k] = label_texels[index[k]];
        continue;
      }
      for (int k = 0; k < n; ++k) {
        // 4 bytes where the next pixel overwrites the fourth, 3 at the end
        const std::uint32_t* texel = &palette[texel_index[index[k]]];
        if (i + k + 1 < end) {
          std::memcpy(out + 3 * (i + k), texel, 4);
        } else {
          std::memcpy(out + 3 * (i + k), texel, 3);
        }
      }
    }
  }

  // Whether a whole block whose circle lies on texels of the common colour is that colour: the
  // circle's texture square, widened by a texel for the float arithmetic (the centre's transform
  // is the pixels' own, and its error is below 1e-3 texel), must hold nothing else (inside the
  // raster, or beyond it where that is the common colour too). For x >= 0, truncation is floor, and
  // every pixel's texel lies between those of the square's corners.
  bool Common(const CameraRays::FloorBlock& block) const {
    if (!blocks_on || block.radius < 0.0f) return false;
    const float col = map.a00 * block.centre_x + map.a01 * block.centre_y + map.a02;
    const float row = map.a10 * block.centre_x + map.a11 * block.centre_y + map.a12;
    const float reach = block.radius * texels_per_m + 1.0f;
    if (col - reach >= 0.0f && row - reach >= 0.0f &&
        col + reach < static_cast<float>(tex.width()) &&
        row + reach < static_cast<float>(tex.height())) {
      return tex.CommonWithin(col, row, reach);
    }
    // A square reaching beyond the raster: LookUp gives a pixel there the bare floor's colour, so
    // where that is the common colour, the square's part inside the raster decides (exactly).
    // Near the track's edge a lane camera sees beyond the raster in a quarter of its blocks.
    if (!tex.outside_is_common()) return false;
    const float c_lo = std::max(col - reach, 0.0f);
    const float r_lo = std::max(row - reach, 0.0f);
    const float c_hi = std::min(col + reach, static_cast<float>(tex.width() - 1));
    const float r_hi = std::min(row + reach, static_cast<float>(tex.height() - 1));
    if (!(c_lo <= c_hi && r_lo <= r_hi)) return true;  // wholly beyond
    return tex.CommonIn(static_cast<int>(c_lo), static_cast<int>(r_lo), static_cast<int>(c_hi),
                        static_cast<int>(r_hi));
  }

  // The `count` pixels from pixel i of row v on: the common colour.
  void FillCommon(int v, int i, int count) const {
    if (count <= 0) return;
    if (labels != nullptr) {
      std::memset(LabelRow(v) + i, common_label, static_cast<std::size_t>(count));
      return;
    }
    constexpr int kBlock = CameraRays::kBlockSize;
    for (; count >= kBlock; count -= kBlock, i += kBlock) {
      std::memcpy(out + 3 * i, common_block.data(), common_block.size());
    }
    std::memcpy(out + 3 * i, common_block.data(), 3 * static_cast<std::size_t>(count));
  }

  const CameraRays& rays;
  const FloorTexture& tex;
  bool blocks_on;
  std::uint8_t* out;
  const LabelOut* labels;
  bool wide;  // CameraRenderer::wide_lanes
  FloorMap map;
  float texels_per_m;
  std::array<std::uint8_t, 3 * CameraRays::kBlockSize> common_block;
  std::uint8_t common_label{0};  // with labels: the common colour's
};

void CameraRenderer::RenderFloor(const world::Pose2& X_map_car, ColorImage* color,
                                 DepthImage* depth, const RowSpans* color_region,
                                 DepthRowHistory* history, const LabelOut* labels) {
  const CameraRays& r = *rays_;
  if (depth != nullptr) RestoreFloorDepth(depth, history);
  if (color == nullptr && labels == nullptr) return;
  const std::vector<CameraRays::Run>* floor_runs = &r.floor_runs();
  const std::vector<CameraRays::Run>* surround_runs = &r.surround_runs();
  if (color_region != nullptr) {
    if (runs_region_ != color_region->columns) {  // (a region has a row per image row)
      Intersect(r.floor_runs(), *color_region, r.width(), &floor_in_region_);
      Intersect(r.surround_runs(), *color_region, r.width(), &surround_in_region_);
      runs_region_ = color_region->columns;
    }
    floor_runs = &floor_in_region_;
    surround_runs = &surround_in_region_;
  }
  const FloorPass pass(*this, X_map_car, color, labels);
  FillSurround(pass, *surround_runs);
  FillFloor(pass, *floor_runs);
}

void CameraRenderer::RestoreFloorDepth(DepthImage* depth, DepthRowHistory* history) const {
  const CameraRays& r = *rays_;
  const std::size_t h = static_cast<std::size_t>(r.height());
  if (history != nullptr && history->valid_ && history->buffer_ == depth->mm.data() &&
      history->prism_columns_.size() == h) {
    // the buffer holds the last frame: only the pixels its prisms wrote go back to the floor
    const std::size_t w = static_cast<std::size_t>(r.width());
    for (std::size_t v = 0; v < h; ++v) {
      const auto [begin, end] = history->prism_columns_[v];
      if (begin == end) continue;
      const std::size_t i = v * w + static_cast<std::size_t>(begin);
      std::memcpy(depth->mm.data() + i, r.floor_depth_mm().data() + i,
                  static_cast<std::size_t>(end - begin) * 2);
    }
    history->changed_ = history->prism_columns_;
  } else {
    std::memcpy(depth->mm.data(), r.floor_depth_mm().data(), depth->mm.size() * 2);
    if (history != nullptr) history->changed_.assign(h, {0, r.width()});
  }
}

void CameraRenderer::FillSurround(const FloorPass& pass,
                                  const std::vector<CameraRays::Run>& runs) const {
  const int w = rays_->width();
  for (const CameraRays::Run& run : runs) {
    if (pass.labels != nullptr) {
      std::memset(pass.LabelRow(run.begin / w) + run.begin, pass.labels->surround,
                  static_cast<std::size_t>(run.end - run.begin));
      continue;
    }
    for (int i = run.begin; i < run.end; ++i) std::memcpy(pass.out + 3 * i, surround_.data(), 3);
  }
}

void CameraRenderer::FillFloor(const FloorPass& pass, const std::vector<CameraRays::Run>& runs) {
  const CameraRays& r = *rays_;
  const int w = r.width();
  constexpr int kBlock = CameraRays::kBlockSize;
  const int blocks_per_row = r.blocks_per_row();
  const CameraRays::FloorBlock* blocks = r.floor_blocks().data();
  // A block's group (CameraRays::floor_block_groups) is looked up once per frame, when a run
  // first reaches it; per group row, as bits: looked up, and not all of the common colour.
  const CameraRays::FloorBlock* groups = r.floor_block_groups().data();
  const int words = (blocks_per_row + 63) / 64;
  group_seen_.assign(r.floor_block_groups().size() / static_cast<std::size_t>(blocks_per_row) *
                         static_cast<std::size_t>(words),
                     0);
  group_mixed_.assign(group_seen_.size(), 0);
  // Per run, the blocks of its groups that are not all common one by one: a block that is common
  // itself joins the stretch of common pixels, filled at once; the others are looked up. A block
  // the run covers in part (at its ends, where a region's edge cuts a row) is common if the whole
  // block is. (The count is kept in a local: the byte stores may alias any member, which the
  // compiler would then reload after each.)
  std::uint64_t common_pixels = 0;
  for (const CameraRays::Run& run : runs) {
    const int row = run.begin / w;  // a run lies in one row
    const int row_start = row * w;
    const int group_row = row / CameraRays::kGroupRows;
    std::uint64_t* seen = group_seen_.data() + static_cast<std::size_t>(group_row) * words;
    std::uint64_t* mixed = group_mixed_.data() + static_cast<std::size_t>(group_row) * words;
    const CameraRays::FloorBlock* row_groups =
        groups + static_cast<std::size_t>(group_row) * blocks_per_row;
    const CameraRays::FloorBlock* row_blocks =
        blocks + static_cast<std::size_t>(row) * blocks_per_row;
    const int k_begin = (run.begin - row_start) / kBlock;
    const int k_end = (run.end - row_start + kBlock - 1) / kBlock;
    int common_from = run.begin;  // the stretch of common pixels [common_from, block's start)
    for (int word = k_begin / 64; word <= (k_end - 1) / 64; ++word) {
      const int lo = std::max(k_begin - 64 * word, 0), hi = std::min(k_end - 64 * word, 64);
      const std::uint64_t in_run = world::BitRange(lo, hi);
      for (std::uint64_t fresh = in_run & ~seen[word]; fresh != 0; fresh &= fresh - 1) {
        const int k = 64 * word + std::countr_zero(fresh);
        if (!pass.Common(row_groups[k])) mixed[word] |= 1ull << (k - 64 * word);
      }
      seen[word] |= in_run;
      for (std::uint64_t left = in_run & mixed[word]; left != 0; left &= left - 1) {
        const int k = 64 * word + std::countr_zero(left);
        if (pass.Common(row_blocks[k])) continue;
        const int from = std::max(run.begin, row_start + k * kBlock);
        const int to = std::min(run.end, row_start + (k + 1) * kBlock);
        pass.FillCommon(row, common_from, from - common_from);
        common_pixels += static_cast<std::uint64_t>(from - common_from);
        pass.LookUp(row, from, to);
        if (pass.labels != nullptr)
          pass.labels->MayBeNonzero(row, from - row_start, to - row_start);
        common_from = to;
      }
    }
    pass.FillCommon(row, common_from, run.end - common_from);
    common_pixels += static_cast<std::uint64_t>(run.end - common_from);
  }
  common_floor_pixels_ += common_pixels;
}

void CameraRenderer::InitTileDepth(std::size_t tile_index) {
  const CameraRays::Tile& tile = rays_->tiles()[tile_index];
  const int w = rays_->width();
  const float* floor_t = rays_->floor_t().data();
  for (int v = tile.v0; v < tile.v1; ++v) {
    const std::size_t row = static_cast<std::size_t>(v) * w;
    std::copy(floor_t + row + tile.u0, floor_t + row + tile.u1, nearest_t_.data() + row + tile.u0);
  }
  tile_stamp_[tile_index] = frame_;
}

std::array<Bgr, 7> PrismFaceColours(const Prism& prism) {
  const double cw = std::cos(prism.footprint.pose.yaw_rad);
  const double sw = std::sin(prism.footprint.pose.yaw_rad);
  const std::array<Eigen::Vector3d, 6> normals{
      Eigen::Vector3d(-cw, -sw, 0.0), Eigen::Vector3d(cw, sw, 0.0),
      Eigen::Vector3d(sw, -cw, 0.0),  Eigen::Vector3d(-sw, cw, 0.0),
      Eigen::Vector3d(0.0, 0.0, 1.0), Eigen::Vector3d(0.0, 0.0, -1.0)};
  std::array<Bgr, 7> face_bgr;
  for (std::size_t f = 0; f < 7; ++f) {
    const double shade =
        f < 6 ? kAmbient + kDiffuse * std::max(0.0, normals[f].dot(kLightDirection)) : 1.0;
    for (int ch = 0; ch < 3; ++ch) {
      face_bgr[f][ch] = static_cast<std::uint8_t>(std::lround(prism.bgr[ch] * shade));
    }
  }
  return face_bgr;
}

namespace {

// A prism in the car's base frame: its footprint's centre p_base and yaw psi (as cos, sin), and
// its half extents and height.
struct PrismInBase {
  Eigen::Vector2d p_base;
  double cp{1.0}, sp{0.0};
  double half_length{0.0}, half_width{0.0}, height{0.0};
};

PrismInBase PlaceInBase(const world::Pose2& X_map_car, const Prism& prism) {
  const world::OrientedBox& box = prism.footprint;
  const double psi = box.pose.yaw_rad - X_map_car.yaw_rad;
  return PrismInBase{.p_base = world::PointsInFrame(X_map_car)(box.pose.position()),
                     .cp = std::cos(psi),
                     .sp = std::sin(psi),
                     .half_length = 0.5 * box.length_m,
                     .half_width = 0.5 * box.width_m,
                     .height = prism.height_m};
}

// The bounds of the normalized rays (x/z, y/z in the optical frame) that can meet a prism.
struct RayBounds {
  float x_lo{kInf}, x_hi{-kInf}, y_lo{kInf}, y_hi{-kInf};
  double z_near{0.0};  // the least optical z of the prism's corners: no point of it is nearer
  void Include(const Eigen::Vector3d& q) {
    const auto qx = static_cast<float>(q.x() / q.z());
    const auto qy = static_cast<float>(q.y() / q.z());
    x_lo = std::min(x_lo, qx);
    x_hi = std::max(x_hi, qx);
    y_lo = std::min(y_lo, qy);
    y_hi = std::max(y_hi, qy);
  }
};

// Cull and bound: the prism's corners in the optical frame, clipped to z >= kProjectionNearZ_m
// and projected; nullopt where the prism lies wholly beyond the far clip or behind the camera.
std::optional<RayBounds> BoundOnImage(const PrismInBase& prism,
                                      const Eigen::Isometry3d& X_camera_base, double clip_far_m) {
  std::array<Eigen::Vector3d, 8> corners;
  double z_min = std::numeric_limits<double>::infinity();
  for (int k = 0; k < 8; ++k) {
    const double lx = (k & 1) ? prism.half_length : -prism.half_length;
    const double ly = (k & 2) ? prism.half_width : -prism.half_width;
    const double lz = (k & 4) ? prism.height : 0.0;
    const Eigen::Vector3d p(prism.p_base.x() + prism.cp * lx - prism.sp * ly,
                            prism.p_base.y() + prism.sp * lx + prism.cp * ly, lz);
    corners[k] = X_camera_base * p;
    z_min = std::min(z_min, corners[k].z());
  }
  if (z_min > clip_far_m) return std::nullopt;  // wholly beyond the far clip
  RayBounds bounds;
  for (int k = 0; k < 8; ++k) {
    if (corners[k].z() >= kProjectionNearZ_m) bounds.Include(corners[k]);
    for (int bit = 1; bit < 8; bit <<= 1) {  // the box's 12 edges: corners one bit apart
      const int j = k | bit;
      if ((k & bit) != 0) continue;
      const double za = corners[k].z() - kProjectionNearZ_m;
      const double zb = corners[j].z() - kProjectionNearZ_m;
      if ((za < 0.0) != (zb < 0.0)) {
        const double f = za / (za - zb);
        bounds.Include(corners[k] + f * (corners[j] - corners[k]));
      }
    }
  }
  if (!(bounds.x_lo <= bounds.x_hi)) return std::nullopt;  // wholly behind the camera
  bounds.z_near = z_min;
  return bounds;
}

bool Misses(const CameraRays::Tile& tile, const RayBounds& bounds) {
  return tile.x_max < bounds.x_lo || tile.x_min > bounds.x_hi || tile.y_max < bounds.y_lo ||
         tile.y_min > bounds.y_hi;
}

// The prism's bounds on the image, or nullopt where it covers no pixel: flat, behind the camera,
// beyond the far clip, or beside every row of tiles.
std::optional<RayBounds> VisibleBounds(const CameraRays& r, const PrismInBase& placed) {
  if (!(placed.half_length > 0.0 && placed.half_width > 0.0 && placed.height > 0.0)) {
    return std::nullopt;
  }
  std::optional<RayBounds> bounds =
      BoundOnImage(placed, r.camera().X_base_camera().inverse(), r.camera().params().clip_far_m);
  if (bounds && std::all_of(r.tile_rows().begin(), r.tile_rows().end(),
                            [&](const CameraRays::Tile& row) { return Misses(row, *bounds); })) {
    return std::nullopt;
  }
  return bounds;
}

}  // namespace

// (named outside the anonymous namespace: CameraRenderer::PrismTrace holds a SlabConstants)
namespace ray_caster_internal {

// The exact ray–prism test's constants, in the prism's frame: the ray's origin o and direction
// R(-psi) · dir, the slabs' bounds relative to o; the pixels' rays; the prism's bounds on the
// image, and (with an interest) each pixel's bound and the prism's least optical depth, rounded
// down: a pixel whose bound is nearer sees nothing of the prism within it.
struct SlabConstants {
  const float *ray_x, *ray_y, *dir_x, *dir_y, *inv_dir_z;
  float box_x_lo, box_x_hi, box_y_lo, box_y_hi;
  float far;
  const float* interest_m{nullptr};  // DepthInterest::pixels_m (null: none)
  float z_near{0.0f};

  float x_lo_o, x_hi_o, y_lo_o, y_hi_o, z_lo_o, z_hi_o;
  float rc, rs;
};

// The slab test of L pixels at a time: SlabConstants splat into L lanes, as locals of the row that
// uses them (the row's stores cannot alias a local, so they stay in registers).
template <int L>
struct SlabTest {
  using F = typename Lanes<L>::F;
  using I = typename Lanes<L>::I;

  [[gnu::always_inline]] explicit SlabTest(const SlabConstants& c)
      : k(c),
        box_x_lo(Splat<F>(c.box_x_lo)),
        box_x_hi(Splat<F>(c.box_x_hi)),
        box_y_lo(Splat<F>(c.box_y_lo)),
        box_y_hi(Splat<F>(c.box_y_hi)),
        far(Splat<F>(c.far)),
        z_near(Splat<F>(c.z_near)),
        x_lo_o(Splat<F>(c.x_lo_o)),
        x_hi_o(Splat<F>(c.x_hi_o)),
        y_lo_o(Splat<F>(c.y_lo_o)),
        y_hi_o(Splat<F>(c.y_hi_o)),
        z_lo_o(Splat<F>(c.z_lo_o)),
        z_hi_o(Splat<F>(c.z_hi_o)),
        rc(Splat<F>(c.rc)),
        rs(Splat<F>(c.rs)) {}

  // The slab test's values for the pixels [i, i + n) (n <= L).
  struct Hits {
    I hit;   // the ray enters the prism, within the far clip, nearer than what it saw
    F t;     // the optical depth it enters at (0: the camera is inside)
    F t_in;  // the largest of the slabs' entries
    F tx_min, ty_min, lx, ly, iz;  // which slab set t_in, and the direction it came from
  };
  // False (and `hits` not set) where no pixel of the L is within the prism's bounds or hits it.
  [[gnu::always_inline]] bool Test(int i, int n, const float* nearest_t, Hits* hits) const {
    // within the prism's bounds on the image, and (with an interest) not beyond the pixel's bound?
    const F nx = Load<F>(k.ray_x + i, n);
    const F ny = Load<F>(k.ray_y + i, n);
    I in_box = FirstLanes<I>(n) & (nx >= box_x_lo) & (nx <= box_x_hi) & (ny >= box_y_lo) &
               (ny <= box_y_hi);
    if (k.interest_m != nullptr) in_box &= Load<F>(k.interest_m + i, n) >= z_near;
    if (!Any(in_box)) return false;
    // slabs: a zero direction gives infinite bounds of the right signs
    const F one = Splat<F>(1.0f);
    const F zero = Splat<F>(0.0f);
    const F dx = Load<F>(k.dir_x + i, n);
    const F dy = Load<F>(k.dir_y + i, n);
    hits->lx = rc * dx + rs * dy;
    hits->ly = rc * dy - rs * dx;
    const F ix = one / hits->lx;
    const F iy = one / hits->ly;
    hits->iz = Load<F>(k.inv_dir_z + i, n);
    const F tx_a = x_lo_o * ix, tx_b = x_hi_o * ix;
    const F ty_a = y_lo_o * iy, ty_b = y_hi_o * iy;
    const F tz_a = z_lo_o * hits->iz, tz_b = z_hi_o * hits->iz;
    hits->tx_min = Min(tx_a, tx_b);
    hits->ty_min = Min(ty_a, ty_b);
    hits->t_in = Max(Max(hits->tx_min, hits->ty_min), Min(tz_a, tz_b));
    const F t_out = Min(Min(Max(tx_a, tx_b), Max(ty_a, ty_b)), Max(tz_a, tz_b));
    hits->t = Max(hits->t_in, zero);  // 0: the camera is inside the prism
    const F nearest = Load<F>(nearest_t + i, n);
    hits->hit =
        in_box & (hits->t_in <= t_out) & (t_out > zero) & (hits->t <= far) & (hits->t < nearest);
    return Any(hits->hit);
  }

  // The face lane j enters through (PrismFaceColours' order): the slab that set t_in.
  static int EntryFace(const Hits& h, int j) {
    if (!(h.t_in[j] > 0.0f)) return 6;
    if (h.t_in[j] == h.tx_min[j]) return h.lx[j] > 0.0f ? 0 : 1;
    if (h.t_in[j] == h.ty_min[j]) return h.ly[j] > 0.0f ? 2 : 3;
    // the z slab set a finite t_in > 0, so iz is finite and has dz's sign
    return h.iz[j] > 0.0f ? 5 : 4;
  }

  const SlabConstants& k;
  F box_x_lo, box_x_hi, box_y_lo, box_y_hi;
  F far;
  F z_near;
  F x_lo_o, x_hi_o, y_lo_o, y_hi_o, z_lo_o, z_hi_o;
  F rc, rs;
};

// Where a faceless row writes (TracePrismFacelessRow): the nearest distance per pixel, and the
// depth (null: none) and the label (null: none) of row v; the near clip (the far one is the
// slab test's).
struct FacelessRowOut {
  float* nearest;
  std::uint16_t* depth_mm;
  std::uint8_t* label_row;
  std::uint8_t label;
  float near_m;
};

// Row v's pixels [u_begin, u_end) (pixel i = row_start + u) traced L at a time; returns the
// columns written [first, last), L at a time (first >= last: none). Each pixel keeps its depth,
// nearest distance and label unless its ray hits (a select, not a branch per pixel).
template <int L>
[[gnu::always_inline]] inline std::pair<int, int> TraceFacelessRow(const SlabConstants& c,
                                                                   int row_start, int u_begin,
                                                                   int u_end,
                                                                   const FacelessRowOut& out) {
  using F = typename Lanes<L>::F;
  using I = typename Lanes<L>::I;
  const SlabTest<L> test(c);
  const F near_m = Splat<F>(out.near_m);
  typename SlabTest<L>::Hits hits;
  int first = u_end, last = u_begin;
  for (int u = u_begin; u < u_end; u += L) {
    const int i = row_start + u;
    const int n = std::min(L, u_end - u);
    if (!test.Test(i, n, out.nearest, &hits)) continue;
    first = std::min(first, u);
    last = u + n;
    // DepthMillimetres in float, as TracePrismRow: 0 outside the clip range (converted only
    // inside it)
    const I in_clip = (hits.t >= near_m) & (hits.t <= test.far);
    const I mm = __builtin_convertvector(in_clip ? hits.t * 1000.0f + 0.5f : Splat<F>(0.0f), I);
    if (n < L) {
      for (int j = 0; j < n; ++j) {
        if (!hits.hit[j]) continue;
        out.nearest[i + j] = hits.t[j];
        if (out.depth_mm != nullptr) out.depth_mm[i + j] = static_cast<std::uint16_t>(mm[j]);
        if (out.label_row != nullptr) out.label_row[u + j] = out.label;
      }
      continue;
    }
    F old_t;
    std::memcpy(&old_t, out.nearest + i, sizeof old_t);
    const F new_t = hits.hit ? hits.t : old_t;
    std::memcpy(out.nearest + i, &new_t, sizeof new_t);
    if (out.depth_mm != nullptr) {
      using U16 = typename Lanes<L>::U16;
      U16 old_mm;
      std::memcpy(&old_mm, out.depth_mm + i, sizeof old_mm);
      const U16 new_mm = __builtin_convertvector(hits.hit, typename Lanes<L>::S16) != 0
                             ? __builtin_convertvector(mm, U16)
                             : old_mm;
      std::memcpy(out.depth_mm + i, &new_mm, sizeof new_mm);
    }
    if (out.label_row != nullptr) {
      using U8 = typename Lanes<L>::U8;
      U8 old_label;
      std::memcpy(&old_label, out.label_row + u, sizeof old_label);
      const U8 new_label = __builtin_convertvector(hits.hit, typename Lanes<L>::S8) != 0
                               ? Splat<U8>(out.label)
                               : old_label;
      std::memcpy(out.label_row + u, &new_label, sizeof new_label);
    }
  }
  return {first, last};
}

std::pair<int, int> TraceFacelessRow4(const SlabConstants& c, int row_start, int u_begin, int u_end,
                                      const FacelessRowOut& out) {
  return TraceFacelessRow<4>(c, row_start, u_begin, u_end, out);
}

#if defined(__x86_64__)
// The same eight lanes at a time in AVX2 registers: the same IEEE operations per lane, so the same
// bits as TraceFacelessRow4 (tested), in about half the instructions. Without FMA, as the rest of
// the program (-ffp-contract=off).
[[gnu::target("avx2")]] std::pair<int, int> TraceFacelessRow8(const SlabConstants& c, int row_start,
                                                              int u_begin, int u_end,
                                                              const FacelessRowOut& out) {
  return TraceFacelessRow<8>(c, row_start, u_begin, u_end, out);
}
#endif

}  // namespace ray_caster_internal

using ray_caster_internal::FacelessRowOut;
using ray_caster_internal::SlabConstants;
using ray_caster_internal::SlabTest;
using ray_caster_internal::TraceFacelessRow4;
#if defined(__x86_64__)
using ray_caster_internal::TraceFacelessRow8;
#endif

namespace {

// (a function of the anonymous namespace's types: SlabConstants is named outside it, being part
// of CameraRenderer::PrismTrace)
SlabConstants MakeSlabConstants(const CameraRays& r, const PrismInBase& prism,
                                const RayBounds& bounds) {
  SlabConstants c{.ray_x = r.ray_x().data(),
                  .ray_y = r.ray_y().data(),
                  .dir_x = r.dir_x().data(),
                  .dir_y = r.dir_y().data(),
                  .inv_dir_z = r.inv_dir_z().data(),
                  .box_x_lo = bounds.x_lo,
                  .box_x_hi = bounds.x_hi,
                  .box_y_lo = bounds.y_lo,
                  .box_y_hi = bounds.y_hi,
                  .far = static_cast<float>(r.camera().params().clip_far_m)};
  const Eigen::Vector3d& origin = r.origin_base();
  const double ox_b = origin.x() - prism.p_base.x();
  const double oy_b = origin.y() - prism.p_base.y();
  const double ox = prism.cp * ox_b + prism.sp * oy_b;
  const double oy = -prism.sp * ox_b + prism.cp * oy_b;
  c.x_lo_o = static_cast<float>(-prism.half_length - ox);
  c.x_hi_o = static_cast<float>(prism.half_length - ox);
  c.y_lo_o = static_cast<float>(-prism.half_width - oy);
  c.y_hi_o = static_cast<float>(prism.half_width - oy);
  c.z_lo_o = static_cast<float>(-origin.z());
  c.z_hi_o = static_cast<float>(prism.height - origin.z());
  c.rc = static_cast<float>(prism.cp);
  c.rs = static_cast<float>(prism.sp);
  return c;
}

}  // namespace

// What a frame writes where a prism's pixels hit it, and the test that finds them.
struct CameraRenderer::PrismTrace {
  PrismTrace(const CameraRays& r, const PrismInBase& prism, const RayBounds& bounds)
      : slab(MakeSlabConstants(r, prism, bounds)) {}

  SlabConstants slab;
  std::array<Bgr, 7> face_bgr;
  std::array<std::uint8_t, 7> face_label{};
  // every face has the same label (a car's body is one class to the lane detector): a labels-only
  // trace needs no entry face either
  bool one_label{false};
};

namespace {

// The largest float not above x.
float FloatBelow(double x) {
  const auto f = static_cast<float>(x);
  return static_cast<double>(f) > x ? std::nextafter(f, -std::numeric_limits<float>::infinity())
                                    : f;
}

// Calls visit(tile index) for each tile of `r` that a prism with these bounds may cover, and
// (with an interest) where some pixel's bound reaches the prism's least depth, until visit
// returns true; returns whether one did.
template <class Visit>
bool ForEachTileReached(const CameraRays& r, const RayBounds& bounds, const DepthInterest* interest,
                        Visit visit) {
  // (optical z is linear in the point, so the nearest point of a box is a corner)
  const auto beyond = [&](float farthest_m) { return bounds.z_near > farthest_m; };
  if (interest != nullptr && beyond(interest->farthest_m())) return false;
  const std::vector<CameraRays::Tile>& tiles = r.tiles();
  const std::vector<CameraRays::Tile>& tile_rows = r.tile_rows();
  const auto per_row = static_cast<std::size_t>(r.tiles_per_row());
  for (std::size_t row = 0; row < tile_rows.size(); ++row) {
    if (Misses(tile_rows[row], bounds)) continue;
    if (interest != nullptr && beyond(interest->tile_row_farthest_m(row))) continue;
    for (std::size_t ti = row * per_row; ti < (row + 1) * per_row; ++ti) {
      if (Misses(tiles[ti], bounds)) continue;
      if (interest != nullptr && beyond(interest->tile_farthest_m(ti))) continue;
      if (visit(ti)) return true;
    }
  }
  return false;
}

}  // namespace

void CameraRenderer::RenderPrism(const world::Pose2& X_map_car, const Prism& prism,
                                 std::size_t index, ColorImage* color, DepthImage* depth,
                                 const RowSpans* region, const LabelOut* labels,
                                 const DepthInterest* interest) {
  const CameraRays& r = *rays_;
  const PrismInBase placed = PlaceInBase(X_map_car, prism);
  const std::optional<RayBounds> bounds = VisibleBounds(r, placed);
  if (!bounds) return;

  PrismTrace trace(r, placed, *bounds);
  trace.face_bgr = PrismFaceColours(prism);
  if (labels != nullptr && !labels->prism_labels.empty()) {
    trace.face_label.fill(labels->prism_labels[index]);
  } else if (labels != nullptr) {
    for (std::size_t f = 0; f < 7; ++f) trace.face_label[f] = (*labels->label)(trace.face_bgr[f]);
  }
  trace.one_label = std::all_of(trace.face_label.begin(), trace.face_label.end(),
                                [&](std::uint8_t l) { return l == trace.face_label[0]; });
  if (interest != nullptr) {
    trace.slab.interest_m = interest->pixels_m().data();
    trace.slab.z_near = FloatBelow(bounds->z_near);
  }
  ForEachTileReached(r, *bounds, interest, [&](std::size_t ti) {
    TracePrismTile(trace, ti, color, depth, region, labels);
    return false;
  });
}

bool CameraRenderer::MaySee(const world::Pose2& X_map_car, const Prism& prism,
                            const DepthInterest* interest) const {
  CheckInterest(interest);
  const std::optional<RayBounds> bounds = VisibleBounds(*rays_, PlaceInBase(X_map_car, prism));
  return bounds && (interest == nullptr || ForEachTileReached(*rays_, *bounds, interest,
                                                              [](std::size_t) { return true; }));
}

void CameraRenderer::TracePrismTile(const PrismTrace& trace, std::size_t ti, ColorImage* color,
                                    DepthImage* depth, const RowSpans* region,
                                    const LabelOut* labels) {
  const CameraRays::Tile& tile = rays_->tiles()[ti];
  // row v's pixels of the tile that are asked for
  const auto columns = [&](int v) {
    if (region == nullptr) return std::pair{tile.u0, tile.u1};
    const auto [begin, end] = region->columns[static_cast<std::size_t>(v)];
    return std::pair{std::max(tile.u0, begin), std::min(tile.u1, end)};
  };
  bool asked = false;
  for (int v = tile.v0; v < tile.v1 && !asked; ++v) {
    const auto [u_begin, u_end] = columns(v);
    asked = u_begin < u_end;
  }
  if (!asked) return;
  if (tile_stamp_[ti] != frame_) InitTileDepth(ti);
  for (int v = tile.v0; v < tile.v1; ++v) {
    const auto [u_begin, u_end] = columns(v);
    if (color == nullptr && (labels == nullptr || trace.one_label)) {
      TracePrismFacelessRow(trace, v, u_begin, u_end, depth, labels);
    } else {
      TracePrismRow(trace, v, u_begin, u_end, color, depth, labels);
    }
  }
}

void CameraRenderer::NoteDepthColumns(int v, int first, int last) {
  WidenColumns(&depth_columns_hit_[static_cast<std::size_t>(v)], first, last);
}

void CameraRenderer::TracePrismFacelessRow(const PrismTrace& trace, int v, int u_begin, int u_end,
                                           DepthImage* depth, const LabelOut* labels) {
  // TracePrismRow's depth and labels, where the face the ray enters through does not matter:
  // without colour, and without labels or with one label for all faces
  const CameraParams& params = rays_->camera().params();
  const FacelessRowOut out{.nearest = nearest_t_.data(),
                           .depth_mm = depth != nullptr ? depth->mm.data() : nullptr,
                           .label_row = labels != nullptr ? labels->Row(v) : nullptr,
                           .label = trace.face_label[0],
                           .near_m = static_cast<float>(params.clip_near_m)};
  const int row_start = v * rays_->width();
#if defined(__x86_64__)
  const auto [first, last] = wide_lanes_
                                 ? TraceFacelessRow8(trace.slab, row_start, u_begin, u_end, out)
                                 : TraceFacelessRow4(trace.slab, row_start, u_begin, u_end, out);
#else
  const auto [first, last] = TraceFacelessRow4(trace.slab, row_start, u_begin, u_end, out);
#endif
  if (first >= last) return;
  if (out.depth_mm != nullptr) NoteDepthColumns(v, first, last);
  if (labels != nullptr && out.label != 0) labels->MayBeNonzero(v, first, last);
}

void CameraRenderer::TracePrismRow(const PrismTrace& trace, int v, int u_begin, int u_end,
                                   ColorImage* color, DepthImage* depth, const LabelOut* labels) {
  const CameraParams& params = rays_->camera().params();
  const float near_m = static_cast<float>(params.clip_near_m);
  const float far_m = static_cast<float>(params.clip_far_m);
  const int w = rays_->width();
  std::uint8_t* out = color != nullptr ? color->bgr.data() : nullptr;
  std::uint16_t* depth_mm = depth != nullptr ? depth->mm.data() : nullptr;
  const SlabTest<kLanes> test(trace.slab);
  SlabTest<kLanes>::Hits hits;
  int first = u_end, last = u_begin;  // the columns written, four at a time
  for (int u = u_begin; u < u_end; u += kLanes) {
    const int i = v * w + u;
    const int n = std::min(kLanes, u_end - u);
    if (!test.Test(i, n, nearest_t_.data(), &hits)) continue;
    first = std::min(first, u);
    last = u + n;
    for (int k = 0; k < n; ++k) {
      if (!hits.hit[k]) continue;
      const auto face = static_cast<std::size_t>(SlabTest<kLanes>::EntryFace(hits, k));
      const std::size_t p = static_cast<std::size_t>(i + k);
      const float t = hits.t[k];
      nearest_t_[p] = t;
      if (out != nullptr) std::memcpy(out + 3 * p, trace.face_bgr[face].data(), 3);
      if (labels != nullptr) {
        labels->Row(v)[u + k] = trace.face_label[face];
      }
      if (depth_mm != nullptr) {
        depth_mm[p] = t >= near_m && t <= far_m ? static_cast<std::uint16_t>(t * 1000.0f + 0.5f)
                                                : std::uint16_t{0};
      }
    }
  }
  if (depth_mm != nullptr && first < last) NoteDepthColumns(v, first, last);
  if (labels != nullptr && first < last) labels->MayBeNonzero(v, first, last);
}

void AddCameraNoise(const CameraNoiseParams& noise, const CameraParams& camera, std::uint64_t seed,
                    ColorImage* color, DepthImage* depth) {
  if (depth != nullptr && noise.AltersDepth()) {
    const std::uint64_t base = Mix64(seed ^ kDepthDomain);
    for (std::size_t i = 0; i < depth->mm.size(); ++i) {
      const std::uint16_t mm = depth->mm[i];
      if (mm == 0) continue;
      const double z = mm / 1000.0;
      const double noisy =
          z + noise.depth_stddev_per_m * z * z * ApproxNormal(Mix64(base + (i + 1) * kGolden));
      depth->mm[i] = DepthMillimetres(noisy, camera.clip_near_m, camera.clip_far_m);
    }
  }
  if (color != nullptr && noise.AltersColor()) {
    // one 64-bit draw per pixel gives its three channels' normals (21 bits each)
    const std::uint64_t base = Mix64(seed ^ kColorDomain);
    const auto stddev = static_cast<float>(noise.color_stddev);
    const std::size_t pixels = color->bgr.size() / 3;
    for (std::size_t p = 0; p < pixels; ++p) {
      const std::uint64_t bits = Mix64(base + (p + 1) * kGolden);
      for (int c = 0; c < 3; ++c) {
        std::uint8_t& channel = color->bgr[3 * p + static_cast<std::size_t>(c)];
        const float value = channel + stddev * ApproxNormal21(bits >> (21 * c));
        // round half up (the +256 keeps the truncated value positive), then saturate
        const int rounded = static_cast<int>(value + 256.5f) - 256;
        channel = static_cast<std::uint8_t>(std::clamp(rounded, 0, 255));
      }
    }
  }
}

}  // namespace autonomsim::vehicle
