// The scenario reference (docs/scenarios.md), generated from the same Describe the loader reads
// with: every key of a scenario file, with its type, unit and default, and each fault and
// expectation kind with its keys. A test checks that the page in docs/ equals this text;
// `autonomsim reference --out docs/scenarios.md` writes it anew.
#pragma once

#include <string>

namespace autonomsim::sim {

std::string ScenarioReferenceMarkdown();

}  // namespace autonomsim::sim
