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

// A fault of the run, from its fault_begin event to its fault_end (each end closes the earliest
// open fault of its kind and car); the video and recovers_within read them.
struct FaultSpan {
  FaultKind kind{FaultKind::kCarStall};
  int car{-1};  // the car it strikes; -1: none in particular
  Time begin{0};
  std::optional<Time> end;  // none: it lasted to the run's end
};
std::vector<FaultSpan> FaultSpans(const RunRecord& record);

std::vector<ExpectationResult> EvaluateExpectations(const Scenario& scenario,
                                                    const RunRecord& record);

}  // namespace autonomsim::sim
