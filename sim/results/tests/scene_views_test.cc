// The 3D views of a run: the chase camera looks at its car from behind, the overview shows every
// car; and the GL backend's render of a snapshot is the ray caster's but for edges.
#include "sim/results/scene_views.h"

#include <gtest/gtest.h>

#include <cstring>

#include "sim/results/track_figure.h"
#include "vehicle/tests/gl_available.h"

namespace autonomsim::sim {
namespace {

constexpr const char* kViewsScenario = "scenarios/static_obstacle.yaml";

// How many pixels of `image` have one of the colours of car `id`'s faces.
int PixelsOfCar(const cv::Mat& image, const Scenario& scenario, const CarBody& car) {
  const cv::Scalar c = CarColourBgr(scenario, car.id);
  const vehicle::Prism prism{
      world::OrientedBox{car.pose, car.length_m, car.width_m}, car.height_m,
      vehicle::Bgr{static_cast<std::uint8_t>(c[0]), static_cast<std::uint8_t>(c[1]),
                   static_cast<std::uint8_t>(c[2])}};
  const std::array<vehicle::Bgr, 7> faces = vehicle::PrismFaceColours(prism);
  int n = 0;
  for (int v = 0; v < image.rows; ++v) {
    for (int u = 0; u < image.cols; ++u) {
      const cv::Vec3b p = image.at<cv::Vec3b>(v, u);
      for (const vehicle::Bgr& f : faces) {
        if (p[0] == f[0] && p[1] == f[1] && p[2] == f[2]) {
          ++n;
          break;
        }
      }
    }
  }
  return n;
}

TEST(SceneViewsTest, TheChaseCameraSeesItsCarFromBehindAndTheOverviewEveryCar) {
  AUTONOMSIM_REQUIRE_GL();
  const LoadedScenario scenario = LoadScenario(kViewsScenario);
  const WorldSnapshot snapshot = SnapshotAt(scenario, FromSeconds(13.0));
  SceneViews views(scenario.track, scenario.scenario);
  const cv::Size size(480, 300);
  for (const CarBody& car : snapshot.cars) {
    const cv::Mat chase = views.Chase(snapshot, car.id, size);
    ASSERT_EQ(chase.size(), size);
    // the chased car fills a good part of the view, centred below the middle
    const int own = PixelsOfCar(chase, scenario.scenario, car);
    EXPECT_GT(own, size.area() / 20) << "car " << car.id;
    const cv::Vec3b centre = chase.at<cv::Vec3b>(size.height * 2 / 3, size.width / 2);
    const int centre_is_car =
        PixelsOfCar(cv::Mat(1, 1, CV_8UC3, cv::Scalar(centre[0], centre[1], centre[2])),
                    scenario.scenario, car);
    EXPECT_EQ(centre_is_car, 1) << "car " << car.id;
  }
  const cv::Mat overview = views.Overview(snapshot, size);
  for (const CarBody& car : snapshot.cars) {
    EXPECT_GT(PixelsOfCar(overview, scenario.scenario, car), 30) << "car " << car.id;
  }
  EXPECT_THROW(views.Chase(snapshot, 7, size), std::invalid_argument);
}

TEST(SceneViewsTest, TheGlBackendRendersASnapshotAsTheRayCasterDoes) {
  AUTONOMSIM_REQUIRE_GL();
  const LoadedScenario scenario = LoadScenario(kViewsScenario);
  const WorldSnapshot snapshot = SnapshotAt(scenario, FromSeconds(13.0));
  const RngStreams streams(scenario.scenario.seed);
  const auto ray_cast = RenderCameras(scenario.track, snapshot, 1, SensorSuiteParams{},
                                      scenario.scenario.appearance, streams);
  const auto gl = RenderCameras(scenario.track, snapshot, 1, SensorSuiteParams{},
                                scenario.scenario.appearance, streams, CameraBackend::kGl);
  ASSERT_EQ(gl.size(), ray_cast.size());
  for (std::size_t k = 0; k < gl.size(); ++k) {
    ASSERT_EQ(gl[k].color.bgr.size(), ray_cast[k].color.bgr.size());
    std::size_t same_colour = 0, depth_within_1mm = 0;
    const std::size_t pixels = gl[k].depth.mm.size();
    for (std::size_t i = 0; i < pixels; ++i) {
      same_colour += std::memcmp(&gl[k].color.bgr[3 * i], &ray_cast[k].color.bgr[3 * i], 3) == 0;
      depth_within_1mm += std::abs(gl[k].depth.mm[i] - ray_cast[k].depth.mm[i]) <= 1;
    }
    // edges included here: a little below the cross-check's figures away from them
    EXPECT_GT(static_cast<double>(same_colour) / pixels, 0.99) << gl[k].name;
    EXPECT_GT(static_cast<double>(depth_within_1mm) / pixels, 0.98) << gl[k].name;
  }
}

}  // namespace
}  // namespace autonomsim::sim
