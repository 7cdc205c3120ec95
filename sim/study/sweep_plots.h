// The plots of a sweep, drawn by gnuplot (Debian's gnuplot-nox, its pngcairo terminal): each key
// metric against each varied key, CPU load over time per board, turnaround histograms per node.
// Every plot is three files in DIR/plots: NAME.png, and NAME.gp with NAME.dat, the script and the
// data that drew it, so that a researcher can restyle a plot or draw it for a paper (change the
// script's `set terminal` line to pdfcairo or svg and run `gnuplot NAME.gp` in that folder).
//
// What a reader needs is on the plot: titles in words with units, what a line averages over and
// how many runs, legends that name the varied keys with their values, each car in the colour it
// has in track.png and the report (a car's runs as dots of its line's colour).
#pragma once

#include <filesystem>
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
  std::string colour;  // "#rrggbb"; empty: the next colour of the palette
  double width{2.0};   // of the line, in gnuplot's line width units
  int dash{1};         // gnuplot's dash type: 1 solid, 2 dashed, 3 dotted, ...
};

struct PlotSpec {
  std::string title;
  std::string subtitle;  // what the plot shows beyond the title (what a line averages), in words
  std::string x_label;
  std::string y_label;
  std::vector<PlotSeries> series;
  // Categorical x axis: the tick at x = i is labelled categories[i] (x values are indices).
  std::vector<std::string> categories;
  bool log_x{false};  // x values are plotted on a log10 scale (must be > 0)
  // Lines under the subtitle, smaller: what the short names of long values stand for
  // ("key=value 2: {lane_detection: {target: sw}}").
  std::vector<std::string> notes;
};

// The data file of a plot: one block per series ("x y" lines, blocks two blank lines apart, a
// comment naming each), read by the script with `index i`.
std::string GnuplotData(const PlotSpec& spec);
// The script that draws `spec` from `data_file` into `png` (names relative to the plots folder).
std::string GnuplotScript(const PlotSpec& spec, const std::string& data_file,
                          const std::string& png);

// Writes NAME.gp and NAME.dat for each (NAME, plot) into `dir` and runs gnuplot on the scripts
// there, which write NAME.png, calling `progress` (if any) before the first and after each plot
// is drawn. std::runtime_error with gnuplot's message when it fails or is not installed.
void RenderPlots(const std::vector<std::pair<std::string, PlotSpec>>& plots,
                 const std::filesystem::path& dir, const PlotProgress& progress = {});

// Every plot of a sweep, (NAME, plot), not drawn. `points[i]` and `summaries[i]` belong together
// (grid order); `table` is their results.csv. A metric a run did not measure (an empty cell) gives
// no point for that run: no dot, and no part in its line's mean.
std::vector<std::pair<std::string, PlotSpec>> SweepPlots(const SweepSpec& spec,
                                                         const std::vector<PointRecord>& points,
                                                         const std::vector<RunSummary>& summaries,
                                                         const ResultsTable& table);

// Writes every plot of a sweep (SweepPlots) into `dir`, replacing what is there (RenderPlots).
void WriteSweepPlots(const SweepSpec& spec, const std::vector<PointRecord>& points,
                     const std::vector<RunSummary>& summaries, const ResultsTable& table,
                     const std::filesystem::path& dir, const PlotProgress& progress = {});

}  // namespace autonomsim::sim
