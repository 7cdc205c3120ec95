// Synthesizes a camera's colour and depth images by ray casting through the 2D world: the painted
// floor (a raster), vertical prisms standing on it (obstacle boxes, other cars) and a plain
// surround.
//
// The structure of the problem does the work. The car moves in the plane and its cameras are
// rigidly mounted, so every pixel's ray, its floor hit in the car's frame and that hit's depth are
// constants of the camera (CameraRays, computed once, lens distortion included). A frame then
// costs, per floor pixel, one 2D rigid transform and one raster look-up (and a block of kBlockSize
// pixels over the bare floor between the painted lines costs one look-up in all), and the empty
// floor's depth image is a copy (only of the pixels a prism changed, for a consumer that keeps its
// buffer). Prisms are culled to those in front of the camera; each one's corners bound it on the
// image, and only the pixels of the tiles under that bound get the exact ray–prism test, which
// keeps the nearest surface.
//
// Depth is the optical-axis z of the surface (what a real depth camera reports, and what
// back-projection with P expects: a pixel's point is z · (x, y, 1) in the optical frame), in
// millimetres as uint16, 0 for no return: nothing hit within the far clip, or the hit is nearer
// than the near clip. Colour is BGR8. Surfaces beyond the far clip are not drawn: the surround
// colour and no depth.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <span>
#include <utility>
#include <vector>

#include "vehicle/camera_model.h"
#include "world/floor_raster.h"
#include "world/geometry.h"

namespace autonomsim::vehicle {

using Bgr = std::array<std::uint8_t, 3>;

// Surfaces nearer to the image plane than this (optical z, m) are not drawn: a prism's corners
// are clipped there before projection (the GL backend's near plane is the same).
inline constexpr double kProjectionNearZ_m = 1e-3;

// A depth image's value for a surface at optical depth t_m: millimetres rounded half up, 0 (no
// return) outside [near_m, far_m]. Both renderers' rule.
inline std::uint16_t DepthMillimetres(double t_m, double near_m, double far_m) {
  if (!(t_m >= near_m && t_m <= far_m)) return 0;
  return static_cast<std::uint16_t>(t_m * 1000.0 + 0.5);
}

// A vertical prism standing on the floor (z from 0 to height_m): an obstacle box or a car body.
struct Prism {
  world::OrientedBox footprint;  // map frame
  double height_m{0.0};
  Bgr bgr{0, 0, 0};
  friend bool operator==(const Prism&, const Prism&) = default;
};

// The colour of each face of a prism as the cameras see it: its colour shaded by one fixed light
// from above (ambient + diffuse, so that a box's faces are told apart), in the order -x, +x, -y,
// +y (the footprint's local axes), top, bottom, and [6] unshaded, for a camera inside the prism.
std::array<Bgr, 7> PrismFaceColours(const Prism& prism);

struct ColorImage {
  int width{0};
  int height{0};
  std::vector<std::uint8_t> bgr;  // row-major, 3 bytes per pixel (bgr8)
};

struct DepthImage {
  int width{0};
  int height{0};
  std::vector<std::uint16_t> mm;  // row-major, millimetres of optical z (mono16); 0 = no return
};

// What the world looks like where the track's raster says nothing. Colours are RGB 0..255, as in
// track files. The defaults are picked to stay clear of the lane detection's white and yellow HSV
// thresholds (reference §5, both sets): grey below their brightness, reds, blues and purples
// outside their hues.
struct SceneAppearance {
  std::array<int, 3> surround_rgb{110, 110, 110};  // assumed: the lab's wall, mid grey
  std::array<int, 3> obstacle_rgb{190, 40, 40};    // assumed: the reference shows no obstacles
  // assumed: the real cars' bodies are not described; a car takes entry id % size.
  std::vector<std::array<int, 3>> car_body_rgb{{30, 80, 200},  {170, 40, 170}, {110, 50, 200},
                                               {210, 80, 140}, {20, 30, 120},  {170, 30, 60}};

  template <class V>
  void Describe(V& v) {
    v("surround_rgb", surround_rgb, "the colour beyond the floor (the lab's wall)");
    v("obstacle_rgb", obstacle_rgb, "the obstacles' colour");
    v("car_body_rgb", car_body_rgb, "the cars' body colours; car id takes entry id % count");
  }
  void Validate() const;  // every channel in [0, 255], at least one car colour

