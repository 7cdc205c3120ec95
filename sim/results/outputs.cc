#include "sim/results/outputs.h"

#include "sim/core/config.h"
#include "sim/core/files.h"
#include "sim/platform/node_metrics.h"
#include "sim/results/png.h"
#include "sim/results/summary.h"
#include "sim/results/track_figure.h"

namespace autonomsim::sim {
namespace {

// Every file but trajectory.csv and events.jsonl, summary.json last (its presence marks a
// complete folder).
void WriteResults(const LoadedScenario& loaded, const RunRecord& record,
                  const std::vector<ExpectationResult>& expectations, double wall_seconds,
                  const std::filesystem::path& folder) {
  if (!record.boards.empty()) {
    WriteFile(folder / "nodes.csv", NodesCsv(record.boards));
    WriteFile(folder / "topics.csv", TopicsCsv(record.boards));
  }
  if (!record.trace_json.empty()) WriteFile(folder / "trace.json", record.trace_json);
  WriteFile(folder / "scenario.resolved.json", loaded.resolved.dump(2) + "\n");
  WritePng(folder / "track.png", DrawTrackFigure(loaded, record));
  WriteFile(folder / "summary.json",
            SummaryJson(Summarize(loaded, record, expectations, wall_seconds)).dump(2) + "\n");
}

}  // namespace

RunFolder::RunFolder(const std::filesystem::path& out_dir, bool force)
    : folder_(out_dir, force), files_(std::make_shared<RecordFiles>(folder_.path())) {}

void RunFolder::Complete(const LoadedScenario& loaded, const RunRecord& record,
                         const std::vector<ExpectationResult>& expectations, double wall_seconds) {
  if (record.store != files_) {
    throw std::logic_error("RunFolder::Complete: the record was not made with this folder's store");
  }
  WriteResults(loaded, record, expectations, wall_seconds, folder_.path());
  folder_.Commit();
}

void WriteRunFolder(const LoadedScenario& loaded, const RunRecord& record,
                    const std::vector<ExpectationResult>& expectations, double wall_seconds,
                    const std::filesystem::path& out_dir, bool force) {
  if (record.store) {
    throw std::logic_error("WriteRunFolder: the record's trajectory is in a store (use RunFolder)");
  }
  WriteFolderAtomically(
      out_dir,
      [&](const std::filesystem::path& partial) {
        WriteFile(partial / "trajectory.csv", TrajectoryCsv(record));
        WriteFile(partial / "events.jsonl", EventsJsonl(record));
        WriteResults(loaded, record, expectations, wall_seconds, partial);
      },
      force);
}

}  // namespace autonomsim::sim
