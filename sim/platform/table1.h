// The paper's Table I (reference §8) and the model run on the paper's test setup: a camera driver
// at 30 fps (AstraSDK for the depth camera, Cam2Image for the colour camera), one processing
// component (point cloud, obstacle detection or lane detection; in software or in hardware; over
// DDS or zero-copy) and a subscriber on its output that measures the frame rate (as `ros2 topic hz`
// does: it takes each sample by copy).
// Table I's rows are sums of the processes the lab's measurement sheet lists for each run
// (benchmark/Benchmark.ods, reference §8: e.g. row 3 = AstraSDK + ReconROS); so is ours, and each
// process is reported beside the sheet's range. A node the sheet lists for no process (the rate
// probe, a source the sheet leaves out) runs and is reported, outside the row's sum.
// Also the whole unit: the three accelerated components in software at once, with the camera
// drivers and the rest of the stack's load, to show what more CPU demand than cores does.
#pragma once

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "sim/platform/node_graph.h"
#include "sim/platform/node_metrics.h"
#include "sim/platform/platform_profile.h"
#include "world/time.h"

namespace autonomsim::sim {

struct PaperRange {
  double lo{0.0};
  double hi{0.0};
  bool Contains(double value) const { return value >= lo && value <= hi; }
};

// One process of a row's run as the sheet measured it (htop, % of one core), and the nodes of
// the model that make it up.
struct SheetProcess {
  std::string name;                // as the sheet names it: AstraSDK, ReconROS, Cam2Image, ...
  std::vector<std::string> nodes;  // the model's nodes of the Table I setup in this process
  PaperRange cpu_percent;
};

// One row of the paper's Table I: min–max of CPU (% of 4 cores: 100 = one core), FPS and
// turnaround (the node's raw computation time, not limited by the input rate).
struct Table1Row {
  std::string component;
  std::string configuration;
  // The two rows without Iceoryx: no compute cost is fitted to them; they must come out of the
  // DDS transport model (the held-out check).
  bool held_out{false};
  PaperRange cpu_percent;
  PaperRange fps;
  PaperRange turnaround_ms;
  std::vector<SheetProcess> sheet;  // the processes cpu_percent sums, as the sheet lists them
};

// The eight rows, in the paper's order.
const std::vector<Table1Row>& PaperTable1();

struct Table1Options {
  Duration duration{std::chrono::seconds(12)};  // simulated per configuration
  Duration warmup{std::chrono::seconds(2)};     // excluded from the measurements
  double camera_fps{30.0};                      // the test publisher (reference §2: 30 fps)
  bool trace{false};  // RunWholeUnit: keep a trace.json and nodes.csv of the run
};

// One process of a row's run in the model: one of the sheet's, or a node the sheet lists for no
// process (no `sheet` range; not in the row's sum).
struct ProcessResult {
  std::string name;  // the sheet's process name; a node's name for one the sheet does not list
  std::vector<std::string> nodes;
  double cpu_percent{0.0};
  std::optional<PaperRange> sheet;
  bool in_range{false};  // within `sheet` (false without one)
};

// A held-out row run with the other DDS reliability than the profile's: the lab's QoS for those
// rows is unknown, so both are shown; the profile's is the one judged.
struct Table1Alternative {
  Reliability reliability{Reliability::kBestEffort};
  double cpu_percent{0.0};
  double fps{0.0};
  double turnaround_ms{0.0};
};

struct Table1Result {
  Table1Row row;
  double cpu_percent{0.0};        // the sum of the sheet's processes, 100 = one core
  double board_cpu_percent{0.0};  // the whole platform: every node, the probe included
  double fps{0.0};  // what the rate probe on the output gets per second (its callbacks)
  // p50 of the processing node's jobs (sum over a hardware chain, with the hand-overs); for a
  // held-out row the period 1000/fps, which is what the paper's figure is there (reference §8:
  // the sheet has no sub->pub time for the rows without Iceoryx)
  double turnaround_ms{0.0};
  bool in_cpu{false}, in_fps{false}, in_turnaround{false};
  std::vector<ProcessResult> processes;          // the sheet's, in its order, then the others
  std::optional<Table1Alternative> alternative;  // held-out rows: the other reliability
  bool all_in() const { return in_cpu && in_fps && in_turnaround; }
};

// Runs all eight configurations. Throws ConfigError if the profile lacks a cost they need.
std::vector<Table1Result> RunTable1(const PlatformProfile& profile,
                                    const Table1Options& options = {});

struct WholeUnitResult {
  std::string transport;  // of every topic: "zero_copy" (the real unit) or "dds"
  MetricsReport report;
  double cpu_percent{0.0};       // what the cores delivered (at most 100 * cores)
  double demand_percent{0.0};    // what the nodes would need to keep up with their inputs
  double capacity_percent{0.0};  // 100 * cores
  // The sheet's figures for the same processes (Table I rows 3, 5 and 7: the camera drivers, the
  // two ReconROS software threads and the lane node) and the profile's background loads beside.
  PaperRange sheet_percent;
  double background_percent{0.0};
  std::string nodes_csv;   // with Table1Options::trace
  std::string trace_json;  // with Table1Options::trace
};

// Depth camera (AstraSDK) -> point cloud (sw) -> obstacle detection (sw); colour camera
// (Cam2Image) -> lane detection (sw); plus the profile's background loads; every topic on
// `transport` (the real unit uses zero-copy; DDS shows the same unit without Iceoryx).
WholeUnitResult RunWholeUnit(const PlatformProfile& profile, const Table1Options& options = {},
                             Transport transport = Transport::kZeroCopy);

// {"rows": [{"component", "configuration", "cpu_percent", "board_cpu_percent", "fps",
//            "turnaround_ms",
//            "paper": {"cpu_percent": [lo, hi], "fps": [lo, hi], "turnaround_ms": [lo, hi]},
//            "in_range": {"cpu_percent", "fps", "turnaround_ms"},
//            "processes": [{"process", "nodes", "cpu_percent", "sheet": [lo, hi] or null,
//                           "in_range": bool or null}]}],
//  "held_out": [row indices],
//  "whole_unit": {"zero_copy": {..., "sheet_percent": [lo, hi], "background_percent"}, "dds"}}
nlohmann::json Table1Json(const std::vector<Table1Result>& rows,
                          const std::vector<WholeUnitResult>& whole);
// The same as a printed table, each cell marked in or out of the paper's (or the sheet's) range.
std::string Table1Text(const std::vector<Table1Result>& rows,
                       const std::vector<WholeUnitResult>& whole, const std::string& profile_name,
                       const Table1Options& options);

}  // namespace autonomsim::sim
