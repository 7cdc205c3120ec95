// The plumb_bob model's inverse: Undistort inverts Distort, and UndistortAll gives Undistort's
// bits point for point (groups of points side by side, of any count), nullopt included.
#include "world/plumb_bob.h"

#include <gtest/gtest.h>

#include <optional>
#include <stdexcept>
#include <vector>

namespace autonomsim::world {
namespace {

// A mild lens, of the order of a small camera's (the lab colour camera's own figures live in
// vehicle::ColorCameraParams), and a strong lens whose model folds within the grid.
const PlumbBob kMildLens{-0.2, 0.04, 0.005, -0.005, 0.0};
const PlumbBob kFoldingLens{-0.4, 0.2, -0.01, 0.003, -0.05};

// Normalized points over [-1.5, 1.5]², `count` of them.
std::vector<Eigen::Vector2d> Grid(int count) {
  std::vector<Eigen::Vector2d> points;
  for (int i = 0; i < count; ++i) {
    points.emplace_back(-1.5 + 3.0 * (i % 37) / 36.0, -1.5 + 3.0 * (i / 37 % 41) / 40.0);
  }
  return points;
}

TEST(PlumbBobTest, UndistortInvertsDistort) {
  for (const Eigen::Vector2d& p : Grid(37 * 41)) {
    const Eigen::Vector2d small = 0.4 * p;  // within the mild lens's monotone range
    const std::optional<Eigen::Vector2d> back = Undistort(kMildLens, Distort(kMildLens, small));
    ASSERT_TRUE(back.has_value());
    EXPECT_LT((*back - small).norm(), 1e-12);
  }
}

TEST(PlumbBobTest, UndistortAllGivesUndistortsBits) {
  for (const PlumbBob& D : {kMildLens, kFoldingLens}) {
    for (const int count : {0, 1, 3, 4, 5, 37 * 41}) {
      const std::vector<Eigen::Vector2d> points = Grid(count);
      std::vector<std::optional<Eigen::Vector2d>> all(points.size(), Eigen::Vector2d(9, 9));
      UndistortAll(D, points, all);
      int folded = 0;
      for (std::size_t i = 0; i < points.size(); ++i) {
        const std::optional<Eigen::Vector2d> one = Undistort(D, points[i]);
        ASSERT_EQ(all[i].has_value(), one.has_value()) << i;
        folded += !one.has_value();
        if (one) {
          ASSERT_EQ(all[i]->x(), one->x()) << i;
          ASSERT_EQ(all[i]->y(), one->y()) << i;
        }
      }
      if (count == 37 * 41 && D == kFoldingLens) {
        EXPECT_GT(folded, 0);
      }
    }
  }
}

TEST(PlumbBobTest, UndistortAllNeedsRoomForEveryPoint) {
  const std::vector<Eigen::Vector2d> points = Grid(3);
  std::vector<std::optional<Eigen::Vector2d>> out(2);
  EXPECT_THROW(UndistortAll(kMildLens, points, out), std::invalid_argument);
}

}  // namespace
}  // namespace autonomsim::world
