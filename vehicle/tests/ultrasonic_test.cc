// The ultrasonic ranger: nearest prism within its cone, REP-117's ±inf, noise.
#include "vehicle/ultrasonic.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

namespace autonomsim::vehicle {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

Prism Box(double x, double y, double yaw, double length, double width) {
  return Prism{world::OrientedBox{world::Pose2{x, y, yaw}, length, width}, 0.2, Bgr{}};
}

TEST(UltrasonicTest, DefaultsAreTheReferenceFigures) {
  const UltrasonicParams params;
  EXPECT_NO_THROW(params.Validate());
  EXPECT_NEAR(params.field_of_view_deg * std::numbers::pi / 180.0, 0.366, 1e-12);
  UltrasonicParams bad;
  bad.max_range_m = 0.01;
  EXPECT_THROW(bad.Validate(), std::invalid_argument);
}

TEST(UltrasonicTest, ABoxAheadReadsTheDistanceToItsFace) {
  const UltrasonicParams params;
  // car at the origin facing +x; the sensor at x = 0.2625; the box's near face at x = 1.5
  const std::vector<Prism> box{Box(1.6, 0.0, 0.0, 0.2, 0.2)};
  EXPECT_NEAR(NearestInCone(params, world::Pose2{}, box), 1.5 - 0.2625, 1e-12);
  // turned with the car: the same
  const world::Pose2 car{1.0, 2.0, 1.0};
  const Eigen::Vector2d ahead = car.position() + 1.6 * car.heading();
  const std::vector<Prism> turned{Box(ahead.x(), ahead.y(), 1.0, 0.2, 0.2)};
  EXPECT_NEAR(NearestInCone(params, car, turned), 1.5 - 0.2625, 1e-9);
}

TEST(UltrasonicTest, OnlyTheConeCounts) {
  const UltrasonicParams params;
  // a box at 1 m but 0.3 m to the side: the cone's half angle (0.183 rad) reaches 0.19 m there
  const std::vector<Prism> aside{Box(1.2625, 0.35, 0.0, 0.1, 0.1)};
  EXPECT_EQ(NearestInCone(params, world::Pose2{}, aside), kInf);
  // a box whose nearest corner is outside the cone: the nearest point of it inside the cone is
  // where the cone's edge crosses its side at y = 0.3
  const std::vector<Prism> edge{Box(1.5, 0.4, 0.0, 1.0, 0.2)};
  EXPECT_NEAR(NearestInCone(params, world::Pose2{}, edge), 0.3 / std::sin(0.5 * 0.366), 1e-9);
  // and the same box nearer to the car's axis: its nearest corner, inside the cone
  const std::vector<Prism> inside{Box(1.5, 0.2, 0.0, 1.0, 0.2)};
  EXPECT_NEAR(NearestInCone(params, world::Pose2{}, inside), std::hypot(1.0 - 0.2625, 0.1), 1e-9);
}

TEST(UltrasonicTest, OutOfRangeReadsAsRep117Infinities) {
  const UltrasonicParams params;
  EXPECT_EQ(UltrasonicRange(params, world::Pose2{}, {}, 0.0), kInf);
  const std::vector<Prism> far{Box(5.0, 0.0, 0.0, 0.2, 0.2)};
  EXPECT_EQ(UltrasonicRange(params, world::Pose2{}, far, 0.0), kInf);
  const std::vector<Prism> near{Box(0.2625 + 0.03 + 0.1, 0.0, 0.0, 0.2, 0.2)};
  EXPECT_EQ(UltrasonicRange(params, world::Pose2{}, near, 0.0), -kInf);
  const std::vector<Prism> fine{Box(1.0, 0.0, 0.0, 0.2, 0.2)};
  EXPECT_NEAR(UltrasonicRange(params, world::Pose2{}, fine, 2.0),
              0.9 - 0.2625 + 2.0 * params.noise_stddev_m, 1e-12);
}

TEST(UltrasonicTest, TheNearestOfSeveralWins) {
  const UltrasonicParams params;
  const std::vector<Prism> boxes{Box(2.0, 0.0, 0.0, 0.2, 0.2), Box(1.0, 0.05, 0.3, 0.2, 0.2)};
  const double one = NearestInCone(params, world::Pose2{}, std::vector<Prism>{boxes[1]});
  EXPECT_EQ(NearestInCone(params, world::Pose2{}, boxes), one);
  EXPECT_LT(one, 2.0 - 0.1 - 0.2625);
}

}  // namespace
}  // namespace autonomsim::vehicle