  Bgr surround() const;
  Bgr obstacle() const;
  Bgr car_body(int car_id) const;
};

// Seeded sensor noise, off or on per camera. The figures are assumed: the reference gives none.
struct CameraNoiseParams {
  bool enabled{false};
  // assumed: σ(z) = c · z², the structured-light error model of Khoshelham & Elberink (2012) for
  // the Kinect (≈1.5 mm at 1 m, ≈4 cm at 5 m); the Astra is a structured-light camera of the
  // same kind.
  double depth_stddev_per_m{0.0016};
  // assumed: a few counts of sensor noise per channel for a small CMOS camera in a lit lab.
  double color_stddev{2.0};

  template <class V>
  void Describe(V& v) {
    v("enabled", enabled, "add seeded noise to the images");
    v("depth_stddev_per_m", depth_stddev_per_m, "depth noise σ = this × depth²");
    v("color_stddev", color_stddev, "colour noise per channel, in counts of 255");
  }
  void Validate() const;  // depth_stddev_per_m in [0, 0.1], color_stddev in [0, 64]
  // Whether AddCameraNoise changes the depth image, the colour image.
  bool AltersDepth() const { return enabled && depth_stddev_per_m > 0.0; }
  bool AltersColor() const { return enabled && color_stddev > 0.0; }
};

// The floor raster as the ray caster reads it: one 32-bit texel (B, G, R, 0 in memory) per raster
// pixel, and one more after them for the bare floor beyond the raster.
class FloorTexture {
 public:
  explicit FloorTexture(const world::FloorRaster& raster);

  int width() const { return width_; }
  int height() const { return height_; }
  double m_per_px() const { return m_per_px_; }
  const world::Vec2& origin_m() const { return origin_m_; }
  // Texel i (row-major; outside_index() is the bare floor beyond the raster) is the colour
  // palette()[palette_index()[i]] (B, G, R and a zero byte): a floor has few colours, and a byte
  // per texel keeps a lookup's memory four times smaller than the colour would.
  const std::uint8_t* palette_index() const { return index_.data(); }
  const std::uint32_t* palette() const { return palette_.data(); }
  int palette_size() const { return static_cast<int>(palette_.size()); }
  std::uint32_t outside_index() const { return static_cast<std::uint32_t>(index_.size() - 1); }
  // Texel i's label under a labelling (`labels`: the label of each palette index), one byte per
  // texel like palette_index() (outside_index() included), then kLabelTexelPadding bytes of 0 (so
  // that four bytes read from any texel's lie inside: a gather's): a labelled look-up is then one
  // load, not two dependent ones. Made once per labelling and kept, shared by every renderer of
  // this texture (the cars of a run); safe to call from several threads.
  using PaletteLabels = std::array<std::uint8_t, 256>;
  static constexpr std::size_t kLabelTexelPadding = 3;
  std::shared_ptr<const std::vector<std::uint8_t>> LabelTexels(const PaletteLabels& labels) const;

  // The colour most of the raster has (the bare floor of a track), as a palette index.
  std::uint8_t common_index() const { return common_index_; }
  // Whether every texel within `reach` texels (in column and row) of the texture point (col, row)
  // has common_index(); the square must be inside the raster (col, row >= reach). Conservative:
  // false may also mean that a texel of another colour is a little farther away (at most two
  // cells of kCommonCell texels), or that reach is above kMaxReachCells cells. One bit look-up:
  // per distance d in cells, a bitmap of the cells whose neighbours within d are all common.
  static constexpr int kCommonCell = 4;
  static constexpr int kMaxReachCells = 8;
  bool CommonWithin(float col, float row, float reach) const {
    const int d = static_cast<int>(reach * (1.0f / kCommonCell)) + 1;
    if (d > kMaxReachCells) return false;
    const int x = static_cast<int>(col) / kCommonCell;
    const int y = static_cast<int>(row) / kCommonCell;
    const std::uint64_t word =
        common_near_[(static_cast<std::size_t>(d) * cells_y_ + static_cast<std::size_t>(y)) *
                         words_per_row_ +
                     static_cast<std::size_t>(x >> 6)];
    return ((word >> (x & 63)) & 1u) != 0;
  }
  // Whether the bare floor beyond the raster (outside_index()) is the common colour.
  bool outside_is_common() const { return index_.back() == common_index_; }
  // Whether every texel of columns [c0, c1] and rows [r0, r1] (inclusive, inside the raster) has
  // common_index(); exact, for a rectangle of fewer than 65536 texels (false for a larger one):
  // four look-ups in a summed-area table of the other colours' texels, kept in 16 bits (the
  // differences are exact modulo 2^16, and the count they give is below it).
  bool CommonIn(int c0, int r0, int c1, int r1) const {
    if ((c1 - c0 + 1) * (r1 - r0 + 1) >= 65536) return false;
    const std::size_t stride = static_cast<std::size_t>(width_) + 1;
    const auto at = [&](int r, int c) {
      return others_before_[static_cast<std::size_t>(r) * stride + static_cast<std::size_t>(c)];
    };
    return static_cast<std::uint16_t>(at(r1 + 1, c1 + 1) - at(r0, c1 + 1) - at(r1 + 1, c0) +
                                      at(r0, c0)) == 0;
  }

