#include "sim/results/track_figure.h"

#include <fmt/format.h>

#include <array>
#include <cmath>
#include <map>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <vector>

#include "world/floor_raster.h"

namespace autonomsim::sim {
namespace {

// Car colours (BGR), chosen to stand out on black, white and yellow.
constexpr std::array<std::array<int, 3>, 6> kCarColours{
    {{255, 160, 0}, {60, 60, 255}, {80, 220, 80}, {255, 0, 255}, {0, 165, 255}, {255, 255, 0}}};

// A car's path is drawn in pieces of this many samples, so drawing holds no whole trajectory.
constexpr std::size_t kPathPieceSamples = 4096;

// The figure's margins around the floor (px): axes and labels left and below, the title above,
// the legend to the right.
constexpr int kLeftPx = 70, kTopPx = 56, kBottomPx = 56, kRightPx = 270;
constexpr double kArrowEvery_m = 2.0;   // direction arrows along each path...
constexpr double kArrowsUpTo_m = 12.0;  // ...over its first metres
constexpr double kArrowLength_m = 0.25;
const cv::Scalar kBackground(32, 32, 32), kText(235, 235, 235), kZoneGrey(120, 120, 120),
    kObstacleBgr(40, 40, 200);
constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;

void Text(cv::Mat& image, const std::string& text, cv::Point at, double scale = 0.5,
          const cv::Scalar& colour = kText, int thickness = 1) {
  cv::putText(image, text, at, kFont, scale, colour, thickness, cv::LINE_AA);
}

void Cross(cv::Mat& image, cv::Point p, int half, const cv::Scalar& colour, int thickness) {
  cv::line(image, p + cv::Point(-half, -half), p + cv::Point(half, half), colour, thickness,
           cv::LINE_AA);
  cv::line(image, p + cv::Point(-half, half), p + cv::Point(half, -half), colour, thickness,
           cv::LINE_AA);
}

// Metre ticks along both axes of the floor, labelled every metre, and the axis names.
void DrawAxes(cv::Mat& image, const TrackFigureLayout& at, double size_m) {
  const double half = 0.5 * size_m;
  for (int k = static_cast<int>(std::ceil(-half * 2)); k <= static_cast<int>(std::floor(half * 2));
       ++k) {
    const double m = 0.5 * k;
    const bool whole = k % 2 == 0;
    const cv::Point bx = at.ToPixel(m, -half), ly = at.ToPixel(-half, m);
    cv::line(image, bx + cv::Point(0, 2), bx + cv::Point(0, whole ? 10 : 6), kText, 1);
    cv::line(image, ly - cv::Point(2, 0), ly - cv::Point(whole ? 10 : 6, 0), kText, 1);
    if (whole) {
      const std::string label = fmt::format("{:g}", m);
      Text(image, label, bx + cv::Point(-4 * static_cast<int>(label.size()), 26), 0.45);
      Text(image, label, ly + cv::Point(-16 - 8 * static_cast<int>(label.size()), 5), 0.45);
    }
  }
  const cv::Point bottom_right = at.ToPixel(half, -half);
  Text(image, "x (m)", {bottom_right.x - 40, bottom_right.y + 46}, 0.5);
  Text(image, "y (m)", {6, at.top_px - 10}, 0.5);
}

}  // namespace

cv::Scalar CarColourBgrAt(std::size_t index) {
  const auto& bgr = kCarColours[index % kCarColours.size()];
  return cv::Scalar(bgr[0], bgr[1], bgr[2]);
}

std::string ColourHex(const cv::Scalar& bgr) {
  return fmt::format("#{:02x}{:02x}{:02x}", static_cast<int>(bgr[2]), static_cast<int>(bgr[1]),
                     static_cast<int>(bgr[0]));
}

cv::Scalar CarColourBgr(const Scenario& scenario, int car_id) {
  std::size_t c = 0;
  while (c < scenario.cars.size() && scenario.cars[c].id != car_id) ++c;
  return CarColourBgrAt(c);
}

cv::Point TrackFigureLayout::ToPixel(double x_m, double y_m) const {
  return {left_px + static_cast<int>(std::lround((x_m - x0_m) / m_per_px - 0.5)),
          top_px + static_cast<int>(std::lround((y0_m - y_m) / m_per_px - 0.5))};
}

namespace {
TrackFigureLayout LayoutOf(const world::FloorRaster& raster) {
  return {raster.m_per_px, raster.origin_m.x(), raster.origin_m.y(), kLeftPx, kTopPx};
}
}  // namespace

TrackFigureLayout TrackFigureLayoutOf(const LoadedScenario& loaded) {
  return LayoutOf(world::RasterizeFloor(loaded.track));
}

TrackFigureBase DrawTrackFigureBase(const Scenario& scenario, const world::Track& track,
                                    bool with_obstacles) {
  const world::FloorRaster raster = world::RasterizeFloor(track);
  const TrackFigureLayout at = LayoutOf(raster);
  cv::Mat image(kTopPx + raster.height_px + kBottomPx, kLeftPx + raster.width_px + kRightPx,
                CV_8UC3, kBackground);
  cv::Mat(raster.height_px, raster.width_px, CV_8UC3, const_cast<std::uint8_t*>(raster.bgr.data()))
      .copyTo(image(cv::Rect(kLeftPx, kTopPx, raster.width_px, raster.height_px)));

  // zone boxes, each area labelled with its intersection's id
  for (const world::IntersectionSpec& i : track.spec().intersections) {
    auto draw_box = [&](const world::Box& b, int thickness) {
      cv::rectangle(image, at.ToPixel(b.x_min_m, b.y_max_m), at.ToPixel(b.x_max_m, b.y_min_m),
                    kZoneGrey, thickness);
    };
    draw_box(i.area, 2);
    for (const world::Box& zone : i.stop_zones) draw_box(zone, 1);
    Text(image, fmt::format("intersection {}", i.id),
         at.ToPixel(i.area.x_min_m, i.area.y_max_m) + cv::Point(4, 16), 0.45, kZoneGrey);
  }
  if (with_obstacles) {
    for (const ObstacleConfig& o : scenario.obstacles) DrawObstacle(image, at, o);
  }

  // axes, scale bar, title
  DrawAxes(image, at, track.spec().size_m);
  const double half = 0.5 * track.spec().size_m;
  const cv::Point bar = at.ToPixel(half - 1.3, -half + 0.15);
  const int one_m = static_cast<int>(std::lround(1.0 / at.m_per_px));
  cv::rectangle(image, cv::Rect(bar.x - 4, bar.y - 24, one_m + 8, 32), cv::Scalar(0, 0, 0),
                cv::FILLED);
  cv::line(image, bar, bar + cv::Point(one_m, 0), kText, 3);
  for (int end : {0, one_m})
    cv::line(image, bar + cv::Point(end, -6), bar + cv::Point(end, 6), kText, 2);
  Text(image, "1 m", bar + cv::Point(one_m / 2 - 14, -10), 0.5);
  Text(image,
       fmt::format("{}  (seed {}, {:g} s)", scenario.name, scenario.seed,
                   ToSeconds(scenario.duration)),
       {kLeftPx, 34}, 0.75, kText, 2);
  return {image, at, kLeftPx + raster.width_px + 20};
}

int DrawTrackLegend(cv::Mat& image, const Scenario& scenario, int legend_x, bool paths) {
  int y = kTopPx + 20;
  for (const CarConfig& car : scenario.cars) {
    const cv::Scalar colour = CarColourBgr(scenario, car.id);
    if (paths) {
      cv::line(image, {legend_x, y - 5}, {legend_x + 26, y - 5}, colour, 3, cv::LINE_AA);
    } else {
      cv::rectangle(image, cv::Rect(legend_x + 4, y - 12, 18, 12), colour, cv::FILLED);
    }
    Text(image,
         fmt::format("car {}: {}, {}", car.id, car.route.value_or("lanes"), ToName(car.driver)),
         {legend_x + 34, y}, 0.45);
    y += 24;
  }
  y += 10;
  if (paths) {
    cv::circle(image, {legend_x + 13, y - 5}, 6, kText, cv::FILLED, cv::LINE_AA);
    Text(image, "start", {legend_x + 34, y}, 0.45);
    y += 24;
    cv::arrowedLine(image, {legend_x, y - 5}, {legend_x + 26, y - 5}, kText, 2, cv::LINE_AA, 0,
                    0.4);
    Text(image, "direction", {legend_x + 34, y}, 0.45);
    y += 24;
  }
  Cross(image, {legend_x + 13, y - 5}, 7, kCollisionMarkerBgr, 3);
  Text(image, "collision", {legend_x + 34, y}, 0.45);  // not a kind: the legend's word
  y += 24;
  cv::rectangle(image, cv::Rect(legend_x, y - 14, 26, 14), kZoneGrey, 2);
  Text(image, "intersection", {legend_x + 34, y}, 0.45);
  y += 24;
  cv::rectangle(image, cv::Rect(legend_x, y - 14, 26, 14), kZoneGrey, 1);
  Text(image, "stop box", {legend_x + 34, y}, 0.45);
  if (!scenario.obstacles.empty()) {
    y += 24;
    cv::rectangle(image, cv::Rect(legend_x, y - 14, 26, 14), kObstacleBgr, cv::FILLED);
    Text(image, "obstacle", {legend_x + 34, y}, 0.45);
  }
  return y + 24;
}

void DrawObstacle(cv::Mat& image, const TrackFigureLayout& at, const ObstacleConfig& o) {
  const cv::RotatedRect box(at.ToPixel(o.x_m, o.y_m),
                            cv::Size2f(static_cast<float>(o.length_m / at.m_per_px),
                                       static_cast<float>(o.width_m / at.m_per_px)),
                            static_cast<float>(-o.yaw_deg));
  cv::Point2f corners[4];
  box.points(corners);
  std::vector<cv::Point> polygon(corners, corners + 4);
  cv::fillConvexPoly(image, polygon, kObstacleBgr);
}

void DrawCollisionMarker(cv::Mat& image, cv::Point p) {
  Cross(image, p, 9, cv::Scalar(255, 255, 255), 5);
  Cross(image, p, 9, kCollisionMarkerBgr, 3);
}

cv::Mat DrawTrackFigure(const LoadedScenario& loaded, const RunRecord& record) {
  TrackFigureBase base = DrawTrackFigureBase(loaded.scenario, loaded.track, true);
  cv::Mat& image = base.image;
  const TrackFigureLayout& at = base.layout;

  // collisions: where the car was at the first sample at or after each
  std::map<int, std::vector<Time>> collisions;  // car -> instants, in order
  ForEachEvent(record, [&](const Event& e) {
    if (e.type == EventKind::kCollision) collisions[e.car].push_back(e.t);
  });
  std::vector<cv::Point> collision_points;

  // the cars' paths, drawn as the samples are read (a long run's trajectory stays on disk)
  struct CarPath {
    std::vector<cv::Point> points;  // not yet drawn
    std::optional<cv::Point> start;
    std::optional<std::pair<double, double>> last_m;
    double travelled_m{0.0};
    double next_arrow_m{1.0};
    std::size_t next_collision{0};
    std::vector<std::pair<cv::Point, cv::Point>> arrows;
  };
  std::map<int, CarPath> paths;
  auto colour_of = [&](int id) { return CarColourBgr(loaded.scenario, id); };
  auto draw = [&](int id, std::vector<cv::Point>& points) {
    cv::polylines(image, points, false, colour_of(id), 2, cv::LINE_AA);
    points.erase(points.begin(), points.end() - 1);  // the next piece starts where this one ends
  };
  ForEachSample(record, [&](const TrajectorySample& s) {
    CarPath& path = paths[s.car];
    const cv::Point p = at.ToPixel(s.x_m, s.y_m);
    path.points.push_back(p);
    if (!path.start) path.start = p;
    if (path.last_m) {
      path.travelled_m += std::hypot(s.x_m - path.last_m->first, s.y_m - path.last_m->second);
    }
    path.last_m = {s.x_m, s.y_m};
    if (path.travelled_m >= path.next_arrow_m && path.next_arrow_m <= kArrowsUpTo_m) {
      path.arrows.push_back({p, at.ToPixel(s.x_m + kArrowLength_m * std::cos(s.yaw_rad),
                                           s.y_m + kArrowLength_m * std::sin(s.yaw_rad))});
      path.next_arrow_m += kArrowEvery_m;
    }
    const auto it = collisions.find(s.car);
    if (it != collisions.end()) {
      // one marker per touching spell: the instants of one contact come every physics step
      while (path.next_collision < it->second.size() && it->second[path.next_collision] <= s.t) {
        if (collision_points.empty() || cv::norm(collision_points.back() - p) > 6.0) {
          collision_points.push_back(p);
        }
        ++path.next_collision;
      }
    }
    if (path.points.size() >= kPathPieceSamples) draw(s.car, path.points);
  });
  for (auto& [id, path] : paths) draw(id, path.points);
  for (const auto& [id, path] : paths) {
    for (const auto& [from, to] : path.arrows) {
      cv::arrowedLine(image, from, to, cv::Scalar(255, 255, 255), 4, cv::LINE_AA, 0, 0.45);
      cv::arrowedLine(image, from, to, colour_of(id), 2, cv::LINE_AA, 0, 0.45);
    }
    if (path.start) {
      cv::circle(image, *path.start, 8, cv::Scalar(255, 255, 255), cv::FILLED, cv::LINE_AA);
      cv::circle(image, *path.start, 6, colour_of(id), cv::FILLED, cv::LINE_AA);
    }
  }
  for (const cv::Point& p : collision_points) DrawCollisionMarker(image, p);

  DrawTrackLegend(image, loaded.scenario, base.legend_x, true);
  return image;
}

}  // namespace autonomsim::sim
