// The result folder of a run: summary.json (sim/results/summary.h), trajectory.csv,
// events.jsonl, nodes.csv and trace.json (with a board), track.png and the resolved scenario.
// Written under a temporary name and renamed when complete, so a killed run never leaves a folder
// that looks complete.
#pragma once

#include <filesystem>
#include <memory>
#include <vector>

#include "sim/core/files.h"
#include "sim/results/expectations.h"
#include "sim/scenario/record_files.h"
#include "sim/scenario/run_record.h"
#include "sim/scenario/scenario.h"

namespace autonomsim::sim {

// A run's folder while the run writes into it, so that a run of any length keeps its trajectory and
// events on disk, not in memory: made (under a temporary name) before the run, after the checks of
// CheckOutputFolder (sim/core/files.h: it replaces only a folder this program wrote, unless
// `force`); the run streams trajectory.csv and events.jsonl into it through store(); Complete
// writes the other files and renames it to `out_dir`. Destroyed incomplete, it leaves nothing.
class RunFolder {
 public:
  RunFolder(const std::filesystem::path& out_dir, bool force = false);

  // Give it to the Simulation (sim/loop/simulation.h).
  std::shared_ptr<RecordStore> store() const { return files_; }
  // `record` is the run's, made with store().
  void Complete(const LoadedScenario& scenario, const RunRecord& record,
                const std::vector<ExpectationResult>& expectations, double wall_seconds);

 private:
  PartialFolder folder_;
  std::shared_ptr<RecordFiles> files_;
};

// Writes every file of the folder of a run kept in memory (a record without a store) to
// `out_dir`, with RunFolder's rules.
void WriteRunFolder(const LoadedScenario& scenario, const RunRecord& record,
                    const std::vector<ExpectationResult>& expectations, double wall_seconds,
                    const std::filesystem::path& out_dir, bool force = false);

}  // namespace autonomsim::sim
