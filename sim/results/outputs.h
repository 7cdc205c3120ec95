// The result folder of a run: summary.json (sim/results/summary.h), trajectory.csv,
// events.jsonl, nodes.csv and trace.json (with a board), track.png and the resolved scenario.
// Written under a temporary name and renamed when complete, so a killed run never leaves a folder
// that looks complete.
#pragma once

#include <filesystem>
#include <vector>

#include "sim/results/expectations.h"
#include "sim/scenario/run_record.h"
#include "sim/scenario/scenario.h"

namespace autonomsim::sim {

// Writes every file of the folder to `out_dir`, replacing a previous result there (a folder this
// program wrote, or with `force` anything but a device: sim/core/files.h CheckOutputFolder).
void WriteRunFolder(const LoadedScenario& scenario, const RunRecord& record,
                    const std::vector<ExpectationResult>& expectations, double wall_seconds,
                    const std::filesystem::path& out_dir, bool force = false);

}  // namespace autonomsim::sim
