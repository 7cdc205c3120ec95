// The plots of a sweep (PNG, drawn with OpenCV): each key metric against each varied key, per-node
// turnaround histograms, CPU load over time. Axes, tick labels, titles and a legend on each.
#pragma once

#include <filesystem>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "sim/results/summary.h"
#include "sim/study/sweep.h"

namespace autonomsim::sim {

struct PlotSeries {
  std::string label;
  std::vector<double> x, y;  // points drawn as dots (if dots) and joined (if line)
  bool dots{true};
  bool line{true};
};

struct PlotSpec {
  std::string title;
  std::string x_label;
  std::string y_label;
  std::vector<PlotSeries> series;
  // Categorical x axis: the tick at x = i is labelled categories[i] (x values are indices).
  std::vector<std::string> categories;
  bool log_x{false};  // x values are plotted on a log10 scale (must be > 0)
};

// One plot, 900 x 560 pixels, white background.
cv::Mat DrawPlot(const PlotSpec& spec);

// "Nice" tick positions (steps of 1, 2 or 5 times a power of ten) covering [lo, hi].
std::vector<double> NiceTicks(double lo, double hi, int target_count = 6);

// Writes every plot of a sweep into `dir` (replacing what is there). `points[i]` and
// `summaries[i]` belong together (grid order); `table` is their results.csv.
void WriteSweepPlots(const SweepSpec& spec, const std::vector<PointRecord>& points,
                     const std::vector<RunSummary>& summaries, const ResultsTable& table,
                     const std::filesystem::path& dir);

}  // namespace autonomsim::sim
