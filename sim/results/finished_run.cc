#include "sim/results/finished_run.h"

#include <yaml-cpp/yaml.h>

#include <fstream>
#include <optional>
#include <stdexcept>
#include <string>

#include "sim/core/config.h"
#include "sim/core/files.h"
#include "sim/scenario/record_files.h"

namespace autonomsim::sim {

namespace fs = std::filesystem;

FinishedRun ReadFinishedRun(const fs::path& dir) {
  if (!fs::is_directory(dir)) throw ConfigError(dir.string() + ": not a folder");
  if (!fs::exists(dir / "summary.json")) {
    throw ConfigError(dir.string() + ": no summary.json, so not a finished run's folder");
  }
  RunSummary summary = ReadSummaryFile(dir / "summary.json");

  const fs::path resolved_file = dir / "scenario.resolved.json";
  RequireRegularFile(resolved_file);
  std::ifstream in(resolved_file);
  if (!in) throw ConfigError(resolved_file.string() + ": cannot read");
  nlohmann::json resolved;
  try {
    resolved = nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    throw ConfigError(resolved_file.string() + ": not valid JSON: " + e.what());
  }
  if (!resolved.contains("scenario") || !resolved.contains("track")) {
    throw ConfigError(resolved_file.string() + ": has no \"scenario\" and \"track\"");
  }
  const ConfigSource source{resolved_file.string(), {}};
  // JSON is YAML: the config readers read the resolved values back as they read a scenario file
  Scenario scenario = ReadConfig<Scenario>(YAML::Load(resolved["scenario"].dump()), source);
  const world::TrackSpec spec =
      ReadConfig<world::TrackSpec>(YAML::Load(resolved["track"].dump()), source);
  std::optional<world::Track> track;
  try {
    track.emplace(spec);
  } catch (const std::invalid_argument& e) {
    throw ConfigError(resolved_file.string() + ": track: " + e.what());
  }
  FinishedRun run{.dir = dir,
                  .summary = std::move(summary),
                  .scenario = std::move(scenario),
                  .track = std::move(*track),
                  .record = {}};

  run.record.sim_duration = FromSeconds(run.summary.sim_seconds);
  run.record.kernel_events = run.summary.kernel_events;
  run.record.cars = run.summary.cars;
  run.record.server = run.summary.server;
  run.record.v2i = run.summary.v2i;
  run.record.realtime = run.summary.realtime;
  try {
    ReadTrajectoryCsv(dir / "trajectory.csv",
                      [&](const TrajectorySample& s) { run.record.trajectory.push_back(s); });
    ReadEventsJsonl(dir / "events.jsonl", [&](const Event& e) { run.record.events.push_back(e); });
  } catch (const ConfigError&) {
    throw;
  } catch (const std::runtime_error& e) {
    throw ConfigError(std::string(e.what()) + " (is this a run's folder?)");
  }
  return run;
}

WorldSnapshot SnapshotOf(const FinishedRun& run, Time t) {
  std::vector<world::Pose2> poses(run.scenario.cars.size());
  std::vector<bool> placed(run.scenario.cars.size(), false);
  for (const TrajectorySample& s : run.record.trajectory) {
    for (std::size_t i = 0; i < run.scenario.cars.size(); ++i) {
      if (run.scenario.cars[i].id != s.car || (placed[i] && s.t > t)) continue;
      poses[i] = world::Pose2{s.x_m, s.y_m, s.yaw_rad};
      placed[i] = true;
    }
  }
  return SnapshotWithPoses(run.scenario, poses, t);
}

}  // namespace autonomsim::sim
