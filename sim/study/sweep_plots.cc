#include "sim/study/sweep_plots.h"

#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <map>
#include <set>
#include <stdexcept>
#include <string_view>

#include "sim/core/files.h"
#include "sim/platform/node_metrics.h"
#include "sim/results/track_figure.h"

namespace autonomsim::sim {

namespace fs = std::filesystem;

namespace {

// Tableau 10, for series that are not a car's.
constexpr std::array<const char*, 10> kPalette = {"#1f77b4", "#ff7f0e", "#2ca02c", "#d62728",
                                                  "#9467bd", "#8c564b", "#e377c2", "#7f7f7f",
                                                  "#bcbd22", "#17becf"};
constexpr const char* kAllCarsColour = "#333333";
constexpr const char* kEachRunColour = "#b8b8b8";
// More runs than this in a plot of one series per run: each run in grey, their mean on top.
constexpr std::size_t kMostRunsNamed = 10;
// Legends with a longer label go below the plot; a longer title takes two lines.
constexpr std::size_t kLongestLabelBeside = 28;
// A legend below the plot: the characters of tic-font text that fit across the picture, and what
// one entry takes beside its label (the line sample and the gap to the next column).
constexpr std::size_t kKeyWidthChars = 120;
constexpr std::size_t kKeyEntryChars = 9;
// Lines under the plot before a legend there: the tic labels, the axis label and a gap.
constexpr double kAxisLinesBelow = 3.5;
// Category names on the x axis are written slanted when, together, they hold more characters
// than fit side by side under the plot (about 80 at the plots' width and tic font).
constexpr std::size_t kCategoryCharsLevel = 80;
constexpr std::size_t kLongestTitleLine = 70;
// A varied key's value longer than this (a YAML mapping given to --vary, printed whole) makes the
// plots name each of the key's values "value 1", "value 2", ..., each written out in a note above
// the plot, cut at kLongestNote characters (what fits across at the notes' font).
constexpr std::size_t kLongestValueShown = 24;
constexpr std::size_t kLongestNote = 140;

// A string in gnuplot's single quotes ('' is a quote).
std::string Quoted(const std::string& text) {
  std::string out = "'";
  for (char c : text) out += c == '\'' ? std::string("''") : std::string(1, c);
  return out + "'";
}

std::string Number(double v) { return fmt::format("{}", v); }

bool ParseDouble(const std::string& text, double* out) {
  const std::optional<double> value = ParseFiniteNumber(text);
  if (value) *out = *value;
  return value.has_value();
}

// `text` cut to at most `most` bytes, ending in "…" when cut (never inside a UTF-8 character).
std::string Cut(const std::string& text, std::size_t most) {
  if (text.size() <= most) return text;
  std::size_t end = most - 3;  // "…" is three bytes
  while (end > 0 && (static_cast<unsigned char>(text[end]) & 0xC0) == 0x80) --end;
  return text.substr(0, end) + "…";
}

std::string FileSafe(const std::string& text) {
  std::string out;
  for (char c : text) {
    out += (std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-') ? c : '_';
  }
  while (out.size() > 1 && out.front() == '_') out.erase(out.begin());
  return out;
}

// The colour of a column prefix: carN in its car's colour, "all" dark grey.
std::string PrefixColour(const std::string& prefix) {
  if (prefix.rfind("car", 0) == 0) {
    double id = 0.0;
    if (ParseDouble(prefix.substr(3), &id) && id >= 0 && id < 1000) {
      // car N taken to be the scenario's N-th, as the shipped scenarios number their cars
      return ColourHex(CarColourBgrAt(static_cast<std::size_t>(id)));
    }
  }
  return kAllCarsColour;
}

// How the plots show each varied key's values: as labelled, or, for a key with a value longer than
// kLongestValueShown, by "value 1", "value 2", ... in the order given, with a note for each.
struct ValueNames {
  std::vector<std::map<std::string, std::string>> short_name;  // per axis: label -> its name
  std::vector<std::string> notes;  // "key=value 2: {lane_detection: {target: sw}}", ...

  std::string Of(std::size_t axis, const std::string& label) const {
    const auto it = short_name[axis].find(label);
    return it == short_name[axis].end() ? label : it->second;
  }
};

ValueNames NamesOf(const SweepSpec& spec) {
  ValueNames names;
  names.short_name.resize(spec.axes.size());
  for (std::size_t a = 0; a < spec.axes.size(); ++a) {
    const std::vector<VaryValue>& values = spec.axes[a].values;
    if (std::none_of(values.begin(), values.end(),
                     [](const VaryValue& v) { return v.label.size() > kLongestValueShown; })) {
      continue;
    }
    for (const VaryValue& v : values) {
      const std::string name = fmt::format("value {}", names.short_name[a].size() + 1);
      if (names.short_name[a].emplace(v.label, name).second) {
        names.notes.push_back(Cut(spec.axes[a].key + "=" + name + ": " + v.label, kLongestNote));
      }
    }
  }
  return names;
}

// A run in legends: its varied keys with their values, and its seed.
std::string RunLabel(const SweepSpec& spec, const ValueNames& names, const PointRecord& p) {
  std::vector<std::string> parts;
  for (std::size_t a = 0; a < spec.axes.size() && a < p.labels.size(); ++a) {
    parts.push_back(spec.axes[a].key + "=" + names.Of(a, p.labels[a]));
  }
  if (spec.repeat > 1 || parts.empty()) parts.push_back(fmt::format("seed {}", p.seed));
  return fmt::format("{}", fmt::join(parts, ", "));
}

// The key metrics plotted against each varied key (the column name without its car/board
// prefix): the plot's title and the y axis, in words.
struct MetricWords {
  const char* column;
  const char* title;
  const char* y_label;
};
constexpr std::array<MetricWords, 16> kKeyMetrics{{
    {"laps_total", "Laps completed, all cars together", "laps"},
    {"collisions_total", "Collisions, all cars together", "collisions"},
    {"max_lateral_error_m", "Largest lateral error from the lane centre", "lateral error (m)"},
    {"rms_lateral_error_m", "RMS lateral error from the lane centre", "lateral error (m)"},
    {"lane_error_max_m", "Largest error of the detected lane", "lane error (m)"},
    {"laps", "Laps completed", "laps"},
    {"mean_lap_time_s", "Mean lap time", "lap time (s)"},
    {"total_wait_s", "Time spent waiting at intersections", "waiting (s)"},
    {"collisions", "Collisions", "collisions"},
    {"cpu_percent", "CPU load of the board", "CPU (%; 100 % = one core)"},
    {"cpu_demand_percent", "CPU the board's nodes ask for", "CPU (%; 100 % = one core)"},
    {"e2e_latency_p50_ms", "End-to-end latency (camera to command), median", "latency (ms)"},
    {"e2e_latency_p99_ms", "End-to-end latency (camera to command), 99th percentile",
     "latency (ms)"},
    {"lanes_latency_p50_ms", "Lane detection latency (camera to lane points), median",
     "latency (ms)"},
    {"lanes_latency_p99_ms", "Lane detection latency (camera to lane points), 99th percentile",
     "latency (ms)"},
    {"min_obstacle_gap_m", "Smallest gap to an obstacle", "gap (m)"},
}};

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

// A second varied key a metric plot draws one line per value of (instead of averaging over it):
// the other key, when exactly one other is varied, over at most kMostSplitValues values.
constexpr std::size_t kMostSplitValues = 4;
std::optional<std::size_t> SplitAxis(const SweepSpec& spec, std::size_t a) {
  if (spec.axes.size() != 2) return std::nullopt;
  const std::size_t other = 1 - a;
  if (spec.axes[other].values.size() > kMostSplitValues) return std::nullopt;
  return other;
}

// In words, what a metric plot against axis `a` averages: the other varied keys (but the one it
// splits by) and the seeds.
std::string AveragedOver(const SweepSpec& spec, const ValueNames& names, std::size_t a,
                         std::optional<std::size_t> split, std::size_t runs_per_x) {
  const std::string lines =
      split ? fmt::format("One line per value of {}. ", spec.axes[*split].key) : "";
  if (runs_per_x <= 1) return lines + "One run at each point.";
  std::vector<std::string> over;
  for (std::size_t o = 0; o < spec.axes.size(); ++o) {
    if (o == a || (split && o == *split)) continue;
    std::vector<std::string> values;
    for (const VaryValue& v : spec.axes[o].values) values.push_back(names.Of(o, v.label));
    over.push_back(fmt::format("{} = {}", spec.axes[o].key, fmt::join(values, ", ")));
  }
  if (spec.repeat > 1) over.push_back(fmt::format("{} seeds", spec.repeat));
  return fmt::format("{}Lines: the mean of the {} runs at each point (over {}); dots: each run.",
                     lines, runs_per_x, fmt::join(over, "; "));
}

// The series of one key metric against one varied key (its values in column `axis_column`): per
// car or board that has the metric (the column's prefix), the mean over its runs at each x as a
// line, and the runs as dots of the line's colour where an x has several. `runs_per_x`: the most
// runs at one x.
// A second key to split lines by: its column and its values (labels), in order.
struct Split {
  std::string key;
  std::size_t column{0};
  std::vector<std::string> values;
  std::vector<std::string> shown;  // the values as legends name them (ValueNames)
};

std::vector<PlotSeries> MetricSeries(const ResultsTable& table, const std::string& metric,
                                     std::size_t axis_column, const AxisPositions& positions,
                                     const std::optional<Split>& split, std::size_t* runs_per_x) {
  std::vector<PlotSeries> series;
  std::vector<std::string> prefixes;  // the columns' cars and boards
  for (std::size_t c = 0; c < table.columns.size(); ++c) {
    const std::string& column = table.columns[c];
    const auto dot = column.rfind('.');
    const std::string suffix = dot == std::string::npos ? column : column.substr(dot + 1);
    if (suffix == metric) prefixes.push_back(dot == std::string::npos ? "" : column.substr(0, dot));
  }
  const std::vector<std::string> values = split ? split->values : std::vector<std::string>{""};
  for (std::size_t c = 0; c < table.columns.size(); ++c) {
    const std::string& column = table.columns[c];
    const auto dot = column.rfind('.');
    const std::string suffix = dot == std::string::npos ? column : column.substr(dot + 1);
    const std::string prefix = dot == std::string::npos ? "all cars" : column.substr(0, dot);
    // only car/board-level columns (carN.metric), not per-node ones (carN.node.metric)
    if (suffix != metric || prefix.find('.') != std::string::npos) continue;
    for (std::size_t v = 0; v < values.size(); ++v) {
      // one car's lines: its colour, a dash per split value; a metric of all cars: a colour each
      const bool one_prefix = prefixes.size() == 1;
      const std::string colour =
          split && one_prefix ? std::string(kPalette[v % kPalette.size()]) : PrefixColour(prefix);
      const int dash = split && !one_prefix ? static_cast<int>(v % 5) + 1 : 1;
      const std::string name =
          split ? fmt::format("{}, {}={}", prefix, split->key, split->shown[v]) : prefix;
      PlotSeries dots{.label = name + ", each run",
                      .dots = true,
                      .line = false,
                      .colour = colour,
                      .dash = dash};
      std::map<double, std::pair<double, int>> mean;  // x -> (sum, count)
      for (const auto& row : table.rows) {
        double y = 0.0, x = 0.0;
        if (split && row[split->column] != values[v]) continue;
        if (!ParseDouble(row[c], &y) || !positions.X(row[axis_column], &x)) continue;
        dots.x.push_back(x);
        dots.y.push_back(y);
        mean[x].first += y;
        mean[x].second += 1;
      }
      if (dots.x.empty()) continue;
      PlotSeries line{.label = name, .dots = false, .line = true, .colour = colour, .dash = dash};
      for (const auto& [x, sum] : mean) {
        line.x.push_back(x);
        line.y.push_back(sum.first / sum.second);
        *runs_per_x = std::max(*runs_per_x, static_cast<std::size_t>(sum.second));
      }
      if (line.x.size() == dots.x.size()) {  // one run per x: the line's own dots
        line.dots = true;
        series.push_back(std::move(line));
      } else {
        line.label = name + ", mean";
        series.push_back(std::move(line));
        series.push_back(std::move(dots));
      }
    }
  }
  return series;
}

// Series of one per run: named while they are few; beyond kMostRunsNamed, each run in grey and
// their mean (point by point, over the runs that have the point) in black on top.
std::vector<PlotSeries> RunSeries(std::vector<PlotSeries> runs) {
  if (runs.size() <= kMostRunsNamed) {
    for (std::size_t i = 0; i < runs.size(); ++i) runs[i].colour = kPalette[i % kPalette.size()];
    return runs;
  }
  std::map<double, std::pair<double, int>> mean;
  for (PlotSeries& r : runs) {
    for (std::size_t i = 0; i < r.x.size(); ++i) {
      mean[r.x[i]].first += r.y[i];
      mean[r.x[i]].second += 1;
    }
    r.colour = kEachRunColour;
    r.width = 1.0;
    r.dots = false;
    r.label.clear();
  }
  runs.front().label = fmt::format("each of the {} runs", runs.size());
  PlotSeries m{
      .label = "mean of the runs", .dots = false, .line = true, .colour = "#000000", .width = 2.5};
  for (const auto& [x, sum] : mean) {
    m.x.push_back(x);
    m.y.push_back(sum.first / sum.second);
  }
  runs.push_back(std::move(m));
  return runs;
}

// A board's CPU load over time in one run (`report`: sim/platform's ReportJson).
PlotSeries LoadSeries(const nlohmann::json& report, const std::string& label) {
  PlotSeries series{.label = label, .dots = false, .line = true};
  const double bin_s = report.value("load_bin_s", 1.0);
  const auto bins = report.value("cpu_load_percent", std::vector<double>{});
  for (std::size_t b = 0; b < bins.size(); ++b) {
    series.x.push_back((static_cast<double>(b) + 0.5) * bin_s);
    series.y.push_back(bins[b]);
  }
  return series;
}

// One node's turnaround histogram in one run: the fraction of its jobs in each bin, at the bin's
// centre, every bin (a mean of runs counts a run's empty bin as 0); nothing for a node without
// jobs. `edges` receives the bins' edges.
std::optional<PlotSeries> HistogramSeries(const nlohmann::json& node, const std::string& label,
                                          std::vector<double>* edges) {
  if (!node.contains("turnaround_histogram_ms")) return std::nullopt;
  const auto counts = node["turnaround_histogram_ms"].value("counts", std::vector<double>{});
  *edges = node["turnaround_histogram_ms"].value("edges", std::vector<double>{});
  double total = 0.0;
  for (double c : counts) total += c;
  if (total == 0.0 || edges->size() != counts.size() + 1) return std::nullopt;
  PlotSeries histogram{.label = label, .dots = false, .line = true};
  for (std::size_t b = 0; b < counts.size(); ++b) {
    histogram.x.push_back(std::sqrt((*edges)[b] * (*edges)[b + 1]));
    histogram.y.push_back(counts[b] / total);
  }
  return histogram;
}

// Histograms (HistogramSeries, and their mean) as steps: each bin a level from its left edge to
// its right, so that a node whose jobs all fall in one bin (a hardware node's turnaround is almost
// constant) reads as a box across that bin, not as a peak joined to zeros. Only the bins from the
// first to the last that any series fills are drawn, with an empty one either side.
std::vector<PlotSeries> HistogramSteps(std::vector<PlotSeries> runs,
                                       const std::vector<double>& edges) {
  const std::size_t bins = edges.size() - 1;
  std::size_t first = bins, last = 0;
  for (const PlotSeries& r : runs) {
    for (std::size_t b = 0; b < r.y.size() && b < bins; ++b) {
      if (r.y[b] > 0.0) {
        first = std::min(first, b);
        last = std::max(last, b + 1);
      }
    }
  }
  if (first >= last) return runs;
  first = first > 0 ? first - 1 : 0;
  last = std::min(bins, last + 1);
  for (PlotSeries& r : runs) {
    PlotSeries steps = r;
    steps.x = {edges[first]};
    steps.y = {0.0};
    for (std::size_t b = first; b < last; ++b) {
      const double y = b < r.y.size() ? r.y[b] : 0.0;
      steps.x.insert(steps.x.end(), {edges[b], edges[b + 1]});
      steps.y.insert(steps.y.end(), {y, y});
    }
    steps.x.push_back(edges[last]);
    steps.y.push_back(0.0);
    steps.dots = false;
    r = std::move(steps);
  }
  return runs;
}

}  // namespace

std::string GnuplotData(const PlotSpec& spec) {
  std::string out = "# " + spec.title + "\n# x y, one block per series\n";
  for (std::size_t i = 0; i < spec.series.size(); ++i) {
    const PlotSeries& s = spec.series[i];
    out += fmt::format("\n\n# series {}: {}\n", i, s.label);
    for (std::size_t k = 0; k < s.x.size(); ++k) {
      if (std::isfinite(s.x[k]) && std::isfinite(s.y[k])) {
        out += Number(s.x[k]) + " " + Number(s.y[k]) + "\n";
      }
    }
  }
  return out;
}

namespace {

// The lines above the plot, left-aligned with it: the title (in two lines when long: broken before
// ", against"), the subtitle, and the notes, smaller.
std::string HeadLines(const PlotSpec& spec) {
  struct Line {
    std::string text;
    const char* font;
    const char* colour;
    double height_chars;  // from the line below's baseline to this one's, in tic-font lines
  };
  std::vector<Line> lines;
  const std::size_t against = spec.title.find(", against ");
  if (spec.title.size() > kLongestTitleLine && against != std::string::npos) {
    lines.push_back({spec.title.substr(0, against), "DejaVu Sans,14", "", 1.7});
    lines.push_back({spec.title.substr(against + 2), "DejaVu Sans,12", "", 1.7});
  } else {
    lines.push_back({spec.title, "DejaVu Sans,14", "", 1.7});
  }
  if (!spec.subtitle.empty()) lines.push_back({spec.subtitle, "DejaVu Sans,10", "#555555", 1.4});
  for (const std::string& note : spec.notes) {
    lines.push_back({note, "DejaVu Sans,9", "#555555", 1.25});
  }
  std::vector<double> offset(lines.size(), 1.1);  // the last line's baseline: 1.1 lines up
  for (std::size_t l = lines.size() - 1; l-- > 0;)
    offset[l] = offset[l + 1] + lines[l].height_chars;
  std::string gp = fmt::format("set tmargin {}\n", std::ceil(offset[0] + 2.9));
  for (std::size_t l = 0; l < lines.size(); ++l) {
    gp += fmt::format(
        "set label {} {} at graph 0, graph 1 left offset 0, char {} font '{}'{}\n", l + 1,
        Quoted(lines[l].text), offset[l], lines[l].font,
        *lines[l].colour ? fmt::format(" textcolor rgb '{}'", lines[l].colour) : std::string());
  }
  return gp;
}

// A legend entry's name as drawn: cut where it would not fit across the picture.
std::string KeyName(const std::string& label) {
  return Cut(label, kKeyWidthChars - kKeyEntryChars);
}

// Where the legend goes: beside the plot on the right while its names are short; else under the
// plot, below the axis label, in as many columns as fit across, the bottom margin grown by its
// rows. Either way it covers neither the plot nor its tic labels nor the axis labels.
// `names_lines`: what slanted category names take under the axis.
std::string KeyLayout(const PlotSpec& spec, std::size_t names_lines) {
  std::size_t longest = 0, entries = 0;
  for (const PlotSeries& s : spec.series) {
    if (s.label.empty()) continue;
    ++entries;
    longest = std::max(longest, KeyName(s.label).size());
  }
  const std::string names_margin =
      names_lines > 0 ? fmt::format("set bmargin {}\n", 2 + names_lines) : std::string();
  if (entries == 0) return "unset key\n" + names_margin;
  if (longest <= kLongestLabelBeside)
    return "set key outside right top Left reverse\n" + names_margin;
  const std::size_t columns =
      std::clamp<std::size_t>(kKeyWidthChars / (longest + kKeyEntryChars), 1, entries);
  const std::size_t rows = (entries + columns - 1) / columns;
  return fmt::format(
      "set key at screen 0.01, screen 0.01 left bottom horizontal Left reverse maxcols {} "
      "maxrows {}\nset bmargin {}\n",
      columns, rows, kAxisLinesBelow + static_cast<double>(names_lines + rows));
}

// A log axis's tics at 1, 2 and 5 times the powers of ten across the data (1 to 9 times where that
// gives fewer than four), as plain numbers: gnuplot's own are powers of ten only, one or none
// across the few bins of a node's turnaround.
std::string LogTics(const PlotSpec& spec) {
  double lo = std::numeric_limits<double>::infinity(), hi = 0.0;
  for (const PlotSeries& s : spec.series) {
    for (double x : s.x) {
      if (std::isfinite(x) && x > 0.0) {
        lo = std::min(lo, x);
        hi = std::max(hi, x);
      }
    }
  }
  if (!(lo < hi)) return "";
  const auto tics_of = [lo, hi](std::initializer_list<int> mantissas) {
    std::vector<std::string> tics;
    for (int e = static_cast<int>(std::floor(std::log10(lo)));
         e <= static_cast<int>(std::ceil(std::log10(hi))); ++e) {
      for (int m : mantissas) {
        // m / 10^-e, not m * 10^e: 3 / 10 is the double 0.3, 3 * 0.1 is not
        const double v = e >= 0 ? m * std::pow(10.0, e) : m / std::pow(10.0, -e);
        if (v >= lo && v <= hi) tics.push_back(Number(v));
      }
    }
    return tics;
  };
  std::vector<std::string> tics = tics_of({1, 2, 5});
  if (tics.size() < 4) tics = tics_of({1, 2, 3, 4, 5, 6, 7, 8, 9});
  return fmt::format("set logscale x 10\nset xtics ({})\n", fmt::join(tics, ", "));
}

// The x axis: its categories (slanted when they do not fit side by side), or a margin around the
// data; and, under it, the legend (KeyLayout).
std::string XAxisAndKey(const PlotSpec& spec) {
  std::size_t category_chars = 0, longest_category = 0;
  for (const std::string& c : spec.categories) {
    category_chars += c.size() + 2;
    longest_category = std::max(longest_category, c.size());
  }
  const bool slanted = category_chars > kCategoryCharsLevel;
  // a character at 30° rises 0.3 of a line
  std::string gp = KeyLayout(spec, slanted ? longest_category * 3 / 10 : 0);
  if (spec.log_x) gp += LogTics(spec);
  if (!spec.categories.empty()) {
    std::vector<std::string> tics;
    for (std::size_t i = 0; i < spec.categories.size(); ++i) {
      tics.push_back(Quoted(spec.categories[i]) + " " + std::to_string(i));
    }
    gp += fmt::format("set xtics ({}){}\nset xrange [-0.5:{}]\n", fmt::join(tics, ", "),
                      slanted ? " rotate by 30 right" : "",
                      static_cast<double>(spec.categories.size()) - 0.5);
  } else {
    gp += "set autoscale xfix\nset offsets graph 0.03, graph 0.03, graph 0.05, 0\n";
  }
  return gp;
}

}  // namespace

std::string GnuplotScript(const PlotSpec& spec, const std::string& data_file,
                          const std::string& png) {
  std::string gp = fmt::format(
      "# Drawn by autonomsim (a sweep's plots). Run `gnuplot {}` in this folder to draw it again;\n"
      "# for a paper, change the terminal, e.g. set terminal pdfcairo size 6in,3.8in.\n"
      "set terminal pngcairo size 1000,620 font 'DejaVu Sans,11' noenhanced\n"
      "set output {}\n",
      Quoted(png.substr(0, png.size() - 4) + ".gp"), Quoted(png));
  gp += HeadLines(spec);
  gp += "set xlabel " + Quoted(spec.x_label) + "\nset ylabel " + Quoted(spec.y_label) + "\n";
  gp += "set grid lc rgb '#e0e0e0'\nset border 3\nset tics nomirror\nset yrange [0:*]\n";
  gp += XAxisAndKey(spec);
  std::vector<std::string> plots;
  for (std::size_t i = 0; i < spec.series.size(); ++i) {
    const PlotSeries& s = spec.series[i];
    const std::string colour = s.colour.empty() ? kPalette[i % kPalette.size()] : s.colour;
    const std::string style = s.line && s.dots ? "linespoints pt 7 ps 0.9"
                              : s.line         ? "lines"
                                               : "points pt 7 ps 0.7";
    plots.push_back(fmt::format("{} index {} using 1:2 with {} lw {} dt {} lc rgb {} title {}",
                                i == 0 ? Quoted(data_file) : "''", i, style, s.width, s.dash,
                                Quoted(colour), s.label.empty() ? "''" : Quoted(KeyName(s.label))));
  }
  gp += "plot " + fmt::format("{}", fmt::join(plots, ", \\\n     ")) + "\n";
  return gp;
}

namespace {

// What the driver script prints after each plot: a line RenderPlots counts instead of showing it.
constexpr std::string_view kPlotDoneLine = "autonomsim: plot drawn\n";

// Runs `command` (its stderr with its stdout), calling `on_plot` for each kPlotDoneLine it prints;
// returns its exit status (-1: it could not be started) and the rest of its output in *output.
int RunCountingPlots(const std::string& command, const std::function<void()>& on_plot,
                     std::string* output) {
  FILE* pipe = ::popen(command.c_str(), "r");
  if (pipe == nullptr) return -1;
  std::array<char, 4096> buffer;
  std::string line;  // fgets returns a long line in pieces
  while (std::fgets(buffer.data(), buffer.size(), pipe) != nullptr) {
    line += buffer.data();
    if (line.back() != '\n') continue;
    if (line == kPlotDoneLine) {
      on_plot();
    } else {
      *output += line;
    }
    line.clear();
  }
  *output += line;
  return ::pclose(pipe);
}

}  // namespace

void RenderPlots(const std::vector<std::pair<std::string, PlotSpec>>& plots, const fs::path& dir,
                 const PlotProgress& progress) {
  if (plots.empty()) return;
  const fs::path folder = fs::absolute(dir);
  // One gnuplot for all: a script that loads each plot's own in the plots folder, and says when
  // it has drawn each (gnuplot prints to stderr)
  std::string all = "cd " + Quoted(folder.string()) + "\n";
  for (const auto& [name, plot] : plots) {
    WriteFile(folder / (name + ".dat"), GnuplotData(plot));
    WriteFile(folder / (name + ".gp"), GnuplotScript(plot, name + ".dat", name + ".png"));
    all += "reset\nload " + Quoted(name + ".gp") + "\nunset output\nprint " +
           Quoted(std::string(kPlotDoneLine.substr(0, kPlotDoneLine.size() - 1))) + "\n";
  }
  const fs::path driver = folder / (".all-" + std::to_string(::getpid()) + ".gp");
  WriteFile(driver, all);
  std::string command = "gnuplot '";
  for (char c : driver.string()) command += c == '\'' ? std::string("'\\''") : std::string(1, c);
  command += "' 2>&1";
  std::size_t drawn = 0;
  if (progress) progress(0, plots.size());
  std::string output;
  const int status = RunCountingPlots(
      command,
      [&] {
        if (progress) progress(++drawn, plots.size());
      },
      &output);
  fs::remove(driver);
  if (status != 0) {
    throw std::runtime_error(
        "gnuplot could not draw the plots" +
        (output.find("not found") != std::string::npos || status == (127 << 8)
             ? std::string(" (is it installed? tools/install_deps.sh installs gnuplot-nox)")
             : std::string()) +
        ": " + output);
  }
}

namespace {

using NamedPlots = std::vector<std::pair<std::string, PlotSpec>>;

// Each key metric against each varied key; one series per car or board (column prefix).
void AddMetricPlots(const SweepSpec& spec, const ValueNames& names, const ResultsTable& table,
                    NamedPlots* plots) {
  for (std::size_t a = 0; a < spec.axes.size(); ++a) {
    const VaryAxis& axis = spec.axes[a];
    const AxisPositions positions = PositionsOf(axis);
    std::vector<std::string> categories;
    if (!positions.numeric) {
      for (const std::string& label : positions.categories)
        categories.push_back(names.Of(a, label));
    }
    std::optional<Split> split;
    if (const std::optional<std::size_t> s = SplitAxis(spec, a)) {
      split = Split{.key = spec.axes[*s].key, .column = 2 + *s, .values = {}, .shown = {}};
      for (const VaryValue& v : spec.axes[*s].values) {
        split->values.push_back(v.label);
        split->shown.push_back(names.Of(*s, v.label));
      }
    }
    for (const MetricWords& metric : kKeyMetrics) {
      std::size_t runs_per_x = 0;
      PlotSpec plot{
          .title = fmt::format("{}, against {}", metric.title, axis.key),
          .subtitle = "",
          .x_label = axis.key,
          .y_label = metric.y_label,
          // the axes' columns follow index and run_id
          .series = MetricSeries(table, metric.column, 2 + a, positions, split, &runs_per_x),
          .categories = categories,
          .log_x = false,
          .notes = names.notes};
      if (plot.series.empty()) continue;
      plot.subtitle = AveragedOver(spec, names, a, SplitAxis(spec, a), runs_per_x);
      plots->emplace_back(FileSafe(metric.column) + "_vs_" + FileSafe(axis.key), std::move(plot));
    }
  }
}

// Each distinct run's CPU load over time and turnaround histograms, per board and per board/node,
// in grid order.
struct PlatformSeries {
  std::map<std::string, std::vector<PlotSeries>> loads;       // by board
  std::map<std::string, std::vector<PlotSeries>> histograms;  // by board/node
  std::map<std::string, std::vector<double>> edges;           // by board/node: its bins' edges
  std::map<std::string, int> cores;
};

PlatformSeries PlatformSeriesOf(const SweepSpec& spec, const ValueNames& names,
                                const std::vector<PointRecord>& points,
                                const std::vector<RunSummary>& summaries) {
  PlatformSeries out;
  std::set<std::string> seen;
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!seen.insert(points[i].run_id).second || !summaries[i].platform) continue;
    const std::string label = RunLabel(spec, names, points[i]);
    for (const auto& [board, report] : *summaries[i].platform) {
      out.loads[board].push_back(LoadSeries(report, label));
      out.cores[board] = report.value("cores", 0);
      for (const nlohmann::json& node : report.at("nodes")) {
        const std::string name = board + "/" + node.at("name").get<std::string>();
        std::vector<double> edges;
        if (auto h = HistogramSeries(node, label, &edges)) {
          out.histograms[name].push_back(std::move(*h));
          out.edges[name] = std::move(edges);
        }
      }
    }
  }
  return out;
}

// CPU load over time per board; turnaround histograms per board and node: a series per run.
void AddPlatformPlots(PlatformSeries series, const ValueNames& names, NamedPlots* plots) {
  for (auto& [board, runs] : series.loads) {
    plots->emplace_back(
        "cpu_load_" + FileSafe(board),
        PlotSpec{.title = fmt::format("CPU load of {}'s board over time", board),
                 .subtitle = fmt::format("Mean over each load bin; {} cores, 100 % = one core.",
                                         series.cores[board]),
                 .x_label = "simulated time (s)",
                 .y_label = "CPU load (%)",
                 .series = RunSeries(std::move(runs)),
                 .categories = {},
                 .log_x = false,
                 .notes = names.notes});
  }
  for (auto& [name, runs] : series.histograms) {
    const auto slash = name.find('/');
    plots->emplace_back(
        "turnaround_" + FileSafe(name),
        PlotSpec{.title = fmt::format("Turnaround of {} on {}'s board", name.substr(slash + 1),
                                      name.substr(0, slash)),
                 .subtitle = fmt::format(
                     "From taking a message to publishing its result, waiting for a core "
                     "included. Log-spaced bins, {} per decade: each step spans one bin.",
                     kHistogramBinsPerDecade),
                 .x_label = "turnaround (ms)",
                 .y_label = "fraction of the node's jobs",
                 .series = HistogramSteps(RunSeries(std::move(runs)), series.edges[name]),
                 .categories = {},
                 .log_x = true,
                 .notes = names.notes});
  }
}

}  // namespace

NamedPlots SweepPlots(const SweepSpec& spec, const std::vector<PointRecord>& points,
                      const std::vector<RunSummary>& summaries, const ResultsTable& table) {
  NamedPlots plots;
  if (points.empty()) return plots;
  const ValueNames names = NamesOf(spec);
  AddMetricPlots(spec, names, table, &plots);
  AddPlatformPlots(PlatformSeriesOf(spec, names, points, summaries), names, &plots);
  return plots;
}

void WriteSweepPlots(const SweepSpec& spec, const std::vector<PointRecord>& points,
                     const std::vector<RunSummary>& summaries, const ResultsTable& table,
                     const fs::path& dir, const PlotProgress& progress) {
  fs::remove_all(dir);
  fs::create_directories(dir);
  RenderPlots(SweepPlots(spec, points, summaries, table), dir, progress);
}

}  // namespace autonomsim::sim
