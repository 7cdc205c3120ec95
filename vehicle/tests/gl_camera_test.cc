// The rasterising backend against the ray caster: two independent renderers of one scene and one
// camera model, compared pixel by pixel on the lab track with cars and obstacles in view. Where
// they differ is where the opening comment of gl_camera.h says they may: at the edges between
// surfaces and, through the lens distortion's resampling, beside painted lines.
//
// Skipped where no EGL display can be made (the message says why), except under CI=true
// (vehicle/tests/gl_available.h).
#include "vehicle/gl_camera.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <memory>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

#include "sim/core/track_loader.h"
#include "vehicle/tests/gl_available.h"
#include "world/floor_raster.h"
#include "world/track.h"

namespace autonomsim::vehicle {
namespace {

// The lab track, its floor, and a context; or why there is no context.
struct Backends {
  world::Track track = sim::LoadTrack("scenarios/tracks/lab.yaml");
  std::shared_ptr<const FloorTexture> floor =
      std::make_shared<const FloorTexture>(world::RasterizeFloor(track));
  std::shared_ptr<GlScene> scene;
  std::string unavailable;

  Backends() {
    try {
      scene = std::make_shared<GlScene>(GlContext::Create(), *floor, SceneAppearance{}.surround());
    } catch (const GlUnavailable& e) {
      unavailable = e.what();
    }
  }
};

Backends& Shared() {
  static Backends backends;  // one context for the whole test program
  return backends;
}

// A pose on a route of the lab track, `lateral_m` left of its centre, turned by `yaw_rad`.
world::Pose2 OnRoute(const world::Track& track, const std::string& route, double s_m,
                     double lateral_m = 0.0, double yaw_rad = 0.0) {
  const world::Polyline& path = track.RouteByName(route).path;
  const world::Vec2 p = path.PointAt(s_m);
  const double heading = path.HeadingAt(s_m);
  return world::Pose2{p.x() - lateral_m * std::sin(heading), p.y() + lateral_m * std::cos(heading),
                      heading + yaw_rad};
}

// A box `ahead_m` ahead of `car` and `left_m` to its left, turned by `yaw_rad` from its heading.
Prism Ahead(const world::Pose2& car, double ahead_m, double left_m, double yaw_rad, double length_m,
            double width_m, double height_m, const Bgr& bgr) {
  const double c = std::cos(car.yaw_rad), s = std::sin(car.yaw_rad);
  return Prism{
      world::OrientedBox{world::Pose2{car.x_m + c * ahead_m - s * left_m,
                                      car.y_m + s * ahead_m + c * left_m, car.yaw_rad + yaw_rad},
                         length_m, width_m},
      height_m, bgr};
}

struct Scene {
  world::Pose2 car;
  std::vector<Prism> prisms;
};

// 24 poses along two loops, each with a car ahead (straight or turned, near or far, left or
// right) and an obstacle box, some partly out of the view, one across the near clip.
std::vector<Scene> Scenes(const world::Track& track) {
  const SceneAppearance look;
  std::vector<Scene> scenes;
  int k = 0;
  for (const char* route : {"outer_loop", "inner_loop"}) {
    const double length = track.RouteByName(route).path.length_m();
    for (int i = 0; i < 12; ++i, ++k) {
      const double s = (i + 0.5) * length / 12.0;
      Scene scene;
      scene.car = OnRoute(track, route, s, 0.03 * ((k % 5) - 2), 0.04 * ((k % 3) - 1));
      const double ahead = 0.6 + 0.15 * (k % 8);
      scene.prisms.push_back(Ahead(scene.car, ahead, 0.12 * ((k % 4) - 1.5), 0.25 * (k % 3), 0.525,
                                   0.296, 0.2, look.car_body(k)));
      scene.prisms.push_back(Ahead(scene.car, ahead + 0.5 + 0.1 * (k % 5), -0.3 + 0.05 * (k % 7),
                                   0.5 * k, 0.2, 0.15, 0.1 + 0.05 * (k % 4), look.obstacle()));
      if (k % 6 == 0) {  // a tall box beside the car, reaching past the camera
        scene.prisms.push_back(Ahead(scene.car, 0.3, 0.35, 0.0, 1.2, 0.1, 0.4, Bgr{40, 160, 60}));
      }
      scenes.push_back(std::move(scene));
    }
  }
  return scenes;
}

// Which surface each pixel of the ray caster's image sees: the prism's index, -1 for the floor,
// -2 for no return (the surround, the floor beyond the far clip); from its depth against the bare
// floor's and from each prism alone.
std::vector<int> Surfaces(CameraRenderer& renderer, const Scene& scene, const DepthImage& depth,
                          const ColorImage& color) {
  ColorImage bare_color, alone_color;
  DepthImage bare_depth, alone_depth;
  renderer.Render(scene.car, {}, &bare_color, &bare_depth);
  std::vector<int> id(depth.mm.size(), -1);
  for (std::size_t k = 0; k < scene.prisms.size(); ++k) {
    renderer.Render(scene.car, std::span(&scene.prisms[k], 1), &alone_color, &alone_depth);
    for (std::size_t i = 0; i < id.size(); ++i) {
      const bool changed = alone_depth.mm[i] != bare_depth.mm[i] ||
                           std::memcmp(&alone_color.bgr[3 * i], &bare_color.bgr[3 * i], 3) != 0;
      if (id[i] < 0 && changed && alone_depth.mm[i] == depth.mm[i] &&
          std::memcmp(&alone_color.bgr[3 * i], &color.bgr[3 * i], 3) == 0) {
        id[i] = static_cast<int>(k);
      }
    }
  }
  for (std::size_t i = 0; i < id.size(); ++i) {
    if (id[i] < 0 && depth.mm[i] == 0) id[i] = -2;  // the surround, or the floor beyond the clip
  }
  return id;
}

// Pixels within one pixel of another surface (edges between surfaces).
std::vector<bool> NearEdges(const std::vector<int>& id, int w, int h) {
  std::vector<bool> edge(id.size(), false);
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      const int own = id[static_cast<std::size_t>(v) * w + u];
      for (int dv = -1; dv <= 1; ++dv) {
        for (int du = -1; du <= 1; ++du) {
          const int uu = u + du, vv = v + dv;
          if (uu < 0 || vv < 0 || uu >= w || vv >= h) continue;
          if (id[static_cast<std::size_t>(vv) * w + uu] != own) {
            edge[static_cast<std::size_t>(v) * w + u] = true;
          }
        }
      }
    }
  }
  return edge;
}