 private:
  void IndexColours(const world::FloorRaster& raster);  // index_ and palette_
  void IndexCommonCells();                              // common_near_ from index_
  void CountOthers();                                   // others_before_ from index_
  int width_;
  int height_;
  double m_per_px_;
  world::Vec2 origin_m_;
  std::vector<std::uint8_t> index_;
  std::vector<std::uint32_t> palette_;
  mutable std::mutex label_texels_mutex_;
  mutable std::map<PaletteLabels, std::shared_ptr<const std::vector<std::uint8_t>>> label_texels_;
  std::uint8_t common_index_{0};
  std::size_t cells_y_{0};
  std::size_t words_per_row_{0};
  // bit x of word [(d · cells_y_ + y) · words_per_row_ + x / 64]: every texel of the cells within
  // d (Chebyshev) of cell (x, y) has common_index_; d = 0..kMaxReachCells.
  std::vector<std::uint64_t> common_near_;
  // [r · (width_ + 1) + c]: how many texels of rows [0, r) and columns [0, c) are not of
  // common_index_, modulo 2^16.
  std::vector<std::uint16_t> others_before_;
};

// Per-pixel geometry of one camera on a car, in the car's base frame: immutable, and shareable by
// every car carrying the same camera. About 22 bytes per pixel (6.7 MB at 640×480).
class CameraRays {
 public:
  // Throws std::invalid_argument if the lens distortion cannot be inverted at some pixel.
  explicit CameraRays(const CameraModel& camera);

  const CameraModel& camera() const { return camera_; }
  int width() const { return width_; }
  int height() const { return height_; }

  // A row segment of pixels [begin, end), as indices into the row-major image.
  struct Run {
    int begin;
    int end;
  };
  // The image tiles that prisms are tested by: their pixels and the bounds of their pixels'
  // normalized rays (x/z, y/z in the optical frame).
  struct Tile {
    int u0, v0, u1, v1;  // pixel columns [u0, u1), rows [v0, v1)
    float x_min, x_max, y_min, y_max;
  };
  static constexpr int kTileSize = 16;

  const Eigen::Vector3d& origin_base() const { return origin_base_; }
  // Each pixel's normalized ray in the optical frame (x/z, y/z; undistorted).
  const std::vector<float>& ray_x() const { return ray_x_; }
  const std::vector<float>& ray_y() const { return ray_y_; }
  // The ray of each pixel in the base frame, scaled so that the optical z is 1: the point at
  // optical depth t is origin_base() + t · dir.
  const std::vector<float>& dir_x() const { return dir_x_; }
  const std::vector<float>& dir_y() const { return dir_y_; }
  // Its z as 1 / z (float division; +-inf for 0), the form every prism's slab test needs.
  const std::vector<float>& inv_dir_z() const { return inv_dir_z_; }
  // Where each pixel's ray meets the floor (base frame, metres), and at what optical depth;
  // floor_t is +inf where it does not within the far clip.
  const std::vector<float>& floor_x() const { return floor_x_; }
  const std::vector<float>& floor_y() const { return floor_y_; }
  const std::vector<float>& floor_t() const { return floor_t_; }
  // The depth image of the bare floor.
  const std::vector<std::uint16_t>& floor_depth_mm() const { return floor_depth_mm_; }
  const std::vector<Run>& floor_runs() const { return floor_runs_; }        // see the floor
  const std::vector<Run>& surround_runs() const { return surround_runs_; }  // see nothing
  const std::vector<Tile>& tiles() const { return tiles_; }
  // The tiles row by row: tile row k is tiles()[k · tiles_per_row(), (k + 1) · tiles_per_row()),
  // and tile_rows()[k] bounds the normalized rays of all of them (its x_min..y_max; u0..v1 unused),
  // so that a prism is tested against the tiles of the rows it can reach only.
  int tiles_per_row() const { return (width_ + kTileSize - 1) / kTileSize; }
  const std::vector<Tile>& tile_rows() const { return tile_rows_; }

