#include "sim/results/finished_run.h"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <optional>
#include <stdexcept>
#include <string>

#include "sim/core/config.h"
#include "sim/core/files.h"
#include "sim/scenario/record_files.h"

namespace autonomsim::sim {

namespace fs = std::filesystem;

namespace {

// What a row of a run's trajectory.csv or events.jsonl must be, beyond its syntax, for the run's
// scenario: a car it has, an instant within the run (a trajectory row's not before the row above),
// a position on (or near) the floor. A row that is not: std::invalid_argument, which the reader
// reports at the file's line (issue 33: report and video drew 13 kinds of damaged folders without a
// word).
class RowChecks {
 public:
  explicit RowChecks(const FinishedRun& run)
      : end_(run.record.sim_duration), reach_m_(run.track.spec().size_m) {
    for (const CarConfig& car : run.scenario.cars) cars_.push_back(car.id);
    for (const world::IntersectionSpec& x : run.track.spec().intersections)
      crossings_.push_back(x.id);
  }

  void Sample(const TrajectorySample& s, const TrajectorySample* previous) const {
    Instant(s.t, previous != nullptr ? &previous->t : nullptr);
    Car(s.car);
    // the floor is ±size_m/2; a car pushed off it stays within a floor's width of it
    if (std::abs(s.x_m) > reach_m_ || std::abs(s.y_m) > reach_m_) {
      throw std::invalid_argument(fmt::format(
          "car {} at ({}, {}) m is far off the track's floor (±{} m; a car pushed off it stays "
          "within ±{} m)",
          s.car, s.x_m, s.y_m, reach_m_ / 2.0, reach_m_));
    }
  }

  // (events are not in strict time order: the server's records carry the instants it received
  // the messages, and reach the file when it reports them)
  void OfEvent(const Event& e) const {
    Instant(e.t, nullptr);
    if (e.car >= 0) Car(e.car);
    if (e.other_car >= 0) Car(e.other_car);
    if (e.intersection >= 0 &&
        std::find(crossings_.begin(), crossings_.end(), e.intersection) == crossings_.end()) {
      throw std::invalid_argument(
          fmt::format("intersection {} is not the track's", e.intersection));
    }
  }

 private:
  void Instant(Time t, const Time* previous) const {
    if (t < kZeroTime || t > end_) {
      throw std::invalid_argument(
          fmt::format("t_s {} is outside the run (0 to {} s)", ToSeconds(t), ToSeconds(end_)));
    }
    if (previous != nullptr && t < *previous) {
      throw std::invalid_argument(
          fmt::format("t_s {} is before the row above ({} s): a run "
                      "writes its rows in time order",
                      ToSeconds(t), ToSeconds(*previous)));
    }
  }
  void Car(int id) const {
    if (std::find(cars_.begin(), cars_.end(), id) == cars_.end()) {
      throw std::invalid_argument(
          fmt::format("car {} is not in the run's scenario (cars {})", id, fmt::join(cars_, ", ")));
    }
  }

  Time end_;
  double reach_m_;
  std::vector<int> cars_;
  std::vector<int> crossings_;
};

}  // namespace

FinishedRun ReadFinishedRun(const fs::path& dir) {
  if (!fs::is_directory(dir)) throw ConfigError(dir.string() + ": not a folder");
  if (!fs::exists(dir / "summary.json")) {
    throw ConfigError(dir.string() + ": no summary.json, so not a finished run's folder");
  }
  RunSummary summary = ReadSummaryFile(dir / "summary.json");

  const fs::path resolved_file = dir / "scenario.resolved.json";
  RequireRegularFile(resolved_file);
  ResolvedScenarioFile resolved = ReadResolvedScenarioFile(resolved_file);
  FinishedRun run{.dir = dir,
                  .summary = std::move(summary),
                  .scenario = std::move(resolved.scenario),
                  .track = std::move(resolved.track),
                  .record = {}};

  run.record.sim_duration = FromSeconds(run.summary.sim_seconds);
  run.record.kernel_events = run.summary.kernel_events;
  run.record.cars = run.summary.cars;
  run.record.server = run.summary.server;
  run.record.v2i = run.summary.v2i;
  run.record.realtime = run.summary.realtime;
  const RowChecks checks(run);
  try {
    ReadTrajectoryCsv(dir / "trajectory.csv", [&](const TrajectorySample& s) {
      checks.Sample(s, run.record.trajectory.empty() ? nullptr : &run.record.trajectory.back());
      run.record.trajectory.push_back(s);
    });
    ReadEventsJsonl(dir / "events.jsonl", [&](const Event& e) {
      checks.OfEvent(e);
      run.record.events.push_back(e);
    });
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
