// The result folder of a run: summary.json, trajectory.csv, events.jsonl, track.png and the
// resolved scenario. Written under a temporary name and renamed when complete, so a killed run
// never leaves a folder that looks complete.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "sim/expectations.h"
#include "sim/run_record.h"
#include "sim/scenario.h"

namespace autonomsim::sim {

std::string TrajectoryCsv(const RunRecord& record);
std::string EventsJsonl(const RunRecord& record);
// SHA-256 over trajectory.csv and events.jsonl: equal hashes mean bit-identical results.
std::string ResultSha256(const RunRecord& record);

nlohmann::json Summary(const LoadedScenario& scenario, const RunRecord& record,
                       const std::vector<ExpectationResult>& expectations, double wall_seconds);

// Writes every file of the folder to `out_dir`, replacing a previous result there.
void WriteRunFolder(const LoadedScenario& scenario, const RunRecord& record,
                    const std::vector<ExpectationResult>& expectations, double wall_seconds,
                    const std::filesystem::path& out_dir);

}  // namespace autonomsim::sim
