#include "world/polyline.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

#include "world/validation.h"

namespace autonomsim::world {
namespace {

constexpr double kPi = std::numbers::pi;
// Arcs are sampled so that no chord strays further than this from the true arc (the painted
// lines are ~36 mm wide and the raster is 5 mm/px, so 0.1 mm is invisible).
constexpr double kMaxChordError_m = 1e-4;
// Coarsest angle step of an arc whatever its radius, so that even a tiny fillet keeps a curvature
// estimate (turn / chord) that means something.
constexpr double kMaxArcStep_rad = kPi / 8.0;
// Collinear within this the corner gets no arc.
constexpr double kStraightTurn_rad = 1e-12;
// A straight piece shorter than this between two tangent points is numerical noise (two arcs
// sharing a side exactly); its end points are merged.
constexpr double kMergeDistance_m = 1e-9;

double Cross(const Vec2& a, const Vec2& b) { return a.x() * b.y() - a.y() * b.x(); }

std::string FormatPoint(const Vec2& p) { return "(" + Num(p.x()) + ", " + Num(p.y()) + ")"; }

}  // namespace

Polyline::Polyline(std::vector<Vec2> points, bool cyclic)
    : points_(std::move(points)), cyclic_(cyclic) {
  if (points_.size() < 2) {
    throw std::invalid_argument("polyline needs at least 2 points, got " +
                                std::to_string(points_.size()));
  }
  for (std::size_t i = 0; i < points_.size(); ++i) {
    if (!points_[i].allFinite()) {
      throw std::invalid_argument("polyline point " + std::to_string(i) + " is not finite");
    }
  }
  if (cyclic_) {
    const double gap = (points_.back() - points_.front()).norm();
    if (gap > kClosureTolerance_m) {
      throw std::invalid_argument("cyclic polyline must end where it starts; last point " +
                                  FormatPoint(points_.back()) + " is " + Num(gap) +
                                  " m from the first " + FormatPoint(points_.front()));
    }
    points_.back() = points_.front();
  }
  const std::size_t chords = points_.size() - 1;
  arc_lengths_m_.resize(points_.size());
  directions_.resize(chords);
  headings_rad_.resize(chords);
  arc_lengths_m_[0] = 0.0;
  for (std::size_t i = 0; i < chords; ++i) {
    const Vec2 d = points_[i + 1] - points_[i];
    const double length = d.norm();
    if (!(length > kMinChord_m)) {
      throw std::invalid_argument("polyline points " + std::to_string(i) + " and " +
                                  std::to_string(i + 1) + " coincide at " +
                                  FormatPoint(points_[i]));
    }
    arc_lengths_m_[i + 1] = arc_lengths_m_[i] + length;
    directions_[i] = d / length;
    headings_rad_[i] = std::atan2(d.y(), d.x());
  }

  // Turn at each vertex over the mean of its two chords: on an arc of radius r sampled at angle
  // step a this is a / (2 r sin(a/2)) = (1/r)(1 + a^2/24 + ...).
  curvatures_per_m_.assign(points_.size(), 0.0);
  auto vertex_curvature = [&](std::size_t in, std::size_t out) {
    const double turn =
        std::atan2(Cross(directions_[in], directions_[out]), directions_[in].dot(directions_[out]));
    const double chord_in = arc_lengths_m_[in + 1] - arc_lengths_m_[in];
    const double chord_out = arc_lengths_m_[out + 1] - arc_lengths_m_[out];
    return turn / (0.5 * (chord_in + chord_out));
  };
  for (std::size_t i = 1; i < chords; ++i) curvatures_per_m_[i] = vertex_curvature(i - 1, i);
  if (cyclic_) {
    curvatures_per_m_.front() = vertex_curvature(chords - 1, 0);
    curvatures_per_m_.back() = curvatures_per_m_.front();
  } else if (chords >= 2) {
    curvatures_per_m_.front() = curvatures_per_m_[1];
    curvatures_per_m_.back() = curvatures_per_m_[chords - 1];
  }
}

double Polyline::NormalizeS(double s_m) const {
  if (!std::isfinite(s_m)) throw std::invalid_argument("arc length s is not finite");
  const double length = length_m();
  if (cyclic_) {
    double s = std::fmod(s_m, length);
    if (s < 0.0) s += length;
    if (s >= length) s = 0.0;  // -tiny + length rounds to length
    return s;
  }
  return std::clamp(s_m, 0.0, length);
}

int Polyline::ChordIndexAt(double s_m) const {
  const auto it = std::upper_bound(arc_lengths_m_.begin(), arc_lengths_m_.end(), s_m);
  const int index = static_cast<int>(it - arc_lengths_m_.begin()) - 1;
  return std::clamp(index, 0, static_cast<int>(directions_.size()) - 1);
}

int Polyline::ChordIndexFrom(double s_m, int near) const {
  // upper_bound's answer u (the first arc length above s, or n), bracketed as [lo, hi] by steps
  // doubling away from `near`, then searched within the bracket
  const auto arc = arc_lengths_m_.begin();
  const auto n = static_cast<std::ptrdiff_t>(arc_lengths_m_.size());
  const std::ptrdiff_t from = std::clamp<std::ptrdiff_t>(near, 0, n - 1);
  std::ptrdiff_t lo = 0, hi = 0;
  if (arc[from] <= s_m) {  // u > from; every index below lo is at or below s
    lo = from + 1;
    hi = lo;
    for (std::ptrdiff_t step = 1; hi < n && arc[hi] <= s_m; step *= 2) {
      lo = hi + 1;
      hi = std::min(n, hi + step);
    }
  } else {  // u <= from; arc[hi] is above s
    hi = from;
    lo = from;
    for (std::ptrdiff_t step = 1; lo > 0 && arc[lo - 1] > s_m; step *= 2) {
      hi = lo - 1;
      lo = std::max<std::ptrdiff_t>(0, lo - step);
    }
  }
  const int index = static_cast<int>(std::upper_bound(arc + lo, arc + hi, s_m) - arc) - 1;
  return std::clamp(index, 0, static_cast<int>(directions_.size()) - 1);
}

Vec2 Polyline::PointAt(double s_m) const {
  if (points_.empty()) throw std::logic_error("PointAt on an empty polyline");
  const double s = NormalizeS(s_m);
  const int i = ChordIndexAt(s);
  return points_[i] + directions_[i] * (s - arc_lengths_m_[i]);
}

double Polyline::HeadingAt(double s_m) const {
  if (points_.empty()) throw std::logic_error("HeadingAt on an empty polyline");
  return headings_rad_[ChordIndexAt(NormalizeS(s_m))];
}

double Polyline::CurvatureAt(double s_m) const {
  if (points_.empty()) throw std::logic_error("CurvatureAt on an empty polyline");
  const double s = NormalizeS(s_m);
  const int i = ChordIndexAt(s);
  const double t = (s - arc_lengths_m_[i]) / (arc_lengths_m_[i + 1] - arc_lengths_m_[i]);
  return curvatures_per_m_[i] + (curvatures_per_m_[i + 1] - curvatures_per_m_[i]) * t;
}

void Polyline::VisitChord(const Vec2& p, int i, double s_lo_m, double s_hi_m, Nearest* best) const {
  const double u_lo = std::max(s_lo_m, arc_lengths_m_[i]) - arc_lengths_m_[i];
  const double u_hi = std::min(s_hi_m, arc_lengths_m_[i + 1]) - arc_lengths_m_[i];
  const double u = std::clamp(directions_[i].dot(p - points_[i]), u_lo, std::max(u_lo, u_hi));
  const Vec2 q = points_[i] + directions_[i] * u;
  const double distance_sq = (p - q).squaredNorm();
  const double s = arc_lengths_m_[i] + u;
  if (distance_sq < best->distance_sq ||
      (distance_sq == best->distance_sq && s < arc_lengths_m_[best->chord] + best->u_m)) {
    *best = Nearest{i, u, distance_sq, q};
  }
}

// Visits the chord at s_start first, then walks outwards both ways. A point at arc distance ds
// from a vertex at distance d from p is at least d - ds from p (no path is shorter than the
// straight line), so while d exceeds the best distance so far by more than a chord, whole runs of
// chords are skipped without being looked at: the cost is that of the chords near p, not of the
// window.
void Polyline::ScanInterval(const Vec2& p, double s_lo_m, double s_hi_m, double s_start_m,
                            Nearest* best) const {
  const int near = ChordIndexAt(s_start_m);
  const int first = ChordIndexFrom(s_lo_m, near);
  const int last = ChordIndexFrom(s_hi_m, near);
  const int start = std::clamp(near, first, last);
  VisitChord(p, start, s_lo_m, s_hi_m, best);
  double best_m = std::sqrt(best->distance_sq);
  const auto arc = arc_lengths_m_.begin();
  for (int j = start + 1; j <= last;) {
    const double chord_m = arc[j + 1] - arc[j];
    const double vertex_m = (p - points_[j]).norm();
    if (vertex_m - best_m > chord_m) {
      const double target = arc[j] + (vertex_m - best_m);
      if (target > s_hi_m) break;
      const int k = static_cast<int>(std::upper_bound(arc + j + 1, arc + last + 1, target) - arc);
      j = std::max(k - 1, j + 1);
      continue;
    }
    VisitChord(p, j, s_lo_m, s_hi_m, best);
    best_m = std::sqrt(best->distance_sq);
    ++j;
  }
  for (int j = start - 1; j >= first;) {
    const double chord_m = arc[j + 1] - arc[j];
    const double vertex_m = (p - points_[j + 1]).norm();
    if (vertex_m - best_m > chord_m) {
      const double target = arc[j + 1] - (vertex_m - best_m);
      if (target < s_lo_m) break;
      j = static_cast<int>(std::upper_bound(arc + first, arc + j, target) - arc) - 1;
      j = std::max(j, first);
      continue;
    }
    VisitChord(p, j, s_lo_m, s_hi_m, best);
    best_m = std::sqrt(best->distance_sq);
    --j;
  }
}

Polyline::Projection Polyline::Finish(const Vec2& p, const Nearest& best) const {
  // At a vertex the side is judged against the bisector of the two chords, so that a point
  // outside a corner is on the same side as the points just before and after it.
  const int chord = best.chord;
  const int last_chord = static_cast<int>(directions_.size()) - 1;
  const double chord_length = arc_lengths_m_[chord + 1] - arc_lengths_m_[chord];
  Vec2 tangent = directions_[chord];
  if (best.u_m <= 0.0 && (chord > 0 || cyclic_)) {
    tangent += directions_[chord > 0 ? chord - 1 : last_chord];
  } else if (best.u_m >= chord_length && (chord < last_chord || cyclic_)) {
    tangent += directions_[chord < last_chord ? chord + 1 : 0];
  }
  if (tangent.squaredNorm() < 1e-24) tangent = directions_[chord];  // the path turned back
  Projection result;
  result.point = best.point;
  result.distance_m = std::sqrt(best.distance_sq);
  result.lateral_m = Cross(tangent, p - best.point) >= 0.0 ? result.distance_m : -result.distance_m;
  result.s_m = NormalizeS(arc_lengths_m_[chord] + std::min(best.u_m, chord_length));
  return result;
}

Polyline::Projection Polyline::Project(const Vec2& p) const {
  if (points_.empty()) throw std::logic_error("Project on an empty polyline");
  // Start the search at the nearest of every stride-th vertex: with a good best distance from the
  // outset the walk skips nearly everything, so a global projection costs O(sqrt(points)).
  const std::size_t stride =
      std::max<std::size_t>(1, static_cast<std::size_t>(std::sqrt(points_.size())));
  std::size_t start = 0;
  double start_distance_sq = (p - points_[0]).squaredNorm();
  for (std::size_t i = stride; i < points_.size(); i += stride) {
    const double distance_sq = (p - points_[i]).squaredNorm();
    if (distance_sq < start_distance_sq) {
      start_distance_sq = distance_sq;
      start = i;
    }
  }
  Nearest best;
  ScanInterval(p, 0.0, length_m(), arc_lengths_m_[start], &best);
  return Finish(p, best);
}

Polyline::Projection Polyline::ProjectNear(const Vec2& p, double s_hint_m, double window_m) const {
  if (points_.empty()) throw std::logic_error("ProjectNear on an empty polyline");
  if (!std::isfinite(s_hint_m) || !std::isfinite(window_m) || window_m < 0.0) {
    throw std::invalid_argument("ProjectNear needs a finite hint and a finite window >= 0, got " +
                                Num(s_hint_m) + " and " + Num(window_m));
  }
  Nearest best;
  const double length = length_m();
  if (!cyclic_) {
    const double lo = std::clamp(s_hint_m - window_m, 0.0, length);
    const double hi = std::clamp(s_hint_m + window_m, 0.0, length);
    ScanInterval(p, lo, hi, std::clamp(s_hint_m, lo, hi), &best);
  } else if (2.0 * window_m >= length) {
    ScanInterval(p, 0.0, length, NormalizeS(s_hint_m), &best);
  } else {
    const double lo = NormalizeS(s_hint_m - window_m);
    const double hi = lo + 2.0 * window_m;
    const double hint = NormalizeS(s_hint_m);
    if (hi <= length) {
      ScanInterval(p, lo, hi, std::clamp(hint, lo, hi), &best);
    } else if (hint >= lo) {  // the window wraps past the end; the hint is before the wrap
      ScanInterval(p, lo, length, hint, &best);
      ScanInterval(p, 0.0, hi - length, 0.0, &best);
    } else {
      ScanInterval(p, 0.0, hi - length, std::min(hint, hi - length), &best);
      ScanInterval(p, lo, length, length, &best);
    }
  }
  return Finish(p, best);
}

namespace {

// The outline's corners without a closing repeat: std::invalid_argument for too few or a point
// that is not finite.
std::vector<Vec2> OutlineCorners(const PointList& points_m, bool closed) {
  std::vector<Vec2> corners;
  corners.reserve(points_m.size());
  for (const auto& [x, y] : points_m) corners.emplace_back(x, y);
  if (closed && corners.size() >= 2 && corners.back() == corners.front()) corners.pop_back();
  const std::size_t n = corners.size();
  const std::size_t min_points = closed ? 3 : 2;
  if (n < min_points) {
    throw std::invalid_argument(std::string(closed ? "a closed" : "an open") +
                                " outline needs at least " + std::to_string(min_points) +
                                " distinct points, got " + std::to_string(n));
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (!corners[i].allFinite()) {
      throw std::invalid_argument("point " + std::to_string(i) + " is not finite");
    }
  }
  return corners;
}

// An outline with an arc of one radius at each inner corner.
struct FilletOutline {
  std::vector<Vec2> corners;
  bool closed{false};
  double corner_radius_m{0.0};
  // Side i runs from corner i to corner i+1 (closed: n sides, open: n-1).
  std::size_t sides{0};
  std::vector<Vec2> side_direction;
  std::vector<double> side_length;
  // The arc at each corner: its turn (signed, left positive) and tangent length.
  std::vector<double> turn;
  std::vector<double> tangent;

