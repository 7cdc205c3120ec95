#include "world/polyline.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <numbers>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

namespace autonomsim::world {
namespace {

using ::testing::HasSubstr;

constexpr double kPi = std::numbers::pi;

// Points on a circle of the given centre and radius, from angle a0 to a1 in `pieces` chords.
std::vector<Vec2> ArcPoints(const Vec2& centre, double radius_m, double a0_rad, double a1_rad,
                            int pieces) {
  std::vector<Vec2> points;
  for (int k = 0; k <= pieces; ++k) {
    const double a = a0_rad + (a1_rad - a0_rad) * k / pieces;
    points.push_back(centre + radius_m * Vec2(std::cos(a), std::sin(a)));
  }
  return points;
}

// Largest heading change between consecutive chords (rad), across the closing point if cyclic.
double MaxChordTurn(const Polyline& path) {
  const std::vector<Vec2>& p = path.points();
  double worst = 0.0;
  const std::size_t n = p.size();
  for (std::size_t i = 1; i + 1 < n; ++i) {
    worst = std::max(worst, std::abs(WrapAngle(path.HeadingAt(path.arc_lengths_m()[i]) -
                                               path.HeadingAt(path.arc_lengths_m()[i - 1]))));
  }
  if (path.cyclic()) {
    worst = std::max(worst, std::abs(WrapAngle(path.HeadingAt(0.0) -
                                               path.HeadingAt(path.arc_lengths_m()[n - 2]))));
  }
  return worst;
}

std::string ErrorOf(const auto& action) {
  try {
    action();
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "(no exception)";
}

// world::Remainder skips std::remainder within half a period of 0, where the remainder is x:
// bit for bit the library's, at and beside the half period, for tiny and huge x, and for a NaN
// and infinities; WrapAngle, which uses it, keeps its (-pi, pi] convention.
TEST(GeometryTest, RemainderIsTheLibrarysBitForBit) {
  const auto same = [](double x, double period) {
    const double ours = Remainder(x, period), theirs = std::remainder(x, period);
    return (std::isnan(ours) && std::isnan(theirs)) ||
           std::memcmp(&ours, &theirs, sizeof ours) == 0;
  };
  std::mt19937_64 rng(17);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  constexpr double kInf = std::numeric_limits<double>::infinity();
  for (const double period : {2.0 * std::numbers::pi, 17.3, 1e-3, 1e6}) {
    const double half = 0.5 * period;
    for (const double x :
         {0.0, -0.0, half, -half, std::nextafter(half, 0.0), std::nextafter(half, kInf),
          -std::nextafter(half, 0.0), -std::nextafter(half, kInf), period, 1e-300, -1e300, kInf,
          -kInf, std::numeric_limits<double>::quiet_NaN()}) {
      EXPECT_TRUE(same(x, period)) << x << " by " << period;
    }
    for (int i = 0; i < 10000; ++i) {
      const double x = unit(rng) * period * (i % 2 == 0 ? 0.6 : 40.0);
      ASSERT_TRUE(same(x, period)) << x << " by " << period;
    }
  }
  EXPECT_EQ(WrapAngle(-std::numbers::pi), std::numbers::pi);
  EXPECT_EQ(WrapAngle(std::numbers::pi), std::numbers::pi);
  EXPECT_EQ(WrapAngle(0.25), 0.25);
}

TEST(PolylineTest, StraightLengthHeadingCurvature) {
  const Polyline path({{0.0, 0.0}, {3.0, 4.0}}, false);
  EXPECT_DOUBLE_EQ(path.length_m(), 5.0);
  EXPECT_FALSE(path.cyclic());
  ASSERT_EQ(path.arc_lengths_m().size(), 2u);
  EXPECT_DOUBLE_EQ(path.arc_lengths_m()[0], 0.0);
  EXPECT_DOUBLE_EQ(path.HeadingAt(1.0), std::atan2(4.0, 3.0));
  EXPECT_DOUBLE_EQ(path.CurvatureAt(2.0), 0.0);
  EXPECT_TRUE(path.PointAt(2.5).isApprox(Vec2(1.5, 2.0)));
  // Open paths clamp.
  EXPECT_TRUE(path.PointAt(-1.0).isApprox(Vec2(0.0, 0.0)));
  EXPECT_TRUE(path.PointAt(7.0).isApprox(Vec2(3.0, 4.0)));
}

TEST(PolylineTest, RejectsBadPoints) {
  EXPECT_THROW(Polyline({{0.0, 0.0}}, false), std::invalid_argument);
  EXPECT_THAT(ErrorOf([] {
                Polyline({{0.0, 0.0}, {1.0, 0.0}, {1.0, 0.0}}, false);
              }),
              HasSubstr("coincide"));
  EXPECT_THROW(Polyline({{0.0, 0.0}, {std::nan(""), 0.0}}, false), std::invalid_argument);
  EXPECT_THAT(ErrorOf([] {
                Polyline({{0.0, 0.0}, {1.0, 0.0}, {1.0, 1.0}}, true);
              }),
              HasSubstr("must end where it starts"));
}

TEST(PolylineTest, ArcCurvatureAndHeading) {
  const double radius = 2.0;
  // Counter-clockwise quarter: a left turn.
  const Polyline left(ArcPoints({0.0, 0.0}, radius, 0.0, kPi / 2, 200), false);
  EXPECT_NEAR(left.length_m(), kPi / 2 * radius, 1e-4);
  for (double f : {0.1, 0.25, 0.5, 0.9}) {
    const double s = f * left.length_m();
    EXPECT_NEAR(left.CurvatureAt(s), 1.0 / radius, 1e-4) << "s=" << s;
    EXPECT_NEAR(WrapAngle(left.HeadingAt(s) - (f * kPi / 2 + kPi / 2)), 0.0, kPi / 400 + 1e-9);
  }
  // Clockwise: a right turn, negative curvature.
  const Polyline right(ArcPoints({0.0, 0.0}, radius, kPi / 2, 0.0, 200), false);
  EXPECT_NEAR(right.CurvatureAt(0.5 * right.length_m()), -1.0 / radius, 1e-4);
  EXPECT_NEAR(right.HeadingAt(0.0), 0.0, kPi / 400 + 1e-9);
}

TEST(PolylineTest, FilletCornerIsATangentArc) {
  const double r = 0.5;
  const Polyline path = SampleFilletPolyline({{0.0, 0.0}, {2.0, 0.0}, {2.0, 2.0}}, r, false);
  // The chords are a little shorter than the arc (by r a^3 / 24 per step a).
  EXPECT_NEAR(path.length_m(), 2.0 * (2.0 - r) + kPi / 2 * r, 1e-4);
  // Chords no longer than the spacing, and on the arc no further than 0.1 mm off it.
  const Vec2 centre(2.0 - r, r);
  const std::vector<Vec2>& p = path.points();
  for (std::size_t i = 0; i + 1 < p.size(); ++i) {
    EXPECT_LE((p[i + 1] - p[i]).norm(), 0.01 + 1e-12);
    const Vec2 middle = 0.5 * (p[i] + p[i + 1]);
    if (middle.x() > 2.0 - r && middle.y() < r) {
      EXPECT_NEAR((p[i] - centre).norm(), r, 1e-12);
      EXPECT_LT(r - (middle - centre).norm(), 1e-4);
    }
  }
  // Straight, arc (curvature 1/r, left positive), straight.
  const double arc_start = 2.0 - r;
  const double arc_end = arc_start + kPi / 2 * r;
  EXPECT_NEAR(path.CurvatureAt(0.5 * arc_start), 0.0, 1e-12);
  EXPECT_NEAR(path.CurvatureAt(0.5 * (arc_start + arc_end)), 1.0 / r, 1e-3);
  EXPECT_NEAR(path.CurvatureAt(0.25 * arc_start + 0.75 * arc_end), 1.0 / r, 1e-3);
  EXPECT_NEAR(path.CurvatureAt(path.length_m() - 0.2), 0.0, 1e-12);
  EXPECT_NEAR(path.HeadingAt(0.1), 0.0, 1e-12);
  EXPECT_NEAR(path.HeadingAt(path.length_m()), kPi / 2, 1e-12);
  // Tangent continuity: no heading jump at the joints bigger than one arc step (< 1.2 deg here).
  EXPECT_LT(MaxChordTurn(path), 1.2 * kPi / 180);

  const Polyline right = SampleFilletPolyline({{0.0, 0.0}, {2.0, 0.0}, {2.0, -2.0}}, r, false);
  EXPECT_NEAR(right.CurvatureAt(0.5 * (arc_start + arc_end)), -1.0 / r, 1e-3);
}

TEST(PolylineTest, SharpCornersWhenRadiusIsZero) {
  const Polyline path =
      SampleFilletPolyline({{0.0, 0.0}, {1.0, 0.0}, {1.0, 1.0}}, 0.0, false, 0.25);
  EXPECT_DOUBLE_EQ(path.length_m(), 2.0);
  EXPECT_EQ(path.points().size(), 9u);
  EXPECT_TRUE(path.PointAt(1.0).isApprox(Vec2(1.0, 0.0)));
}

TEST(PolylineTest, ClosedRoundedSquareIsCyclic) {
  const double r = 0.3;
  const Polyline path =
      SampleFilletPolyline({{1.0, -1.0}, {1.0, 1.0}, {-1.0, 1.0}, {-1.0, -1.0}}, r, true);
  EXPECT_TRUE(path.cyclic());
  EXPECT_EQ(path.points().front(), path.points().back());
  EXPECT_NEAR(path.length_m(), 4.0 * (2.0 - 2.0 * r) + 2.0 * kPi * r, 2e-4);
  // Starts where the arc at the first corner ends, heading along the first side.
  EXPECT_TRUE(path.points().front().isApprox(Vec2(1.0, -1.0 + r)));
  EXPECT_NEAR(path.HeadingAt(0.0), kPi / 2, 1e-12);
  EXPECT_LT(MaxChordTurn(path), 2.0 * kPi / 180);
  // A repeated first point at the end is the same outline.
  const Polyline repeated = SampleFilletPolyline(
      {{1.0, -1.0}, {1.0, 1.0}, {-1.0, 1.0}, {-1.0, -1.0}, {1.0, -1.0}}, r, true);
  EXPECT_EQ(repeated.points().size(), path.points().size());
}

TEST(PolylineTest, StadiumArcsMayShareASideExactly) {
  // Height 0.64 = 2 r: the two end arcs meet with no straight between them.
  const Polyline path =
      SampleFilletPolyline({{1.0, 0.0}, {1.0, 0.64}, {-1.0, 0.64}, {-1.0, 0.0}}, 0.32, true);
  EXPECT_NEAR(path.length_m(), 2.0 * (2.0 - 0.64) + 2.0 * kPi * 0.32, 2e-4);
  EXPECT_LT(MaxChordTurn(path), 2.0 * kPi / 180);
  EXPECT_NEAR(path.Project({1.0, 0.32}).distance_m, 0.0, 1e-4);  // the east end
}

TEST(PolylineTest, FilletThatDoesNotFitThrows) {
  // The middle side is 1 m; two 90-degree arcs of 0.6 m need 1.2 m of it.
  EXPECT_THAT(ErrorOf([] {
                SampleFilletPolyline({{0.0, 0.0}, {1.0, 0.0}, {1.0, 1.0}, {2.0, 1.0}}, 0.6, false);
              }),
              HasSubstr("does not fit"));
  // An end side shorter than the tangent length.
  EXPECT_THROW(SampleFilletPolyline({{0.0, 0.0}, {0.3, 0.0}, {0.3, 1.0}}, 0.5, false),
               std::invalid_argument);
  // Closed: the arcs at all four corners of a 0.5 m square need 0.6 m per side.
  EXPECT_THROW(SampleFilletPolyline({{0.0, 0.0}, {0.5, 0.0}, {0.5, 0.5}, {0.0, 0.5}}, 0.3, true),
               std::invalid_argument);
  EXPECT_THROW(SampleFilletPolyline({{0.0, 0.0}, {1.0, 0.0}, {0.0, 0.0}}, 0.1, false),
               std::invalid_argument);  // turns back on itself
  EXPECT_THROW(SampleFilletPolyline({{0.0, 0.0}, {1.0, 0.0}}, -0.1, false), std::invalid_argument);
  EXPECT_THROW(SampleFilletPolyline({{0.0, 0.0}, {1.0, 0.0}}, 0.1, false, 0.0),
               std::invalid_argument);
}

TEST(PolylineTest, ProjectionSignIsLeftPositive) {
  const Polyline path({{0.0, 0.0}, {2.0, 0.0}}, false);
  const Polyline::Projection left = path.Project({1.0, 0.5});
  EXPECT_DOUBLE_EQ(left.s_m, 1.0);
  EXPECT_DOUBLE_EQ(left.lateral_m, 0.5);
  EXPECT_DOUBLE_EQ(left.distance_m, 0.5);
  EXPECT_TRUE(left.point.isApprox(Vec2(1.0, 0.0)));
  const Polyline::Projection right = path.Project({0.5, -0.25});
  EXPECT_DOUBLE_EQ(right.s_m, 0.5);
  EXPECT_DOUBLE_EQ(right.lateral_m, -0.25);
  // Reversed direction of travel flips the side.
  const Polyline reversed({{2.0, 0.0}, {0.0, 0.0}}, false);
  EXPECT_DOUBLE_EQ(reversed.Project({1.0, 0.5}).lateral_m, -0.5);
  // Outside a corner: the side of the points around it.
  const Polyline corner({{0.0, 0.0}, {1.0, 0.0}, {1.0, 1.0}}, false);
  const Polyline::Projection outside = corner.Project({1.5, -0.5});
  EXPECT_DOUBLE_EQ(outside.s_m, 1.0);
  EXPECT_NEAR(outside.lateral_m, -std::sqrt(0.5), 1e-12);
  EXPECT_GT(corner.Project({0.5, 0.3}).lateral_m, 0.0);
}

TEST(PolylineTest, ProjectNearAgreesWithProject) {
  const Polyline path = SampleFilletPolyline(
      {{0.0, 0.0}, {2.0, 0.0}, {2.0, 2.0}, {0.0, 2.0}, {0.0, 1.0}}, 0.5, false);
  for (int i = 0; i <= 20; ++i) {
    for (int j = 0; j <= 20; ++j) {
      const Vec2 p(-0.2 + 0.12 * i, -0.2 + 0.12 * j);
      const Polyline::Projection global = path.Project(p);
      // Only where the nearest point is unambiguous (not near the medial axis).
      if (global.distance_m > 0.35) continue;
      const Polyline::Projection near = path.ProjectNear(p, global.s_m + 0.1, 0.5);
      EXPECT_NEAR(near.s_m, global.s_m, 1e-12) << p.transpose();
      EXPECT_NEAR(near.lateral_m, global.lateral_m, 1e-12) << p.transpose();
      EXPECT_TRUE(near.point.isApprox(global.point)) << p.transpose();
    }
  }
}

// The search skips chords it can prove are further than the best so far; check it against
// looking at every chord, on a path that comes back near itself (a wavy loop inside a spiral).
TEST(PolylineTest, ProjectMatchesExhaustiveSearch) {
  std::vector<Vec2> points;
  for (int k = 0; k <= 1000; ++k) {
    const double a = 6.0 * kPi * k / 1000;
    const double r = 0.5 + 0.1 * a + 0.05 * std::sin(7.0 * a);
    points.emplace_back(r * std::cos(a), r * std::sin(a));
  }
  const Polyline path(points, false);
  // Nearest distance to the chords whose arc length lies in [lo, hi].
  auto exhaustive = [&](const Vec2& p, double lo, double hi) {
    double best = 1e9;
    for (std::size_t i = 0; i + 1 < points.size(); ++i) {
      const double s0 = path.arc_lengths_m()[i], s1 = path.arc_lengths_m()[i + 1];
      if (s1 < lo || s0 > hi) continue;
      const Vec2 d = (points[i + 1] - points[i]) / (s1 - s0);
      const double u =
          std::clamp(d.dot(p - points[i]), std::max(lo, s0) - s0, std::min(hi, s1) - s0);
      best = std::min(best, (p - (points[i] + d * u)).norm());
    }
    return best;
  };
  for (int i = -8; i <= 8; ++i) {
    for (int j = -8; j <= 8; ++j) {
      const Vec2 p(0.37 * i, 0.37 * j);
      EXPECT_NEAR(path.Project(p).distance_m, exhaustive(p, 0.0, path.length_m()), 1e-12)
          << p.transpose();
      for (double hint : {0.0, 3.0, 7.5, path.length_m()}) {
        const Polyline::Projection near = path.ProjectNear(p, hint, 1.5);
        EXPECT_NEAR(near.distance_m, exhaustive(p, hint - 1.5, hint + 1.5), 1e-12)
            << p.transpose() << " hint " << hint;
        EXPECT_LE(std::abs(near.s_m - hint), 1.5 + 1e-12);
      }
    }
  }
}

// ProjectNear finds its window's first and last chords by steps doubling away from the hint's
// chord (Polyline::ChordIndexFrom); on chords of very unequal lengths, with windows of every
// size and at both ends of an open path, it must still see exactly the window's chords.
TEST(PolylineTest, ProjectNearSeesItsWholeWindowOnUnequalChords) {
  std::mt19937 rng(23);
  std::uniform_real_distribution<double> spacing(0.001, 0.2), unit(0.0, 1.0);
  std::vector<Vec2> points;
  double x = 0.0;
  for (int k = 0; k < 400; ++k, x += spacing(rng)) points.emplace_back(x, 0.3 * std::sin(x));
  const Polyline path(points, false);
  const std::vector<double>& arc = path.arc_lengths_m();
  const auto exhaustive = [&](const Vec2& p, double lo, double hi) {
    double best = 1e9;
    for (std::size_t i = 0; i + 1 < points.size(); ++i) {
      if (arc[i + 1] < lo || arc[i] > hi) continue;
      const Vec2 d = (points[i + 1] - points[i]) / (arc[i + 1] - arc[i]);
      const double u = std::clamp(d.dot(p - points[i]), std::max(lo, arc[i]) - arc[i],
                                  std::min(hi, arc[i + 1]) - arc[i]);
      best = std::min(best, (p - (points[i] + d * u)).norm());
    }
    return best;
  };
  for (int trial = 0; trial < 3000; ++trial) {
    const double hint = (1.4 * unit(rng) - 0.2) * path.length_m();
    const double window = trial % 3 == 0 ? 0.0 : unit(rng) * (trial % 3 == 1 ? 0.3 : 30.0);
    const Vec2 p(unit(rng) * x, 2.0 * unit(rng) - 1.0);
    const Polyline::Projection near = path.ProjectNear(p, hint, window);
    const double lo = std::clamp(hint - window, 0.0, path.length_m());
    const double hi = std::clamp(hint + window, 0.0, path.length_m());
    ASSERT_NEAR(near.distance_m, exhaustive(p, lo, hi), 1e-12)
        << "hint " << hint << " window " << window;
    ASSERT_GE(near.s_m, lo - 1e-12);
    ASSERT_LE(near.s_m, hi + 1e-12);
  }
}

TEST(PolylineTest, ProjectNearStaysInItsWindow) {
  // A U: the start and the end run side by side 0.2 m apart.
  const Polyline path({{2.0, 0.0}, {0.0, 0.0}, {0.0, 0.2}, {2.0, 0.2}}, false);
  const Vec2 p(1.0, 0.02);
  EXPECT_NEAR(path.Project(p).s_m, 1.0, 1e-12);
  const Polyline::Projection near = path.ProjectNear(p, 3.2, 0.5);  // on the return leg
  EXPECT_NEAR(near.s_m, 3.2, 1e-12);
  EXPECT_NEAR(near.lateral_m, -0.18, 1e-12);  // the return leg runs +x: (1, 0.02) is on its right
  // The window's edge bounds s even when the nearest point lies beyond it.
  EXPECT_NEAR(path.ProjectNear(p, 2.9, 0.1).s_m, 3.0, 1e-12);
  EXPECT_NEAR(path.ProjectNear(p, 0.4, 0.0).s_m, 0.4, 1e-12);
  // Midway between the legs: equally near both, the smaller s wins wherever the search starts.
  EXPECT_DOUBLE_EQ(path.Project({1.0, 0.1}).s_m, 1.0);
  EXPECT_DOUBLE_EQ(path.ProjectNear({1.0, 0.1}, 3.2, 5.0).s_m, 1.0);
  EXPECT_THROW(path.ProjectNear(p, 0.4, -1.0), std::invalid_argument);
  EXPECT_THROW(path.ProjectNear(p, std::nan(""), 1.0), std::invalid_argument);
}

TEST(PolylineTest, CyclicPathWrapsAround) {
  const Polyline loop({{0.0, 0.0}, {1.0, 0.0}, {1.0, 1.0}, {0.0, 1.0}, {0.0, 0.0}}, true);
  EXPECT_DOUBLE_EQ(loop.length_m(), 4.0);
  EXPECT_TRUE(loop.PointAt(4.3).isApprox(Vec2(0.3, 0.0)));
  EXPECT_TRUE(loop.PointAt(-0.3).isApprox(Vec2(0.0, 0.3)));
  EXPECT_TRUE(loop.PointAt(-8.3).isApprox(Vec2(0.0, 0.3)));
  EXPECT_DOUBLE_EQ(loop.HeadingAt(-0.3), -kPi / 2);
  // The closing vertex has the curvature of a corner, not of an open end.
  EXPECT_GT(loop.CurvatureAt(0.0), 1.0);
  EXPECT_DOUBLE_EQ(loop.CurvatureAt(0.0), loop.CurvatureAt(4.0 - 1e-15));

  // Just before the closing point, found from a hint just after it, and the other way round.
  const Polyline::Projection a = loop.ProjectNear({-0.05, 0.1}, 0.05, 0.3);
  EXPECT_NEAR(a.s_m, 3.9, 1e-12);
  EXPECT_NEAR(a.lateral_m, -0.05, 1e-12);  // west of a southbound side is its right
  const Polyline::Projection b = loop.ProjectNear({0.1, -0.05}, 3.95, 0.3);
  EXPECT_NEAR(b.s_m, 0.1, 1e-12);
  EXPECT_NEAR(b.lateral_m, -0.05, 1e-12);
  // s from Project is in [0, length).
  const Polyline::Projection at_start = loop.Project({-0.1, -0.1});
  EXPECT_GE(at_start.s_m, 0.0);
  EXPECT_LT(at_start.s_m, loop.length_m());
  EXPECT_TRUE(at_start.point.isApprox(Vec2(0.0, 0.0)));
  // A window wider than the loop searches all of it.
  EXPECT_NEAR(loop.ProjectNear({0.5, 1.1}, 0.0, 3.0).s_m, 2.5, 1e-12);
}

}  // namespace
}  // namespace autonomsim::world
