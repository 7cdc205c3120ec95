// planner_map_diff: our planner's static map (world::BuildStaticMap from a track file) against the
// lab's map picture (code/ros_ws/src/nav2_local/maps/final_map.png; a copy sits in the shared
// reference folder, never in this repository). Prints the picture's grey levels (the measurement
// behind the track file's planner_grey) and the cell counts of each class, and writes a
// difference image of the map's middle:
//   black      occupied (value 100, what the planner's StaticLayer makes LETHAL) in both maps
//   red        occupied in ours only
//   blue       occupied in the lab's only
//   light grey graded (1..99: FREE for the planner) in either map, occupied in neither
//   white      clear (value 0) in both
// Run from the repository root:
//   build/bin/planner_map_diff --lab-image ../shared/reference/lab_final_map.png
//       --out docs/images/planner_map_diff.png --force   (an existing --out only with --force)
#include <CLI/CLI.hpp>
#include <array>
#include <cstdint>
#include <cstdio>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>

#include "sim/core/config.h"
#include "sim/core/files.h"
#include "sim/core/track_loader.h"
#include "world/occupancy_map.h"

namespace {

using autonomsim::world::OccupancyMap;

// The picture's grey per pixel (the mean of R, G and B, as map_server's `scale` mode takes it),
// with its alpha checked: map_server makes a pixel that is not opaque unknown.
cv::Mat GreyOf(const cv::Mat& picture, int* transparent) {
  cv::Mat grey(picture.rows, picture.cols, CV_8UC1);
  *transparent = 0;
  for (int r = 0; r < picture.rows; ++r) {
    for (int c = 0; c < picture.cols; ++c) {
      const cv::Vec4b bgra = picture.at<cv::Vec4b>(r, c);
      grey.at<std::uint8_t>(r, c) =
          static_cast<std::uint8_t>(std::lround((bgra[0] + bgra[1] + bgra[2]) / 3.0));
      *transparent += bgra[3] != 255;
    }
  }
  return grey;
}

void PrintGreyLevels(const cv::Mat& grey, int transparent) {
  std::map<int, long> count;
  for (int r = 0; r < grey.rows; ++r) {
    for (int c = 0; c < grey.cols; ++c) ++count[grey.at<std::uint8_t>(r, c)];
  }
  long between = 0;
  std::printf("lab picture: %d x %d px, %d not opaque\ngrey levels with more than 100 px:",
              grey.cols, grey.rows, transparent);
  for (const auto& [level, n] : count) {
    if (n > 100) std::printf(" %d (%ld px)", level, n);
    if (n <= 100) between += n;
  }
  std::printf("; every other level: %ld px in all (anti-aliased edges)\n", between);
}

enum Class { kFreeClass = 0, kGraded = 1, kOccupiedClass = 2 };
Class ClassOf(int value) {
  return value < 0 || value >= OccupancyMap::kOccupied ? kOccupiedClass
         : value > 0                                   ? kGraded
                                                       : kFreeClass;
}

// The difference image of the pixels within crop_m of the origin, and the counts over the map.
cv::Mat Difference(const OccupancyMap& ours, const cv::Mat& lab_grey,
                   const autonomsim::world::MapServerParams& map_server, double crop_m) {
  const int side = ours.width_cells;
  const int half = static_cast<int>(crop_m / ours.resolution_m);
  const int lo = side / 2 - half;
  cv::Mat image(2 * half, 2 * half, CV_8UC3, cv::Scalar(255, 255, 255));
  std::array<std::array<long, 3>, 3> counts{};
  for (int r = 0; r < side; ++r) {
    for (int c = 0; c < side; ++c) {
      const Class mine = ClassOf(ours.At(c, side - 1 - r));  // the picture's row 0 is north
      const Class theirs = ClassOf(map_server.ValueOfGrey(lab_grey.at<std::uint8_t>(r, c)));
      ++counts[mine][theirs];
      if (r < lo || r >= lo + 2 * half || c < lo || c >= lo + 2 * half) continue;
      cv::Vec3b& px = image.at<cv::Vec3b>(r - lo, c - lo);
      if (mine == kOccupiedClass && theirs == kOccupiedClass) {
        px = {0, 0, 0};
      } else if (mine == kOccupiedClass) {
        px = {0, 0, 230};
      } else if (theirs == kOccupiedClass) {
        px = {230, 110, 0};
      } else if (mine == kGraded || theirs == kGraded) {
        px = {190, 190, 190};
      }
    }
  }
  const char* names[] = {"clear", "graded", "occupied"};
  std::printf("cells (ours x lab's):\n");
  for (int m = 0; m < 3; ++m) {
    for (int t = 0; t < 3; ++t) {
      std::printf("  ours %-8s lab %-8s %9ld\n", names[m], names[t], counts[m][t]);
    }
  }
  return image;
}

void DrawLegend(cv::Mat* image, double crop_m) {
  const std::array<std::pair<cv::Scalar, std::string>, 4> rows = {{
      {{0, 0, 0}, "occupied in both"},
      {{0, 0, 230}, "occupied in ours only"},
      {{230, 110, 0}, "occupied in the lab's only"},
      {{190, 190, 190}, "graded (free to the planner)"},
  }};
  int y = 24;
  for (const auto& [colour, text] : rows) {
    cv::rectangle(*image, {12, y - 14}, {30, y + 2}, colour, cv::FILLED);
    cv::putText(*image, text, {38, y}, cv::FONT_HERSHEY_SIMPLEX, 0.55, {0, 0, 0}, 1, cv::LINE_AA);
    y += 24;
  }
  char caption[96];
  std::snprintf(caption, sizeof caption, "x, y in [-%.1f, %.1f] m, 0.00517 m/px", crop_m, crop_m);
  cv::putText(*image, caption, {12, image->rows - 12}, cv::FONT_HERSHEY_SIMPLEX, 0.55, {0, 0, 0}, 1,
              cv::LINE_AA);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Our planner's static map against the lab's map picture"};
  std::string lab_image, track = "scenarios/tracks/lab.yaml", out;
  double crop_m = 2.6;
  app.add_option("--lab-image", lab_image, "the lab's final_map.png")->required();
  app.add_option("--track", track, "the track file our map is drawn from");
  app.add_option("--out", out, "the difference image (PNG) to write");
  app.add_option("--crop-m", crop_m, "half the side of the square shown, metres");
  bool force = false;
  app.add_flag("--force", force,
               "Replace --out even if it is a file this tool may not have written");
  CLI11_PARSE(app, argc, argv);
  if (!out.empty()) {
    try {  // nothing of a user's is overwritten unless asked (a PNG carries no mark of its maker)
      out = autonomsim::sim::CheckOutputFile(out, force).string();
    } catch (const autonomsim::sim::ConfigError& e) {
      std::fprintf(stderr, "error: %s\n", e.what());
      return 2;
    }
  }

  const cv::Mat picture = cv::imread(lab_image, cv::IMREAD_UNCHANGED);
  if (picture.empty() || picture.type() != CV_8UC4) {
    std::fprintf(stderr, "%s: not an 8-bit RGBA PNG\n", lab_image.c_str());
    return 2;
  }
  int transparent = 0;
  const cv::Mat grey = GreyOf(picture, &transparent);
  PrintGreyLevels(grey, transparent);
  const OccupancyMap ours = autonomsim::world::BuildStaticMap(
      autonomsim::sim::LoadTrack(track), autonomsim::world::kLabMapResolution_m);
  if (ours.width_cells != picture.cols || ours.height_cells != picture.rows) {
    std::fprintf(stderr, "our map is %d x %d cells, the picture %d x %d px\n", ours.width_cells,
                 ours.height_cells, picture.cols, picture.rows);
    return 2;
  }
  cv::Mat image = Difference(ours, grey, {}, crop_m);
  DrawLegend(&image, crop_m);
  if (!out.empty() && !cv::imwrite(out, image)) {
    std::fprintf(stderr, "%s: cannot write\n", out.c_str());
    return 2;
  }
  return 0;
}
