// A densely sampled path with arc length: the painted lines and the lane centre paths are all of
// this kind. Sampling turns every query into table look-ups, so a path of any shape (fillet
// corners, joined lane segments) is queried the same way and costs the same.
#pragma once

#include <limits>
#include <vector>

#include "world/geometry.h"
#include "world/track_spec.h"

namespace autonomsim::world {

class Polyline {
 public:
  // Consecutive points closer than this are rejected as duplicates (a zero-length chord has no
  // direction).
  static constexpr double kMinChord_m = 1e-9;
  // A cyclic path's last point must lie this close to its first; it is then set equal to it.
  static constexpr double kClosureTolerance_m = 1e-9;

  Polyline() = default;
  // >= 2 finite points, consecutive points distinct (throws std::invalid_argument). cyclic: the
  // path is a loop (the last point equals the first): s wraps modulo length.
  Polyline(std::vector<Vec2> points, bool cyclic);

  double length_m() const { return arc_lengths_m_.empty() ? 0.0 : arc_lengths_m_.back(); }
  bool cyclic() const { return cyclic_; }
  const std::vector<Vec2>& points() const { return points_; }
  const std::vector<double>& arc_lengths_m() const { return arc_lengths_m_; }  // cumulative, [0]=0
  // Discrete curvature at each point (1/m, left positive): the turn between the chords meeting
  // there over their mean length. The ends of an open path repeat their neighbour's value.
  const std::vector<double>& curvatures_per_m() const { return curvatures_per_m_; }

  // Interpolated along the chords; s is clamped to [0, length] (wrapped if cyclic).
  Vec2 PointAt(double s_m) const;
  // Direction of travel of the chord containing s (rad, (-pi, pi]). Piecewise constant: on an arc
  // sampled at angle step d it is off the true tangent by at most d/2.
  double HeadingAt(double s_m) const;
  // 1/m, left turn positive: curvatures_per_m() interpolated linearly along the chord.
  double CurvatureAt(double s_m) const;

  struct Projection {
    double s_m{0.0};        // arc length of the nearest point; in [0, length) if cyclic
    double lateral_m{0.0};  // signed distance: left of the direction of travel positive;
                            // |lateral_m| == distance_m (beyond an open path's ends too)
    double distance_m{0.0};
    Vec2 point{0.0, 0.0};  // the nearest point on the path
  };
  // Globally nearest point. Equal distances: the smallest s wins. Chords that cannot be nearer
  // than the best so far are skipped in runs: typically O(sqrt(points)), O(points) at worst.
  Projection Project(const Vec2& p) const;
  // Nearest point whose s lies within [hint - window, hint + window] (clamped to [0, length] on an
  // open path, wrapping on a cyclic one), searched outwards from the hint; for per-step use: cost
  // O(log points + the chords near p), at most O(window / spacing). Equal distances: smaller s.
  // Throws std::invalid_argument if window < 0 or an argument is not finite.
  Projection ProjectNear(const Vec2& p, double s_hint_m, double window_m) const;

  // s mapped into [0, length) on a cyclic path, clamped into [0, length] on an open one. Every
  // query taking an s throws std::invalid_argument if it is not finite.
  double NormalizeS(double s_m) const;

 private:
  int ChordIndexAt(double s_m) const;  // s already normalized
  // The same, searched outwards from chord `near` (cheaper when s is a few chords from it)
  int ChordIndexFrom(double s_m, int near) const;
  struct Nearest {
    int chord{0};
    double u_m{0.0};  // along the chord
    double distance_sq{std::numeric_limits<double>::infinity()};
    Vec2 point{0.0, 0.0};
  };
  void VisitChord(const Vec2& p, int chord, double s_lo_m, double s_hi_m, Nearest* best) const;
  void ScanInterval(const Vec2& p, double s_lo_m, double s_hi_m, double s_start_m,
                    Nearest* best) const;
  Projection Finish(const Vec2& p, const Nearest& best) const;

  std::vector<Vec2> points_;
  std::vector<double> arc_lengths_m_;
  std::vector<Vec2> directions_;      // unit vector of chord i (points i -> i+1)
  std::vector<double> headings_rad_;  // of chord i
  std::vector<double> curvatures_per_m_;
  bool cyclic_{false};
};

// A polyline with every interior corner (and, if closed, every corner) rounded by a circular arc
// of corner_radius_m (0 = sharp), sampled at <= spacing_m (arcs by angle, chord error < 0.1 mm).
// A closed outline lists each corner once (a repeated first point at the end is dropped); its
// path starts where the arc at the first corner ends (at the first point if sharp) and is cyclic.
// Throws std::invalid_argument if an arc does not fit (its tangent length exceeds what the
// adjacent sides allow — two arcs may share a side exactly, e.g. a stadium whose radius is half
// its height), if the path turns back on itself at a rounded corner, or on bad arguments.
Polyline SampleFilletPolyline(const PointList& points_m, double corner_radius_m, bool closed,
                              double spacing_m = 0.01);

}  // namespace autonomsim::world
