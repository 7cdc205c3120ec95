// The scenario reference (docs/scenarios.md), generated from the same Describe the loader reads
// with: every key of a scenario file with its type (the names a closed set takes), unit, default
// and meaning (the last argument of its `v(...)`); the obstacle and its keys; the start poses,
// routes, lanes and intersections of the default track, from the track file the loader reads;
// and each fault and expectation kind with what it does or checks (its kMeaning) and its keys. A
// test checks that the page in docs/ equals this text; `autonomsim reference --out
// docs/scenarios.md` writes it anew.
#pragma once

#include <string>

namespace autonomsim::sim {

std::string ScenarioReferenceMarkdown();

}  // namespace autonomsim::sim
