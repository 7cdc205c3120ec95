#include "sim/study/sweep_plots.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <opencv2/imgproc.hpp>
#include <set>

#include "sim/results/png.h"

namespace autonomsim::sim {

namespace fs = std::filesystem;

namespace {

constexpr int kWidth = 900;
constexpr int kHeight = 560;
constexpr int kLeft = 90;
constexpr int kRight = 200;  // room for the legend
constexpr int kTop = 50;
constexpr int kBottom = 70;
constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;

// Tableau 10, as BGR.
constexpr std::array<std::array<int, 3>, 10> kPalette = {{{180, 119, 31},
                                                          {14, 127, 255},
                                                          {44, 160, 44},
                                                          {40, 39, 214},
                                                          {189, 103, 148},
                                                          {75, 86, 140},
                                                          {194, 119, 227},
                                                          {127, 127, 127},
                                                          {34, 189, 188},
                                                          {207, 190, 23}}};

cv::Scalar Colour(std::size_t i) {
  const auto& c = kPalette[i % kPalette.size()];
  return cv::Scalar(c[0], c[1], c[2]);
}

std::string TickText(double value, double step) {
  if (value == 0.0) return "0";
  const double magnitude = std::abs(value);
  if (magnitude >= 1e5 || magnitude < 1e-3) return fmt::format("{:.1e}", value);
  const int decimals = std::max(0, static_cast<int>(std::ceil(-std::log10(step) - 1e-9)));
  return fmt::format("{:.{}f}", value, decimals);
}

std::string Shorten(const std::string& text, std::size_t max_chars) {
  if (text.size() <= max_chars) return text;
  return text.substr(0, max_chars - 2) + "..";
}

void PutText(cv::Mat& image, const std::string& text, cv::Point at, double scale, int thickness = 1,
             cv::Scalar colour = cv::Scalar(30, 30, 30)) {
  cv::putText(image, text, at, kFont, scale, colour, thickness, cv::LINE_AA);
}

int TextWidth(const std::string& text, double scale, int thickness = 1) {
  int baseline = 0;
  return cv::getTextSize(text, kFont, scale, thickness, &baseline).width;
}

bool ParseDouble(const std::string& text, double* out) {
  const std::optional<double> value = ParseFiniteNumber(text);
  if (value) *out = *value;
  return value.has_value();
}

std::string FileSafe(const std::string& text) {
  std::string out;
  for (char c : text) {
    out += (std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-') ? c : '_';
  }
  while (out.size() > 1 && out.front() == '_') out.erase(out.begin());
  return out;
}

// A run's label in legends: its varied values.
std::string RunLabel(const PointRecord& p) {
  std::string label;
  for (const std::string& l : p.labels) label += (label.empty() ? "" : " ") + l;
  if (p.repeat > 0 || label.empty())
    label += (label.empty() ? "" : " ") + fmt::format("r{}", p.repeat);
  return label;
}

// The key metrics plotted against each varied key: the column name without its car/board prefix.
const std::vector<std::string> kKeyMetrics = {
    "laps_total",          "collisions_total",     "max_lateral_error_m",
    "rms_lateral_error_m", "lane_error_max_m",     "laps",
    "mean_lap_time_s",     "total_wait_s",         "collisions",
    "cpu_percent",         "cpu_demand_percent",   "e2e_latency_p50_ms",
    "e2e_latency_p99_ms",  "lanes_latency_p50_ms", "lanes_latency_p99_ms",
    "min_obstacle_gap_m"};

}  // namespace

std::vector<double> NiceTicks(double lo, double hi, int target_count) {
  if (!(hi > lo)) {
    const double pad = lo == 0.0 ? 1.0 : std::abs(lo) * 0.1;
    lo -= pad;
    hi += pad;
  }
  const double raw = (hi - lo) / std::max(1, target_count);
  const double power = std::pow(10.0, std::floor(std::log10(raw)));
  double step = power;
  for (double m : {1.0, 2.0, 5.0, 10.0}) {
    step = m * power;
    if (step >= raw) break;
  }
  std::vector<double> ticks;
  for (double t = std::floor(lo / step) * step; t <= hi + step * 0.999; t += step) {
    ticks.push_back(std::abs(t) < step * 1e-9 ? 0.0 : t);
    if (ticks.size() > 50) break;
  }
  return ticks;
}

namespace {

// Where the data goes in the picture: the plotted ranges, their ticks, and the mapping to pixels.
struct Frame {
  bool log_x{false};
  double x_lo{0.0}, x_hi{1.0}, y_lo{0.0}, y_hi{1.0};  // x on the log10 scale when log_x
  std::vector<double> x_ticks, y_ticks;               // no x_ticks: categories
  int plot_w{kWidth - kLeft - kRight};
  int plot_h{kHeight - kTop - kBottom};

