// The closed loop: the track, the cars in a Box2D world, their drivers and intersection clients,
// the traffic-light server and the V2I link between them, on one event kernel. One Simulation is
// one run; several can live in one process (tests, sweeps).
#pragma once

#include <functional>
#include <memory>

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

  // Runs to the scenario's duration (with v2i.link: realtime, paced to the wall clock). `progress`,
  // if given, is called with the simulated time every `progress_period` of simulated time (the CLI
  // turns it into a progress line).
  void Run(const std::function<void(Time)>& progress = {},
           Duration progress_period = std::chrono::seconds(1));

  const RunRecord& record() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Loads nothing and writes nothing: runs the scenario and returns its record.
RunRecord RunScenario(const LoadedScenario& scenario);

}  // namespace autonomsim::sim
