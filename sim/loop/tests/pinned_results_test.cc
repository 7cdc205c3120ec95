// The shipped scenarios' results, pinned (as Box2D pins a hash of its determinism scene): each
// run's result_sha256 (trajectory.csv, events.jsonl, nodes.csv: sim/scenario/run_record.h) must
// equal the value recorded here. A change that alters one is a change of behaviour: its commit
// message says why, and updates the value here. A refactor leaves them all unchanged.
#include <gtest/gtest.h>

#include <ostream>
#include <string>

#include "sim/loop/simulation.h"
#include "sim/scenario/run_record.h"

namespace autonomsim::sim {
namespace {

struct Pinned {
  const char* scenario;
  const char* result_sha256;
};
void PrintTo(const Pinned& pinned, std::ostream* os) { *os << pinned.scenario; }

// "scenarios/lab_two_cars.yaml" -> "lab_two_cars"
std::string ScenarioName(const ::testing::TestParamInfo<Pinned>& param) {
  const std::string file = param.param.scenario;
  const std::string base = file.substr(file.rfind('/') + 1);
  return base.substr(0, base.find('.'));
}

class PinnedResults : public ::testing::TestWithParam<Pinned> {};

TEST_P(PinnedResults, TheShippedScenarioGivesItsPinnedResult) {
  const Pinned& pinned = GetParam();
  const RunRecord record = RunScenario(LoadScenario(pinned.scenario));
  EXPECT_EQ(ResultSha256(record), pinned.result_sha256) << pinned.scenario;
}

// Recorded at 0d2ff5c (before the restructure of sim/ into modules). The three stack-driven
// scenarios' values changed once since, when node turnaround and topic latency percentiles moved to
// a bounded-memory histogram (sim/platform/duration_histogram.h: nodes.csv's p50/p95 within
// 0.05 %); their trajectory.csv and events.jsonl stayed byte for byte the same.
INSTANTIATE_TEST_SUITE_P(
    Shipped, PinnedResults,
    ::testing::Values(Pinned{"scenarios/lab_two_cars.yaml",
                             "2ec3b7cf9694fefba4bbac6b68de05ce46bd7cf8c143cda232ac27eea21d8f24"},
                      Pinned{"scenarios/lab_two_cars_oracle.yaml",
                             "87799d3fb3dae09b49cfb18daf06317b523f79d166d03e3627470f00f35691a1"},
                      Pinned{"scenarios/lab_two_cars_all_sw.yaml",
                             "13ffcf78ea11f7d4861ae88ac6484e21d6bfb6ac6f904eeeb95bc5da2ec84b0d"},
                      Pinned{"scenarios/stack_obstacle.yaml",
                             "102a08b89d41d401ec408bf368ac818a80879ec35eed098cef774d222c6958eb"},
                      Pinned{"scenarios/static_obstacle.yaml",
                             "d3555d049b14523fcbe98b9559ab961463666b996c8292cbee8700d23ffc38f2"},
                      Pinned{"scenarios/intersection_conflict.yaml",
                             "73a208ba11300d79c2fc316d67ce75ab3654d707b067b8cf4ba99c03104a4301"}),
    ScenarioName);

}  // namespace
}  // namespace autonomsim::sim