  // Aligned blocks of kBlockSize pixels of a row, columns [k · kBlockSize, (k + 1) · kBlockSize):
  // where all of a block's pixels see the floor, a circle (base frame, metres) holding their floor
  // points. A frame whose floor texture is one colour all over a block's circle gives the block
  // that colour without looking its pixels up (the bare floor between the painted lines).
  static constexpr int kBlockSize = 32;
  struct FloorBlock {
    float centre_x{0.0f}, centre_y{0.0f};
    float radius{-1.0f};  // < 0: not every pixel of the block sees the floor
  };
  // [row · blocks_per_row() + k]; the last block of a row is partial if the width is not a
  // multiple of kBlockSize and then never used.
  const std::vector<FloorBlock>& floor_blocks() const { return floor_blocks_; }
  int blocks_per_row() const { return (width_ + kBlockSize - 1) / kBlockSize; }
  // The same for groups of kGroupRows blocks one above the other, rows [g · kGroupRows,
  // (g + 1) · kGroupRows), at [g · blocks_per_row() + k]: near the car, where a pixel sees a few
  // millimetres of floor, one look-up settles 512 pixels.
  static constexpr int kGroupRows = 16;
  const std::vector<FloorBlock>& floor_block_groups() const { return floor_block_groups_; }

 private:
  // The constructor's steps, in order: each pixel's ray and floor hit, the floor and surround
  // runs, the floor blocks (FloorCircle of each block and group), the tiles.
  void ComputePixelRays();
  void ComputeRuns();
  FloorBlock FloorCircle(int u0, int u1, int v0, int v1) const;  // pixels [u0, u1) × [v0, v1)
  void ComputeFloorBlocks();
  void ComputeTiles();

  CameraModel camera_;
  int width_;
  int height_;
  Eigen::Vector3d origin_base_;
  std::vector<float> ray_x_, ray_y_;
  std::vector<float> dir_x_, dir_y_, inv_dir_z_;
  std::vector<float> floor_x_, floor_y_, floor_t_;
  std::vector<std::uint16_t> floor_depth_mm_;
  std::vector<Run> floor_runs_;
  std::vector<Run> surround_runs_;
  std::vector<Tile> tiles_;
  std::vector<Tile> tile_rows_;
  std::vector<FloorBlock> floor_blocks_;
  std::vector<FloorBlock> floor_block_groups_;
};

// The pixels a consumer of a colour image reads, per image row: columns [begin, end) (begin ==
// end: none of the row). A renderer asked for a region computes the colour of those pixels only
// (demand-driven sensing): the lane detector reads a third of the image.
struct RowSpans {
  std::vector<std::pair<int, int>> columns;  // one entry per image row
};
// A row's columns [first, second) widened to take in [begin, end) (an empty one, first >= second,
// set {width, 0}, takes just them).
inline void WidenColumns(std::pair<int, int>* columns, int begin, int end) {
  columns->first = std::min(columns->first, begin);
  columns->second = std::max(columns->second, end);
}

// What a consumer keeps with a depth buffer it renders one camera into frame after frame, so that
// the renderer rewrites only the pixels that can have changed: the bare floor's depth is the same
// in every frame, and only the pixels a prism covered in the last frame or covers in this one
// differ from it. It keeps, per row, the columns between the first and the last pixel the last
// frame's prisms wrote (another car usually covers a small part of a row). After each frame,
// changed_columns() says which pixels of each row may differ from the previous frame in the same
// buffer (all of them after the first frame, or after Forget()).
class DepthRowHistory {
 public:
  // Per image row: the columns [begin, end) outside which this frame's depth is the previous
  // frame's (begin == end == 0: the whole row is), the smallest range holding the groups of
  // pixels traced together (four or eight, CameraRenderer::set_wide_lanes) that the previous
  // frame's prisms and this frame's wrote: a bound, whose width may differ with the lanes; empty
  // where that is not known (every pixel may differ).
  std::span<const std::pair<int, int>> changed_columns() const { return changed_; }
  // Something else wrote the buffer (a black frame, noise): the next frame is rendered whole.
  void Forget() {
    valid_ = false;
    changed_.clear();
  }