  double tx(double x) const { return log_x ? std::log10(x) : x; }
  int px(double x) const {
    return kLeft + static_cast<int>(std::lround((x - x_lo) / (x_hi - x_lo) * plot_w));
  }
  int py(double y) const {
    return kTop + plot_h - static_cast<int>(std::lround((y - y_lo) / (y_hi - y_lo) * plot_h));
  }
  // Whether a point is drawn at all: a finite y, and x > 0 on a log scale.
  bool Shown(double x, double y) const { return std::isfinite(y) && !(log_x && x <= 0); }
};

Frame FrameFor(const PlotSpec& spec) {
  Frame f{.log_x = spec.log_x};
  double x_lo = INFINITY, x_hi = -INFINITY, y_lo = INFINITY, y_hi = -INFINITY;
  for (const PlotSeries& s : spec.series) {
    for (std::size_t i = 0; i < s.x.size(); ++i) {
      if (!f.Shown(s.x[i], s.y[i])) continue;
      x_lo = std::min(x_lo, f.tx(s.x[i]));
      x_hi = std::max(x_hi, f.tx(s.x[i]));
      y_lo = std::min(y_lo, s.y[i]);
      y_hi = std::max(y_hi, s.y[i]);
    }
  }
  if (!std::isfinite(x_lo)) x_lo = 0, x_hi = 1, y_lo = 0, y_hi = 1;
  if (!spec.categories.empty()) {
    x_lo = -0.5;
    x_hi = static_cast<double>(spec.categories.size()) - 0.5;
  }
  y_lo = std::min(y_lo, 0.0);  // metrics here are >= 0: show the zero line
  f.y_ticks = NiceTicks(y_lo, y_hi);
  f.y_lo = f.y_ticks.front();
  f.y_hi = f.y_ticks.back();
  if (spec.categories.empty()) {
    if (spec.log_x) {
      for (double d = std::floor(x_lo); d <= std::ceil(x_hi); d += 1.0) f.x_ticks.push_back(d);
    } else {
      f.x_ticks = NiceTicks(x_lo, x_hi);
    }
    x_lo = std::min(x_lo, f.x_ticks.front());
    x_hi = std::max(x_hi, f.x_ticks.back());
    if (x_hi <= x_lo) x_hi = x_lo + 1;
  }
  f.x_lo = x_lo;
  f.x_hi = x_hi;
  return f;
}

// Grid lines, ticks and tick labels, and the frame around the plot area.
void DrawAxes(cv::Mat& image, const PlotSpec& spec, const Frame& f) {
  const cv::Scalar grid(225, 225, 225), axis(60, 60, 60);
  for (double y : f.y_ticks) {
    cv::line(image, {kLeft, f.py(y)}, {kLeft + f.plot_w, f.py(y)}, grid, 1);
    const std::string text = TickText(y, f.y_ticks.size() > 1 ? f.y_ticks[1] - f.y_ticks[0] : 1.0);
    PutText(image, text, {kLeft - 8 - TextWidth(text, 0.45), f.py(y) + 5}, 0.45);
  }
  const int bottom = kTop + f.plot_h;
  for (std::size_t i = 0; i < spec.categories.size(); ++i) {
    const int x = f.px(static_cast<double>(i));
    cv::line(image, {x, kTop}, {x, bottom}, grid, 1);
    // labels alternate between two rows when there are many, so each may be twice as wide
    const bool stagger = spec.categories.size() > 6;
    const std::size_t max_chars = std::max<std::size_t>(
        4, static_cast<std::size_t>(f.plot_w * (stagger ? 2 : 1) /
                                    std::max<std::size_t>(1, spec.categories.size()) / 8));
    const std::string text = Shorten(spec.categories[i], max_chars);
    const int row = stagger ? static_cast<int>(i % 2) : 0;
    PutText(image, text, {x - TextWidth(text, 0.42) / 2, bottom + 20 + 16 * row}, 0.42);
  }
  for (double x : f.x_ticks) {
    cv::line(image, {f.px(x), kTop}, {f.px(x), bottom}, grid, 1);
    const std::string text =
        spec.log_x ? TickText(std::pow(10.0, x), std::pow(10.0, x))
                   : TickText(x, f.x_ticks.size() > 1 ? f.x_ticks[1] - f.x_ticks[0] : 1.0);
    PutText(image, text, {f.px(x) - TextWidth(text, 0.45) / 2, bottom + 20}, 0.45);
  }
  cv::rectangle(image, {kLeft, kTop}, {kLeft + f.plot_w, bottom}, axis, 1);
}

// The title above, the x label below, and the y label rotated along the left edge.
void DrawTitles(cv::Mat& image, const PlotSpec& spec, const Frame& f) {
  PutText(image, spec.title, {(kWidth - TextWidth(spec.title, 0.62, 2)) / 2, 30}, 0.62, 2);
  const std::string x_label = spec.x_label + (spec.log_x ? " (log scale)" : "");
  PutText(image, x_label, {kLeft + (f.plot_w - TextWidth(x_label, 0.5)) / 2, kHeight - 14}, 0.5);
  // the y label, written horizontally and rotated into place
  const int w = TextWidth(spec.y_label, 0.5) + 10;
  cv::Mat label(24, w, CV_8UC3, cv::Scalar(255, 255, 255));
  PutText(label, spec.y_label, {5, 17}, 0.5);
  cv::Mat rotated;
  cv::rotate(label, rotated, cv::ROTATE_90_COUNTERCLOCKWISE);
  const int top = std::max(0, kTop + (f.plot_h - rotated.rows) / 2);
  const int rows = std::min(rotated.rows, kHeight - top);
  rotated(cv::Rect(0, 0, rotated.cols, rows)).copyTo(image(cv::Rect(8, top, rotated.cols, rows)));
}

// The series' lines and dots, clipped to the plot area.
void DrawSeries(cv::Mat& image, const PlotSpec& spec, const Frame& f) {
  cv::Mat area = image(cv::Rect(kLeft, kTop, f.plot_w + 1, f.plot_h + 1));
  const cv::Point offset(kLeft, kTop);
  for (std::size_t s = 0; s < spec.series.size(); ++s) {
    const PlotSeries& series = spec.series[s];
    std::vector<cv::Point> points;
    for (std::size_t i = 0; i < series.x.size(); ++i) {
      if (!f.Shown(series.x[i], series.y[i])) continue;
      points.push_back(cv::Point(f.px(f.tx(series.x[i])), f.py(series.y[i])) - offset);
    }
    if (series.line && points.size() > 1) {
      cv::polylines(area, points, false, Colour(s), 2, cv::LINE_AA);
    }
    if (series.dots) {
      for (const cv::Point& p : points) cv::circle(area, p, 4, Colour(s), cv::FILLED, cv::LINE_AA);
    }
  }
}

// The legend right of the plot area: the first 20 series, and how many more there are.
void DrawLegend(cv::Mat& image, const PlotSpec& spec, const Frame& f) {
  const int x = kLeft + f.plot_w;
  const std::size_t shown = std::min<std::size_t>(spec.series.size(), 20);
  for (std::size_t s = 0; s < shown; ++s) {
    const int y = kTop + 12 + 20 * static_cast<int>(s);
    cv::line(image, {x + 12, y - 4}, {x + 32, y - 4}, Colour(s), 3);
    PutText(image, Shorten(spec.series[s].label, 22), {x + 38, y}, 0.4);
  }
  if (spec.series.size() > shown) {
    PutText(image, fmt::format("+{} more", spec.series.size() - shown),
            {x + 38, kTop + 12 + 20 * static_cast<int>(shown)}, 0.4);
  }
}

}  // namespace

cv::Mat DrawPlot(const PlotSpec& spec) {
  cv::Mat image(kHeight, kWidth, CV_8UC3, cv::Scalar(255, 255, 255));
  const Frame frame = FrameFor(spec);
  DrawAxes(image, spec, frame);
  DrawTitles(image, spec, frame);
  DrawSeries(image, spec, frame);
  DrawLegend(image, spec, frame);
  return image;
}

namespace {

// Where a run lands on a varied key's x axis: its value when every value of the key is a number,
// else the index of its label (a categorical axis, labels in their first-given order).
struct AxisPositions {
  bool numeric{true};
  std::vector<std::string> categories;
  std::map<std::string, std::size_t> category;  // label -> index in categories