  const Vec2& In(std::size_t c) const { return side_direction[(c + sides - 1) % sides]; }
  const Vec2& Out(std::size_t c) const { return side_direction[c % sides]; }
  Vec2 ArcStart(std::size_t c) const { return corners[c] - In(c) * tangent[c]; }
  Vec2 ArcEnd(std::size_t c) const { return corners[c] + Out(c) * tangent[c]; }
};

void MeasureSides(FilletOutline* o) {
  const std::size_t n = o->corners.size();
  o->sides = o->closed ? n : n - 1;
  o->side_direction.resize(o->sides);
  o->side_length.resize(o->sides);
  for (std::size_t i = 0; i < o->sides; ++i) {
    const Vec2 d = o->corners[(i + 1) % n] - o->corners[i];
    o->side_length[i] = d.norm();
    if (!(o->side_length[i] > Polyline::kMinChord_m)) {
      throw std::invalid_argument("points " + std::to_string(i) + " and " +
                                  std::to_string((i + 1) % n) + " coincide at " +
                                  FormatPoint(o->corners[i]));
    }
    o->side_direction[i] = d / o->side_length[i];
  }
}

// Each corner's turn and tangent length; std::invalid_argument where a path turns back or two
// arcs do not fit on the side between them.
void FitArcs(FilletOutline* o) {
  const std::size_t n = o->corners.size();
  o->turn.assign(n, 0.0);
  o->tangent.assign(n, 0.0);
  for (std::size_t c = 0; c < n; ++c) {
    if (!o->closed && (c == 0 || c == n - 1)) continue;
    o->turn[c] = std::atan2(Cross(o->In(c), o->Out(c)), o->In(c).dot(o->Out(c)));
    if (o->corner_radius_m == 0.0 || std::abs(o->turn[c]) < kStraightTurn_rad) continue;
    if (std::abs(o->turn[c]) > kPi - 1e-9) {
      throw std::invalid_argument("the path turns back on itself at point " + std::to_string(c) +
                                  " " + FormatPoint(o->corners[c]) + "; it cannot be rounded");
    }
    o->tangent[c] = o->corner_radius_m * std::tan(0.5 * std::abs(o->turn[c]));
  }
  for (std::size_t i = 0; i < o->sides; ++i) {
    const std::size_t a = i;
    const std::size_t b = (i + 1) % n;
    const double needed = o->tangent[a] + o->tangent[b];
    if (needed > o->side_length[i] + kMergeDistance_m) {
      throw std::invalid_argument("corner radius " + Num(o->corner_radius_m) +
                                  " m does not fit: the arcs at points " + std::to_string(a) + " " +
                                  FormatPoint(o->corners[a]) + " and " + std::to_string(b) + " " +
                                  FormatPoint(o->corners[b]) + " need " + Num(needed) +
                                  " m of a side " + Num(o->side_length[i]) + " m long");
    }
  }
}

// Largest angle step that keeps both the chord length and the chord error in bounds.
double MaxArcStep_rad(double corner_radius_m, double spacing_m) {
  double max_step_rad = kMaxArcStep_rad;
  if (corner_radius_m > 0.0) {
    if (spacing_m < 2.0 * corner_radius_m) {
      max_step_rad = std::min(max_step_rad, 2.0 * std::asin(spacing_m / (2.0 * corner_radius_m)));
    }
    if (kMaxChordError_m < corner_radius_m) {
      max_step_rad =
          std::min(max_step_rad, 2.0 * std::acos(1.0 - kMaxChordError_m / corner_radius_m));
    }
  }
  return max_step_rad;
}

// The points along a fitted outline: straight pieces at most spacing_m long, arcs in steps of at
// most max_step_rad; points within kMergeDistance_m of the previous one merged.
class FilletSampler {
 public:
  FilletSampler(const FilletOutline& outline, double spacing_m)
      : o_(outline),
        spacing_m_(spacing_m),
        max_step_rad_(MaxArcStep_rad(outline.corner_radius_m, spacing_m)) {}

