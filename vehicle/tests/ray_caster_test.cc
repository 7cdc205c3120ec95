// The ray caster: geometry (depth back-projects onto the floor, an obstacle face reads its
// distance, a floor marking lands on its predicted pixel, a car occludes what is behind it), the
// culling against a brute-force reference, frame independence, and seeded noise.
#include "vehicle/ray_caster.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <numbers>
#include <set>
#include <span>
#include <string>
#include <utility>
#include <vector>

namespace autonomsim::vehicle {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
const Bgr kWhite{255, 255, 255};

// A black floor of side size_m centred on the origin.
world::FloorRaster BlackFloor(double size_m = 6.0, double m_per_px = 0.005) {
  world::FloorRaster raster;
  raster.width_px = static_cast<int>(std::lround(size_m / m_per_px));
  raster.height_px = raster.width_px;
  raster.m_per_px = m_per_px;
  raster.origin_m = world::Vec2(-0.5 * size_m, 0.5 * size_m);
  raster.bgr.assign(3 * static_cast<std::size_t>(raster.width_px) * raster.height_px, 0);
  return raster;
}

// Paints the raster pixels whose centres lie in the box.
void Paint(world::FloorRaster* raster, double x_min, double x_max, double y_min, double y_max,
           const Bgr& bgr) {
  for (int row = 0; row < raster->height_px; ++row) {
    for (int col = 0; col < raster->width_px; ++col) {
      const world::Vec2 c = raster->PixelCentre(col, row);
      if (c.x() >= x_min && c.x() <= x_max && c.y() >= y_min && c.y() <= y_max) {
        std::copy(
            bgr.begin(), bgr.end(),
            raster->bgr.begin() + 3 * (static_cast<std::ptrdiff_t>(row) * raster->width_px + col));
      }
    }
  }
}

CameraRenderer MakeRenderer(const CameraParams& params, const world::FloorRaster& raster) {
  return CameraRenderer(std::make_shared<const CameraRays>(CameraModel(params)),
                        std::make_shared<const FloorTexture>(raster), SceneAppearance{}.surround());
}

Prism Box(double x, double y, double yaw, double length, double width, double height,
          const Bgr& bgr = SceneAppearance{}.obstacle()) {
  return Prism{world::OrientedBox{world::Pose2{x, y, yaw}, length, width}, height, bgr};
}

Bgr PixelAt(const ColorImage& image, int u, int v) {
  const std::size_t i = 3 * (static_cast<std::size_t>(v) * image.width + u);
  return {image.bgr[i], image.bgr[i + 1], image.bgr[i + 2]};
}

// A pixel's ray in the map frame, scaled to optical z = 1, in double precision.
Eigen::Vector3d MapRay(const CameraModel& camera, const world::Pose2& car, int u, int v) {
  const auto ray = camera.NormalizedRay(u, v);
  return camera.X_map_camera(car).linear() * Eigen::Vector3d(ray->x(), ray->y(), 1.0);
}

// The floor's labels per texel (one load per labelled look-up): each texel's is the labelling's
// label of its palette index, the bare floor beyond the raster's included; one table per
// labelling, the same table when asked again.
TEST(FloorTextureTest, LabelTexelsAreThePalettesLabelOfEachTexel) {
  world::FloorRaster raster = BlackFloor(2.0, 0.01);
  Paint(&raster, -0.5, 0.0, -0.2, 0.3, Bgr{255, 255, 255});
  Paint(&raster, 0.2, 0.4, -0.9, 0.9, Bgr{0, 200, 220});
  raster.floor_bgr = {40, 40, 40};
  const FloorTexture tex(raster);
  ASSERT_GE(tex.palette_size(), 3);
  FloorTexture::PaletteLabels first{}, second{};
  for (int k = 0; k < tex.palette_size(); ++k) {
    first[static_cast<std::size_t>(k)] = static_cast<std::uint8_t>(k + 1);
    second[static_cast<std::size_t>(k)] = static_cast<std::uint8_t>(k % 2);
  }
  for (const FloorTexture::PaletteLabels& labels : {first, second}) {
    const auto texels = tex.LabelTexels(labels);
    const std::size_t n = static_cast<std::size_t>(tex.outside_index()) + 1;
    ASSERT_EQ(texels->size(), n + FloorTexture::kLabelTexelPadding);
    for (std::size_t i = 0; i < n; ++i) {
      ASSERT_EQ((*texels)[i], labels[tex.palette_index()[i]]) << i;
    }
    for (std::size_t i = n; i < texels->size(); ++i) EXPECT_EQ((*texels)[i], 0) << i;
    EXPECT_EQ(tex.LabelTexels(labels), texels);
  }
  EXPECT_NE(tex.LabelTexels(first), tex.LabelTexels(second));
}

TEST(RayCasterTest, EmptyFloorDepthBackProjectsOntoTheFloor) {
  // Back-projection with P as the point cloud code does it (reference §3): X = (u·z - cx·z - Tx) /
  // fx, Y = (v·z - cy·z - Ty) / fy, Z = z; then through X_map_camera. Stated tolerance: the
  // height error comes from rounding depth to millimetres alone, |Δz| <= 0.5 mm · |ray_z| < 0.5 mm,
  // at every range of the clip (0.6–8 m).
  const CameraParams params = DepthCameraParams();
  const CameraModel camera(params);
  CameraRenderer renderer = MakeRenderer(params, BlackFloor());
  const world::Pose2 car{0.3, -0.2, 0.7};
  DepthImage depth;
  renderer.Render(car, {}, nullptr, &depth);
  ASSERT_EQ(depth.width, 640);
  ASSERT_EQ(depth.height, 480);

  const CameraInfo info = camera.Info();
  const auto& P = info.P;
  const Eigen::Isometry3d X_map_camera = camera.X_map_camera(car);
  const std::vector<double> edges{0.6, 1.0, 2.0, 4.0, 8.0 + 1e-9};
  std::vector<double> worst(edges.size() - 1, 0.0);
  std::vector<int> count(edges.size() - 1, 0);
  int missing = 0;
  for (int v = 0; v < depth.height; ++v) {
    for (int u = 0; u < depth.width; ++u) {
      const std::uint16_t mm = depth.mm[static_cast<std::size_t>(v) * depth.width + u];
      // where the floor is, independently: the ray from the camera's centre in double
      const Eigen::Vector3d ray = MapRay(camera, car, u, v);
      const double t_floor = ray.z() < 0.0 ? -X_map_camera.translation().z() / ray.z() : kInf;
      if (t_floor >= 0.6005 && t_floor <= 7.9995 && mm == 0) ++missing;
      if (t_floor < 0.5995 || t_floor > 8.0005) {
        EXPECT_EQ(mm, 0) << u << "," << v;
      }
      if (mm == 0) continue;
      const double z = mm / 1000.0;
      const Eigen::Vector3d p_camera((u * z - P[2] * z - P[3]) / P[0],
                                     (v * z - P[6] * z - P[7]) / P[5], z);
      const double height = (X_map_camera * p_camera).z();
      for (std::size_t b = 0; b + 1 < edges.size(); ++b) {
        if (z >= edges[b] && z < edges[b + 1]) {
          worst[b] = std::max(worst[b], std::abs(height));
          ++count[b];
        }
      }
    }
  }
  EXPECT_EQ(missing, 0);
  for (std::size_t b = 0; b + 1 < edges.size(); ++b) {
    EXPECT_GT(count[b], 1000) << "range [" << edges[b] << ", " << edges[b + 1] << ") m";
    EXPECT_LE(worst[b], 0.0005) << "range [" << edges[b] << ", " << edges[b + 1] << ") m";
  }
}

TEST(RayCasterTest, AFaceSquareToTheCameraReadsItsDistance) {
  // a level camera 0.3 m up, a wall whose near face is 2 m ahead across the optical axis
  CameraParams params = DepthCameraParams();
  params.mount = CameraMount{.z_m = 0.3};
  params.clip_near_m = 0.1;
  CameraRenderer renderer = MakeRenderer(params, BlackFloor());
  const std::vector<Prism> wall{Box(2.25, 0.0, 0.0, 0.5, 4.0, 1.0, Bgr{0, 0, 200})};
  ColorImage color;
  DepthImage depth;
  renderer.Render(world::Pose2{}, wall, &color, &depth);
  int face_pixels = 0;
  for (std::size_t i = 0; i < depth.mm.size(); ++i) {
    // the wall (pure red), not the black floor in front of it nor the grey surround
    if (color.bgr[3 * i + 2] != 0 && color.bgr[3 * i] == 0) {
      ++face_pixels;
      EXPECT_EQ(depth.mm[i], 2000);
    }
  }
  EXPECT_GT(face_pixels, 640 * 200);  // the wall spans the width and a band of rows
}

TEST(RayCasterTest, AnObliqueFaceReadsItsDistanceAtEveryPixel) {
  // the real depth camera; a box turned by 30°; the expected optical depth of each pixel on its
  // near face from a ray–plane intersection in double. Tolerance: ± 2 mm (issue 3); met with
  // ± 1 mm (rounding to millimetres plus single-precision rays).
  const CameraParams params = DepthCameraParams();
  const CameraModel camera(params);
  CameraRenderer renderer = MakeRenderer(params, BlackFloor());
  const world::Pose2 car{0.5, 0.2, 0.1};
  const double yaw = 30.0 * std::numbers::pi / 180.0;
  const Prism box = Box(2.3, 0.4, yaw, 0.4, 1.2, 0.5);
  DepthImage depth;
  renderer.Render(car, std::vector<Prism>{box}, nullptr, &depth);

  const Eigen::Vector3d axis(std::cos(yaw), std::sin(yaw), 0.0);
  const Eigen::Vector3d side(-std::sin(yaw), std::cos(yaw), 0.0);
  const Eigen::Vector3d centre(2.3, 0.4, 0.0);
  const Eigen::Vector3d normal = -axis;  // the near face, x_local = -length / 2
  const Eigen::Vector3d on_face = centre - 0.2 * axis;
  const Eigen::Vector3d origin = camera.X_map_camera(car).translation();
  constexpr double kMargin_m = 0.005;  // away from the face's edges
  int checked = 0;
  for (int v = 0; v < depth.height; ++v) {
    for (int u = 0; u < depth.width; ++u) {
      const Eigen::Vector3d ray = MapRay(camera, car, u, v);
      const double facing = normal.dot(ray);
      if (!(facing < 0.0)) continue;
      const double t = normal.dot(on_face - origin) / facing;
      const Eigen::Vector3d hit = origin + t * ray;
      const double along = side.dot(hit - centre);
      if (std::abs(along) > 0.6 - kMargin_m || hit.z() < kMargin_m || hit.z() > 0.5 - kMargin_m) {
        continue;
      }
      ++checked;
      const double mm = depth.mm[static_cast<std::size_t>(v) * depth.width + u];
      EXPECT_NEAR(mm, 1000.0 * t, 1.0) << u << "," << v;
    }
  }
  EXPECT_GT(checked, 5000);
}

TEST(RayCasterTest, FloorMarkingsLandOnTheirPredictedPixels) {
  // 2 cm white squares on a black floor, seen through the real colour camera with its lens
  // distortion (at its strongest towards the image's corners); each blob's centroid must be
  // within 1 px of its centre's projection. (Up to 1.5 m: farther, rows are > 2 cm apart on the
  // floor and a 2 cm mark is hit by one row or none, see LaneLine... for the far field.)
  const CameraParams params = ColorCameraParams();
  const CameraModel camera(params);
  world::FloorRaster raster = BlackFloor();
  const world::Pose2 car{-0.4, 0.3, -0.25};
  const std::vector<Eigen::Vector2d> marks_car{{0.5, 0.0},  {0.8, 0.3},   {1.5, -0.6},
                                               {0.7, 0.35}, {0.6, -0.35}, {1.2, 0.45}};
  std::vector<Eigen::Vector3d> marks_map;
  for (const Eigen::Vector2d& m : marks_car) {
    // centred on a raster pixel corner, so that the painted 4 × 4 pixels are centred on it
    Eigen::Vector3d p = Lift(car) * Eigen::Vector3d(m.x(), m.y(), 0.0);
    p.x() = raster.origin_m.x() + std::round((p.x() - raster.origin_m.x()) / 0.005) * 0.005;
    p.y() = raster.origin_m.y() + std::round((p.y() - raster.origin_m.y()) / 0.005) * 0.005;
    marks_map.push_back(p);
    Paint(&raster, p.x() - 0.01, p.x() + 0.01, p.y() - 0.01, p.y() + 0.01, kWhite);
  }
  CameraRenderer renderer = MakeRenderer(params, raster);
  ColorImage image;
  renderer.Render(car, {}, &image, nullptr);

  const Eigen::Isometry3d X_camera_map = camera.X_map_camera(car).inverse();
  for (const Eigen::Vector3d& p_map : marks_map) {
    const auto predicted = camera.Project(X_camera_map * p_map);
    ASSERT_TRUE(predicted.has_value());
    ASSERT_GT(predicted->x(), 10);
    ASSERT_LT(predicted->x(), 629);
    ASSERT_GT(predicted->y(), 10);
    ASSERT_LT(predicted->y(), 469);
    double sum_u = 0.0, sum_v = 0.0;
    int n = 0;
    const int u0 = static_cast<int>(predicted->x());
    const int v0 = static_cast<int>(predicted->y());
    for (int v = std::max(0, v0 - 25); v <= std::min(479, v0 + 25); ++v) {
      for (int u = std::max(0, u0 - 25); u <= std::min(639, u0 + 25); ++u) {
        if (PixelAt(image, u, v) == kWhite) {
          sum_u += u;
          sum_v += v;
          ++n;
        }
      }
    }
    ASSERT_GT(n, 0) << "mark at " << p_map.transpose() << " not seen";

    EXPECT_NEAR(sum_u / n, predicted->x(), 1.0) << p_map.transpose();
    EXPECT_NEAR(sum_v / n, predicted->y(), 1.0) << p_map.transpose();
  }
}

TEST(RayCasterTest, LaneLinePointsLandOnTheirPredictedPixelsOutToFourMetres) {
  // a 3.6 cm lane line (reference §1) running ahead from 0.5 m to 4 m, 0.3 m left of the car;
  // in each image row its centroid must be within 1 px of where its centreline projects
  const CameraParams params = ColorCameraParams();
  const CameraModel camera(params);
  world::FloorRaster raster = BlackFloor(12.0);
  const double y_line = 0.3 + 0.0025;  // centred between raster pixel centres
  Paint(&raster, 0.5, 4.0, y_line - 0.018, y_line + 0.018, kWhite);
  CameraRenderer renderer = MakeRenderer(params, raster);
  const world::Pose2 car{};
  ColorImage image;
  renderer.Render(car, {}, &image, nullptr);

  // the centreline's projection, row by row
  const Eigen::Isometry3d X_camera_map = camera.X_map_camera(car).inverse();
  std::map<int, std::pair<double, int>> predicted;  // row -> (sum of u, count)
  for (double x = 0.55; x <= 3.95; x += 0.0002) {
    const auto pixel = camera.Project(X_camera_map * Eigen::Vector3d(x, y_line, 0.0));
    ASSERT_TRUE(pixel.has_value());
    const int row = static_cast<int>(std::lround(pixel->y()));
    if (std::abs(pixel->y() - row) > 0.05) continue;  // through the row's pixel centres
    predicted[row].first += pixel->x();
    ++predicted[row].second;
  }
  int rows = 0;
  double worst = 0.0;
  for (const auto& [row, sum] : predicted) {
    if (row < 0 || row >= 480 || sum.second == 0) continue;
    double sum_u = 0.0;
    int n = 0;
    for (int u = 0; u < 640; ++u) {
      if (PixelAt(image, u, row) == kWhite) {
        sum_u += u;
        ++n;
      }
    }
    if (n < 3) continue;  // too far for a stable centroid (the line is thinner than 3 px)
    if (PixelAt(image, 0, row) == kWhite || PixelAt(image, 639, row) == kWhite) continue;  // cut
    ++rows;
    worst = std::max(worst, std::abs(sum_u / n - sum.first / sum.second));
  }
  EXPECT_GT(rows, 100);
  EXPECT_LE(worst, 1.0);
}

TEST(RayCasterTest, AnotherCarOccludesTheFloorBehindIt) {
  const CameraParams params = ColorCameraParams();
  const CameraModel camera(params);
  world::FloorRaster raster = BlackFloor();
  Paint(&raster, 1.4, 1.6, -1.0, 1.0, kWhite);  // a stop line across the lane, 1.4–1.6 m ahead
  CameraRenderer renderer = MakeRenderer(params, raster);
  const world::Pose2 car{};
  const auto pixel =
      camera.Project(camera.X_map_camera(car).inverse() * Eigen::Vector3d(1.5, 0.0, 0.0));
  ASSERT_TRUE(pixel.has_value());
  const int u = static_cast<int>(std::lround(pixel->x()));
  const int v = static_cast<int>(std::lround(pixel->y()));

  ColorImage clear;
  DepthImage clear_depth;
  renderer.Render(car, {}, &clear, &clear_depth);
  EXPECT_EQ(PixelAt(clear, u, v), kWhite);

  // another car 0.9 m ahead: its rear face (0.64 m ahead, 0.2 m tall) hides the line
  const SceneAppearance appearance;
  const Prism other = Box(0.9, 0.0, 0.0, 0.525, 0.296, 0.2, appearance.car_body(1));
  ColorImage blocked;
  DepthImage blocked_depth;
  renderer.Render(car, std::vector<Prism>{other}, &blocked, &blocked_depth);
  const Bgr body = appearance.car_body(1);
  // the rear face faces away from the light: ambient shade only (0.6)
  const Bgr rear{static_cast<std::uint8_t>(std::lround(body[0] * 0.6)),
                 static_cast<std::uint8_t>(std::lround(body[1] * 0.6)),
                 static_cast<std::uint8_t>(std::lround(body[2] * 0.6))};
  EXPECT_EQ(PixelAt(blocked, u, v), rear);
  const std::size_t i = static_cast<std::size_t>(v) * 640 + u;
  EXPECT_LT(blocked_depth.mm[i], clear_depth.mm[i]);
  // every pixel that changed now sees the car, nearer than the floor it hides
  int changed = 0;
  for (std::size_t k = 0; k < clear_depth.mm.size(); ++k) {
    if (blocked_depth.mm[k] != clear_depth.mm[k]) {
      ++changed;
      EXPECT_TRUE(blocked_depth.mm[k] < clear_depth.mm[k] || clear_depth.mm[k] == 0) << k;
    }
  }
  EXPECT_GT(changed, 10000);
}

// A brute-force reference: every prism against every pixel, in double precision.
struct Reference {
  std::vector<double> t;  // nearest hit, +inf for none
  std::vector<int> what;  // prism index, -1 floor, -2 nothing
};

Reference BruteForce(const CameraModel& camera, const world::Pose2& car,
                     const std::vector<Prism>& prisms) {
  Reference ref;
  const Eigen::Vector3d origin = camera.X_map_camera(car).translation();
  for (int v = 0; v < camera.height(); ++v) {
    for (int u = 0; u < camera.width(); ++u) {
      const Eigen::Vector3d ray = MapRay(camera, car, u, v);
      double best = kInf;
      int what = -2;
      if (ray.z() < 0.0) {
        const double t = -origin.z() / ray.z();
        if (t <= camera.params().clip_far_m) {
          best = t;
          what = -1;
        }
      }
      for (std::size_t k = 0; k < prisms.size(); ++k) {
        const world::Pose2& pose = prisms[k].footprint.pose;
        const double c = std::cos(pose.yaw_rad), s = std::sin(pose.yaw_rad);
        const Eigen::Vector3d o(c * (origin.x() - pose.x_m) + s * (origin.y() - pose.y_m),
                                -s * (origin.x() - pose.x_m) + c * (origin.y() - pose.y_m),
                                origin.z());
        const Eigen::Vector3d d(c * ray.x() + s * ray.y(), -s * ray.x() + c * ray.y(), ray.z());
        const Eigen::Vector3d lo(-0.5 * prisms[k].footprint.length_m,
                                 -0.5 * prisms[k].footprint.width_m, 0.0);
        const Eigen::Vector3d hi(-lo.x(), -lo.y(), prisms[k].height_m);
        double t_in = -kInf, t_out = kInf;
        bool miss = false;
        for (int a = 0; a < 3; ++a) {
          if (d[a] == 0.0) {
            miss = miss || o[a] < lo[a] || o[a] > hi[a];
            continue;
          }
          double ta = (lo[a] - o[a]) / d[a], tb = (hi[a] - o[a]) / d[a];
          if (ta > tb) std::swap(ta, tb);
          t_in = std::max(t_in, ta);
          t_out = std::min(t_out, tb);
        }
        if (miss || t_in > t_out || t_out <= 0.0 || t_in <= 0.0) continue;
        if (t_in <= camera.params().clip_far_m && t_in < best) {
          best = t_in;
          what = static_cast<int>(k);
        }
      }
      ref.t.push_back(best);
      ref.what.push_back(what);
    }
  }
  return ref;
}

TEST(RayCasterTest, CullingMatchesABruteForceRender) {
  // prisms ahead, beside, straddling the image plane, far, and behind the camera
  const CameraParams params = ColorCameraParams();
  const CameraModel camera(params);
  CameraRenderer renderer = MakeRenderer(params, BlackFloor());
  const world::Pose2 car{0.2, -0.1, 0.3};
  const Eigen::Isometry3d X_map_car = Lift(car);
  auto at = [&](double x, double y) { return X_map_car * Eigen::Vector3d(x, y, 0.0); };
  std::vector<Prism> prisms;
  const std::vector<std::array<double, 6>> boxes{
      {1.2, 0.1, 0.4, 0.525, 0.296, 0.2},  // a car ahead, turned
      {0.6, -0.5, 0.0, 2.0, 0.1, 0.3},     // a wall alongside, reaching behind the camera
      {6.0, 1.0, 0.2, 0.5, 0.5, 0.8},      // far
      {-1.0, 0.0, 0.0, 0.4, 0.4, 0.4},     // behind
      {0.9, 0.8, -0.3, 0.3, 0.3, 1.5},     // tall, at the edge of the view
      {1.3, -0.05, 0.0, 0.2, 0.2, 0.1}};   // partly hidden by the car
  for (std::size_t k = 0; k < boxes.size(); ++k) {
    const auto& b = boxes[k];
    const Eigen::Vector3d c = at(b[0], b[1]);
    prisms.push_back(Box(c.x(), c.y(), car.yaw_rad + b[2], b[3], b[4], b[5],
                         Bgr{static_cast<std::uint8_t>(30 * (k + 1)), 250, 10}));
  }
  ColorImage image;
  DepthImage depth;
  renderer.Render(car, prisms, &image, &depth);
  const Reference ref = BruteForce(camera, car, prisms);

  int prism_pixels = 0;
  int mismatches = 0;
  for (std::size_t i = 0; i < ref.t.size(); ++i) {
    if (ref.what[i] < 0) continue;
    ++prism_pixels;
    const Bgr got{image.bgr[3 * i], image.bgr[3 * i + 1], image.bgr[3 * i + 2]};
    // which prism the renderer drew: blue / green = 30 (k + 1) / 250 under any face shade
    const bool same_prism = got[1] >= 140 && std::lround(got[0] * 250.0 / (30.0 * got[1]) - 1.0) ==
                                                 static_cast<long>(ref.what[i]);
    const double expected_mm = ref.t[i] >= params.clip_near_m ? std::round(ref.t[i] * 1000.0) : 0.0;
    if (!same_prism || std::abs(depth.mm[i] - expected_mm) > 1.0) ++mismatches;
  }
  EXPECT_GT(prism_pixels, 20000);
  // edge pixels may differ (single vs double precision); a culling error would cost whole tiles
  EXPECT_LE(mismatches, prism_pixels / 1000) << mismatches << " of " << prism_pixels;
}

TEST(RayCasterTest, AFrameDependsOnlyOnItsInputs) {
  const CameraParams params = DepthCameraParams();
  world::FloorRaster raster = BlackFloor();
  Paint(&raster, 0.5, 0.7, -1.0, 1.0, kWhite);
  CameraRenderer renderer = MakeRenderer(params, raster);
  const world::Pose2 a{0.0, 0.0, 0.0};
  const world::Pose2 b{0.3, 0.2, 0.5};
  const std::vector<Prism> prisms_a{Box(1.5, 0.0, 0.0, 0.3, 0.3, 0.3)};
  const std::vector<Prism> prisms_b{Box(1.6, 1.0, 0.2, 0.5, 0.3, 0.3),
                                    Box(1.2, 0.3, 0.0, 0.3, 0.3, 0.3)};
  ColorImage color_1, color_2, color_b;
  DepthImage depth_1, depth_2, depth_b;
  renderer.Render(a, prisms_a, &color_1, &depth_1);
  renderer.Render(b, prisms_b, &color_b, &depth_b);
  renderer.Render(a, prisms_a, &color_2, &depth_2);
  EXPECT_EQ(color_1.bgr, color_2.bgr);
  EXPECT_EQ(depth_1.mm, depth_2.mm);
  EXPECT_NE(depth_1.mm, depth_b.mm);
  // and a fresh renderer agrees
  CameraRenderer fresh = MakeRenderer(params, raster);
  ColorImage color_3;
  DepthImage depth_3;
  fresh.Render(a, prisms_a, &color_3, &depth_3);
  EXPECT_EQ(color_1.bgr, color_3.bgr);
  EXPECT_EQ(depth_1.mm, depth_3.mm);
}

TEST(RayCasterTest, ColourOnlyAndDepthOnlyRendersAgreeWithABothRender) {
  const CameraParams params = DepthCameraParams();
  CameraRenderer renderer = MakeRenderer(params, BlackFloor());
  const std::vector<Prism> prisms{Box(1.5, 0.1, 0.3, 0.4, 0.3, 0.3)};
  ColorImage both_color, color;
  DepthImage both_depth, depth;
  renderer.Render(world::Pose2{}, prisms, &both_color, &both_depth);
  renderer.Render(world::Pose2{}, prisms, &color, nullptr);
  renderer.Render(world::Pose2{}, prisms, nullptr, &depth);
  EXPECT_EQ(both_color.bgr, color.bgr);
  EXPECT_EQ(both_depth.mm, depth.mm);
}

TEST(RayCasterTest, ADepthOnlyRenderIsTheBothRendersDepthAmongOverlappingPrismsAndTheClips) {
  // the depth-only path finds no entry face: overlapping prisms in both orders, one nearer than
  // the near clip, one enclosing the camera, one reaching past the far clip, at several poses
  CameraParams params = DepthCameraParams();
  params.clip_near_m = 0.45;  // the box at x = 0.25 m is nearer, 0.4 m from the camera
  params.clip_far_m = 6.0;    // the box at 11 m reaches inside it
  CameraRenderer renderer = MakeRenderer(params, BlackFloor());
  const std::vector<Prism> prisms{
      Box(1.2, 0.1, 0.4, 0.525, 0.296, 0.2), Box(1.5, 0.0, 0.0, 0.3, 0.3, 0.3),
      Box(0.25, 0.0, 0.0, 0.05, 0.6, 0.4),   Box(11.0, 0.5, 0.2, 4.0, 2.0, 1.0),
      Box(0.9, -0.3, 0.7, 0.2, 0.2, 0.6),    Box(0.0, 0.0, 0.0, 0.8, 0.6, 0.5)};
  for (int k = 0; k < 6; ++k) {
    const world::Pose2 car{0.05 * k, -0.02 * k, 0.1 * k - 0.2};
    // (the enclosing box only in every other frame; the others in turned order)
    std::vector<Prism> scene(prisms.begin(), prisms.end() - (k % 2 == 0 ? 1 : 0));
    if (k % 3 == 1) std::reverse(scene.begin(), scene.end());
    ColorImage both_color;
    DepthImage both_depth, depth;
    renderer.Render(car, scene, &both_color, &both_depth);
    renderer.Render(car, scene, nullptr, &depth);
    EXPECT_EQ(both_depth.mm, depth.mm) << "frame " << k;
    EXPECT_NE(std::count(depth.mm.begin(), depth.mm.end(), std::uint16_t{0}), 0) << "frame " << k;
  }
}

// A floor of 4 m with lines of two colours, 0.3 m apart both ways.
world::FloorRaster FloorWithLines() {
  world::FloorRaster raster = BlackFloor(4.0);
  for (int k = -6; k <= 6; ++k) {
    Paint(&raster, 0.3 * k, 0.3 * k + 0.02, -2.0, 2.0, kWhite);
    Paint(&raster, -2.0, 2.0, 0.3 * k + 0.1, 0.3 * k + 0.13, Bgr{0, 235, 235});
  }
  return raster;
}

// A depth interest whose bounds run from 1 m to 2.5 m and back every 1500 pixels.
DepthInterest RaggedInterest(const CameraRays& rays) {
  std::vector<float> bounds(static_cast<std::size_t>(rays.width()) * rays.height());
  for (std::size_t i = 0; i < bounds.size(); ++i) bounds[i] = 1.0f + 0.001f * (i % 1500);
  return DepthInterest(rays, bounds);
}

// Scenes of three to five boxes at staggered distances, yaws and sizes (no randomness needed),
// the farther ones first in every other scene: nearer edges cut through groups of pixels traced
// together, and a farther prism drawn after a nearer one must show exactly where it leaves off.
std::vector<Prism> StaggeredBoxes(int scene_index) {
  std::vector<Prism> scene;
  const int boxes = 3 + scene_index % 3;
  for (int b = 0; b < boxes; ++b) {
    const double k = scene_index * 7 + b * 3;
    scene.push_back(Box(0.7 + 0.45 * b + 0.013 * k, 0.23 * std::sin(1.7 * k), 0.37 * k,
                        0.18 + 0.02 * b, 0.11 + 0.015 * b, 0.12 + 0.05 * b));
  }
  if (scene_index % 2 == 1) std::reverse(scene.begin(), scene.end());
  return scene;
}

// The depth-only path writes a group of pixels at once: each keeps its depth (and the nearest
// distance the prisms drawn later compare with) unless its ray hits.
TEST(RayCasterTest,
     ADepthOnlyRenderKeepsWhatEachMissingPixelSawWhereNearerEdgesCrossFartherPrisms) {
  const CameraParams params = DepthCameraParams();
  CameraRenderer renderer = MakeRenderer(params, BlackFloor());
  int edge_pixels = 0;  // pixels whose depth differs from their left neighbour's
  for (int scene_index = 0; scene_index < 24; ++scene_index) {
    const std::vector<Prism> scene = StaggeredBoxes(scene_index);
    ColorImage both_color;
    DepthImage both_depth, depth;
    renderer.Render(world::Pose2{}, scene, &both_color, &both_depth);
    renderer.Render(world::Pose2{}, scene, nullptr, &depth);
    ASSERT_EQ(both_depth.mm, depth.mm) << "scene " << scene_index;
    for (std::size_t i = 1; i < depth.mm.size(); ++i) edge_pixels += depth.mm[i] != depth.mm[i - 1];
  }
  EXPECT_GT(edge_pixels, 1000);  // the scenes do have edges
}

// Eight pixels at a time (AVX2) or four: the same depth, with or without an interest, and the same
// labels of prisms and of a floor with lines, bit for bit.
TEST(RayCasterTest, TheWideLanesAreTheNarrowOnesBitForBit) {
  const CameraParams params = DepthCameraParams();
  const world::FloorRaster raster = FloorWithLines();
  CameraRenderer narrow = MakeRenderer(params, raster);
  CameraRenderer wide = MakeRenderer(params, raster);
  EXPECT_TRUE(narrow.set_wide_lanes(false));
  EXPECT_FALSE(narrow.wide_lanes());
  if (!wide.set_wide_lanes(true)) GTEST_SKIP() << "this CPU has no AVX2";
  const CameraRays& rays = narrow.rays();
  const DepthInterest interest = RaggedInterest(rays);
  RowSpans ragged;  // rows cut at odd columns: groups of fewer than eight or four pixels
  for (int v = 0; v < params.height_px; ++v)
    ragged.columns.emplace_back(v % 13, params.width_px - v % 7);
  const auto lines_label = [](const Bgr& c) {  // prisms are labelled by their index below
    return static_cast<std::uint8_t>(c == kWhite ? 10 : c == Bgr{0, 235, 235} ? 11 : 0);
  };
  DepthRowHistory narrow_history, wide_history;
  DepthImage narrow_limited, wide_limited;
  std::map<std::uint8_t, int> labelled;  // pixels per prism label, over the scenes
  for (int scene_index = 0; scene_index < 24; ++scene_index) {
    const std::vector<Prism> scene = StaggeredBoxes(scene_index);
    const world::Pose2 car{0.02 * scene_index, -0.01 * scene_index, 0.03 * scene_index};
    std::array<DepthImage, 2> depth;
    narrow.Render(car, scene, nullptr, &depth[0]);
    wide.Render(car, scene, nullptr, &depth[1]);
    ASSERT_EQ(depth[0].mm, depth[1].mm) << "scene " << scene_index;
    narrow.RenderDepth(car, scene, &narrow_limited, &narrow_history, &interest);
    wide.RenderDepth(car, scene, &wide_limited, &wide_history, &interest);
    ASSERT_EQ(narrow_limited.mm, wide_limited.mm) << "scene " << scene_index;
    std::vector<std::uint8_t> ids(scene.size());
    for (std::size_t k = 0; k < ids.size(); ++k) ids[k] = static_cast<std::uint8_t>(k + 1);
    std::array<std::vector<std::uint8_t>, 2> labels;
    for (std::size_t w = 0; w < 2; ++w) {
      labels[w].assign(depth[0].mm.size(), 99);
      (w == 0 ? narrow : wide)
          .RenderLabels(car, scene, ragged, lines_label,
                        LabelView{labels[w].data(), params.width_px}, ids);
    }
    ASSERT_EQ(labels[0], labels[1]) << "scene " << scene_index;
    for (std::uint8_t l : labels[0]) ++labelled[l];
  }
  // every scene's boxes seen, each nearer one hiding part of the others; both lines' colours
  for (std::uint8_t id : {1, 2, 3, 4, 5, 10, 11}) EXPECT_GT(labelled[id], 10000) << int{id};
}

// The same where a tile's rows are cut short by the image's edge (643 columns: the last tile three
// wide), so that both widths trace groups of fewer pixels than their lanes, for the depth image
// with and without an interest, against the render with faces too.
TEST(RayCasterTest, TheWideLanesAreTheNarrowOnesWhereTheImageEdgeCutsATilesRows) {
  CameraParams params = DepthCameraParams();
  params.width_px = 643;  // (K's centre as it was: the image reaches three columns further right)
  CameraRenderer narrow = MakeRenderer(params, BlackFloor());
  CameraRenderer wide = MakeRenderer(params, BlackFloor());
  narrow.set_wide_lanes(false);
  const bool has_wide = wide.set_wide_lanes(true);
  const CameraRays& rays = narrow.rays();
  const DepthInterest interest = RaggedInterest(rays);
  DepthRowHistory narrow_history, wide_history;
  DepthImage narrow_limited, wide_limited;
  int edge_hits = 0;  // depth written in the last three columns
  for (int scene_index = 0; scene_index < 24; ++scene_index) {
    std::vector<Prism> scene = StaggeredBoxes(scene_index);
    for (Prism& prism : scene) prism.footprint.pose.y_m -= 0.5;  // towards the right edge
    const world::Pose2 car{0.02 * scene_index, -0.01 * scene_index, -0.03 * scene_index};
    ColorImage both_color;
    std::array<DepthImage, 3> depth;  // faces, narrow, wide
    narrow.Render(car, scene, &both_color, &depth[0]);
    narrow.Render(car, scene, nullptr, &depth[1]);
    wide.Render(car, scene, nullptr, &depth[2]);
    ASSERT_EQ(depth[0].mm, depth[1].mm) << "scene " << scene_index;
    ASSERT_EQ(depth[1].mm, depth[2].mm) << "scene " << scene_index;
    narrow.RenderDepth(car, scene, &narrow_limited, &narrow_history, &interest);
    wide.RenderDepth(car, scene, &wide_limited, &wide_history, &interest);
    ASSERT_EQ(narrow_limited.mm, wide_limited.mm) << "scene " << scene_index;
    for (int v = 0; v < params.height_px; ++v) {
      for (int u = 640; u < 643; ++u) {
        const std::size_t i = static_cast<std::size_t>(v) * 643 + static_cast<std::size_t>(u);
        edge_hits += static_cast<int>(depth[1].mm[i] != rays.floor_depth_mm()[i]);
      }
    }
  }
  EXPECT_GT(edge_hits, 500);  // prisms do reach the cut tiles (1117 pixels)
  if (!has_wide) GTEST_SKIP() << "this CPU has no AVX2: the narrow lanes checked alone";
}

// RenderDepth with a depth interest (issue 38: the obstacle grid reads each pixel's depth only up
// to where its ray leaves the obstacle box) is Render's image wherever that is within the pixel's
// bound, frame after frame in one buffer, and leaves out what lies beyond it.
TEST(RayCasterTest, ADepthInterestLeavesOutOnlyWhatIsBeyondEachPixelsBound) {
  const CameraParams params = DepthCameraParams();
  CameraRenderer renderer = MakeRenderer(params, BlackFloor());
  const CameraRays& rays = renderer.rays();
  // bounds as the grid's: farthest at the image's centre, nearer towards its sides; none in the
  // top rows, all of the depth in a band of rows
  std::vector<float> bounds(static_cast<std::size_t>(rays.width()) * rays.height());
  for (int v = 0; v < rays.height(); ++v) {
    for (int u = 0; u < rays.width(); ++u) {
      const double off_centre = std::abs(u - 0.5 * rays.width()) / (0.5 * rays.width());
      float bound = static_cast<float>(2.2 - 1.4 * off_centre);
      if (v < 40) bound = -std::numeric_limits<float>::infinity();
      if (v >= 300 && v < 310) bound = std::numeric_limits<float>::infinity();
      bounds[static_cast<std::size_t>(v) * rays.width() + u] = bound;
    }
  }
  const DepthInterest interest(rays, bounds);
  EXPECT_FLOAT_EQ(interest.farthest_m(), std::numeric_limits<float>::infinity());
  const std::vector<Prism> prisms{Box(1.2, 0.0, 0.3, 0.3, 0.3, 0.3),    // near
                                  Box(3.0, 0.1, 0.0, 0.5, 0.4, 0.3),    // far, partly behind it
                                  Box(2.6, -0.6, 0.5, 0.4, 0.4, 0.3),   // far, beside
                                  Box(1.9, 0.5, 0.0, 0.8, 0.2, 0.3),    // straddling the bounds
                                  Box(0.9, -0.7, 0.0, 0.3, 0.3, 0.3)};  // near, beside
  DepthImage limited;
  DepthRowHistory history;
  for (int k = 0; k < 4; ++k) {
    const world::Pose2 car{0.1 * k, 0.05 * k, 0.05 * k};
    DepthImage full;
    renderer.Render(car, prisms, nullptr, &full);
    renderer.RenderDepth(car, prisms, &limited, &history, &interest);
    int within = 0, left_out = 0;
    for (std::size_t i = 0; i < full.mm.size(); ++i) {
      if (full.mm[i] != 0 && full.mm[i] <= 1000.0 * bounds[i]) {
        ++within;
        EXPECT_EQ(limited.mm[i], full.mm[i]) << "frame " << k << " pixel " << i;
      } else if (limited.mm[i] != full.mm[i]) {
        ++left_out;  // a prism's pixel now shows what is behind it: farther still, or nothing
        EXPECT_TRUE(limited.mm[i] == 0 || limited.mm[i] > full.mm[i]) << "pixel " << i;
      }
    }
    EXPECT_GT(within, 10000) << "frame " << k;
    EXPECT_GT(left_out, 1000) << "frame " << k;
    // MaySee with the interest names the prisms that matter: the others changed nothing
    std::vector<Prism> seen;
    for (const Prism& prism : prisms) {
      if (renderer.MaySee(car, prism, &interest)) seen.push_back(prism);
    }
    EXPECT_TRUE(seen.size() >= 1 && seen.size() < prisms.size()) << seen.size();
    DepthImage only_seen;
    DepthRowHistory fresh;
    renderer.RenderDepth(car, seen, &only_seen, &fresh, &interest);
    EXPECT_EQ(only_seen.mm, limited.mm) << "frame " << k;
  }
  // an interest everywhere beyond reach leaves nothing out
  const DepthInterest all(rays, std::vector<float>(bounds.size(), 1e9f));
  DepthImage full, whole;
  DepthRowHistory fresh;
  renderer.Render(world::Pose2{}, prisms, nullptr, &full);
  renderer.RenderDepth(world::Pose2{}, prisms, &whole, &fresh, &all);
  EXPECT_EQ(whole.mm, full.mm);
  // an interest of another size is refused
  EXPECT_THROW(DepthInterest(rays, std::vector<float>(10, 1.0f)), std::invalid_argument);
  CameraParams small = params;
  small.width_px = 320;
  small.height_px = 240;
  CameraRenderer other = MakeRenderer(small, BlackFloor());
  EXPECT_THROW(other.RenderDepth(world::Pose2{}, prisms, &whole, &fresh, &interest),
               std::invalid_argument);
}

// MaySee is false only for a prism that changes no pixel: with it left out, the images are the
// same (issue 38: a consumer keys its frames on the car's pose and the prisms it may see).
TEST(RayCasterTest, APrismTheCameraMayNotSeeChangesNoPixel) {
  const CameraParams params = ColorCameraParams();
  world::FloorRaster raster = BlackFloor();
  Paint(&raster, 0.5, 0.54, -2.0, 2.0, kWhite);
  CameraRenderer renderer = MakeRenderer(params, raster);
  const world::Pose2 car{0.1, -0.2, 0.4};
  const Prism ahead = Box(1.0, 0.0, 0.2, 0.3, 0.3, 0.3);
  int unseen = 0, seen = 0;
  // a ring of boxes around the car, near and far, beside, behind and ahead of the camera
  for (int k = 0; k < 48; ++k) {
    const double bearing = car.yaw_rad + k * (2.0 * std::numbers::pi / 24.0);
    const double range = k < 24 ? 0.9 : 12.0;
    const Prism other = Box(car.x_m + range * std::cos(bearing),
                            car.y_m + range * std::sin(bearing), 0.1 * k, 0.3, 0.2, 0.25);
    if (renderer.MaySee(car, other)) {
      ++seen;
      continue;
    }
    ++unseen;
    ColorImage with_color, without_color;
    DepthImage with_depth, without_depth;
    renderer.Render(car, std::vector<Prism>{ahead, other}, &with_color, &with_depth);
    renderer.Render(car, std::vector<Prism>{ahead}, &without_color, &without_depth);
    EXPECT_EQ(with_color.bgr, without_color.bgr) << "box " << k;
    EXPECT_EQ(with_depth.mm, without_depth.mm) << "box " << k;
  }
  EXPECT_TRUE(renderer.MaySee(car, ahead));
  EXPECT_GT(unseen, 20);
  EXPECT_GT(seen, 3);
}

TEST(RayCasterTest, ADemandDrivenRenderIsTheFullRenderWhereItIsAsked) {
  // a textured floor, cars and boxes in view, 24 poses; the region a trapezoid like the lane
  // detector's, reaching both image edges, with rows left out, and shifted now and then (the
  // renderer keeps what it cut for the last region)
  const CameraParams params = ColorCameraParams();
  world::FloorRaster raster = BlackFloor();
  Paint(&raster, 0.5, 0.54, -2.0, 2.0, kWhite);
  Paint(&raster, -2.0, 2.0, 0.3, 0.34, kWhite);
  Paint(&raster, 1.0, 1.04, -2.0, 2.0, Bgr{0, 235, 235});
  CameraRenderer renderer = MakeRenderer(params, raster);
  int untouched = 0;
  int prism_pixels_in_region = 0;
  for (int k = 0; k < 24; ++k) {
    RowSpans region;
    region.columns.assign(static_cast<std::size_t>(params.height_px), {0, 0});
    const int shift = k % 5 < 2 ? 0 : 15 * (k % 5);
    for (int row = 200; row < params.height_px; ++row) {
      if (row % 37 == 0) continue;
      const int half = (row - 200) * 2;
      region.columns[static_cast<std::size_t>(row)] = {
          std::max(0, 300 + shift - half), std::min(params.width_px, 340 + shift + half)};
    }
    const world::Pose2 pose{-1.0 + 0.1 * k, 0.4 - 0.05 * k, 0.26 * k};
    const Eigen::Isometry3d X_map_car = Lift(pose);
    const Eigen::Vector3d ahead = X_map_car * Eigen::Vector3d(1.0 + 0.05 * k, 0.2 - 0.02 * k, 0.0);
    const Eigen::Vector3d side = X_map_car * Eigen::Vector3d(0.7, -0.35, 0.0);
    const std::vector<Prism> prisms{
        Box(ahead.x(), ahead.y(), 0.4 * k, 0.525, 0.296, 0.2, Bgr{200, 80, 30}),
        Box(side.x(), side.y(), 0.0, 0.2, 0.2, 0.3, Bgr{40, 40, 190})};
    ColorImage full, demand;
    DepthImage full_depth, demand_depth;
    renderer.Render(pose, prisms, &full, &full_depth);
    demand.width = full.width;
    demand.height = full.height;
    demand.bgr.assign(full.bgr.size(), 0xAB);  // what the buffer held
    renderer.Render(pose, prisms, &demand, &demand_depth, region);
    EXPECT_EQ(demand_depth.mm, full_depth.mm);
    // colour alone: the prisms too are computed only inside the region
    ColorImage colour_only;
    renderer.Render(pose, prisms, &colour_only, nullptr, region);
    for (int row = 0; row < params.height_px; ++row) {
      const auto [c0, c1] = region.columns[static_cast<std::size_t>(row)];
      for (int col = 0; col < params.width_px; ++col) {
        const std::size_t i = 3 * (static_cast<std::size_t>(row) * params.width_px + col);
        if (col >= c0 && col < c1) {
          ASSERT_TRUE(std::equal(&full.bgr[i], &full.bgr[i] + 3, &demand.bgr[i]))
              << "pose " << k << " row " << row << " col " << col;
          ASSERT_TRUE(std::equal(&full.bgr[i], &full.bgr[i] + 3, &colour_only.bgr[i]))
              << "colour alone: pose " << k << " row " << row << " col " << col;
          prism_pixels_in_region += full.bgr[i] != 0 && full.bgr[i] != 255 && full.bgr[i] != 110;
        } else {
          untouched += demand.bgr[i] == 0xAB && demand.bgr[i + 1] == 0xAB;
        }
      }
    }
  }
  EXPECT_GT(untouched, 24 * 100000);             // the floor outside the region was not computed
  EXPECT_GT(prism_pixels_in_region, 24 * 1000);  // the comparison saw the prisms
  EXPECT_THROW(renderer.Render(world::Pose2{}, {}, nullptr, nullptr, RowSpans{}),
               std::invalid_argument);
}

TEST(RayCasterTest, AFloorBlockFilledWithTheCommonColourIsWhatItsPixelsWouldLookUp) {
  // Thin lines every 0.3 m both ways (a block's circle often touches one), a second bare colour
  // beyond the raster; poses all over it, some looking out of it, with cars and boxes in view.
  const CameraParams params = ColorCameraParams();
  world::FloorRaster raster = BlackFloor(4.0);
  raster.floor_bgr = {10, 20, 30};
  for (int k = -6; k <= 6; ++k) {
    Paint(&raster, 0.3 * k, 0.3 * k + 0.02, -2.0, 2.0, kWhite);
    Paint(&raster, -2.0, 2.0, 0.3 * k + 0.1, 0.3 * k + 0.13, Bgr{0, 235, 235});
  }
  CameraRenderer fast = MakeRenderer(params, raster);
  CameraRenderer each_pixel = MakeRenderer(params, raster);
  each_pixel.set_common_floor_blocks(false);
  for (int k = 0; k < 24; ++k) {
    const world::Pose2 pose{-1.8 + 0.16 * k, 1.2 - 0.11 * k, 0.27 * k};
    const Eigen::Isometry3d X_map_car = Lift(pose);
    const Eigen::Vector3d ahead = X_map_car * Eigen::Vector3d(0.9, 0.1, 0.0);
    const std::vector<Prism> prisms{Box(ahead.x(), ahead.y(), 0.3 * k, 0.525, 0.296, 0.2)};
    ColorImage a, b;
    fast.Render(pose, prisms, &a, nullptr);
    each_pixel.Render(pose, prisms, &b, nullptr);
    ASSERT_EQ(a.bgr, b.bgr) << "pose " << k;
    // a region whose edges cut rows anywhere in a block (a lane detector's trapezoid): a block
    // the region covers in part is filled where the whole block is of the common colour
    RowSpans region;
    for (int v = 0; v < params.height_px; ++v) {
      region.columns.emplace_back(std::min(params.width_px, (v * 7 + k) % 61 + v / 3),
                                  std::max(0, params.width_px - (v * 5 + 3 * k) % 37 - v / 4));
    }
    std::fill(a.bgr.begin(), a.bgr.end(), std::uint8_t{77});  // what is not written stays
    std::fill(b.bgr.begin(), b.bgr.end(), std::uint8_t{77});
    fast.Render(pose, prisms, &a, nullptr, region);
    each_pixel.Render(pose, prisms, &b, nullptr, region);
    ASSERT_EQ(a.bgr, b.bgr) << "pose " << k << " in the region";
    // the same as labels (a label per colour, the lane nodes' path)
    const ColourLabel label = [](const Bgr& bgr) {
      return static_cast<std::uint8_t>(bgr[0] / 64 + 1);
    };
    std::vector<std::uint8_t> la(a.bgr.size() / 3, 0), lb(la.size(), 0);
    fast.RenderLabels(pose, prisms, region, label, LabelView{la.data(), params.width_px});
    each_pixel.RenderLabels(pose, prisms, region, label, LabelView{lb.data(), params.width_px});
    ASSERT_EQ(la, lb) << "pose " << k << ", labels in the region";
  }
  EXPECT_EQ(each_pixel.common_floor_pixels(), 0u);
  // most of a 640x480 view is bare floor: 640 / kBlockSize blocks a row, hundreds of rows
  EXPECT_GT(fast.common_floor_pixels(), 24u * 2000u * CameraRays::kBlockSize);
}

// Where the bare floor beyond the raster is the common colour, a block whose circle reaches
// beyond the raster is decided by its part inside (issue 38: a lane camera near the track's edge
// sees beyond it in a quarter of its blocks). Looking out of the raster from near its edge, the
// images are the pixel-by-pixel ones either way, and more blocks are filled when the colours match.
TEST(RayCasterTest, BeyondTheRasterTheBareFloorOfTheCommonColourFillsBlocks) {
  const CameraParams params = ColorCameraParams();
  std::uint64_t filled[2] = {0, 0};
  for (int same = 0; same < 2; ++same) {
    world::FloorRaster raster = BlackFloor(4.0);
    raster.floor_bgr = same != 0 ? Bgr{0, 0, 0} : Bgr{10, 20, 30};
    for (int k = -6; k <= 6; ++k) Paint(&raster, 0.3 * k, 0.3 * k + 0.02, -2.0, 2.0, kWhite);
    CameraRenderer fast = MakeRenderer(params, raster);
    CameraRenderer each_pixel = MakeRenderer(params, raster);
    each_pixel.set_common_floor_blocks(false);
    for (int k = 0; k < 16; ++k) {
      // near the raster's edges (±2 m), looking out or along them
      const double a = k * (std::numbers::pi / 8.0);
      const world::Pose2 pose{1.5 * std::cos(a), 1.5 * std::sin(a), a + 0.3 * (k % 3 - 1)};
      ColorImage fast_image, reference;
      fast.Render(pose, {}, &fast_image, nullptr);
      each_pixel.Render(pose, {}, &reference, nullptr);
      ASSERT_EQ(fast_image.bgr, reference.bgr) << "pose " << k << ", same colour " << same;
    }
    filled[same] = fast.common_floor_pixels();
  }
  EXPECT_GT(filled[1], filled[0] + 16u * 500u * CameraRays::kBlockSize)
      << filled[0] << " " << filled[1];
}

// Every pixel where `image` differs from `previous` lies within its row's changed columns.
void ExpectChangedColumnsHoldEveryChange(const DepthImage& image, const DepthImage& previous,
                                         std::span<const std::pair<int, int>> changed,
                                         const std::string& where) {
  ASSERT_EQ(changed.size(), static_cast<std::size_t>(image.height)) << where;
  for (int v = 0; v < image.height; ++v) {
    const auto [begin, end] = changed[static_cast<std::size_t>(v)];
    ASSERT_TRUE(begin >= 0 && begin <= end && end <= image.width) << where << " row " << v;
    ASSERT_TRUE(begin < end || begin == 0) << where << " row " << v << ": none is (0, 0)";
    for (int u = 0; u < image.width; ++u) {
      const std::size_t i = static_cast<std::size_t>(v) * image.width + u;
      if (image.mm[i] != previous.mm[i]) {
        ASSERT_TRUE(u >= begin && u < end) << where << " pixel (" << u << ", " << v
                                           << ") changed outside [" << begin << ", " << end << ")";
      }
    }
  }
}

TEST(RayCasterTest, ADepthBufferWithItsHistoryIsRewrittenOnlyWhereItCanHaveChanged) {
  // A box drives into view, across and out again; one buffer, frame after frame.
  const CameraParams params = DepthCameraParams();
  const int w = params.width_px;
  CameraRenderer renderer = MakeRenderer(params, BlackFloor());
  DepthImage buffer, previous, whole;
  DepthRowHistory history;
  int unchanged_rows = 0;
  for (int k = 0; k < 30; ++k) {
    std::vector<Prism> prisms;
    if (k >= 3 && k < 25) prisms.push_back(Box(1.2, -0.8 + 0.08 * k, 0.2 * k, 0.525, 0.296, 0.2));
    if (k == 10) prisms.push_back(Box(0.8, 0.0, 0.0, 0.2, 0.2, 0.3));  // one frame only
    renderer.RenderDepth(world::Pose2{}, prisms, &buffer, &history);
    renderer.Render(world::Pose2{}, prisms, nullptr, &whole);
    ASSERT_EQ(buffer.mm, whole.mm) << "frame " << k;
    const std::span<const std::pair<int, int>> changed = history.changed_columns();
    if (k == 0) {
      EXPECT_EQ(std::count(changed.begin(), changed.end(), std::pair{0, w}), params.height_px)
          << "the first frame is all new";
    } else {
      ExpectChangedColumnsHoldEveryChange(whole, previous, changed, "frame " + std::to_string(k));
    }
    unchanged_rows += std::count(changed.begin(), changed.end(), std::pair{0, 0});
    previous = whole;
  }
  EXPECT_GT(unchanged_rows, 29 * 200);  // rows without the box are not rewritten
  // After Forget the next frame is whole again and says so.
  history.Forget();
  EXPECT_TRUE(history.changed_columns().empty());
  std::fill(buffer.mm.begin(), buffer.mm.end(), 7);
  renderer.RenderDepth(world::Pose2{}, {}, &buffer, &history);
  renderer.Render(world::Pose2{}, {}, nullptr, &whole);
  EXPECT_EQ(buffer.mm, whole.mm);
  EXPECT_EQ(std::count(history.changed_columns().begin(), history.changed_columns().end(),
                       std::pair{0, w}),
            params.height_px);
}

TEST(RayCasterTest, ADepthBufferRestoredWhereTheLastFramesPrismsWereIsTheFullRenderEveryFrame) {
  // Prisms moving, appearing and disappearing, several in the same rows: a car crossing the whole
  // view (half out of it at either end), a box that comes and goes, one at the right edge that
  // flickers, a wall across the view for one frame and a box around the camera for another. Each
  // frame of the one buffer is a fresh renderer's full render, and only the columns near the
  // prisms are said to have changed.
  const CameraParams params = DepthCameraParams();
  const int w = params.width_px;
  CameraRenderer renderer = MakeRenderer(params, BlackFloor());
  CameraRenderer fresh = MakeRenderer(params, BlackFloor());
  DepthImage buffer, previous, whole;
  DepthRowHistory history;
  int untouched_rows = 0, part_rows = 0, whole_rows = 0;
  for (int k = 0; k < 32; ++k) {
    std::vector<Prism> prisms;
    prisms.push_back(Box(1.5, 1.0 - 0.065 * k, 0.1 * k, 0.525, 0.296, 0.2));
    if ((k >= 5 && k < 12) || (k >= 18 && k < 22)) {
      prisms.push_back(Box(0.9, 0.3 * std::sin(0.7 * k), 0.3, 0.2, 0.2, 0.3));
    }
    if (k % 2 == 0) prisms.push_back(Box(0.8 + 0.01 * k, -0.62, 0.0, 0.2, 0.2, 0.25));
    if (k == 15) prisms.push_back(Box(2.5, 0.0, 0.0, 0.1, 6.0, 0.5));
    if (k == 26) prisms.push_back(Box(0.0, 0.0, 0.0, 2.0, 2.0, 1.0));  // the camera inside
    renderer.RenderDepth(world::Pose2{}, prisms, &buffer, &history);
    fresh.Render(world::Pose2{}, prisms, nullptr, &whole);
    ASSERT_EQ(buffer.mm, whole.mm) << "frame " << k;
    if (k > 0) {
      ExpectChangedColumnsHoldEveryChange(whole, previous, history.changed_columns(),
                                          "frame " + std::to_string(k));
    }
    for (const auto& [begin, end] : history.changed_columns()) {
      untouched_rows += end == begin;
      part_rows += end > begin && end - begin < w;
      whole_rows += end - begin == w;
    }
    previous = whole;
  }
  // the prisms cover part of a row, except in frame 0 and the wall's and the enclosing box's
  // frames and those after them
  EXPECT_GT(part_rows, 31 * 50);
}

TEST(RayCasterTest, LabelsAreEachPixelsColourLabelledWhereAskedAndNothingElseIsWritten) {
  // Lines of two colours, cars and boxes in view (their shaded faces: more colours), 24 poses;
  // a label that tells many colours apart; the labels into a padded buffer, as the lane detector
  // keeps its classes.
  const CameraParams params = ColorCameraParams();
  const world::FloorRaster raster = FloorWithLines();
  CameraRenderer renderer = MakeRenderer(params, raster);
  RowSpans region;
  region.columns.assign(static_cast<std::size_t>(params.height_px), {0, 0});
  for (int row = 150; row < params.height_px; ++row) {
    if (row % 41 == 0) continue;
    region.columns[static_cast<std::size_t>(row)] = {
        std::max(0, 310 - 2 * (row - 150)), std::min(params.width_px, 330 + 3 * (row - 150))};
  }
  const ColourLabel label = [](const Bgr& c) {
    return static_cast<std::uint8_t>(1 + (c[0] * 7 + c[1] * 3 + c[2]) % 251);
  };
  const ColourLabel lines_or_not = [](const Bgr& c) {
    return static_cast<std::uint8_t>(c == kWhite ? 1 : c == Bgr{0, 235, 235} ? 2 : 3);
  };
  const std::ptrdiff_t stride = params.width_px + 2;
  std::vector<std::uint8_t> padded(static_cast<std::size_t>(stride) * (params.height_px + 2));
  std::set<std::uint8_t> seen;
  for (int k = 0; k < 24; ++k) {
    const world::Pose2 pose{-1.6 + 0.14 * k, 1.0 - 0.09 * k, 0.27 * k};
    const Eigen::Isometry3d X_map_car = Lift(pose);
    const Eigen::Vector3d ahead = X_map_car * Eigen::Vector3d(0.8 + 0.03 * k, 0.15, 0.0);
    const Eigen::Vector3d side = X_map_car * Eigen::Vector3d(0.6, -0.3, 0.0);
    const std::vector<Prism> prisms{Box(ahead.x(), ahead.y(), 0.3 * k, 0.525, 0.296, 0.2),
                                    Box(side.x(), side.y(), 0.0, 0.2, 0.2, 0.3, Bgr{40, 40, 190})};
    ColorImage full;
    renderer.Render(pose, prisms, &full, nullptr);
    // a label per colour, and (as the lane detector's) one for the lines' colours and one for
    // every other, every face of a prism alike
    for (const ColourLabel& labelling : {label, lines_or_not}) {
      std::fill(padded.begin(), padded.end(), 0);
      renderer.RenderLabels(pose, prisms, region, labelling,
                            LabelView{padded.data() + stride + 1, stride});
      for (int v = -1; v <= params.height_px; ++v) {
        for (int u = -1; u <= params.width_px; ++u) {
          const std::uint8_t got = padded[static_cast<std::size_t>((v + 1) * stride + u + 1)];
          const bool asked = v >= 0 && v < params.height_px &&
                             u >= region.columns[static_cast<std::size_t>(v)].first &&
                             u < region.columns[static_cast<std::size_t>(v)].second;
          if (!asked) {
            ASSERT_EQ(got, 0) << "pose " << k << " (" << u << ", " << v << ") was not asked for";
            continue;
          }
          ASSERT_EQ(got, labelling(PixelAt(full, u, v)))
              << "pose " << k << " (" << u << ", " << v << ")";
          seen.insert(got);
        }
      }
    }
  }
  EXPECT_GE(seen.size(), 6u);  // floor, lines, surround and prism faces were all compared
  EXPECT_THROW(renderer.RenderLabels(world::Pose2{}, {}, RowSpans{}, label,
                                     LabelView{padded.data(), stride}),
               std::invalid_argument);
}

// LabelView::nonzero_columns: every pixel outside a row's columns got label 0 (the lane detector
// searches only inside them), and the columns are a small part of the region where the floor's
// common colour and the surround are labelled 0; otherwise they are the whole region.
TEST(RayCasterTest, NonzeroColumnsBoundEveryLabelOtherThanZero) {
  const CameraParams params = ColorCameraParams();
  world::FloorRaster raster = BlackFloor(4.0);
  Paint(&raster, -2.0, 2.0, 0.0, 0.03, kWhite);  // one line along x
  CameraRenderer renderer = MakeRenderer(params, raster);
  const Bgr surround = SceneAppearance{}.surround();
  const ColourLabel lines = [&](const Bgr& c) {  // 0 for the black floor and the surround
    return static_cast<std::uint8_t>(c == Bgr{0, 0, 0} || c == surround ? 0 : 1 + c[2] % 7);
  };
  RowSpans region;
  for (int v = 0; v < params.height_px; ++v) {
    region.columns.emplace_back(v % 50, params.width_px - v % 70);
  }
  std::vector<std::uint8_t> labels(static_cast<std::size_t>(params.width_px) * params.height_px);
  std::vector<std::pair<int, int>> nonzero;
  std::size_t region_pixels = 0, inside = 0, labelled = 0;
  for (const auto& [begin, end] : region.columns) region_pixels += end - begin;
  for (int k = 0; k < 12; ++k) {
    const world::Pose2 pose{-1.5 + 0.25 * k, 0.1 * (k % 5 - 2), 0.08 * (k % 7 - 3)};
    const Eigen::Vector3d ahead = Lift(pose) * Eigen::Vector3d(1.2, 0.2 * (k % 3 - 1), 0.0);
    const std::vector<Prism> prisms{
        Box(ahead.x(), ahead.y(), 0.3 * k, 0.525, 0.296, 0.2, Bgr{40, 40, 190})};
    std::fill(labels.begin(), labels.end(), std::uint8_t{0});
    renderer.RenderLabels(pose, prisms, region, lines,
                          LabelView{labels.data(), params.width_px, &nonzero});
    ASSERT_EQ(nonzero.size(), region.columns.size());
    for (int v = 0; v < params.height_px; ++v) {
      const auto [begin, end] = nonzero[static_cast<std::size_t>(v)];
      inside += static_cast<std::size_t>(std::max(0, end - begin));
      for (int u = 0; u < params.width_px; ++u) {
        const std::uint8_t got = labels[static_cast<std::size_t>(v) * params.width_px + u];
        labelled += got != 0;
        if (u < begin || u >= end) {
          ASSERT_EQ(got, 0) << "pose " << k << " (" << u << ", " << v << ")";
        }
      }
    }
  }
  std::printf("  per frame: %zu pixels labelled, %zu in the columns, %zu in the region\n",
              labelled / 12, inside / 12, region_pixels);
  EXPECT_GT(labelled, 12u * 1000u);  // the line and the box were in view
  EXPECT_LT(inside, 2 * labelled);   // the columns hug them
  EXPECT_LT(inside, 12u * region_pixels / 2);
  // with the floor's colour labelled, every column of the region may hold a label
  const ColourLabel all = [](const Bgr& c) { return static_cast<std::uint8_t>(1 + c[0] % 5); };
  renderer.RenderLabels(world::Pose2{}, {}, region, all,
                        LabelView{labels.data(), params.width_px, &nonzero});
  EXPECT_EQ(nonzero, region.columns);
}

TEST(RayCasterTest, PrismLabelsNameTheObjectEachPixelSeesWhateverItsColour) {
  // two boxes of one colour, the nearer hiding part of the farther: told apart by their labels
  const CameraParams params = DepthCameraParams();
  CameraRenderer renderer = MakeRenderer(params, BlackFloor());
  const world::Pose2 car{};
  const std::vector<Prism> prisms{Box(1.5, 0.1, 0.0, 0.3, 0.6, 0.3),
                                  Box(1.0, -0.1, 0.4, 0.2, 0.2, 0.2)};
  ColorImage colour;
  DepthImage depth;
  renderer.Render(car, prisms, &colour, &depth);
  RowSpans all;
  all.columns.assign(static_cast<std::size_t>(params.height_px), {0, params.width_px});
  std::vector<std::uint8_t> ids(static_cast<std::size_t>(params.width_px) * params.height_px, 99);
  const std::vector<std::uint8_t> prism_ids{1, 2};
  renderer.RenderLabels(
      car, prisms, all, [](const Bgr&) { return std::uint8_t{0}; },
      LabelView{ids.data(), params.width_px}, prism_ids);
  std::array<DepthImage, 2> alone;
  for (std::size_t k = 0; k < 2; ++k)
    renderer.Render(car, std::span(&prisms[k], 1), nullptr, &alone[k]);
  std::array<int, 3> count{};
  for (std::size_t i = 0; i < ids.size(); ++i) {
    ASSERT_LE(ids[i], 2) << i;
    ++count[ids[i]];
    // the object a pixel is labelled with is the one at its depth
    if (ids[i] != 0) {
      ASSERT_EQ(alone[ids[i] - 1u].mm[i], depth.mm[i]) << i;
    }
  }
  EXPECT_GT(count[1], 1000);
  EXPECT_GT(count[2], 1000);
  EXPECT_THROW(renderer.RenderLabels(
                   car, prisms, all, [](const Bgr&) { return std::uint8_t{0}; },
                   LabelView{ids.data(), params.width_px}, std::vector<std::uint8_t>{1}),
               std::invalid_argument);
}

TEST(RayCasterTest, OutsideTheRasterIsBareFloorAndAboveTheHorizonTheSurround) {
  world::FloorRaster raster = BlackFloor(1.0);
  raster.floor_bgr = {10, 20, 30};
  std::fill(raster.bgr.begin(), raster.bgr.end(), 200);
  const CameraParams params = ColorCameraParams();
  CameraRenderer renderer = MakeRenderer(params, raster);
  ColorImage image;
  DepthImage depth;
  renderer.Render(world::Pose2{}, {}, &image, &depth);
  EXPECT_EQ(PixelAt(image, 0, 0), SceneAppearance{}.surround());  // top: beyond the far clip
  EXPECT_EQ(depth.mm[0], 0);
  EXPECT_EQ(PixelAt(image, 320, 479), (Bgr{200, 200, 200}));  // just ahead: on the raster
  // a floor pixel well beyond the raster's 0.5 m half-size
  const CameraModel camera(params);
  const auto far = camera.Project(camera.X_map_camera(world::Pose2{}).inverse() *
                                  Eigen::Vector3d(3.0, 0.0, 0.0));
  ASSERT_TRUE(far.has_value());
  EXPECT_EQ(PixelAt(image, static_cast<int>(far->x()), static_cast<int>(far->y())),
            (Bgr{10, 20, 30}));
}

// Issue 34: these messages said "got 0.000000"; a number reads as the user wrote it.
TEST(RayCasterTest, ACameraOnTheFloorIsRefusedNamingTheHeightAsWritten) {
  CameraParams params = DepthCameraParams();
  params.mount.z_m = 0.0;
  try {
    CameraRays rays{CameraModel(params)};
    FAIL() << "a camera at z 0 was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), ::testing::EndsWith("(mount.z_m > 0), got 0"));
  }
  CameraNoiseParams noise;
  noise.color_stddev = 65.0;
  try {
    noise.Validate();
    FAIL() << "color_stddev 65 was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(), "color_stddev must be in [0, 64], got 65");
  }
}

TEST(CameraNoiseTest, OffIsExactOnIsSeededAndScaledByDistanceSquared) {
  const CameraParams params = DepthCameraParams();
  world::FloorRaster raster = BlackFloor();
  std::fill(raster.bgr.begin(), raster.bgr.end(), 128);
  CameraRenderer renderer = MakeRenderer(params, raster);
  ColorImage color;
  DepthImage depth;
  renderer.Render(world::Pose2{}, {}, &color, &depth);
  const ColorImage clean_color = color;
  const DepthImage clean_depth = depth;

  CameraNoiseParams noise;
  noise.enabled = false;
  AddCameraNoise(noise, params, 7, &color, &depth);
  EXPECT_EQ(color.bgr, clean_color.bgr);
  EXPECT_EQ(depth.mm, clean_depth.mm);

  noise.enabled = true;
  auto noisy = [&](std::uint64_t seed) {
    ColorImage c = clean_color;
    DepthImage d = clean_depth;
    AddCameraNoise(noise, params, seed, &c, &d);
    return std::pair{c, d};
  };
  const auto [c1, d1] = noisy(7);
  const auto [c2, d2] = noisy(7);
  const auto [c3, d3] = noisy(8);
  EXPECT_EQ(c1.bgr, c2.bgr);
  EXPECT_EQ(d1.mm, d2.mm);
  EXPECT_NE(c1.bgr, c3.bgr);
  EXPECT_NE(d1.mm, d3.mm);

  // statistics: σ(z) / z² ≈ depth_stddev_per_m; colour σ ≈ color_stddev; no new returns
  double sum_sq = 0.0, sum = 0.0;
  int n = 0;
  for (std::size_t i = 0; i < clean_depth.mm.size(); ++i) {
    if (clean_depth.mm[i] == 0) {
      EXPECT_EQ(d1.mm[i], 0);
      continue;
    }
    if (d1.mm[i] == 0) continue;  // pushed outside the clip
    const double z = clean_depth.mm[i] / 1000.0;
    const double e = (d1.mm[i] - clean_depth.mm[i]) / 1000.0 / (z * z);
    sum += e;
    sum_sq += e * e;
    ++n;
  }
  ASSERT_GT(n, 10000);
  EXPECT_NEAR(std::sqrt(sum_sq / n), noise.depth_stddev_per_m, 0.1 * noise.depth_stddev_per_m);
  EXPECT_NEAR(sum / n, 0.0, 0.05 * noise.depth_stddev_per_m);
  double color_sq = 0.0;
  for (std::size_t i = 0; i < c1.bgr.size(); ++i) {
    const double e = static_cast<double>(c1.bgr[i]) - clean_color.bgr[i];
    color_sq += e * e;
  }
  // rounding to whole counts adds 1/12 to the variance
  EXPECT_NEAR(std::sqrt(color_sq / c1.bgr.size()),
              std::sqrt(noise.color_stddev * noise.color_stddev + 1.0 / 12.0), 0.05);
}

TEST(SceneAppearanceTest, ValidatesAndCyclesCarColours) {
  SceneAppearance appearance;
  EXPECT_NO_THROW(appearance.Validate());
  EXPECT_EQ(appearance.car_body(0), appearance.car_body(6));
  EXPECT_NE(appearance.car_body(0), appearance.car_body(1));
  appearance.car_body_rgb.clear();
  EXPECT_THROW(appearance.Validate(), std::invalid_argument);
  appearance = SceneAppearance{};
  appearance.surround_rgb = {0, 0, 256};
  EXPECT_THROW(appearance.Validate(), std::invalid_argument);
}

}  // namespace
}  // namespace autonomsim::vehicle