  // false when the label is not a number on a numeric axis
  bool X(const std::string& label, double* x) const {
    if (numeric) return ParseDouble(label, x);
    *x = static_cast<double>(category.at(label));
    return true;
  }
};

AxisPositions PositionsOf(const VaryAxis& axis) {
  AxisPositions positions;
  double unused = 0.0;
  for (const VaryValue& v : axis.values) {
    positions.numeric = positions.numeric && ParseDouble(v.label, &unused);
    if (positions.category.emplace(v.label, positions.categories.size()).second) {
      positions.categories.push_back(v.label);
    }
  }
  return positions;
}

// The series of one key metric against one varied key (its values in column `axis_column`): per
// car or board that has the metric (the column's prefix), the mean over its runs at each x as a
// line, and the runs as dots of their own where an x has several.
std::vector<PlotSeries> MetricSeries(const ResultsTable& table, const std::string& metric,
                                     std::size_t axis_column, const AxisPositions& positions) {
  std::vector<PlotSeries> series;
  for (std::size_t c = 0; c < table.columns.size(); ++c) {
    const std::string& column = table.columns[c];
    const auto dot = column.rfind('.');
    const std::string suffix = dot == std::string::npos ? column : column.substr(dot + 1);
    const std::string prefix = dot == std::string::npos ? "all" : column.substr(0, dot);
    // only car/board-level columns (carN.metric), not per-node ones (carN.node.metric)
    if (suffix != metric || prefix.find('.') != std::string::npos) continue;
    PlotSeries dots{.label = prefix, .x = {}, .y = {}, .dots = true, .line = false};
    std::map<double, std::pair<double, int>> mean;  // x -> (sum, count)
    for (const auto& row : table.rows) {
      double y = 0.0, x = 0.0;
      if (!ParseDouble(row[c], &y) || !positions.X(row[axis_column], &x)) continue;
      dots.x.push_back(x);
      dots.y.push_back(y);
      mean[x].first += y;
      mean[x].second += 1;
    }
    if (dots.x.empty()) continue;
    PlotSeries line{.label = prefix, .x = {}, .y = {}, .dots = false, .line = true};
    for (const auto& [x, sum] : mean) {
      line.x.push_back(x);
      line.y.push_back(sum.first / sum.second);
    }
    // dots and the mean line share a colour: put them in one series when one run per x
    if (line.x.size() == dots.x.size()) {
      line.dots = true;
      series.push_back(std::move(line));
    } else {
      series.push_back(std::move(line));
      dots.label = prefix + " (runs)";
      series.push_back(std::move(dots));
    }
  }
  return series;
}

// Each key metric against one varied key, one plot each (those no run has are left out).
void WriteMetricPlots(const VaryAxis& axis, std::size_t axis_column, const ResultsTable& table,
                      const fs::path& dir) {
  const AxisPositions positions = PositionsOf(axis);
  for (const std::string& metric : kKeyMetrics) {
    const PlotSpec plot{
        .title = fmt::format("{} vs {}", metric, axis.key),
        .x_label = axis.key,
        .y_label = metric,
        .series = MetricSeries(table, metric, axis_column, positions),
        .categories = positions.numeric ? std::vector<std::string>{} : positions.categories,
        .log_x = false};
    if (plot.series.empty()) continue;
    WritePng(dir / (FileSafe(metric) + "_vs_" + FileSafe(axis.key) + ".png"), DrawPlot(plot));
  }
}

// One run's turnaround histogram of one node (`node` from sim/platform's ReportJson) as a series of
// the node's plot in `histograms` (by board/node); nothing for a node without jobs.
void AddHistogramSeries(const std::string& board, const nlohmann::json& node,
                        const std::string& label, std::map<std::string, PlotSpec>* histograms) {
  if (!node.contains("turnaround_histogram_ms")) return;
  const auto counts = node["turnaround_histogram_ms"].value("counts", std::vector<double>{});
  const auto edges = node["turnaround_histogram_ms"].value("edges", std::vector<double>{});
  double total = 0.0;
  for (double c : counts) total += c;
  if (total == 0.0 || edges.size() != counts.size() + 1) return;
  const std::string name = node.at("name").get<std::string>();
  PlotSpec& h = (*histograms)[board + "/" + name];
  h.title = fmt::format("Turnaround of {} on {}", name, board);
  h.x_label = "turnaround [ms], bin centre";
  h.y_label = "fraction of jobs";
  h.log_x = true;
  // empty bins trimmed at both ends (one kept) so the plot shows where the jobs are
  std::size_t first = 0, last = counts.size();
  while (first < last && counts[first] == 0) ++first;
  while (last > first && counts[last - 1] == 0) --last;
  first = first > 0 ? first - 1 : 0;
  last = std::min(counts.size(), last + 1);
  PlotSeries histogram{.label = label, .x = {}, .y = {}, .dots = true, .line = true};
  for (std::size_t b = first; b < last; ++b) {
    histogram.x.push_back(std::sqrt(edges[b] * edges[b + 1]));
    histogram.y.push_back(counts[b] / total);
  }
  h.series.push_back(std::move(histogram));
}

// One run's series in the CPU load plot of a board (`report`: sim/platform's ReportJson) and in
// the turnaround histograms of the board's nodes.
void AddBoardSeries(const std::string& board, const nlohmann::json& report,
                    const std::string& label, std::map<std::string, PlotSpec>* loads,
                    std::map<std::string, PlotSpec>* histograms) {
  PlotSpec& load = (*loads)[board];
  load.title = fmt::format("CPU load over time, {}", board);
  load.x_label = "simulated time [s]";
  load.y_label = fmt::format("CPU load [%, 100 = one core, {} cores]", report.value("cores", 0));
  PlotSeries series{.label = label, .x = {}, .y = {}, .dots = false, .line = true};
  const double bin_s = report.value("load_bin_s", 1.0);
  const auto bins = report.value("cpu_load_percent", std::vector<double>{});
  for (std::size_t b = 0; b < bins.size(); ++b) {
    series.x.push_back((static_cast<double>(b) + 0.5) * bin_s);
    series.y.push_back(bins[b]);
  }
  load.series.push_back(std::move(series));
  for (const nlohmann::json& node : report.at("nodes")) {
    AddHistogramSeries(board, node, label, histograms);
  }
}

}  // namespace

void WriteSweepPlots(const SweepSpec& spec, const std::vector<PointRecord>& points,
                     const std::vector<RunSummary>& summaries, const ResultsTable& table,
                     const fs::path& dir) {
  fs::remove_all(dir);
  fs::create_directories(dir);
  if (points.empty()) return;

  // 1. Each key metric against each varied key; one series per car or board (column prefix).
  for (std::size_t a = 0; a < spec.axes.size(); ++a) {
    WriteMetricPlots(spec.axes[a], 2 + a, table, dir);  // the axes' columns follow index, run_id
  }

  // 2. CPU load over time per board; 3. turnaround histograms per board and node: a series per
  // distinct run, in grid order.
  std::map<std::string, PlotSpec> loads;       // by board, in name order
  std::map<std::string, PlotSpec> histograms;  // by board/node, in name order
  std::set<std::string> seen;
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!seen.insert(points[i].run_id).second || !summaries[i].platform) continue;
    for (const auto& [board, report] : *summaries[i].platform) {
      AddBoardSeries(board, report, RunLabel(points[i]), &loads, &histograms);
    }
  }
  for (const auto& [board, plot] : loads) {
    WritePng(dir / ("cpu_load_" + FileSafe(board) + ".png"), DrawPlot(plot));
  }
  for (const auto& [name, plot] : histograms) {
    WritePng(dir / ("turnaround_" + FileSafe(name) + ".png"), DrawPlot(plot));
  }
}

}  // namespace autonomsim::sim