 private:
  friend class CameraRenderer;
  bool valid_{false};
  const std::uint16_t* buffer_{nullptr};  // the buffer it describes
  // per row: the columns [begin, end) the last frame's prisms wrote depth in (0, 0: none)
  std::vector<std::pair<int, int>> prism_columns_;
  std::vector<std::pair<int, int>> changed_;
};

// What a consumer of depth images reads (demand-driven sensing, as RowSpans is for colour): per
// pixel, the farthest optical depth (metres) it can use. A surface beyond a pixel's bound is of
// no use there, nor is anything behind it, so a renderer may leave it out: the image is exact
// wherever its depth is within the bound. Also kept per tile and per row of tiles of the camera's
// rays (CameraRays::tiles), so that a prism beyond every pixel of a tile costs one comparison.
class DepthInterest {
 public:
  // farthest_m: a bound per pixel of `rays`' image, row-major (-inf: none of the pixel's depth is
  // read, +inf: all of it); std::invalid_argument if the count is not the image's or one is NaN.
  DepthInterest(const CameraRays& rays, std::vector<float> farthest_m);

  std::span<const float> pixels_m() const { return pixels_m_; }
  float farthest_m() const { return farthest_m_; }  // the largest of every pixel's
  float tile_farthest_m(std::size_t tile) const { return tiles_m_[tile]; }
  float tile_row_farthest_m(std::size_t row) const { return tile_rows_m_[row]; }
  int width() const { return width_; }
  int height() const { return height_; }

 private:
  int width_, height_;
  std::vector<float> pixels_m_;
  std::vector<float> tiles_m_;      // per CameraRays::tiles() entry
  std::vector<float> tile_rows_m_;  // per CameraRays::tile_rows() entry
  float farthest_m_;
};

// Where RenderLabels writes: the label of pixel (u, v) at origin[v · stride + u]. If
// nonzero_columns is set, RenderLabels also says there, per image row, the columns [begin, end)
// outside which every pixel it labelled got label 0 (begin >= end: none), so that a consumer
// looking for the other labels need not read the rest. A bound: it may hold label-0 pixels too,
// and its width may differ with CameraRenderer::set_wide_lanes (the images never do).
struct LabelView {
  std::uint8_t* origin{nullptr};
  std::ptrdiff_t stride{0};
  std::vector<std::pair<int, int>>* nonzero_columns{nullptr};
};
// A label per colour, for a consumer that reads a function of each pixel's colour alone (the lane
// detector reads its line classes). Called once per colour in view, not per pixel.
using ColourLabel = std::function<std::uint8_t(const Bgr&)>;

// Renders one camera. Owns its scratch memory, so frames allocate nothing once the output images
// have their size; one renderer per thread. A frame depends only on its inputs, never on the
// frames rendered before it.
class CameraRenderer {
 public:
  CameraRenderer(std::shared_ptr<const CameraRays> rays, std::shared_ptr<const FloorTexture> floor,
                 Bgr surround);

  const CameraRays& rays() const { return *rays_; }
  const CameraModel& camera() const { return rays_->camera(); }

  // The images with the car at X_map_car among `prisms` (the car's own body must not be among
  // them: its box would enclose the colour camera). Either output may be null; both are resized
  // to the camera's size.
  void Render(const world::Pose2& X_map_car, std::span<const Prism> prisms, ColorImage* color,
              DepthImage* depth);
  // The same, with the floor's and the surround's colour computed only inside `color_region`
  // (one entry per row of the camera; std::invalid_argument otherwise): those pixels are exactly
  // Render's, the others of `color` are left as they were (the depth image is always whole).
  void Render(const world::Pose2& X_map_car, std::span<const Prism> prisms, ColorImage* color,
              DepthImage* depth, const RowSpans& color_region);
  // The depth image alone, into a buffer that `history` describes (DepthRowHistory): only the
  // columns of each row that the last frame's prisms wrote are set back to the bare floor. The
  // image is exactly Render's wherever Render's is within `interest`'s bound for the pixel (null:
  // everywhere): a prism is left out where all of it is beyond the bound of every pixel of a
  // tile (or of four neighbouring pixels), for a consumer that reads nothing farther (the
  // obstacle grid, stack::FarthestCountedDepths_m); what it would have hidden is farther still.
  // std::invalid_argument if `interest` is not of this camera's size.
  void RenderDepth(const world::Pose2& X_map_car, std::span<const Prism> prisms, DepthImage* depth,
                   DepthRowHistory* history, const DepthInterest* interest = nullptr);

