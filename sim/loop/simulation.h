// The closed loop: the track, the cars in a Box2D world, their drivers and intersection clients,
// the traffic-light server and the V2I link between them, on one event kernel. One Simulation is
// one run; several can live in one process (tests, sweeps).
#pragma once

#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "sim/loop/run_observer.h"
#include "sim/scenario/run_record.h"
#include "sim/scenario/scenario.h"

namespace autonomsim::sim {

class Simulation {
 public:
  // With a `store`, the run's trajectory samples and events go there as they are made (and the
  // record points to it once the run is over); without, into the record's vectors.
  explicit Simulation(const LoadedScenario& scenario, std::shared_ptr<RecordStore> store = nullptr);
  ~Simulation();
  Simulation(const Simulation&) = delete;
  Simulation& operator=(const Simulation&) = delete;

  // Adds an observer (sim/loop/run_observer.h) before the run starts; it is told of each board at
  // once and must outlive the run. std::logic_error once the run has advanced.
  void AddObserver(RunObserver* observer);

  // Runs to the scenario's duration (with v2i.link: realtime, paced to the wall clock). `progress`,
  // if given, is called with the simulated time every `progress_period` of simulated time (the CLI
  // turns it into a progress line).
  void Run(const std::function<void(Time)>& progress = {},
           Duration progress_period = std::chrono::seconds(1));

  // Stepping, for a caller that looks at the run between pieces (the Python module's Simulation,
  // python/). AdvanceTo(t) runs every event before `t`; those at `t` come with the next piece, so
  // a fault injected at now() strikes among that instant's events as a scenario's would. Advancing
  // in any number of pieces, then Finish, gives the record Run gives. std::logic_error for a `t`
  // before now() or after the end, for a real-time run (it paces itself), and after Finish.
  void AdvanceTo(Time t);
  // The time advanced to: every event before it has run, none after it.
  Time now() const;
  Time end() const;
  // Runs what is left, to the end inclusive, and completes the record (Run's last step). Once.
  void Finish();
  bool finished() const;
  // A fault as a scenario's `faults:` entry has it, its at_s replaced by now(): it strikes at
  // now() (ConfigError for a car or node the run does not have; std::logic_error after Finish
  // and for a real-time run).
  void Inject(FaultClause fault);

  // What the run is now (between pieces; ground truth unless named an estimate).
  struct CarState {
    int id{0};
    world::Pose2 pose;  // map frame, the chassis centre
    double speed_mps{0.0};
    double steering_rad{0.0};
    double lateral_error_m{0.0};  // from the route's lane centre
    double route_progress_m{0.0};
    int laps{0};
    std::optional<world::Pose2> estimate;      // the stack's EKF, its last estimate (driver: stack)
    std::optional<std::string> behavior_mode;  // the stack's behaviour (driver: stack)
  };
  std::vector<CarState> Cars() const;
  // The traffic-light server: per intersection id, its holder (-1: none) and its queue.
  struct IntersectionState {
    int id{0};
    int holder{-1};
    std::vector<int> queue;
  };
  std::vector<IntersectionState> Server() const;
  // Per board (the cars that have one): its name, the cores busy now, and its metrics' report
  // over [0, now()] (sim/platform ReportJson's format).
  struct BoardState {
    int car{0};
    std::string name;
    double busy_cores{0.0};
    nlohmann::json report;
  };
  std::vector<BoardState> Boards() const;

  const RunRecord& record() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Loads nothing and writes nothing: runs the scenario and returns its record.
RunRecord RunScenario(const LoadedScenario& scenario);

}  // namespace autonomsim::sim
