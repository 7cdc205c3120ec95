// A finished run read back from its folder, for what is made from a run after it ended (the
// replay report, the video): summary.json, the resolved scenario and track
// (scenario.resolved.json, so `--set` overrides and presets are the run's own, whatever the
// scenario file says today), trajectory.csv and events.jsonl.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>

#include "sim/results/render.h"
#include "sim/results/summary.h"
#include "sim/scenario/run_record.h"
#include "sim/scenario/scenario.h"
#include "world/track.h"

namespace autonomsim::sim {

struct FinishedRun {
  std::filesystem::path dir;
  RunSummary summary;
  Scenario scenario;  // as the run resolved it
  world::Track track;
  // events and trajectory in memory (a run's whole record: ~100 B per sample), the cars' metrics,
  // the counters and sim_duration from summary.json
  RunRecord record;
};

// ConfigError naming the folder and the file for a folder that is not a finished run (a missing
// or unreadable file, a line the run did not write).
FinishedRun ReadFinishedRun(const std::filesystem::path& dir);

// The world at t as the run's trajectory has it: each car at its last sample at or before t (at
// its start sample before that), the obstacles present at t.
WorldSnapshot SnapshotOf(const FinishedRun& run, Time t);

}  // namespace autonomsim::sim