  std::vector<Vec2> Sample() && {
    const std::size_t n = o_.corners.size();
    if (o_.closed) {
      Emit(o_.ArcEnd(0));
      for (std::size_t k = 1; k <= n; ++k) ToCorner(k % n);
      out_.back() = out_.front();  // the arc at corner 0 ends where the path began
    } else {
      Emit(o_.corners[0]);
      for (std::size_t c = 1; c + 1 < n; ++c) ToCorner(c);
      EmitStraightTo(o_.corners[n - 1]);
    }
    return std::move(out_);
  }

 private:
  void Emit(const Vec2& p) {
    if (out_.empty() || (p - out_.back()).norm() > kMergeDistance_m) out_.push_back(p);
  }
  // The straight piece to corner c's arc, then the arc.
  void ToCorner(std::size_t c) {
    EmitStraightTo(o_.ArcStart(c));
    if (o_.tangent[c] > 0.0) EmitArc(c);
  }
  void EmitStraightTo(const Vec2& to) {
    const Vec2 from = out_.back();
    const double length = (to - from).norm();
    if (length <= kMergeDistance_m) return;
    const int pieces = std::max(1, static_cast<int>(std::ceil(length / spacing_m_)));
    for (int k = 1; k < pieces; ++k) Emit(from + (to - from) * (static_cast<double>(k) / pieces));
    Emit(to);
  }
  // Arc at corner c, from its start tangent point (already emitted) to its end tangent point.
  void EmitArc(std::size_t c) {
    const Vec2& in = o_.In(c);
    const Vec2 start = o_.ArcStart(c);
    const double turn = o_.turn[c];
    const double sign = turn > 0.0 ? 1.0 : -1.0;
    const Vec2 left(-in.y(), in.x());
    const Vec2 centre = start + left * (sign * o_.corner_radius_m);
    const double start_angle = std::atan2(start.y() - centre.y(), start.x() - centre.x());
    const int pieces = std::max(1, static_cast<int>(std::ceil(std::abs(turn) / max_step_rad_)));
    for (int k = 1; k < pieces; ++k) {
      const double angle = start_angle + turn * (static_cast<double>(k) / pieces);
      Emit(centre + o_.corner_radius_m * Vec2(std::cos(angle), std::sin(angle)));
    }
    Emit(o_.ArcEnd(c));
  }

  const FilletOutline& o_;
  double spacing_m_;
  double max_step_rad_;
  std::vector<Vec2> out_;
};

}  // namespace

Polyline SampleFilletPolyline(const PointList& points_m, double corner_radius_m, bool closed,
                              double spacing_m) {
  if (!(std::isfinite(corner_radius_m) && corner_radius_m >= 0.0)) {
    throw std::invalid_argument("corner_radius_m must be finite and >= 0, got " +
                                Num(corner_radius_m));
  }
  if (!(std::isfinite(spacing_m) && spacing_m > 0.0)) {
    throw std::invalid_argument("spacing_m must be finite and > 0, got " + Num(spacing_m));
  }
  FilletOutline outline;
  outline.corners = OutlineCorners(points_m, closed);
  outline.closed = closed;
  outline.corner_radius_m = corner_radius_m;
  MeasureSides(&outline);
  FitArcs(&outline);
  return Polyline(FilletSampler(outline, spacing_m).Sample(), closed);
}

}  // namespace autonomsim::world
