#include "sim/results/outputs.h"

#include <fmt/format.h>

#include <array>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "sim/core/config.h"
#include "sim/core/files.h"
#include "sim/platform/node_metrics.h"
#include "sim/results/png.h"
#include "sim/results/summary.h"
#include "world/floor_raster.h"

namespace autonomsim::sim {
namespace {

// Car colours in track.png (BGR), chosen to stand out on black, white and yellow.
constexpr std::array<std::array<int, 3>, 6> kCarColours{
    {{255, 160, 0}, {60, 60, 255}, {80, 220, 80}, {255, 0, 255}, {0, 165, 255}, {255, 255, 0}}};

cv::Point ToPixel(const world::FloorRaster& raster, double x_m, double y_m) {
  return {static_cast<int>(std::lround((x_m - raster.origin_m.x()) / raster.m_per_px - 0.5)),
          static_cast<int>(std::lround((raster.origin_m.y() - y_m) / raster.m_per_px - 0.5))};
}

cv::Mat DrawTrack(const LoadedScenario& loaded, const RunRecord& record) {
  const world::FloorRaster raster = world::RasterizeFloor(loaded.track);
  cv::Mat image(raster.height_px, raster.width_px, CV_8UC3,
                const_cast<std::uint8_t*>(raster.bgr.data()));
  image = image.clone();
  const cv::Scalar zone_grey(110, 110, 110);
  for (const world::IntersectionSpec& i : loaded.track.spec().intersections) {
    auto draw_box = [&](const world::Box& b, int thickness) {
      cv::rectangle(image, ToPixel(raster, b.x_min_m, b.y_max_m),
                    ToPixel(raster, b.x_max_m, b.y_min_m), zone_grey, thickness);
    };
    draw_box(i.area, 2);
    for (const world::Box& zone : i.stop_zones) draw_box(zone, 1);
  }
  for (const ObstacleConfig& o : loaded.scenario.obstacles) {
    const cv::RotatedRect box(ToPixel(raster, o.x_m, o.y_m),
                              cv::Size2f(static_cast<float>(o.length_m / raster.m_per_px),
                                         static_cast<float>(o.width_m / raster.m_per_px)),
                              static_cast<float>(-o.yaw_deg));
    cv::Point2f corners[4];
    box.points(corners);
    std::vector<cv::Point> polygon(corners, corners + 4);
    cv::fillConvexPoly(image, polygon, cv::Scalar(40, 40, 200));
  }
  for (std::size_t c = 0; c < loaded.scenario.cars.size(); ++c) {
    const int id = loaded.scenario.cars[c].id;
    const auto& rgb = kCarColours[c % kCarColours.size()];
    const cv::Scalar colour(rgb[0], rgb[1], rgb[2]);
    std::vector<cv::Point> path;
    for (const TrajectorySample& s : record.trajectory) {
      if (s.car == id) path.push_back(ToPixel(raster, s.x_m, s.y_m));
    }
    cv::polylines(image, path, false, colour, 2, cv::LINE_AA);
    if (!path.empty()) cv::circle(image, path.front(), 7, colour, cv::FILLED, cv::LINE_AA);
    cv::putText(image, fmt::format("car {}", id), cv::Point(14, 30 + 26 * static_cast<int>(c)),
                cv::FONT_HERSHEY_SIMPLEX, 0.7, colour, 2, cv::LINE_AA);
  }
  return image;
}

}  // namespace

void WriteRunFolder(const LoadedScenario& loaded, const RunRecord& record,
                    const std::vector<ExpectationResult>& expectations, double wall_seconds,
                    const std::filesystem::path& out_dir, bool force) {
  namespace fs = std::filesystem;
  WriteFolderAtomically(
      out_dir,
      [&](const fs::path& partial) {
        WriteFile(partial / "trajectory.csv", TrajectoryCsv(record));
        WriteFile(partial / "events.jsonl", EventsJsonl(record));
        if (!record.boards.empty()) WriteFile(partial / "nodes.csv", NodesCsv(record.boards));
        if (!record.trace_json.empty()) WriteFile(partial / "trace.json", record.trace_json);
        WriteFile(partial / "scenario.resolved.json", loaded.resolved.dump(2) + "\n");
        WritePng(partial / "track.png", DrawTrack(loaded, record));
        // summary.json last: its presence marks a complete folder
        WriteFile(
            partial / "summary.json",
            SummaryJson(Summarize(loaded, record, expectations, wall_seconds)).dump(2) + "\n");
      },
      force);
}

}  // namespace autonomsim::sim
