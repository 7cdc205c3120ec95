#include "vehicle/ray_caster.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <utility>

#include "world/validation.h"

namespace autonomsim::vehicle {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

// Four lanes of float or int32 (GCC/Clang vector extensions: SSE2 on x86-64, NEON on ARM, scalar
// code elsewhere). The arithmetic is IEEE lane by lane, so a lane computes bit for bit what scalar
// code would; a comparison gives -1 (true) or 0 per lane.
using F4 = float __attribute__((vector_size(16)));
using I4 = std::int32_t __attribute__((vector_size(16)));
constexpr int kLanes = 4;

F4 Splat(float x) { return F4{x, x, x, x}; }
I4 SplatInt(std::int32_t x) { return I4{x, x, x, x}; }
// Lanes [0, n) from p (n in 1..4); the others repeat p[0] and must be masked by the caller.
F4 Load(const float* p, int n) {
  F4 v = Splat(p[0]);
  if (n == kLanes) {
    std::memcpy(&v, p, sizeof v);
  } else {
    for (int k = 1; k < n; ++k) v[k] = p[k];
  }
  return v;
}
I4 FirstLanes(int n) { return I4{0, 1, 2, 3} < SplatInt(n); }
F4 Min(F4 a, F4 b) { return a < b ? a : b; }
F4 Max(F4 a, F4 b) { return a > b ? a : b; }
bool Any(I4 mask) { return (mask[0] | mask[1] | mask[2] | mask[3]) != 0; }
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
  Require(depth_stddev_per_m >= 0.0 && depth_stddev_per_m <= 0.1, [&] {
    return "depth_stddev_per_m must be in [0, 0.1], got " + std::to_string(depth_stddev_per_m);
  });
  Require(color_stddev >= 0.0 && color_stddev <= 64.0,
          [&] { return "color_stddev must be in [0, 64], got " + std::to_string(color_stddev); });
}

