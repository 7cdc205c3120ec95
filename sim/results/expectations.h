// Judges a scenario's `expect:` clauses against a run's record. Pure: the verdicts depend only on
// the record, so they are tested on hand-made records without running a simulation.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "sim/scenario/run_record.h"
#include "sim/scenario/scenario.h"

namespace autonomsim::sim {

struct ExpectationResult {
  std::string name;  // e.g. "completes(car=0, laps=3, within_s=120)"
  bool passed{false};
  std::string detail;  // what was measured, and the first violation if any
  // Where a failure can be pinned to one instant: the first violation's time and car (the report
  // links each failure there). Empty for a pass and for verdicts over the whole run (rates, CPU).
  std::optional<double> at_s;
  std::optional<int> car;
};

std::vector<ExpectationResult> EvaluateExpectations(const Scenario& scenario,
                                                    const RunRecord& record);

}  // namespace autonomsim::sim
