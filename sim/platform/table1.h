// The paper's Table I (reference §8) and the model run on the paper's test setup: a camera
// publisher at 30 fps, one processing component (point cloud, obstacle detection or lane
// detection; in software or in hardware; over DDS or zero-copy) and a subscriber on its output that
// measures the frame rate (as `ros2 topic hz` does: it takes each sample by copy).
// Also the whole unit: the three accelerated components in software at once, with the rest of the
// stack's load, to show what more CPU demand than cores does (queues, drops, rates).
#pragma once

#include <nlohmann/json.hpp>
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
};

// The eight rows, in the paper's order.
const std::vector<Table1Row>& PaperTable1();

struct Table1Options {
  Duration duration{std::chrono::seconds(12)};  // simulated per configuration
  Duration warmup{std::chrono::seconds(2)};     // excluded from the measurements
  double camera_fps{30.0};                      // the test publisher (reference §2: 30 fps)
  bool trace{false};  // RunWholeUnit: keep a trace.json and nodes.csv of the run
};

struct Table1Result {
  Table1Row row;
  double cpu_percent{0.0};    // whole platform, 100 = one core
  double fps{0.0};            // output messages per second
  double turnaround_ms{0.0};  // p50 of the processing node's jobs (sum over a hardware chain)
  bool in_cpu{false}, in_fps{false}, in_turnaround{false};
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
  std::string nodes_csv;         // with Table1Options::trace
  std::string trace_json;        // with Table1Options::trace
};

// Depth camera -> point cloud (sw) -> obstacle detection (sw); colour camera -> lane detection
// (sw); plus the profile's background loads; every topic on `transport` (the real unit uses
// zero-copy; DDS shows the same unit without Iceoryx).
WholeUnitResult RunWholeUnit(const PlatformProfile& profile, const Table1Options& options = {},
                             Transport transport = Transport::kZeroCopy);

// {"rows": [{"component", "configuration", "cpu_percent", "fps", "turnaround_ms",
//            "paper": {"cpu_percent": [lo, hi], "fps": [lo, hi], "turnaround_ms": [lo, hi]},
//            "in_range": {"cpu_percent", "fps", "turnaround_ms"}}],
//  "held_out": [row indices], "whole_unit": {"zero_copy": {...}, "dds": {...}}}
nlohmann::json Table1Json(const std::vector<Table1Result>& rows,
                          const std::vector<WholeUnitResult>& whole);
// The same as a printed table, each cell marked in or out of the paper's range.
std::string Table1Text(const std::vector<Table1Result>& rows,
                       const std::vector<WholeUnitResult>& whole, const std::string& profile_name,
                       const Table1Options& options);

}  // namespace autonomsim::sim