  // label(c) for each pixel of `region` whose colour Render would make c, written to `out`; no
  // other pixel is written. The floor has few colours and a prism's faces seven, so this costs
  // what the colour does, without the colour image.
  void RenderLabels(const world::Pose2& X_map_car, std::span<const Prism> prisms,
                    const RowSpans& region, const ColourLabel& label, LabelView out);
  // The same, except that each pixel of prism k is labelled prism_labels[k] whatever its colour
  // (one entry per prism; std::invalid_argument otherwise): which object a pixel sees, the ground
  // truth of a dataset's instance and class labels.
  void RenderLabels(const world::Pose2& X_map_car, std::span<const Prism> prisms,
                    const RowSpans& region, const ColourLabel& label, LabelView out,
                    std::span<const std::uint8_t> prism_labels);

  // Whether `prism` may cover a pixel of the image with the car at X_map_car: false only for a
  // prism the renderer would draw nothing of (behind the camera, beyond the far clip, beside the
  // view, or beyond `interest`'s bounds wherever it may be seen, as RenderDepth leaves it out),
  // so that a consumer may tell two frames apart by the car's pose and the prisms it may see.
  bool MaySee(const world::Pose2& X_map_car, const Prism& prism,
              const DepthInterest* interest = nullptr) const;

  // Floor blocks of the texture's common colour (CameraRays::FloorBlock) filled without looking
  // their pixels up, a group of them at a time where the group's circle allows: on by default;
  // off, every floor pixel is looked up (the reference that tests and benchmarks compare with).
  // The images are the same either way.
  void set_common_floor_blocks(bool on) { common_floor_blocks_on_ = on; }
  // How many pixels were filled that way, over every frame so far.
  std::uint64_t common_floor_pixels() const { return common_floor_pixels_; }

  // Whether a prism's depth (and its labels, where its faces share one) and the floor's labels
  // are computed eight pixels at a time in AVX2 registers: on by default where the CPU has AVX2
  // (x86-64; elsewhere never), four at a time otherwise. The images are the same either way, bit
  // for bit. Returns whether the setting took (false: asked for eight without AVX2).
  bool set_wide_lanes(bool on);
  bool wide_lanes() const { return wide_lanes_; }