struct Agreement {
  std::size_t pixels{0};  // away from edges
  std::size_t depth_within_1mm{0};
  std::size_t colour_equal{0};
  std::size_t edge_pixels{0};
  std::size_t edge_colour_equal{0};
  int max_depth_error_mm{0};  // away from edges
};

Agreement Compare(const CameraParams& params, const std::vector<Scene>& scenes) {
  Backends& b = Shared();
  const auto rays = std::make_shared<const CameraRays>(CameraModel(params));
  CameraRenderer ray_caster(rays, b.floor, SceneAppearance{}.surround());
  GlCameraRenderer gl(b.scene, rays);
  Agreement a;
  for (const Scene& scene : scenes) {
    ColorImage rc_color, gl_color;
    DepthImage rc_depth, gl_depth;
    ray_caster.Render(scene.car, scene.prisms, &rc_color, &rc_depth);
    gl.Render(scene.car, scene.prisms, &gl_color, &gl_depth);
    const std::vector<bool> edge = NearEdges(Surfaces(ray_caster, scene, rc_depth, rc_color),
                                             params.width_px, params.height_px);
    for (std::size_t i = 0; i < edge.size(); ++i) {
      const bool same_colour = std::memcmp(&rc_color.bgr[3 * i], &gl_color.bgr[3 * i], 3) == 0;
      if (edge[i]) {
        ++a.edge_pixels;
        a.edge_colour_equal += same_colour ? 1 : 0;
        continue;
      }
      ++a.pixels;
      const int error = std::abs(static_cast<int>(rc_depth.mm[i]) - gl_depth.mm[i]);
      a.depth_within_1mm += error <= 1 ? 1 : 0;
      a.max_depth_error_mm = std::max(a.max_depth_error_mm, error);
      a.colour_equal += same_colour ? 1 : 0;
    }
  }
  return a;
}

double Share(std::size_t part, std::size_t whole) {
  return static_cast<double>(part) / static_cast<double>(whole);
}

