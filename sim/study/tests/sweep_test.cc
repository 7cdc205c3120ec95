// Sweeps: --vary parsing, grid order, shards, the results table, study files, plots, and small
// real sweeps (resume, --jobs and sharding do not change results.csv).
#include "sim/study/sweep.h"

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <fstream>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <set>
#include <sstream>

#include "sim/core/config.h"
#include "sim/core/parallel.h"
#include "sim/platform/node_metrics.h"
#include "sim/study/sweep_index.h"
#include "sim/study/sweep_plots.h"

namespace autonomsim::sim {
namespace {

namespace fs = std::filesystem;
using ::testing::ElementsAre;
using ::testing::HasSubstr;

std::vector<std::string> Labels(const VaryAxis& axis) {
  std::vector<std::string> out;
  for (const VaryValue& v : axis.values) out.push_back(v.label);
  return out;
}

std::string ReadText(const fs::path& file) {
  std::ifstream in(file);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// A fresh folder under the build's temporary directory, removed at the end of the test.
struct TempDir {
  TempDir() {
    path = fs::temp_directory_path() /
           ("autonomsim_sweep_test_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~TempDir() { fs::remove_all(path); }
  fs::path path;
};

TEST(Sweep, VaryTakesAListOrARange) {
  EXPECT_THAT(Labels(ParseVary("cars[0].sensors.color_camera.rate_hz=10,15,30")),
              ElementsAre("10", "15", "30"));
  const VaryAxis range = ParseVary("v2i.latency_s=0:2:5");
  EXPECT_EQ(range.key, "v2i.latency_s");
  EXPECT_THAT(Labels(range), ElementsAre("0", "0.5", "1", "1.5", "2"));
  EXPECT_THAT(Labels(ParseVary("x=0.1:0.3:3")), ElementsAre("0.1", "0.2", "0.3"));
  EXPECT_THAT(Labels(ParseVary("x=3:3:1")), ElementsAre("3"));
  // YAML flow values stay whole: commas inside {} and [] do not split
  const VaryAxis maps = ParseVary("cars[0].platform.mapping={lane_detection: {target: sw}}, {}");
  EXPECT_THAT(Labels(maps), ElementsAre("{lane_detection: {target: sw}}", "{}"));
  EXPECT_THAT(Labels(ParseVary("k=[1, 2],[3]")), ElementsAre("[1, 2]", "[3]"));

  for (const std::string bad : {"novalue", "=1,2", "x=0:1:zero", "x=0:1:0", "x=0:1:2.5", "x=1,,2",
                                "x=a:1:3", "x=0:1", "x=0:1:5:2"}) {
    try {
      ParseVary(bad);
      FAIL() << "expected a ConfigError for " << bad;
    } catch (const ConfigError& e) {
      EXPECT_THAT(e.what(), HasSubstr(bad)) << "the message names the spec";
    }
  }
}

// Issue 34, smaller items: a range's points were printed (and run) with float noise, 0.1:0.5:5
// giving 0.30000000000000004 in results.csv; two numbers for a range said nothing of its form.
TEST(Sweep, RangePointsAreRoundedAndRunAsShownAndABadRangeSaysItsForm) {
  const VaryAxis tenths = ParseVary("x=0.1:0.5:5");
  EXPECT_THAT(Labels(tenths), ElementsAre("0.1", "0.2", "0.3", "0.4", "0.5"));
  for (const VaryValue& v : tenths.values) EXPECT_EQ(v.yaml, v.label);  // what the row shows ran
  EXPECT_THAT(Labels(ParseVary("x=0:1:4")), ElementsAre("0", "0.3333333", "0.6666667", "1"));
  EXPECT_THAT(Labels(ParseVary("x=-0.3:0.3:3")), ElementsAre("-0.3", "0", "0.3"));
  EXPECT_THAT(Labels(ParseVary("x=0.0001:0.0003:3")), ElementsAre("0.0001", "0.0002", "0.0003"));
  EXPECT_THAT(Labels(ParseVary("x=1e6:2e6:3")), ElementsAre("1000000", "1500000", "2000000"));
  // values of a list stay as typed
  EXPECT_THAT(Labels(ParseVary("x=0.30,1e-3,.5")), ElementsAre("0.30", "1e-3", ".5"));
  for (const std::string bad : {"v2i.latency_s=0:1", "v2i.latency_s=0:1:5:2"}) {
    try {
      ParseVary(bad);
      FAIL() << bad;
    } catch (const ConfigError& e) {
      EXPECT_THAT(e.what(), HasSubstr("--vary " + bad +
                                      ": a range is start:stop:count, three "
                                      "numbers (e.g. v2i.latency_s=0:1:5"));
    }
  }
}

TEST(Sweep, TheGridIsTheProductWithTheLastAxisFastestAndRepeatsInnermost) {
  SweepSpec spec;
  spec.axes = {ParseVary("a=1,2"), ParseVary("b=x,y,z")};
  spec.repeat = 2;
  const std::vector<SweepPoint> grid = ExpandGrid(spec);
  ASSERT_EQ(grid.size(), 12u);
  std::size_t index = 0;
  for (std::size_t a = 0; a < 2; ++a) {
    for (std::size_t b = 0; b < 3; ++b) {
      for (int r = 0; r < 2; ++r, ++index) {
        EXPECT_EQ(grid[index].index, index);
        EXPECT_THAT(grid[index].value_index, ElementsAre(a, b));
        EXPECT_EQ(grid[index].repeat, r);
      }
    }
  }
  spec.overrides = {"duration_s=5"};
  EXPECT_THAT(PointOverrides(spec, grid[7]), ElementsAre("duration_s=5", "a=2", "b=x"));

  SweepSpec empty;  // no --vary: one run
  EXPECT_EQ(ExpandGrid(empty).size(), 1u);
}

TEST(Sweep, ShardsPartitionTheGrid) {
  for (int n = 1; n <= 5; ++n) {
    std::multiset<std::size_t> seen;
    for (int k = 1; k <= n; ++k) {
      for (std::size_t i = 0; i < 23; ++i) {
        if (InShard(i, Shard{k, n})) seen.insert(i);
      }
    }
    ASSERT_EQ(seen.size(), 23u) << n;
    for (std::size_t i = 0; i < 23; ++i) EXPECT_EQ(seen.count(i), 1u);
  }
  const Shard s = ParseShard("3/4");
  EXPECT_EQ(s.k, 3);
  EXPECT_EQ(s.n, 4);
  for (const std::string bad : {"0/4", "5/4", "1", "a/b", "1/0", "2/3x"}) {
    EXPECT_THROW(ParseShard(bad), ConfigError) << bad;
  }
}

RunSummary FakeSummary(double error_m, int laps, bool with_board) {
  CarMetrics car;
  car.id = 0;
  car.laps = laps;
  car.lap_times_s = std::vector<double>(static_cast<std::size_t>(laps), 0.0);
  if (laps > 0) car.lap_times_s.back() = 30.0 * laps;
  car.max_lateral_error_m = error_m;
  car.rms_lateral_error_m = error_m / 2;
  RunSummary s;
  s.passed = true;
  s.cars = {car};
  if (with_board) {
    s.platform.emplace();
    (*s.platform)["car0"] = {
        {"cpu_percent", 150.0},
        {"cpu_demand_percent", 160.0},
        {"topics",
         {{{"name", "/carcontrol/command"}, {"latency_ms", {{"p50", 40.0}, {"p99", 90.0}}}}}},
        {"nodes",
         {{{"name", "poly_fit"},
           {"rate_hz", 30.0},
           {"turnaround_ms", {{"p50", 9.5}}},
           {"cpu_percent", 2.0}}}}};
  }
  return s;
}

TEST(Sweep, TheTableHasOneRowPerPointInGridOrderWhateverTheInputOrder) {
  const std::vector<PointRecord> points = {
      {.index = 2, .run_id = "cc", .labels = {"2", "a,b"}, .repeat = 0, .seed = 42},
      {.index = 0, .run_id = "aa", .labels = {"0", "plain"}, .repeat = 0, .seed = 42},
      {.index = 1, .run_id = "bb", .labels = {"1", "say \"hi\""}, .repeat = 1, .seed = 43}};
  const std::vector<RunSummary> summaries = {FakeSummary(0.3, 2, true), FakeSummary(0.1, 3, false),
                                             FakeSummary(0.2, 0, false)};
  const ResultsTable table = BuildResultsTable({"v2i.latency_s", "label"}, points, summaries);
  ASSERT_EQ(table.rows.size(), 3u);
  EXPECT_THAT(std::vector<std::string>(table.columns.begin(), table.columns.begin() + 6),
              ElementsAre("index", "run_id", "v2i.latency_s", "label", "repeat", "seed"));
  const auto col = [&](const std::string& name) { return *table.Column(name); };
  EXPECT_EQ(table.rows[0][col("run_id")], "aa");
  EXPECT_EQ(table.rows[1][col("run_id")], "bb");
  EXPECT_EQ(table.rows[2][col("run_id")], "cc");
  EXPECT_EQ(table.rows[1][col("seed")], "43");
  EXPECT_EQ(table.rows[0][col("car0.max_lateral_error_m")], "0.1");
  EXPECT_EQ(table.rows[2][col("car0.rms_lateral_error_m")], "0.15");
  EXPECT_EQ(table.rows[0][col("car0.mean_lap_time_s")], "30");   // 90 s for 3 laps
  EXPECT_EQ(table.rows[1][col("car0.mean_lap_time_s")], "");     // no lap
  EXPECT_EQ(table.rows[0][col("car0.min_obstacle_gap_m")], "");  // none came near
  // board columns exist for the run that has a board, and are empty for the others
  EXPECT_EQ(table.rows[2][col("car0.e2e_latency_p99_ms")], "90");
  EXPECT_EQ(table.rows[2][col("car0.poly_fit.turnaround_p50_ms")], "9.5");
  EXPECT_EQ(table.rows[0][col("car0.poly_fit.rate_hz")], "");
  // CSV: fields with commas or quotes are quoted
  const std::string csv = table.Csv();
  EXPECT_THAT(csv, HasSubstr(",\"a,b\","));
  EXPECT_THAT(csv, HasSubstr(",\"say \"\"hi\"\"\","));
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 4);
}

// `--vary seed=...` gave results.csv two columns named `seed`; the varied one is now `vary.seed`,
// and `seed` stays the run's own (the varied seed plus its repeat).
TEST(Sweep, AVariedSeedHasAColumnOfItsOwn) {
  const std::vector<PointRecord> points = {
      {.index = 0, .run_id = "aa", .labels = {"7"}, .repeat = 0, .seed = 7},
      {.index = 1, .run_id = "bb", .labels = {"7"}, .repeat = 1, .seed = 8}};
  const ResultsTable table =
      BuildResultsTable({"seed"}, points, {FakeSummary(0.1, 1, false), FakeSummary(0.1, 1, false)});
  EXPECT_THAT(std::vector<std::string>(table.columns.begin(), table.columns.begin() + 5),
              ElementsAre("index", "run_id", "vary.seed", "repeat", "seed"));
  EXPECT_EQ(std::count(table.columns.begin(), table.columns.end(), "seed"), 1);
  EXPECT_EQ(table.rows[1][*table.Column("vary.seed")], "7");
  EXPECT_EQ(table.rows[1][*table.Column("seed")], "8");
}

RunSummary WithLaneError(std::optional<double> lane_error_max_m) {
  RunSummary s = FakeSummary(0.1, 1, false);
  s.cars[0].perception = PerceptionMetrics{.lane_frames = 300, .lane_valid_frames = 200};
  if (lane_error_max_m) {
    s.cars[0].perception->lane_error_samples = 50;
    s.cars[0].perception->lane_error_max_m = lane_error_max_m;
    s.cars[0].perception->lane_error_rms_m = *lane_error_max_m / 2;
  }
  return s;
}

// Issue 34, item 3: a run whose lane detector gave no sample to judge had lane_error_max_m 0, a
// "0" in results.csv, and a point at 0 m in the plot, pulling its line's mean down.
TEST(Sweep, AMetricARunDidNotMeasureIsAnEmptyCellAndNoPoint) {
  SweepSpec spec;
  spec.axes = {ParseVary("v2i.latency_s=0,1")};
  spec.repeat = 2;
  const std::vector<PointRecord> points = {
      {.index = 0, .run_id = "a0", .labels = {"0"}, .repeat = 0, .seed = 1},
      {.index = 1, .run_id = "a1", .labels = {"0"}, .repeat = 1, .seed = 2},
      {.index = 2, .run_id = "b0", .labels = {"1"}, .repeat = 0, .seed = 1},
      {.index = 3, .run_id = "b1", .labels = {"1"}, .repeat = 1, .seed = 2}};
  const std::vector<RunSummary> summaries = {WithLaneError(0.02), WithLaneError(std::nullopt),
                                             WithLaneError(0.04), WithLaneError(0.06)};
  const ResultsTable table = BuildResultsTable({"v2i.latency_s"}, points, summaries);
  const std::size_t column = table.Column("car0.lane_error_max_m").value();
  EXPECT_EQ(table.rows[0][column], "0.02");
  EXPECT_EQ(table.rows[1][column], "");  // not measured: empty, not 0
  EXPECT_EQ(table.rows[1][table.Column("car0.lane_error_rms_m").value()], "");
  EXPECT_EQ(table.rows[1][table.Column("car0.lane_valid_fraction").value()], "0.6666666666666666");

  const auto plots = SweepPlots(spec, points, summaries, table);
  const auto plot = std::find_if(plots.begin(), plots.end(), [](const auto& p) {
    return p.first == "lane_error_max_m_vs_v2i_latency_s";
  });
  ASSERT_NE(plot, plots.end());
  std::map<std::string, const PlotSeries*> series;
  for (const PlotSeries& s : plot->second.series) series[s.label] = &s;
  ASSERT_TRUE(series.count("car0, mean") && series.count("car0, each run"));
  // the mean at latency 0 is the one measured run's, not (0.02 + 0) / 2
  EXPECT_THAT(series["car0, mean"]->x, ElementsAre(0.0, 1.0));
  EXPECT_THAT(series["car0, mean"]->y, ElementsAre(0.02, 0.05));
  // three dots: the unmeasured run has none
  EXPECT_THAT(series["car0, each run"]->x, ElementsAre(0.0, 1.0, 1.0));
  EXPECT_THAT(series["car0, each run"]->y, ElementsAre(0.02, 0.04, 0.06));
  EXPECT_THAT(GnuplotData(plot->second), ::testing::Not(HasSubstr("\n0 0\n")));
}

// Issue 34, smaller items: a board sweep's index.html showed 149 columns, most of them one node's
// each, with no way to hide them. The page is told which columns are a node's, and hides them
// until asked (the browser's side: SweepCliTest.TheIndexHidesPerNodeColumnsUntilAsked).
TEST(Sweep, TheIndexKnowsWhichColumnsAreANodes) {
  const std::vector<PointRecord> points = {
      {.index = 0, .run_id = "aa", .labels = {"a.b"}, .repeat = 0, .seed = 42}};
  const std::vector<RunSummary> summaries = {FakeSummary(0.3, 2, true)};
  // a varied key with two dots is not a node's column
  const ResultsTable table = BuildResultsTable({"cars[0].platform.mapping"}, points, summaries);
  const std::string page = SweepIndexHtml(
      SweepIndexInput{.title = "t", .axis_keys = {"cars[0].platform.mapping"}, .table = &table});
  const std::string open = "<script type=\"application/json\" id=\"sweep-data\">";
  const std::size_t begin = page.find(open) + open.size();
  const nlohmann::json data =
      nlohmann::json::parse(page.substr(begin, page.find("</script>", begin) - begin));
  std::vector<std::string> node_columns;
  for (std::size_t c : data.at("node_columns")) node_columns.push_back(table.columns.at(c));
  EXPECT_THAT(node_columns, ElementsAre("car0.poly_fit.rate_hz", "car0.poly_fit.turnaround_p50_ms",
                                        "car0.poly_fit.cpu_percent"));
  EXPECT_THAT(page, HasSubstr("show per-node columns"));
}

// Issue 33: `--vary K=a,b --vary K=c` was accepted: two columns named K, and rows of the same run.
TEST(Sweep, AKeyVariedTwiceIsRefused) {
  EXPECT_NO_THROW(CheckAxesDistinct({ParseVary("a=1,2"), ParseVary("b=3")}));
  try {
    CheckAxesDistinct({ParseVary("v2i.loss=0,0.1"), ParseVary("a=1"), ParseVary("v2i.loss=0.2")});
    FAIL() << "a key varied twice was accepted";
  } catch (const ConfigError& e) {
    EXPECT_THAT(e.what(), HasSubstr("v2i.loss is varied twice"));
  }
  TempDir dir;
  std::ofstream(dir.path / "study.yaml") << "scenario: x.yaml\nvary: [a=1, a=2]\n";
  EXPECT_THROW(LoadStudy(dir.path / "study.yaml"), ConfigError);
}

// Issue 33, items 3 and 4: `sweep --repeat 1e9` and a 10^4 × 10^4 grid ended in std::bad_alloc
// with no word of why; a 10^6-point range was refused as "count must be >= 1".
TEST(Sweep, ASweepBeyondItsRunLimitIsRefusedSayingHowToRaiseIt) {
  SweepSpec spec;
  spec.axes = {ParseVary("seed=1:10000:10000"), ParseVary("duration_s=1:100:10000")};
  try {
    CheckSweepSize(spec, kDefaultMaxRuns);
    FAIL() << "10^8 runs accepted";
  } catch (const ConfigError& e) {
    EXPECT_THAT(e.what(), HasSubstr("the sweep has 100000000 runs (100000000 grid point(s) × 1 "
                                    "seed(s)); the limit is --max-runs 100000"));
  }
  spec.axes.clear();
  spec.repeat = 1'000'000'000;
  EXPECT_THROW(CheckSweepSize(spec, kDefaultMaxRuns), ConfigError);
  EXPECT_EQ(CheckSweepSize(spec, 2'000'000'000), 1'000'000'000u);  // raised: accepted
  spec.repeat = 4;
  spec.axes = {ParseVary("a=1,2,3")};
  EXPECT_EQ(CheckSweepSize(spec, 12), 12u);
  EXPECT_THROW(CheckSweepSize(spec, 11), ConfigError);
  // RunSweep checks too, before it makes anything
  TempDir dir;
  SweepOptions options;
  options.out_dir = dir.path / "out";
  options.max_runs = 11;
  EXPECT_THROW(RunSweep(spec, options), ConfigError);
  EXPECT_FALSE(std::filesystem::exists(options.out_dir / "results.csv"));
  try {
    ParseVary("seed=1:2000000:2000000");
    FAIL() << "a 2·10^6-point range accepted";
  } catch (const ConfigError& e) {
    EXPECT_THAT(e.what(), HasSubstr("count must be a whole number in [1, 1000000], got '2000000'"));
  }
}

TEST(Sweep, AStudyFileGivesTheScenarioSetRepeatAndVary) {
  TempDir dir;
  std::ofstream(dir.path / "study.yaml") << R"(
scenario: ../scenarios/x.yaml
description: test
set: [duration_s=5]
repeat: 2
vary:
  - key: cars[0].platform.mapping
    values:
      all_hw: {}
      lane_sw: {lane_detection: {target: sw}}
  - key: v2i.latency_s
    range: [0, 1, 3]
  - v2i.loss=0,0.1
)";
  EXPECT_TRUE(IsStudyFile(dir.path / "study.yaml"));
  EXPECT_FALSE(IsStudyFile("scenarios/lab_two_cars.yaml"));
  const SweepSpec spec = LoadStudy(dir.path / "study.yaml");
  EXPECT_EQ(spec.scenario, (dir.path / "../scenarios/x.yaml").lexically_normal());
  EXPECT_THAT(spec.overrides, ElementsAre("duration_s=5"));
  EXPECT_EQ(spec.repeat, 2);
  ASSERT_EQ(spec.axes.size(), 3u);
  EXPECT_THAT(Labels(spec.axes[0]), ElementsAre("all_hw", "lane_sw"));
  EXPECT_EQ(spec.axes[0].values[1].yaml, "{lane_detection: {target: sw}}");
  EXPECT_THAT(Labels(spec.axes[1]), ElementsAre("0", "0.5", "1"));
  EXPECT_THAT(Labels(spec.axes[2]), ElementsAre("0", "0.1"));
  EXPECT_EQ(SweepSpec::FromJson(spec.ToJson()).ToJson(), spec.ToJson());

  // without vary: one point, `repeat` seeds of it
  std::ofstream(dir.path / "seeds.yaml") << "scenario: x.yaml\nrepeat: 5\n";
  EXPECT_TRUE(IsStudyFile(dir.path / "seeds.yaml"));
  const SweepSpec seeds = LoadStudy(dir.path / "seeds.yaml");
  EXPECT_TRUE(seeds.axes.empty());
  EXPECT_EQ(seeds.repeat, 5);
  EXPECT_EQ(ExpandGrid(seeds).size(), 5u);

  std::ofstream(dir.path / "bad.yaml") << "scenario: x.yaml\nvary: []\nrepat: 2\n";
  try {
    LoadStudy(dir.path / "bad.yaml");
    FAIL() << "expected a ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_THAT(e.what(), HasSubstr("bad.yaml:3:1: unknown key 'repat'"));
    // issue 34: a scenario's typo got a suggestion, a study's none
    EXPECT_THAT(e.what(), HasSubstr("(did you mean 'repeat'? a study has scenario, description, "
                                    "set, repeat, vary)"));
  }
  std::ofstream(dir.path / "entry.yaml")
      << "scenario: x.yaml\nvary:\n  - {key: seed, vlaues: [1]}\n";
  try {
    LoadStudy(dir.path / "entry.yaml");
    FAIL() << "expected a ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_THAT(e.what(), HasSubstr("unknown key 'vlaues' (did you mean 'values'? a vary entry has "
                                    "key, values, range)"));
  }
}

TEST(Sweep, ParallelForRunsEveryIndexOnce) {
  std::vector<int> hits(1000, 0);
  ParallelFor(hits.size(), 4, [&](std::size_t i) { ++hits[i]; });
  EXPECT_EQ(std::count(hits.begin(), hits.end(), 1), 1000);
  ParallelFor(0, 4, [&](std::size_t) { FAIL(); });
}

TEST(SweepPlots, TheScriptDrawsEachSeriesFromItsBlockWithItsColourAndName) {
  const PlotSpec spec{
      .title = "Largest lateral error, against v2i.latency_s",
      .subtitle = "One run at each value.",
      .x_label = "v2i.latency_s",
      .y_label = "lateral error (m)",
      .series =
          {PlotSeries{.label = "car0", .x = {0, 1, 2}, .y = {0.1, 0.3, 0.2}, .colour = "#00a0ff"},
           PlotSeries{
               .label = "car1's runs", .x = {0, 1}, .y = {0.2, NAN}, .dots = true, .line = false}},
      .categories = {"lab", "safe"},
      .log_x = false};
  const std::string data = GnuplotData(spec);
  EXPECT_THAT(data, HasSubstr("# series 0: car0\n0 0.1\n1 0.3\n2 0.2\n"));
  EXPECT_THAT(data, ::testing::EndsWith("# series 1: car1's runs\n0 0.2\n"));  // no NaN line
  const std::string gp = GnuplotScript(spec, "p.dat", "p.png");
  EXPECT_THAT(gp, HasSubstr("set output 'p.png'"));
  EXPECT_THAT(gp, HasSubstr("noenhanced"));  // key names with underscores stay as written
  EXPECT_THAT(gp, HasSubstr("set label 2 'One run at each value.'"));
  EXPECT_THAT(gp, HasSubstr("set xtics ('lab' 0, 'safe' 1)"));
  EXPECT_THAT(gp, HasSubstr("'p.dat' index 0 using 1:2 with linespoints"));
  EXPECT_THAT(gp, HasSubstr("lc rgb '#00a0ff' title 'car0'"));
  EXPECT_THAT(gp, HasSubstr("'' index 1 using 1:2 with points"));
  EXPECT_THAT(gp, HasSubstr("title 'car1''s runs'"));  // gnuplot's quote in quotes
}

TEST(SweepPlots, ManyLongCategoryNamesAreSlantedAndGivenRoomBelow) {
  PlotSpec spec{
      .title = "Collisions, against faults", .x_label = "faults", .y_label = "collisions"};
  spec.series = {PlotSeries{.label = "all cars", .x = {0, 1}, .y = {0, 1}}};
  spec.categories = {"lab", "safe"};
  EXPECT_THAT(GnuplotScript(spec, "p.dat", "p.png"), ::testing::Not(HasSubstr("rotate")));
  // the faults study's twelve kinds do not fit side by side
  spec.categories = {"none",          "v2i_partition",   "v2i_loss_burst", "server_restart",
                     "broker_outage", "car_stall",       "node_crash",     "node_hang",
                     "camera_freeze", "camera_blackout", "imu_bias_step",  "localization_jump"};
  const std::string gp = GnuplotScript(spec, "p.dat", "p.png");
  EXPECT_THAT(gp, HasSubstr("'localization_jump' 11) rotate by 30 right"));
  EXPECT_THAT(gp, HasSubstr("set bmargin 7"));  // 2 lines + 0.3 of a line per character
}

// Issue 34, item 4: with six long legend names or more the legend, under the plot in gnuplot's own
// layout, covered the tic labels and the axis label. Under the plot it now sits at the picture's
// bottom in columns, and the bottom margin holds the tic labels, the axis label and its rows.
TEST(SweepPlots, ALegendOfManyLongNamesGoesBelowTheAxisLabelWithRoomForItsRows) {
  PlotSpec spec{.title = "CPU load", .x_label = "simulated time (s)", .y_label = "CPU (%)"};
  for (int i = 0; i < 7; ++i) {
    spec.series.push_back(PlotSeries{
        .label = fmt::format("cars[0].platform.cost_scale.lane_planner={}, seed 4{}", i, i),
        .x = {0, 1},
        .y = {1, 2}});
  }
  const std::string gp = GnuplotScript(spec, "p.dat", "p.png");
  // 51 characters a name: two columns across, four rows; 3.5 lines for the tics and axis label
  EXPECT_THAT(gp, HasSubstr("set key at screen 0.01, screen 0.01 left bottom horizontal Left "
                            "reverse maxcols 2 maxrows 4\nset bmargin 7.5\n"));
  // short names stay beside the plot, on the right
  spec.series.resize(3);
  for (PlotSeries& s : spec.series) s.label = s.label.substr(s.label.size() - 7);
  EXPECT_THAT(GnuplotScript(spec, "p.dat", "p.png"),
              HasSubstr("set key outside right top Left reverse\n"));
  // a name longer than the picture is wide is cut, not drawn past its edge
  spec.series[0].label = std::string(300, 'k');
  EXPECT_THAT(GnuplotScript(spec, "p.dat", "p.png"), HasSubstr(std::string(108, 'k') + "…'"));
}

RunSummary WithTurnaround(const std::vector<double>& counts) {
  RunSummary s = FakeSummary(0.1, 1, true);
  nlohmann::json& node = (*s.platform)["car0"]["nodes"][0];
  node["turnaround_histogram_ms"] = {{"edges", HistogramEdgesMs()}, {"counts", counts}};
  return s;
}

// Issue 34, item 4: a hardware node's turnaround, all in one log-spaced bin, was drawn as a
// triangle: zeros at the neighbouring bins' centres joined to one peak. Each bin is now a step
// from its left edge to its right.
TEST(SweepPlots, AHistogramIsDrawnAsStepsSoThatOneFullBinIsABox) {
  const std::vector<double> edges = HistogramEdgesMs();  // 0.1, 0.158, ... 3.98, 6.31, 10, ...
  std::vector<double> counts(edges.size() - 1, 0.0);
  counts[9] = 300;  // every job in [6.31, 10) ms
  SweepSpec spec;
  spec.axes = {ParseVary("v2i.latency_s=0,1")};
  const std::vector<PointRecord> points = {
      {.index = 0, .run_id = "a", .labels = {"0"}, .repeat = 0, .seed = 1},
      {.index = 1, .run_id = "b", .labels = {"1"}, .repeat = 0, .seed = 1}};
  std::vector<double> half = counts;
  half[9] = 150;
  half[10] = 150;  // and half of them in [10, 15.8)
  const std::vector<RunSummary> summaries = {WithTurnaround(counts), WithTurnaround(half)};
  const auto plots =
      SweepPlots(spec, points, summaries, BuildResultsTable({"v2i.latency_s"}, points, summaries));
  const auto plot = std::find_if(plots.begin(), plots.end(), [](const auto& p) {
    return p.first == "turnaround_car0_poly_fit";
  });
  ASSERT_NE(plot, plots.end());
  ASSERT_EQ(plot->second.series.size(), 2u);
  const PlotSeries& one_bin = plot->second.series[0];
  EXPECT_EQ(one_bin.label, "v2i.latency_s=0");
  EXPECT_FALSE(one_bin.dots);
  // from the empty bin before the data to the empty bin after the last filled one (either run's)
  EXPECT_THAT(one_bin.x, ElementsAre(edges[8], edges[8], edges[9], edges[9], edges[10], edges[10],
                                     edges[11], edges[11], edges[12], edges[12]));
  EXPECT_THAT(one_bin.y, ElementsAre(0.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0));
  EXPECT_THAT(plot->second.series[1].y,
              ElementsAre(0.0, 0.0, 0.0, 0.5, 0.5, 0.5, 0.5, 0.0, 0.0, 0.0));
  // the log axis has tics to read the bins by, not only the one power of ten in range
  EXPECT_THAT(GnuplotScript(plot->second, "t.dat", "t.png"),
              HasSubstr("set xtics (4, 5, 6, 7, 8, 9, 10, 20)\n"));
}

// Issue 34, item 4: a mapping given to --vary was printed whole on the axis and in every legend.
// Its values are named "value 1", "value 2", ..., each written out once above the plot.
TEST(SweepPlots, LongValuesAreNamedShortOnThePlotAndWrittenOutInANote) {
  SweepSpec spec;
  spec.axes = {
      ParseVary("cars[0].platform.mapping={},{lane_detection: {target: sw}, "
                "obstacle_detection: {target: sw}}")};
  const std::vector<PointRecord> points = {
      {.index = 0, .run_id = "a", .labels = {"{}"}, .repeat = 0, .seed = 1},
      {.index = 1,
       .run_id = "b",
       .labels = {"{lane_detection: {target: sw}, obstacle_detection: {target: sw}}"},
       .repeat = 0,
       .seed = 1}};
  const std::vector<RunSummary> summaries = {FakeSummary(0.1, 1, true), FakeSummary(0.2, 1, true)};
  const ResultsTable table = BuildResultsTable({"cars[0].platform.mapping"}, points, summaries);
  // the table keeps the values as given
  EXPECT_EQ(table.rows[1][2], "{lane_detection: {target: sw}, obstacle_detection: {target: sw}}");
  const auto plots = SweepPlots(spec, points, summaries, table);
  std::map<std::string, PlotSpec> by_name(plots.begin(), plots.end());
  const PlotSpec& laps = by_name.at("laps_vs_cars_0__platform_mapping");
  EXPECT_THAT(laps.categories, ElementsAre("value 1", "value 2"));
  EXPECT_THAT(laps.notes, ElementsAre("cars[0].platform.mapping=value 1: {}",
                                      "cars[0].platform.mapping=value 2: {lane_detection: {target: "
                                      "sw}, obstacle_detection: {target: sw}}"));
  const std::string gp = GnuplotScript(laps, "p.dat", "p.png");
  EXPECT_THAT(gp, HasSubstr("set xtics ('value 1' 0, 'value 2' 1)\n"));
  EXPECT_THAT(gp, HasSubstr("set label 4 'cars[0].platform.mapping=value 2: {lane_detection: "
                            "{target: sw}, obstacle_detection: {target: sw}}'"));
  const PlotSpec& load = by_name.at("cpu_load_car0");
  EXPECT_EQ(load.series.size(), 2u);
  EXPECT_EQ(load.series[1].label, "cars[0].platform.mapping=value 2");
  EXPECT_EQ(load.notes, laps.notes);
  // short values (a study file's labels) are shown as they are
  spec.axes = {ParseVary("cars[0].platform.mapping=all_hw,lane_sw")};
  const std::vector<PointRecord> labelled = {
      {.index = 0, .run_id = "a", .labels = {"all_hw"}, .repeat = 0, .seed = 1},
      {.index = 1, .run_id = "b", .labels = {"lane_sw"}, .repeat = 0, .seed = 1}};
  const auto short_plots =
      SweepPlots(spec, labelled, summaries,
                 BuildResultsTable({"cars[0].platform.mapping"}, labelled, summaries));
  EXPECT_THAT(short_plots.front().second.categories, ElementsAre("all_hw", "lane_sw"));
  EXPECT_TRUE(short_plots.front().second.notes.empty());
}

// Issue 34, item 8: a sweep said nothing for the seconds its plots took. RenderPlots says how many
// are drawn, before the first and after each, when that plot's picture is complete.
TEST(SweepPlots, RenderingReportsEachPlotAsItIsDrawn) {
  TempDir dir;
  std::vector<std::pair<std::string, PlotSpec>> plots;
  for (const char* name : {"a", "b", "c"}) {
    plots.emplace_back(name,
                       PlotSpec{.title = name,
                                .x_label = "x",
                                .y_label = "y",
                                .series = {PlotSeries{.label = "s", .x = {0, 1}, .y = {1, 2}}}});
  }
  std::vector<std::pair<std::size_t, std::size_t>> calls;
  std::vector<bool> complete;  // each plot's picture readable when its call came
  RenderPlots(plots, dir.path, [&](std::size_t done, std::size_t total) {
    calls.emplace_back(done, total);
    if (done > 0) {
      complete.push_back(
          !cv::imread((dir.path / (plots[done - 1].first + ".png")).string()).empty());
    }
  });
  EXPECT_THAT(calls, ElementsAre(std::pair<std::size_t, std::size_t>{0, 3},
                                 std::pair<std::size_t, std::size_t>{1, 3},
                                 std::pair<std::size_t, std::size_t>{2, 3},
                                 std::pair<std::size_t, std::size_t>{3, 3}));
  EXPECT_THAT(complete, ElementsAre(true, true, true));
}

// ---- Real sweeps on the oracle scenario (no board: fast) ----

SweepSpec TinySweep() {
  SweepSpec spec;
  spec.scenario = "scenarios/lab_two_cars_oracle.yaml";
  spec.overrides = {"duration_s=3", "expect=[]"};
  spec.axes = {ParseVary("cars[0].oracle.speed_mps=0.3,0.5"), ParseVary("v2i.latency_s=0,1")};
  return spec;
}

TEST(SweepRun, APlotSaysWhatItsLinesAverageAndShowsEachRun) {
  TempDir dir;
  SweepSpec spec;
  spec.scenario = "scenarios/lab_two_cars_oracle.yaml";
  spec.overrides = {"duration_s=3", "expect=[]"};
  spec.axes = {ParseVary("v2i.latency_s=0,1")};
  spec.repeat = 2;
  RunSweep(spec, SweepOptions{
                     .out_dir = dir.path, .jobs = 2, .shard = {}, .plots = true, .progress = {}});
  const std::string gp = ReadText(dir.path / "plots" / "laps_vs_v2i_latency_s.gp");
  EXPECT_THAT(gp, HasSubstr("Lines: the mean of the 2 runs at each point (over 2 seeds); dots: "
                            "each run."));
  EXPECT_THAT(gp, HasSubstr("lc rgb '#00a0ff' title 'car0, mean'"));
  EXPECT_THAT(gp, HasSubstr("with points pt 7 ps 0.7 lw 2 dt 1 lc rgb '#00a0ff' title 'car0, "
                            "each run'"));
}

TEST(SweepRun, ResumesAndGivesTheSameTableWhateverTheJobsAndShards) {
  TempDir dir;
  const SweepSpec spec = TinySweep();
  SweepOptions one{
      .out_dir = dir.path / "one", .jobs = 1, .shard = {}, .plots = true, .progress = {}};
  const SweepSummary first = RunSweep(spec, one);
  EXPECT_EQ(first.grid_points, 4u);
  EXPECT_EQ(first.ran, 4u);
  EXPECT_TRUE(first.failures.empty());
  const std::string table = ReadText(dir.path / "one" / "results.csv");
  EXPECT_EQ(std::count(table.begin(), table.end(), '\n'), 5);
  // the plots: drawn by gnuplot, with their script and data beside them, saying what they average
  const fs::path plots = dir.path / "one" / "plots";
  const cv::Mat png = cv::imread((plots / "max_lateral_error_m_vs_v2i_latency_s.png").string());
  ASSERT_FALSE(png.empty());
  EXPECT_EQ(png.cols, 1000);
  const std::string gp = ReadText(plots / "max_lateral_error_m_vs_v2i_latency_s.gp");
  EXPECT_THAT(gp, HasSubstr("Largest lateral error from the lane centre, against v2i.latency_s"));
  // the other varied key has a line per value, each car in its colour, a dash per value
  EXPECT_THAT(gp, HasSubstr("One line per value of cars[0].oracle.speed_mps. One run at each "
                            "point."));
  EXPECT_THAT(gp, HasSubstr("dt 2 lc rgb '#00a0ff' title 'car0, cars[0].oracle.speed_mps=0.5'"));
  EXPECT_TRUE(fs::exists(plots / "max_lateral_error_m_vs_v2i_latency_s.dat"));

  // resumed: nothing is redone, the table is the same
  const SweepSummary again = RunSweep(spec, one);
  EXPECT_EQ(again.ran, 0u);
  EXPECT_EQ(again.already_done, 4u);
  EXPECT_EQ(ReadText(dir.path / "one" / "results.csv"), table);

  // a run folder removed is run again
  std::string some_id;
  for (const auto& e : fs::directory_iterator(dir.path / "one" / "runs")) {
    some_id = e.path().filename().string();
  }
  fs::remove_all(dir.path / "one" / "runs" / some_id);
  EXPECT_EQ(RunSweep(spec, one).ran, 1u);
  EXPECT_EQ(ReadText(dir.path / "one" / "results.csv"), table);

  // two threads; two shards merged
  SweepOptions two = one;
  two.out_dir = dir.path / "two";
  two.jobs = 2;
  two.plots = false;
  RunSweep(spec, two);
  EXPECT_EQ(ReadText(dir.path / "two" / "results.csv"), table);
  SweepOptions shard1 = two, shard2 = two;
  shard1.out_dir = dir.path / "s1";
  shard1.shard = {1, 2};
  shard2.out_dir = dir.path / "s2";
  shard2.shard = {2, 2};
  EXPECT_EQ(RunSweep(spec, shard1).selected, 2u);
  EXPECT_EQ(RunSweep(spec, shard2).selected, 2u);
  EXPECT_EQ(MergeSweeps({dir.path / "s1", dir.path / "s2"}, dir.path / "merged", false).missing,
            0u);
  EXPECT_EQ(ReadText(dir.path / "merged" / "results.csv"), table);
  // one shard alone is incomplete, and says so
  EXPECT_EQ(MergeSweeps({dir.path / "s1"}, dir.path / "half", false).missing, 2u);
  // a shard writes its own table, never results.csv (issue 33: `--shard 1/2` into a complete
  // sweep's folder rewrote its results.csv with the shard's two rows)
  EXPECT_FALSE(fs::exists(dir.path / "s1" / "results.csv"));
  EXPECT_FALSE(fs::exists(dir.path / "s1" / "index.html"));
  EXPECT_EQ(RunSweep(spec, shard1).table, dir.path / "s1" / "results.1-of-2.csv");
  SweepOptions into_complete = shard1;
  into_complete.out_dir = dir.path / "two";  // the complete sweep's folder
  EXPECT_EQ(RunSweep(spec, into_complete).already_done, 2u);
  EXPECT_EQ(ReadText(dir.path / "two" / "results.csv"), table);
  const std::string shard_table = ReadText(dir.path / "two" / "results.1-of-2.csv");
  EXPECT_EQ(std::count(shard_table.begin(), shard_table.end(), '\n'), 3);  // header + 2 rows
  // merged in place, the folder's table is the whole grid's again
  EXPECT_EQ(MergeSweeps({dir.path / "two"}, dir.path / "two", false).missing, 0u);
  EXPECT_EQ(ReadText(dir.path / "two" / "results.csv"), table);
}

// The sweep reads the wall clock only through the one it is given: a fake clock, 1.5 s later at
// each reading, gives every run 1.5 s (one reading before its simulation, one after) and the
// progress its own readings; no clock, no wall time.
TEST(SweepRun, WallTimesComeFromTheClockItIsGiven) {
  TempDir dir;
  SweepSpec spec = TinySweep();
  spec.axes.pop_back();  // two runs, of 3 s simulated
  std::atomic<int> readings{0};
  std::vector<SweepProgress> progress;
  SweepOptions options{.out_dir = dir.path / "fake",
                       .jobs = 1,  // one thread: the readings come in a known order
                       .shard = {},
                       .plots = false,
                       .progress = [&](const SweepProgress& p) { progress.push_back(p); },
                       .wall_clock = [&] { return std::chrono::milliseconds(1500) * readings++; }};
  ASSERT_EQ(RunSweep(spec, options).ran, 2u);
  // readings: 0 the start; 1, 2 around run 1; 3 its progress; 4, 5 around run 2; 6 its progress
  EXPECT_EQ(readings.load(), 7);
  ASSERT_EQ(progress.size(), 3u);
  EXPECT_EQ(progress[0].wall_s, 0.0);
  EXPECT_EQ(progress[1].done, 1u);
  EXPECT_EQ(progress[1].wall_s, 4.5);
  EXPECT_EQ(progress[2].done, 2u);
  EXPECT_EQ(progress[2].wall_s, 9.0);
  std::size_t runs = 0;
  for (const auto& run : fs::directory_iterator(dir.path / "fake" / "runs")) {
    const nlohmann::json summary = nlohmann::json::parse(ReadText(run.path() / "summary.json"));
    EXPECT_EQ(summary.at("wall_seconds"), 1.5);
    EXPECT_EQ(summary.at("real_time_factor"), 2.0);  // 3 s simulated in 1.5 s
    ++runs;
  }
  EXPECT_EQ(runs, 2u);

  options.out_dir = dir.path / "none";
  options.wall_clock = {};
  progress.clear();
  RunSweep(spec, options);
  ASSERT_EQ(progress.size(), 3u);
  EXPECT_EQ(progress[2].wall_s, 0.0);
  for (const auto& run : fs::directory_iterator(dir.path / "none" / "runs")) {
    const nlohmann::json summary = nlohmann::json::parse(ReadText(run.path() / "summary.json"));
    EXPECT_EQ(summary.at("wall_seconds"), 0.0);
    EXPECT_TRUE(summary.at("real_time_factor").is_null());
  }
}

TEST(SweepRun, UnusableInputStopsTheSweepBeforeAnyRunNamingTheKey) {
  TempDir dir;
  SweepSpec spec = TinySweep();
  spec.axes.push_back(ParseVary("v2i.latnecy_s=0,1"));
  try {
    RunSweep(
        spec,
        SweepOptions{.out_dir = dir.path, .jobs = 2, .shard = {}, .plots = false, .progress = {}});
    FAIL() << "expected a ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_THAT(e.what(), HasSubstr("latnecy_s"));
  }
  EXPECT_FALSE(fs::exists(dir.path / "runs"));

  // a different sweep's folder cannot be merged in
  SweepSpec a = TinySweep(), b = TinySweep();
  b.axes.pop_back();
  RunSweep(
      a,
      SweepOptions{
          .out_dir = dir.path / "a", .jobs = 2, .shard = {1, 4}, .plots = false, .progress = {}});
  RunSweep(
      b,
      SweepOptions{
          .out_dir = dir.path / "b", .jobs = 2, .shard = {1, 4}, .plots = false, .progress = {}});
  EXPECT_THROW(MergeSweeps({dir.path / "a", dir.path / "b"}, dir.path / "m", false), ConfigError);
}

}  // namespace
}  // namespace autonomsim::sim