 private:
  // std::invalid_argument unless `region` has a row per image row.
  void CheckRegion(const RowSpans& region, const char* what) const;
  // std::invalid_argument unless `interest` is null or of this camera's size.
  void CheckInterest(const DepthInterest* interest) const;
  // RenderLabels' output: where, and the labels of the floor's and the surround's colours.
  struct LabelOut {
    LabelView view;
    const ColourLabel* label{nullptr};
    std::array<std::uint8_t, 256> palette{};  // by floor palette index
    const std::uint8_t* texels{nullptr};      // by texel: FloorTexture::LabelTexels(palette)
    std::uint8_t surround{0};
    std::span<const std::uint8_t> prism_labels;  // per prism; empty: label(face colour)
    // per row, the columns that may hold a label other than 0, widened as they are written
    // (LabelView::nonzero_columns; null where not asked for, or where it is the whole region)
    std::vector<std::pair<int, int>>* nonzero{nullptr};
    // row v's labels: pixel u's at Row(v)[u]
    std::uint8_t* Row(int v) const {
      return view.origin + static_cast<std::ptrdiff_t>(v) * view.stride;
    }
    void MayBeNonzero(int v, int begin, int end) const {
      if (nonzero != nullptr) WidenColumns(&(*nonzero)[static_cast<std::size_t>(v)], begin, end);
    }
  };
  void RenderImpl(const world::Pose2& X_map_car, std::span<const Prism> prisms, ColorImage* color,
                  DepthImage* depth, const RowSpans* color_region, DepthRowHistory* history,
                  const LabelOut* labels = nullptr, const DepthInterest* interest = nullptr);
  // After a frame rendered into the buffer `history` describes: what changed, what to restore.
  void KeepHistory(const DepthImage* depth, DepthRowHistory* history);
  // Colour (or, with `labels`, labels) and depth of the floor and the surround.
  void RenderFloor(const world::Pose2& X_map_car, ColorImage* color, DepthImage* depth,
                   const RowSpans* color_region, DepthRowHistory* history, const LabelOut* labels);
  // RenderFloor's steps: the bare floor's depth (only the pixels `history` says can differ), then
  // the surround's colour and the floor's, texel by texel or a block of the common colour at once.
  struct FloorPass;
  void RestoreFloorDepth(DepthImage* depth, DepthRowHistory* history) const;
  void FillSurround(const FloorPass& pass, const std::vector<CameraRays::Run>& runs) const;
  void FillFloor(const FloorPass& pass, const std::vector<CameraRays::Run>& runs);
  // `region`: only its pixels (colour alone), or null: all of the prism's.
  // `index`: the prism's place in the frame's list (its entry of LabelOut::prism_labels).
  // `interest`: nothing is drawn where the prism is wholly beyond it (RenderDepth), or null.
  void RenderPrism(const world::Pose2& X_map_car, const Prism& prism, std::size_t index,
                   ColorImage* color, DepthImage* depth, const RowSpans* region,
                   const LabelOut* labels, const DepthInterest* interest);
  // RenderPrism's per-pixel step: the exact ray test of pixels [u_begin, u_end) of row v, and
  // the nearest surface's colour, label and depth where the prism is nearer than what they saw.
  struct PrismTrace;
  void TracePrismRow(const PrismTrace& trace, int v, int u_begin, int u_end, ColorImage* color,
                     DepthImage* depth, const LabelOut* labels);
  // The same without colour, and without labels or with one label for every face: no face to
  // find.
  void TracePrismFacelessRow(const PrismTrace& trace, int v, int u_begin, int u_end,
                             DepthImage* depth, const LabelOut* labels);
  // RenderPrism's step for one tile that the prism's bounds reach: each row's pixels (of
  // `region`, if given) traced.
  void TracePrismTile(const PrismTrace& trace, std::size_t tile, ColorImage* color,
                      DepthImage* depth, const RowSpans* region, const LabelOut* labels);
  // Columns [first, last) of row v got a prism's depth in this frame (depth_columns_hit_).
  void NoteDepthColumns(int v, int first, int last);
  void InitTileDepth(std::size_t tile);

  std::shared_ptr<const CameraRays> rays_;
  std::shared_ptr<const FloorTexture> floor_;
  Bgr surround_;
  std::vector<float> nearest_t_;           // per pixel, valid in tiles stamped with frame_
  std::vector<std::uint32_t> tile_stamp_;  // the frame in which a tile's nearest_t_ was set
  std::uint32_t frame_{0};
  // the floor's and the surround's runs within the last colour region asked for (a consumer asks
  // for the same region frame after frame: they are cut again only when it changes)
  std::vector<CameraRays::Run> floor_in_region_, surround_in_region_;
  std::vector<std::pair<int, int>> runs_region_;  // that region's columns (none: not yet cut)
  // per row: the columns [begin, end) prisms wrote depth in this frame (begin >= end: none)
  std::vector<std::pair<int, int>> depth_columns_hit_;
  // per row of floor block groups, this frame, as bits of the groups (RenderFloor): looked up;
  // not all of the common colour
  std::vector<std::uint64_t> group_seen_, group_mixed_;
  bool common_floor_blocks_on_{true};
  bool wide_lanes_;  // set_wide_lanes
  std::uint64_t common_floor_pixels_{0};
};

// Adds seeded noise to a rendered frame (either image may be null): depth z + N(0, (c·z²)²), a
// result outside the clip range reads 0; colour + N(0, σ²) per channel, rounded and saturated.
// Pixels without a return stay 0. The draws come from `seed` and the pixel's index alone (a
// counter-based generator), so a frame's noise does not depend on any other frame. The normals are
// approximated by sums of uniforms (Irwin–Hall; variance matched, tails cut at ±3.5 σ for depth
// and ±3 σ for colour), which is fast: one 64-bit draw per pixel.
void AddCameraNoise(const CameraNoiseParams& noise, const CameraParams& camera, std::uint64_t seed,
                    ColorImage* color, DepthImage* depth);

}  // namespace autonomsim::vehicle
