#include "sim/platform/table1.h"

#include <fmt/format.h>

#include <memory>
#include <set>
#include <stdexcept>

#include "sim/core/kernel.h"
#include "sim/platform/node_graph.h"
#include "sim/platform/platform.h"

namespace autonomsim::sim {
namespace {

// What the Table I setup moves between nodes: a frame token. The functional content does not
// matter for timing; a topic's byte size comes from its message type.
struct Frame {
  std::uint64_t sequence{0};
};
struct PassParams {};
struct PassState {
  std::uint64_t frames{0};
};
Frame PassStep(const PassParams&, const Frame& in, PassState* state) {
  ++state->frames;
  return in;
}

// One processing stage of a test setup.
struct Stage {
  std::string node;  // also its cost name in the profile
  bool hw{false};
  int slot{0};
  MessageType output;
};

// What publishes the row's input at the camera rate: a camera driver, or for row 5 a test
// publisher of point clouds. Its node is named after its cost.
struct Source {
  std::string cost;
  MessageType output;
};

struct Setup {
  Source source;
  std::vector<Stage> stages;
  Transport transport{Transport::kZeroCopy};
};

// The sheet's camera drivers (reference §8): AstraSDK publishes the depth camera's images,
// Cam2Image the colour camera's (reference §2).
const char* const kAstraSdk = "astra_sdk";
const char* const kCam2Image = "cam2image";
const char* const kProbe = "fps_probe";

// Test setups of the eight rows, in PaperTable1() order. In hardware the point cloud and the
// obstacle grid are fused in slot 0, lane detection is the lane planner (slot 1) followed by the
// polynomial fit (slot 2) (reference §8). Software obstacle detection takes point clouds.
std::vector<Setup> Setups() {
  const Source depth{kAstraSdk, msg::Image640mono()};
  const Source colour{kCam2Image, msg::Image640rgb()};
  const Source clouds{"camera_publisher", msg::PointCloud640()};
  const Stage pc_sw{"point_cloud", false, 0, msg::PointCloud640()};
  const Stage pc_hw{"point_cloud", true, 0, msg::PointCloud640()};
  return {
      {depth, {pc_sw}, Transport::kDds},
      {depth, {pc_hw}, Transport::kDds},
      {depth, {pc_sw}, Transport::kZeroCopy},
      {depth, {pc_hw}, Transport::kZeroCopy},
      {clouds, {{"obstacle_detection", false, 0, msg::Grid234()}}},
      {depth, {{"obstacle_detection", true, 0, msg::Grid234()}}},
      {colour, {{"lane_detection", false, 0, msg::LanePoints()}}},
      {colour,
       {{"lane_planner", true, 1, msg::Image640mono()}, {"poly_fit", true, 2, msg::LanePoints()}}},
  };
}

Duration CameraPeriod(const Table1Options& options) {
  return FromSeconds(1.0 / options.camera_fps);
}

// The row's processes: the sheet's, each the sum of its nodes, then every node the sheet lists
// for no process (outside the row's sum).
std::vector<ProcessResult> Processes(const Table1Row& row, const MetricsReport& report) {
  std::vector<ProcessResult> out;
  std::set<std::string> listed;
  for (const SheetProcess& p : row.sheet) {
    ProcessResult r{.name = p.name, .nodes = p.nodes, .sheet = p.cpu_percent};
    for (const std::string& node : p.nodes) {
      const NodeReport* n = report.FindNode(node);
      if (n == nullptr) throw std::logic_error("Table I: the sheet's node '" + node + "' not run");
      r.cpu_percent += n->cpu_percent;
      listed.insert(node);
    }
    r.in_range = p.cpu_percent.Contains(r.cpu_percent);
    out.push_back(std::move(r));
  }
  for (const NodeReport& n : report.nodes) {
    if (listed.count(n.name) == 0) {
      out.push_back(ProcessResult{.name = n.name, .nodes = {n.name}, .cpu_percent = n.cpu_percent});
    }
  }
  return out;
}

// A row's run; its DDS topics (the rows without Iceoryx) with `reliability`.
Table1Result RunOne(const PlatformProfile& profile, const Table1Row& row, const Setup& setup,
                    const Table1Options& options, Reliability reliability) {
  Kernel kernel;
  RunMetrics metrics(MetricsOptions{.measure_from = options.warmup, .trace = false});
  Platform platform(kernel, profile, &metrics);
  NodeGraph graph(platform, &metrics);
  if (setup.transport == Transport::kDds) {
    PlatformConfig config;
    const TopicTransportConfig dds{.transport = Transport::kDds, .reliability = reliability};
    config.transport["/camera"] = dds;
    for (const Stage& stage : setup.stages) config.transport["/" + stage.node] = dds;
    graph.ApplyConfig(config);
  }

  TopicId<Frame> in = graph.AddTopic<Frame>(
      {.name = "/camera", .type = setup.source.output, .transport = setup.transport});
  auto frames = std::make_shared<std::uint64_t>(0);
  AddSourceNode(graph, NodeSpec{.name = setup.source.cost}, in, kZeroTime, CameraPeriod(options),
                [frames](Time) { return Frame{(*frames)++}; });
  for (const Stage& stage : setup.stages) {
    TopicId<Frame> out = graph.AddTopic<Frame>(
        {.name = "/" + stage.node, .type = stage.output, .transport = setup.transport});
    NodeMappingConfig mapping;
    if (stage.hw) mapping = {.target = Target::kHw, .slot = stage.slot};
    AddComponentNode(graph, NodeSpec{.name = stage.node, .mapping = mapping}, in, out, PassParams{},
                     std::make_shared<PassState>(), PassStep);
    in = out;
  }
  AddSinkNode(graph, NodeSpec{.name = kProbe}, in, SubscriptionOptions{.loaned = false});

  kernel.RunUntil(options.duration);
  const MetricsReport report = BuildReport(metrics, options.duration);

  Table1Result result{.row = row, .board_cpu_percent = report.cpu_percent};
  result.processes = Processes(row, report);
  for (const ProcessResult& p : result.processes) {
    if (p.sheet) result.cpu_percent += p.cpu_percent;
  }
  // FPS as the lab measured it: what the subscriber on the output gets (its callbacks per second)
  result.fps = report.FindNode(kProbe)->rate_hz;
  if (row.held_out) {
    // The sheet has no sub->pub time for these rows: the paper's figure is the period, 1000/FPS
    result.turnaround_ms = result.fps > 0.0 ? 1000.0 / result.fps : 0.0;
  }
  for (std::size_t i = 0; i < setup.stages.size() && !row.held_out; ++i) {
    result.turnaround_ms += report.FindNode(setup.stages[i].node)->turnaround_ms.p50;
    if (i > 0) {  // a chain: the hand-over between its stages counts too
      const Duration latency =
          setup.transport == Transport::kDds ? profile.dds.latency : profile.zero_copy.latency;
      result.turnaround_ms += ToSeconds(latency) * 1e3;
    }
  }
  result.in_cpu = row.cpu_percent.Contains(result.cpu_percent);
  result.in_fps = row.fps.Contains(result.fps);
  result.in_turnaround = row.turnaround_ms.Contains(result.turnaround_ms);
  return result;
}

nlohmann::json RangeJson(const PaperRange& r) { return nlohmann::json::array({r.lo, r.hi}); }

std::string Cell(double value, const PaperRange& range, bool in) {
  return fmt::format("{:7.1f} ({:g}-{:g}) {:<3}", value, range.lo, range.hi, in ? "in" : "OUT");
}

nlohmann::json ProcessesJson(const std::vector<ProcessResult>& processes) {
  nlohmann::json out = nlohmann::json::array();
  for (const ProcessResult& p : processes) {
    out.push_back({{"process", p.name},
                   {"nodes", p.nodes},
                   {"cpu_percent", p.cpu_percent},
                   {"sheet", p.sheet ? RangeJson(*p.sheet) : nlohmann::json()},
                   {"in_range", p.sheet ? nlohmann::json(p.in_range) : nlohmann::json()}});
  }
  return out;
}

std::string Join(const std::vector<std::string>& names) {
  std::string out;
  for (const std::string& name : names) out += (out.empty() ? "" : "+") + name;
  return out;
}

// The row's processes, one line each, under the row: the sheet's with its range, the others
// marked as outside the row's sum.
std::string ProcessLines(const Table1Result& r) {
  std::string text;
  for (const ProcessResult& p : r.processes) {
    if (p.sheet) {
      text += fmt::format("    {:<21}{:<26}{}\n", p.name, Join(p.nodes),
                          Cell(p.cpu_percent, *p.sheet, p.in_range));
    } else {
      text += fmt::format("    {:<21}{:<26}{:7.1f} (not in the sheet: outside the row's sum)\n",
                          "-", Join(p.nodes), p.cpu_percent);
    }
  }
  return text;
}

std::string WholeUnitText(const WholeUnitResult& w) {
  std::string text = fmt::format(
      "\nWhole unit in software (point cloud, obstacle detection, lane detection), every topic "
      "{}, with the camera drivers and the background loads:\n"
      "  CPU demand {:.1f} % of {:.0f} % available; delivered {:.1f} %\n"
      "  the sheet's figures for these processes (Table I rows 3, 5, 7) {:g}-{:g} % + the "
      "profile's background loads {:g} % = {:g}-{:g} %\n",
      w.transport, w.demand_percent, w.capacity_percent, w.cpu_percent, w.sheet_percent.lo,
      w.sheet_percent.hi, w.background_percent, w.sheet_percent.lo + w.background_percent,
      w.sheet_percent.hi + w.background_percent);
  text += fmt::format("  {:<20}{:>9}{:>9}{:>8}{:>8}{:>12}{:>12}{:>8}\n", "node", "demand%", "cpu%",
                      "in/s", "out/s", "turn p50", "turn p95", "drops");
  for (const NodeReport& n : w.report.nodes) {
    text += fmt::format("  {:<20}{:>9.1f}{:>9.1f}{:>8.1f}{:>8.1f}{:>9.1f} ms{:>9.1f} ms{:>8}\n",
                        n.name, n.demand_percent, n.cpu_percent, n.input_hz, n.rate_hz,
                        n.turnaround_ms.p50, n.turnaround_ms.p95, n.drops);
  }
  return text;
}

std::vector<Table1Row> MakePaperTable1() {
  // Reference §8: the paper's Table I (min–max), rows in the paper's order, each with the
  // processes of the lab's sheet (benchmark/Benchmark.ods) whose CPU it sums.
  const SheetProcess astra_dds{"AstraSDK", {kAstraSdk}, {80, 100}};
  const SheetProcess astra{"AstraSDK", {kAstraSdk}, {60, 70}};
  const SheetProcess cam2image{"Cam2Image", {kCam2Image}, {20, 30}};
  auto recon_ros = [](std::vector<std::string> nodes, PaperRange cpu) {
    return SheetProcess{"ReconROS", std::move(nodes), cpu};
  };
  const char* const pc = "point cloud @640x480";
  return {
      {pc,
       "SW, without Iceoryx",
       true,
       {180, 220},
       {9, 12},
       {83, 111},
       {astra_dds, recon_ros({"point_cloud"}, {100, 120})}},
      {pc,
       "HW, without Iceoryx",
       true,
       {180, 210},
       {13, 14},
       {71, 76},
       {astra_dds, recon_ros({"point_cloud"}, {100, 110})}},
      {pc,
       "SW, with Iceoryx",
       false,
       {90, 110},
       {29, 30},
       {11, 15},
       {astra, recon_ros({"point_cloud"}, {30, 40})}},
      {pc,
       "HW, with Iceoryx",
       false,
       {64, 78},
       {29, 30},
       {17, 18},
       {astra, recon_ros({"point_cloud"}, {4, 8})}},
      {"obstacle detection",
       "SW, with Iceoryx",
       false,
       {50, 60},
       {29, 30},
       {15, 17},
       {recon_ros({"obstacle_detection"}, {50, 60})}},
      {"obstacle detection",
       "HW, with Iceoryx",
       false,
       {4, 8},
       {29, 30},
       {9, 11},
       {recon_ros({"obstacle_detection"}, {4, 8})}},
      {"lane detection",
       "ROS 2 SW node, with Iceoryx",
       false,
       {170, 190},
       {29, 30},
       {27, 31},
       {{"lane detection node", {"lane_detection"}, {150, 160}}, cam2image}},
      {"lane detection",
       "HW, with Iceoryx",
       false,
       {24, 38},
       {29, 30},
       {9, 18},
       {cam2image, recon_ros({"lane_planner", "poly_fit"}, {4, 8})}},
  };
}

}  // namespace

const std::vector<Table1Row>& PaperTable1() {
  static const std::vector<Table1Row> rows = MakePaperTable1();
  return rows;
}

std::vector<Table1Result> RunTable1(const PlatformProfile& profile, const Table1Options& options) {
  const std::vector<Setup> setups = Setups();
  std::vector<Table1Result> results;
  for (std::size_t i = 0; i < setups.size(); ++i) {
    const Table1Row& row = PaperTable1()[i];
    results.push_back(RunOne(profile, row, setups[i], options, profile.dds.reliability));
    if (row.held_out) {
      // The lab's QoS for these rows is unknown (docs/model.md#dds-transport): the other one too
      const Reliability other = profile.dds.reliability == Reliability::kReliable
                                    ? Reliability::kBestEffort
                                    : Reliability::kReliable;
      const Table1Result alt = RunOne(profile, row, setups[i], options, other);
      results.back().alternative = Table1Alternative{.reliability = other,
                                                     .cpu_percent = alt.cpu_percent,
                                                     .fps = alt.fps,
                                                     .turnaround_ms = alt.turnaround_ms};
    }
  }
  return results;
}

WholeUnitResult RunWholeUnit(const PlatformProfile& profile, const Table1Options& options,
                             Transport transport) {
  Kernel kernel;
  PlatformConfig config;
  config.trace = options.trace;
  config.trace_receive_threads = true;  // the DDS rows' question is where DDS spends the CPU
  Board board(kernel, "zcu104", config, profile, nullptr, options.warmup);
  NodeGraph& graph = board.graph();

  const Duration period = CameraPeriod(options);
  auto topic = [&](const char* name, MessageType type) {
    return graph.AddTopic<Frame>({.name = name, .type = type, .transport = transport});
  };
  auto depth = topic("/depth", msg::Image640mono());
  auto image = topic("/image", msg::Image640rgb());
  auto points = topic("/points", msg::PointCloud640());
  auto grid = topic("/grid", msg::Grid234());
  auto lanes = topic("/lane_points", msg::LanePoints());
  auto depth_frames = std::make_shared<std::uint64_t>(0);
  auto image_frames = std::make_shared<std::uint64_t>(0);
  // The colour camera runs half a period after the depth camera (free-running sensors).
  AddSourceNode(graph, NodeSpec{.name = kAstraSdk}, depth, kZeroTime, period,
                [depth_frames](Time) { return Frame{(*depth_frames)++}; });
  AddSourceNode(graph, NodeSpec{.name = kCam2Image}, image, period / 2, period,
                [image_frames](Time) { return Frame{(*image_frames)++}; });
  AddComponentNode(graph, NodeSpec{.name = "point_cloud"}, depth, points, PassParams{},
                   std::make_shared<PassState>(), PassStep);
  AddComponentNode(graph, NodeSpec{.name = "obstacle_detection"}, points, grid, PassParams{},
                   std::make_shared<PassState>(), PassStep);
  AddComponentNode(graph, NodeSpec{.name = "lane_detection"}, image, lanes, PassParams{},
                   std::make_shared<PassState>(), PassStep);
  board.Finish(kZeroTime);

  kernel.RunUntil(options.duration);
  WholeUnitResult result;
  result.transport = std::string(ToName(transport));
  BoardReport report = board.Report(options.duration);
  result.cpu_percent = report.report.cpu_percent;
  result.demand_percent = report.report.cpu_demand_percent;
  result.capacity_percent = 100.0 * profile.cpu.cores;
  // the sheet's processes of rows 3 (AstraSDK, point cloud), 5 (obstacles) and 7 (lane node,
  // Cam2Image): the same nodes
  for (std::size_t row : {2, 4, 6}) {
    for (const SheetProcess& p : PaperTable1()[row].sheet) {
      result.sheet_percent.lo += p.cpu_percent.lo;
      result.sheet_percent.hi += p.cpu_percent.hi;
    }
  }
  for (const BackgroundLoadConfig& load : profile.background) {
    result.background_percent += load.cpu_percent;
  }
  if (options.trace) {
    result.nodes_csv = NodesCsv({report});
    result.trace_json = TraceJson({{board.name(), &board.metrics()}});
  }
  result.report = std::move(report.report);
  return result;
}

nlohmann::json Table1Json(const std::vector<Table1Result>& rows,
                          const std::vector<WholeUnitResult>& whole) {
  nlohmann::json out = {{"rows", nlohmann::json::array()}, {"held_out", nlohmann::json::array()}};
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const Table1Result& r = rows[i];
    out["rows"].push_back(
        {{"component", r.row.component},
         {"configuration", r.row.configuration},
         {"cpu_percent", r.cpu_percent},
         {"board_cpu_percent", r.board_cpu_percent},
         {"fps", r.fps},
         {"turnaround_ms", r.turnaround_ms},
         {"paper",
          {{"cpu_percent", RangeJson(r.row.cpu_percent)},
           {"fps", RangeJson(r.row.fps)},
           {"turnaround_ms", RangeJson(r.row.turnaround_ms)}}},
         {"in_range",
          {{"cpu_percent", r.in_cpu}, {"fps", r.in_fps}, {"turnaround_ms", r.in_turnaround}}},
         {"processes", ProcessesJson(r.processes)}});
    if (r.alternative) {
      const Table1Alternative& a = *r.alternative;
      out["rows"].back()["alternative"] = {{"reliability", std::string(ToName(a.reliability))},
                                           {"cpu_percent", a.cpu_percent},
                                           {"fps", a.fps},
                                           {"turnaround_ms", a.turnaround_ms}};
    }
    if (r.row.held_out) out["held_out"].push_back(i);
  }
  out["whole_unit"] = nlohmann::json::object();
  for (const WholeUnitResult& w : whole) {
    out["whole_unit"][w.transport] = {{"cpu_percent", w.cpu_percent},
                                      {"demand_percent", w.demand_percent},
                                      {"capacity_percent", w.capacity_percent},
                                      {"sheet_percent", RangeJson(w.sheet_percent)},
                                      {"background_percent", w.background_percent},
                                      {"platform", ReportJson(w.report)}};
  }
  return out;
}