FloorTexture::FloorTexture(const world::FloorRaster& raster)
    : width_(raster.width_px),
      height_(raster.height_px),
      m_per_px_(raster.m_per_px),
      origin_m_(raster.origin_m) {
  Require(width_ > 0 && height_ > 0 && std::isfinite(m_per_px_) && m_per_px_ > 0.0,
          "FloorTexture: the raster needs a positive size and m_per_px");
  const std::size_t n = static_cast<std::size_t>(width_) * static_cast<std::size_t>(height_);
  Require(raster.bgr.size() == 3 * n, "FloorTexture: raster.bgr must hold 3 bytes per pixel");
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

  std::vector<std::size_t> uses(palette_.size(), 0);
  for (std::size_t i = 0; i < n; ++i) ++uses[index_[i]];
  common_index_ =
      static_cast<std::uint8_t>(std::max_element(uses.begin(), uses.end()) - uses.begin());
  const int cells_x = (width_ + kCommonCell - 1) / kCommonCell;
  const int cells_y = (height_ + kCommonCell - 1) / kCommonCell;
  cells_y_ = static_cast<std::size_t>(cells_y);
  words_per_row_ = static_cast<std::size_t>((cells_x + 63) / 64);
  // other[y][x]: the cell holds a texel of another colour; near: the same within d, grown by one
  // cell per level
  std::vector<std::uint8_t> near(static_cast<std::size_t>(cells_x) * cells_y, 0);
  for (int row = 0; row < height_; ++row) {
    for (int col = 0; col < width_; ++col) {
      if (index_[static_cast<std::size_t>(row) * width_ + col] != common_index_) {
        near[static_cast<std::size_t>(row / kCommonCell) * cells_x + col / kCommonCell] = 1;
      }
    }
  }
  common_near_.assign((kMaxReachCells + 1) * cells_y_ * words_per_row_, 0);
  std::vector<std::uint8_t> grown(near.size());
  for (int d = 0; d <= kMaxReachCells; ++d) {
    if (d > 0) {
      for (int y = 0; y < cells_y; ++y) {
        for (int x = 0; x < cells_x; ++x) {
          std::uint8_t any = 0;
          for (int yy = std::max(0, y - 1); yy <= std::min(cells_y - 1, y + 1); ++yy) {
            for (int xx = std::max(0, x - 1); xx <= std::min(cells_x - 1, x + 1); ++xx) {
              any |= near[static_cast<std::size_t>(yy) * cells_x + xx];
            }
          }
          grown[static_cast<std::size_t>(y) * cells_x + x] = any;
        }
      }
      near.swap(grown);
    }
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

CameraRays::CameraRays(const CameraModel& camera)
    : camera_(camera), width_(camera.width()), height_(camera.height()) {
  const CameraParams& params = camera_.params();
  const Eigen::Isometry3d& X_base_camera = camera_.X_base_camera();
  origin_base_ = X_base_camera.translation();
  Require(origin_base_.z() > 0.0, [&] {
    return params.name + ": the camera must be above the floor (mount.z_m > 0), got " +
           std::to_string(origin_base_.z());
  });
  const Eigen::Matrix3d R = X_base_camera.linear();
  const std::size_t n = static_cast<std::size_t>(width_) * static_cast<std::size_t>(height_);
  dir_x_.resize(n);
  dir_y_.resize(n);
  inv_dir_z_.resize(n);
  floor_x_.resize(n);
  floor_y_.resize(n);
  floor_t_.resize(n);
  floor_depth_mm_.resize(n);
  ray_x_.resize(n);
  ray_y_.resize(n);

  for (int v = 0; v < height_; ++v) {
    for (int u = 0; u < width_; ++u) {
      const std::size_t i = static_cast<std::size_t>(v) * width_ + u;
      const std::optional<Eigen::Vector2d> ray = camera_.NormalizedRay(u, v);
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

  // The circle holding the floor points of pixels [u0, u1) × [v0, v1), or a negative radius where
  // one of them does not see the floor.
  const auto circle = [&](int u0, int u1, int v0, int v1) {
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
  };
  const int blocks = blocks_per_row();
  floor_blocks_.assign(static_cast<std::size_t>(blocks) * height_, FloorBlock{});
  const int groups_high = (height_ + kGroupRows - 1) / kGroupRows;
  floor_block_groups_.assign(static_cast<std::size_t>(blocks) * groups_high, FloorBlock{});
  for (int k = 0; k < blocks; ++k) {
    const int u0 = k * kBlockSize;
    const int u1 = u0 + kBlockSize;
    if (u1 > width_) continue;
    for (int v = 0; v < height_; ++v) {
      floor_blocks_[static_cast<std::size_t>(v) * blocks + k] = circle(u0, u1, v, v + 1);
    }
    for (int g = 0; g < groups_high; ++g) {
      floor_block_groups_[static_cast<std::size_t>(g) * blocks + k] =
          circle(u0, u1, g * kGroupRows, std::min(height_, (g + 1) * kGroupRows));
    }
  }

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
}

CameraRenderer::CameraRenderer(std::shared_ptr<const CameraRays> rays,
                               std::shared_ptr<const FloorTexture> floor, Bgr surround)
    : rays_(std::move(rays)), floor_(std::move(floor)), surround_(surround) {
  Require(rays_ != nullptr && floor_ != nullptr, "CameraRenderer needs rays and a floor texture");
  nearest_t_.resize(rays_->floor_t().size());
  tile_stamp_.assign(rays_->tiles().size(), 0u);
}

void CameraRenderer::Render(const world::Pose2& X_map_car, std::span<const Prism> prisms,
                            ColorImage* color, DepthImage* depth) {
  RenderImpl(X_map_car, prisms, color, depth, nullptr, nullptr);
}

void CameraRenderer::RenderDepth(const world::Pose2& X_map_car, std::span<const Prism> prisms,
                                 DepthImage* depth, DepthRowHistory* history) {
  Require(depth != nullptr && history != nullptr, "CameraRenderer::RenderDepth needs its outputs");
  RenderImpl(X_map_car, prisms, nullptr, depth, nullptr, history);
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
                                DepthRowHistory* history, const LabelOut* labels) {
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
  depth_rows_hit_.assign(static_cast<std::size_t>(h), 0);
  RenderFloor(X_map_car, color, depth, color_region, history, labels);
  // Without a depth image, only the colour region's pixels of a prism are needed.
  const RowSpans* prism_region = depth == nullptr ? color_region : nullptr;
  for (std::size_t k = 0; k < prisms.size(); ++k) {
    RenderPrism(X_map_car, prisms[k], k, color, depth, prism_region, labels);
  }
  if (history != nullptr) {
    // rows that differ from the bare floor now or did in the last frame
    for (int v = 0; v < h; ++v) {
      history->changed_[v] |= depth_rows_hit_[v];
    }
    history->prism_rows_ = depth_rows_hit_;
    history->buffer_ = depth->mm.data();
    history->valid_ = true;
  }
}

void CameraRenderer::RenderFloor(const world::Pose2& X_map_car, ColorImage* color,
                                 DepthImage* depth, const RowSpans* color_region,
                                 DepthRowHistory* history, const LabelOut* labels) {
  const CameraRays& r = *rays_;
  if (depth != nullptr) {
    const std::size_t h = static_cast<std::size_t>(r.height());
    if (history != nullptr && history->valid_ && history->buffer_ == depth->mm.data() &&
        history->prism_rows_.size() == h) {
      // the buffer holds the last frame: only its prisms' rows go back to the floor
      const std::size_t w = static_cast<std::size_t>(r.width());
      for (std::size_t v = 0; v < h; ++v) {
        if (history->prism_rows_[v] == 0) continue;
        std::memcpy(depth->mm.data() + v * w, r.floor_depth_mm().data() + v * w, w * 2);
      }
      history->changed_ = history->prism_rows_;
    } else {
      std::memcpy(depth->mm.data(), r.floor_depth_mm().data(), depth->mm.size() * 2);
      if (history != nullptr) history->changed_.assign(h, 1);
    }
  }
  if (color == nullptr && labels == nullptr) return;
  const std::vector<CameraRays::Run>* floor_runs = &r.floor_runs();
  const std::vector<CameraRays::Run>* surround_runs = &r.surround_runs();
  if (color_region != nullptr) {
    Intersect(r.floor_runs(), *color_region, r.width(), &floor_in_region_);
    Intersect(r.surround_runs(), *color_region, r.width(), &surround_in_region_);
    floor_runs = &floor_in_region_;
    surround_runs = &surround_in_region_;
  }

  // Colour: 3 bytes per pixel at out + 3 · i. Labels: one byte, at label_row[i] for pixel i of
  // row v (label_row is the view's row v shifted back by v · width).
  const int w = r.width();
  std::uint8_t* out = color != nullptr ? color->bgr.data() : nullptr;
  const auto label_row = [&](int v) {
    return labels->view.origin + static_cast<std::ptrdiff_t>(v) * labels->view.stride -
           static_cast<std::ptrdiff_t>(v) * w;
  };
  for (const CameraRays::Run& run : *surround_runs) {
    if (labels != nullptr) {
      std::memset(label_row(run.begin / w) + run.begin, labels->surround,
                  static_cast<std::size_t>(run.end - run.begin));
      continue;
    }
    for (int i = run.begin; i < run.end; ++i) std::memcpy(out + 3 * i, surround_.data(), 3);
  }

  // base frame (x, y) -> texture (column, row), continuous: column = (x_map - origin_x) / m,
  // row = (origin_y - y_map) / m, with p_map = p_car + R(yaw) · p_base.
  const FloorTexture& tex = *floor_;
  const double c = std::cos(X_map_car.yaw_rad);
  const double s = std::sin(X_map_car.yaw_rad);
  const double m = tex.m_per_px();
  const float a00 = static_cast<float>(c / m);
  const float a01 = static_cast<float>(-s / m);
  const float a02 = static_cast<float>((X_map_car.x_m - tex.origin_m().x()) / m);
  const float a10 = static_cast<float>(-s / m);
  const float a11 = static_cast<float>(-c / m);
  const float a12 = static_cast<float>((tex.origin_m().y() - X_map_car.y_m) / m);
  const F4 cols = Splat(static_cast<float>(tex.width()));
  const F4 rows = Splat(static_cast<float>(tex.height()));
  const F4 zero = Splat(0.0f);
  const I4 width = SplatInt(tex.width());
  const I4 outside = SplatInt(static_cast<std::int32_t>(tex.outside_index()));
  const std::uint8_t* texel_index = tex.palette_index();
  const std::uint32_t* palette = tex.palette();
  const float* fx = r.floor_x().data();
  const float* fy = r.floor_y().data();
  // Pixels [begin, end) of row v, each looked up.
  const auto look_up = [&](int v, int begin, int end) {
    for (int i = begin; i < end; i += kLanes) {
      const int n = std::min(kLanes, end - i);
      const F4 x = Load(fx + i, n);
      const F4 y = Load(fy + i, n);
      const F4 col = a00 * x + a01 * y + a02;
      const F4 row = a10 * x + a11 * y + a12;
      const I4 inside = (col >= zero) & (col < cols) & (row >= zero) & (row < rows);
      const I4 texel_col = __builtin_convertvector(inside ? col : zero, I4);
      const I4 texel_row = __builtin_convertvector(inside ? row : zero, I4);
      const I4 index = inside ? texel_row * width + texel_col : outside;
      if (labels != nullptr) {
        std::uint8_t* label = label_row(v) + i;
        for (int k = 0; k < n; ++k) label[k] = labels->palette[texel_index[index[k]]];
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
  };
  // A whole block whose circle lies on texels of the common colour is that colour: the circle's
  // texture square, widened by a texel for the float arithmetic (the centre's transform is the
  // pixels' own, and its error is below 1e-3 texel), must be inside the raster and hold nothing
  // else. For x >= 0, truncation is floor, and every pixel's texel lies between those of the
  // square's corners.
  constexpr int kBlock = CameraRays::kBlockSize;
  const int blocks_per_row = r.blocks_per_row();
  const CameraRays::FloorBlock* blocks = r.floor_blocks().data();
  std::array<std::uint8_t, 3 * kBlock> common_block;
  for (int k = 0; k < kBlock; ++k) {
    std::memcpy(common_block.data() + 3 * k, &palette[tex.common_index()], 3);
  }
  const auto texels_per_m = static_cast<float>(1.0 / m);
  const auto tex_cols = static_cast<float>(tex.width());
  const auto tex_rows = static_cast<float>(tex.height());
  const auto common = [&](const CameraRays::FloorBlock& block) {
    if (!common_floor_blocks_on_ || block.radius < 0.0f) return false;
    const float col = a00 * block.centre_x + a01 * block.centre_y + a02;
    const float row = a10 * block.centre_x + a11 * block.centre_y + a12;
    const float reach = block.radius * texels_per_m + 1.0f;
    return col - reach >= 0.0f && row - reach >= 0.0f && col + reach < tex_cols &&
           row + reach < tex_rows && tex.CommonWithin(col, row, reach);
  };
  // A block's group (CameraRays::floor_block_groups) is looked up once per frame, when the first
  // of its blocks is met: 0 not yet, 1 all of the common colour, 2 not known to be.
  const CameraRays::FloorBlock* groups = r.floor_block_groups().data();
  group_common_.assign(r.floor_block_groups().size(), 0);
  const auto group_common = [&](int row, int k) {
    const std::size_t g = static_cast<std::size_t>(row / CameraRays::kGroupRows) * blocks_per_row +
                          static_cast<std::size_t>(k);
    if (group_common_[g] == 0) group_common_[g] = common(groups[g]) ? 1 : 2;
    return group_common_[g] == 1;
  };
  for (const CameraRays::Run& run : *floor_runs) {
    const int row = run.begin / w;  // a run lies in one row
    int i = run.begin;
    while (i < run.end) {
      const int column = i - row * w;
      if (column % kBlock == 0 && i + kBlock <= run.end &&
          (group_common(row, column / kBlock) ||
           common(blocks[row * blocks_per_row + column / kBlock]))) {
        if (labels != nullptr) {
          std::memset(label_row(row) + i, labels->palette[tex.common_index()], kBlock);
        } else {
          std::memcpy(out + 3 * i, common_block.data(), common_block.size());
        }
        ++common_floor_blocks_;
        i += kBlock;
        continue;
      }
      const int next = std::min(run.end, row * w + (column / kBlock + 1) * kBlock);
      look_up(row, i, next);
      i = next;
    }
  }
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

void CameraRenderer::RenderPrism(const world::Pose2& X_map_car, const Prism& prism,
                                 std::size_t index, ColorImage* color, DepthImage* depth,
                                 const RowSpans* region, const LabelOut* labels) {
  const CameraRays& r = *rays_;
  const CameraParams& params = r.camera().params();
  const world::OrientedBox& box = prism.footprint;
  const double half_length = 0.5 * box.length_m;
  const double half_width = 0.5 * box.width_m;
  const double height = prism.height_m;
  if (!(half_length > 0.0 && half_width > 0.0 && height > 0.0)) return;

  // the prism in the car's base frame: centre p, yaw psi
  const double cy = std::cos(X_map_car.yaw_rad);
  const double sy = std::sin(X_map_car.yaw_rad);
  const double rel_x = box.pose.x_m - X_map_car.x_m;
  const double rel_y = box.pose.y_m - X_map_car.y_m;
  const Eigen::Vector2d p_base(cy * rel_x + sy * rel_y, -sy * rel_x + cy * rel_y);
  const double psi = box.pose.yaw_rad - X_map_car.yaw_rad;
  const double cp = std::cos(psi);
  const double sp = std::sin(psi);

  // cull and bound: the corners in the optical frame, clipped to z >= kProjectionNearZ_m
  const Eigen::Isometry3d X_camera_base = r.camera().X_base_camera().inverse();
  std::array<Eigen::Vector3d, 8> corners;
  double z_min = std::numeric_limits<double>::infinity();
  for (int k = 0; k < 8; ++k) {
    const double lx = (k & 1) ? half_length : -half_length;
    const double ly = (k & 2) ? half_width : -half_width;
    const double lz = (k & 4) ? height : 0.0;
    const Eigen::Vector3d p(p_base.x() + cp * lx - sp * ly, p_base.y() + sp * lx + cp * ly, lz);
    corners[k] = X_camera_base * p;
    z_min = std::min(z_min, corners[k].z());
  }
  if (z_min > params.clip_far_m) return;  // wholly beyond the far clip
  float x_lo = kInf, x_hi = -kInf, y_lo = kInf, y_hi = -kInf;
  auto include = [&](const Eigen::Vector3d& q) {
    const auto qx = static_cast<float>(q.x() / q.z());
    const auto qy = static_cast<float>(q.y() / q.z());
    x_lo = std::min(x_lo, qx);
    x_hi = std::max(x_hi, qx);
    y_lo = std::min(y_lo, qy);
    y_hi = std::max(y_hi, qy);
  };
  for (int k = 0; k < 8; ++k) {
    if (corners[k].z() >= kProjectionNearZ_m) include(corners[k]);
    for (int bit = 1; bit < 8; bit <<= 1) {  // the box's 12 edges: corners one bit apart
      const int j = k | bit;
      if ((k & bit) != 0) continue;
      const double za = corners[k].z() - kProjectionNearZ_m;
      const double zb = corners[j].z() - kProjectionNearZ_m;
      if ((za < 0.0) != (zb < 0.0)) {
        const double f = za / (za - zb);
        include(corners[k] + f * (corners[j] - corners[k]));
      }
    }
  }
  if (!(x_lo <= x_hi)) return;  // wholly behind the camera

  const std::array<Bgr, 7> face_bgr = PrismFaceColours(prism);
  std::array<std::uint8_t, 7> face_label{};
  if (labels != nullptr && !labels->prism_labels.empty()) {
    face_label.fill(labels->prism_labels[index]);
  } else if (labels != nullptr) {
    for (std::size_t f = 0; f < 7; ++f) face_label[f] = (*labels->label)(face_bgr[f]);
  }

  // the ray test in the prism's frame: origin o, direction R(-psi) · dir; the slabs' bounds
  // relative to o
  const Eigen::Vector3d& origin = r.origin_base();
  const double ox_b = origin.x() - p_base.x();
  const double oy_b = origin.y() - p_base.y();
  const double ox = cp * ox_b + sp * oy_b;
  const double oy = -sp * ox_b + cp * oy_b;
  const F4 x_lo_o = Splat(static_cast<float>(-half_length - ox));
  const F4 x_hi_o = Splat(static_cast<float>(half_length - ox));
  const F4 y_lo_o = Splat(static_cast<float>(-half_width - oy));
  const F4 y_hi_o = Splat(static_cast<float>(half_width - oy));
  const F4 z_lo_o = Splat(static_cast<float>(-origin.z()));
  const F4 z_hi_o = Splat(static_cast<float>(height - origin.z()));
  const F4 rc = Splat(static_cast<float>(cp));
  const F4 rs = Splat(static_cast<float>(sp));
  const F4 box_x_lo = Splat(x_lo), box_x_hi = Splat(x_hi);
  const F4 box_y_lo = Splat(y_lo), box_y_hi = Splat(y_hi);
  const F4 zero = Splat(0.0f);
  const F4 one = Splat(1.0f);
  const F4 far = Splat(static_cast<float>(params.clip_far_m));
  const float near_m = static_cast<float>(params.clip_near_m);
  const float far_m = static_cast<float>(params.clip_far_m);
  const float* ray_x = r.ray_x().data();
  const float* ray_y = r.ray_y().data();
  const float* dir_x = r.dir_x().data();
  const float* dir_y = r.dir_y().data();
  const float* inv_dir_z = r.inv_dir_z().data();
  const int w = r.width();
  std::uint8_t* out = color != nullptr ? color->bgr.data() : nullptr;
  std::uint16_t* depth_mm = depth != nullptr ? depth->mm.data() : nullptr;

  const std::vector<CameraRays::Tile>& tiles = r.tiles();
  for (std::size_t ti = 0; ti < tiles.size(); ++ti) {
    const CameraRays::Tile& tile = tiles[ti];
    if (tile.x_max < x_lo || tile.x_min > x_hi || tile.y_max < y_lo || tile.y_min > y_hi) continue;
    if (tile_stamp_[ti] != frame_) InitTileDepth(ti);
    for (int v = tile.v0; v < tile.v1; ++v) {
      int u_begin = tile.u0, u_end = tile.u1;
      if (region != nullptr) {
        u_begin = std::max(u_begin, region->columns[static_cast<std::size_t>(v)].first);
        u_end = std::min(u_end, region->columns[static_cast<std::size_t>(v)].second);
      }
      for (int u = u_begin; u < u_end; u += kLanes) {
        const int i = v * w + u;
        const int n = std::min(kLanes, u_end - u);
        // within the prism's bounds on the image?
        const F4 nx = Load(ray_x + i, n);
        const F4 ny = Load(ray_y + i, n);
        const I4 in_box = FirstLanes(n) & (nx >= box_x_lo) & (nx <= box_x_hi) & (ny >= box_y_lo) &
                          (ny <= box_y_hi);
        if (!Any(in_box)) continue;
        // slabs: a zero direction gives infinite bounds of the right signs
        const F4 dx = Load(dir_x + i, n);
        const F4 dy = Load(dir_y + i, n);
        const F4 lx = rc * dx + rs * dy;
        const F4 ly = rc * dy - rs * dx;
        const F4 ix = one / lx;
        const F4 iy = one / ly;
        const F4 iz = Load(inv_dir_z + i, n);
        const F4 tx_a = x_lo_o * ix, tx_b = x_hi_o * ix;
        const F4 ty_a = y_lo_o * iy, ty_b = y_hi_o * iy;
        const F4 tz_a = z_lo_o * iz, tz_b = z_hi_o * iz;
        const F4 tx_min = Min(tx_a, tx_b), ty_min = Min(ty_a, ty_b), tz_min = Min(tz_a, tz_b);
        const F4 t_in = Max(Max(tx_min, ty_min), tz_min);
        const F4 t_out = Min(Min(Max(tx_a, tx_b), Max(ty_a, ty_b)), Max(tz_a, tz_b));
        const F4 t = Max(t_in, zero);  // 0: the camera is inside the prism
        const F4 nearest = Load(nearest_t_.data() + i, n);
        const I4 hit = in_box & (t_in <= t_out) & (t_out > zero) & (t <= far) & (t < nearest);
        if (!Any(hit)) continue;
        for (int k = 0; k < n; ++k) {
          if (!hit[k]) continue;
          // the face it enters through: the slab that set t_in
          int face = 6;
          if (t_in[k] > 0.0f) {
            if (t_in[k] == tx_min[k]) {
              face = lx[k] > 0.0f ? 0 : 1;
            } else if (t_in[k] == ty_min[k]) {
              face = ly[k] > 0.0f ? 2 : 3;
            } else {
              // the z slab set a finite t_in > 0, so iz is finite and has dz's sign
              face = iz[k] > 0.0f ? 5 : 4;
            }
          }
          const std::size_t p = static_cast<std::size_t>(i + k);
          nearest_t_[p] = t[k];
          if (out != nullptr)
            std::memcpy(out + 3 * p, face_bgr[static_cast<std::size_t>(face)].data(), 3);
          if (labels != nullptr) {
            labels->view.origin[static_cast<std::ptrdiff_t>(v) * labels->view.stride + u + k] =
                face_label[static_cast<std::size_t>(face)];
          }
          if (depth_mm != nullptr) {
            depth_rows_hit_[static_cast<std::size_t>(v)] = 1;
            depth_mm[p] = t[k] >= near_m && t[k] <= far_m
                              ? static_cast<std::uint16_t>(t[k] * 1000.0f + 0.5f)
                              : std::uint16_t{0};
          }
        }
      }
    }
  }
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