// The figures docs/renderers.md#they-agree quotes, printed with the test's output.
void Print(const char* camera, const Agreement& a) {
  std::printf(
      "%s, %zu pixels away from edges: depth within 1 mm %.4f %%, colour equal %.4f %%, "
      "largest depth difference %d mm; %zu edge pixels, colour equal %.2f %%\n",
      camera, a.pixels, 100.0 * Share(a.depth_within_1mm, a.pixels),
      100.0 * Share(a.colour_equal, a.pixels), a.max_depth_error_mm, a.edge_pixels,
      100.0 * Share(a.edge_colour_equal, a.edge_pixels));
}

TEST(GlCameraTest, TheDepthCameraAgreesWithTheRayCasterOnTwentyFourPoses) {
  AUTONOMSIM_REQUIRE_GL();
  const Agreement a = Compare(DepthCameraParams(), Scenes(Shared().track));
  Print("depth camera", a);
  EXPECT_GE(Share(a.depth_within_1mm, a.pixels), 0.99);
  // no lens distortion: both sample each pixel's own ray, and differ only where float rounding
  // puts a ray on the other side of a texel's border
  EXPECT_GE(Share(a.colour_equal, a.pixels), 0.999);
}

TEST(GlCameraTest, TheDistortedColourCameraAgreesWithTheRayCasterOnTwentyFourPoses) {
  AUTONOMSIM_REQUIRE_GL();
  const Agreement a = Compare(ColorCameraParams(), Scenes(Shared().track));
  Print("colour camera", a);
  // the raw image is resampled from a pinhole image twice as fine: a pixel takes the colour of
  // a ray up to a quarter of a pixel from its own, which differs beside a painted line's edge
  EXPECT_GE(Share(a.depth_within_1mm, a.pixels), 0.99);
  EXPECT_GE(Share(a.colour_equal, a.pixels), 0.99);
}

TEST(GlCameraTest, ACameraInsideABoxSeesItsInsideAsTheRayCasterDoes) {
  AUTONOMSIM_REQUIRE_GL();
  const auto rays = std::make_shared<const CameraRays>(CameraModel(ColorCameraParams()));
  CameraRenderer ray_caster(rays, Shared().floor, SceneAppearance{}.surround());
  GlCameraRenderer gl(Shared().scene, rays);
  const world::Pose2 car = OnRoute(Shared().track, "outer_loop", 1.0);
  const std::vector<Prism> around{Ahead(car, 0.0, 0.0, 0.3, 1.0, 1.0, 0.5, Bgr{20, 200, 90})};
  ColorImage rc_color, gl_color;
  DepthImage rc_depth, gl_depth;
  ray_caster.Render(car, around, &rc_color, &rc_depth);
  gl.Render(car, around, &gl_color, &gl_depth);
  EXPECT_EQ(gl_color.bgr, rc_color.bgr);
  EXPECT_EQ(gl_depth.mm, rc_depth.mm);
  EXPECT_EQ(gl_depth.mm.front(), 0);  // no return: nearer than the near clip
}

TEST(GlCameraTest, AFrameDependsOnlyOnItsInputs) {
  AUTONOMSIM_REQUIRE_GL();
  const auto rays = std::make_shared<const CameraRays>(CameraModel(ColorCameraParams()));
  GlCameraRenderer gl(Shared().scene, rays);
  const std::vector<Scene> scenes = Scenes(Shared().track);
  ColorImage first, other, again;
  DepthImage first_depth, other_depth, again_depth;
  gl.Render(scenes[0].car, scenes[0].prisms, &first, &first_depth);
  gl.Render(scenes[5].car, scenes[5].prisms, &other, &other_depth);
  gl.Render(scenes[0].car, scenes[0].prisms, &again, &again_depth);
  EXPECT_NE(first.bgr, other.bgr);
  EXPECT_EQ(first.bgr, again.bgr);
  EXPECT_EQ(first_depth.mm, again_depth.mm);
  // a colour-only frame is the colour of a full one
  ColorImage alone;
  gl.Render(scenes[0].car, scenes[0].prisms, &alone, nullptr);
  EXPECT_EQ(alone.bgr, first.bgr);
  EXPECT_FALSE(Shared().scene->context().renderer().empty());
}

}  // namespace
}  // namespace autonomsim::vehicle