std::string Table1Text(const std::vector<Table1Result>& rows,
                       const std::vector<WholeUnitResult>& whole, const std::string& profile_name,
                       const Table1Options& options) {
  // the judged reliability: the other one than the held-out rows' alternative
  Reliability reliability = Reliability::kReliable;
  for (const Table1Result& r : rows) {
    if (r.alternative && r.alternative->reliability == Reliability::kReliable) {
      reliability = Reliability::kBestEffort;
    }
  }
  std::string text = fmt::format(
      "Table I: the paper (min-max) vs autonomsim, profile '{}'.\n"
      "Setup per row: camera driver at {:g} fps -> component -> rate probe; {:g} s simulated, "
      "the first {:g} s not measured.\n"
      "CPU in % of one core (400 = all four): the sum of the processes the lab's sheet lists for "
      "the row (benchmark/Benchmark.ods), each shown under it beside the sheet's range.\n"
      "* = held-out row (nothing fitted to it): FPS is what the subscriber gets, turnaround the "
      "period "
      "1000/FPS (the sheet has no sub->pub time for these rows); DDS {} (the profile's), the other "
      "reliability below.\n\n",
      profile_name, options.camera_fps, ToSeconds(options.duration), ToSeconds(options.warmup),
      ToName(reliability));
  text += fmt::format("{:<21}{:<30}{:<26}{:<24}{}\n", "component", "configuration", "CPU %", "FPS",
                      "turnaround ms");
  int in = 0;
  int cells = 0;
  int processes_in = 0;
  int processes = 0;
  for (const Table1Result& r : rows) {
    text += fmt::format("{:<21}{:<30}{:<26}{:<24}{}\n", r.row.component,
                        r.row.configuration + (r.row.held_out ? " *" : ""),
                        Cell(r.cpu_percent, r.row.cpu_percent, r.in_cpu),
                        Cell(r.fps, r.row.fps, r.in_fps),
                        Cell(r.turnaround_ms, r.row.turnaround_ms, r.in_turnaround));
    if (r.alternative) {
      const Table1Alternative& a = *r.alternative;
      const bool in_all = r.row.cpu_percent.Contains(a.cpu_percent) && r.row.fps.Contains(a.fps) &&
                          r.row.turnaround_ms.Contains(a.turnaround_ms);
      text += fmt::format(
          "    {:<47}{:7.1f}{:<19}{:7.1f}{:<17}{:7.1f}   (not judged: the lab's QoS is unknown; "
          "{})\n",
          fmt::format("with DDS {} instead:", ToName(a.reliability)), a.cpu_percent, "", a.fps, "",
          a.turnaround_ms, in_all ? "all three in range" : "not all in range");
    }
    text += ProcessLines(r);
    in +=
        static_cast<int>(r.in_cpu) + static_cast<int>(r.in_fps) + static_cast<int>(r.in_turnaround);
    cells += 3;
    for (const ProcessResult& p : r.processes) {
      processes_in += static_cast<int>(p.sheet && p.in_range);
      processes += static_cast<int>(p.sheet.has_value());
    }
  }
  text += fmt::format("\n{} of {} cells in the paper's range; {} of {} processes in the sheet's.\n",
                      in, cells, processes_in, processes);
  for (const WholeUnitResult& w : whole) text += WholeUnitText(w);
  return text;
}

}  // namespace autonomsim::sim
