#include "sim/results/outputs.h"

#include <fmt/format.h>

#include <array>
#include <map>
#include <stdexcept>
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

// A car's path is drawn in pieces of this many samples, so drawing holds no whole trajectory.
constexpr std::size_t kPathPieceSamples = 4096;

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
  // the cars' paths, drawn as the samples are read (a long run's trajectory stays on disk)
  std::map<int, std::vector<cv::Point>> paths;  // car id -> points not yet drawn
  std::map<int, cv::Point> starts;
  auto colour_of = [&](int id) {
    std::size_t c = 0;
    while (c < loaded.scenario.cars.size() && loaded.scenario.cars[c].id != id) ++c;
    const auto& rgb = kCarColours[c % kCarColours.size()];
    return cv::Scalar(rgb[0], rgb[1], rgb[2]);
  };
  auto draw = [&](int id, std::vector<cv::Point>& path) {
    cv::polylines(image, path, false, colour_of(id), 2, cv::LINE_AA);
    path.erase(path.begin(), path.end() - 1);  // the next piece starts where this one ends
  };
  ForEachSample(record, [&](const TrajectorySample& s) {
    std::vector<cv::Point>& path = paths[s.car];
    path.push_back(ToPixel(raster, s.x_m, s.y_m));
    starts.try_emplace(s.car, path.back());
    if (path.size() >= kPathPieceSamples) draw(s.car, path);
  });
  for (auto& [id, path] : paths) draw(id, path);
  for (std::size_t c = 0; c < loaded.scenario.cars.size(); ++c) {
    const int id = loaded.scenario.cars[c].id;
    const cv::Scalar colour = colour_of(id);
    if (starts.contains(id)) cv::circle(image, starts[id], 7, colour, cv::FILLED, cv::LINE_AA);
    cv::putText(image, fmt::format("car {}", id), cv::Point(14, 30 + 26 * static_cast<int>(c)),
                cv::FONT_HERSHEY_SIMPLEX, 0.7, colour, 2, cv::LINE_AA);
  }
  return image;
}

// Every file but trajectory.csv and events.jsonl, summary.json last (its presence marks a
// complete folder).
void WriteResults(const LoadedScenario& loaded, const RunRecord& record,
                  const std::vector<ExpectationResult>& expectations, double wall_seconds,
                  const std::filesystem::path& folder) {
  if (!record.boards.empty()) WriteFile(folder / "nodes.csv", NodesCsv(record.boards));
  if (!record.trace_json.empty()) WriteFile(folder / "trace.json", record.trace_json);
  WriteFile(folder / "scenario.resolved.json", loaded.resolved.dump(2) + "\n");
  WritePng(folder / "track.png", DrawTrack(loaded, record));
  WriteFile(folder / "summary.json",
            SummaryJson(Summarize(loaded, record, expectations, wall_seconds)).dump(2) + "\n");
}

}  // namespace

RunFolder::RunFolder(const std::filesystem::path& out_dir, bool force)
    : folder_(out_dir, force), files_(std::make_shared<RecordFiles>(folder_.path())) {}

void RunFolder::Complete(const LoadedScenario& loaded, const RunRecord& record,
                         const std::vector<ExpectationResult>& expectations,
                         double wall_seconds) {
  if (record.store != files_) {
    throw std::logic_error("RunFolder::Complete: the record was not made with this folder's store");
  }
  WriteResults(loaded, record, expectations, wall_seconds, folder_.path());
  folder_.Commit();
}

void WriteRunFolder(const LoadedScenario& loaded, const RunRecord& record,
                    const std::vector<ExpectationResult>& expectations, double wall_seconds,
                    const std::filesystem::path& out_dir, bool force) {
  if (record.store) {
    throw std::logic_error("WriteRunFolder: the record's trajectory is in a store (use RunFolder)");
  }
  WriteFolderAtomically(
      out_dir,
      [&](const std::filesystem::path& partial) {
        WriteFile(partial / "trajectory.csv", TrajectoryCsv(record));
        WriteFile(partial / "events.jsonl", EventsJsonl(record));
        WriteResults(loaded, record, expectations, wall_seconds, partial);
      },
      force);
}

}  // namespace autonomsim::sim
