// Simulation's stepping (AdvanceTo, Finish, Inject and the views between pieces), which the Python
// module's Simulation is (python/): a run in pieces is the run in one.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "sim/core/config.h"
#include "sim/loop/simulation.h"
#include "sim/scenario/run_record.h"

namespace autonomsim::sim {
namespace {

constexpr const char* kSteppedScenario = "scenarios/lab_two_cars.yaml";

LoadedScenario LoadStepped(const std::string& faults, double duration_s = 4.0) {
  return LoadScenario(kSteppedScenario,
                      {"duration_s=" + std::to_string(duration_s), "faults=" + faults});
}

TEST(SimulationStepping, PiecesGiveTheRecordOfOneRun) {
  const LoadedScenario scenario = LoadStepped("[]");
  const std::string whole = ResultSha256(RunScenario(scenario));
  Simulation simulation(scenario);
  for (const double t_s : {0.0, 0.001, 0.5, 0.5, 1.2345, 3.999}) {
    simulation.AdvanceTo(FromSeconds(t_s));
    EXPECT_EQ(simulation.now(), FromSeconds(t_s));
    EXPECT_EQ(simulation.Cars().size(), 2u);  // looking changes nothing
    EXPECT_EQ(simulation.Boards().size(), 2u);
    EXPECT_EQ(simulation.Server().size(), 2u);
  }
  simulation.Finish();
  EXPECT_EQ(ResultSha256(simulation.record()), whole);
}

TEST(SimulationStepping, EventsAtTheInstantAdvancedToComeWithTheNextPiece) {
  const LoadedScenario scenario = LoadStepped("[]");
  Simulation simulation(scenario);
  // the first trajectory samples are taken at 0 s (one per car)
  simulation.AdvanceTo(kZeroTime);
  EXPECT_TRUE(simulation.record().trajectory.empty());
  simulation.AdvanceTo(FromSeconds(1e-9));
  EXPECT_EQ(simulation.record().trajectory.size(), 2u);
}

TEST(SimulationStepping, AnInjectedFaultIsTheSameFaultInTheScenario) {
  const std::string written =
      ResultSha256(RunScenario(LoadStepped("[{car_stall: {car: 0, at_s: 1.5, for_s: 1.0}}]")));
  const LoadedScenario scenario = LoadStepped("[]");
  Simulation simulation(scenario);
  simulation.AdvanceTo(FromSeconds(1.5));
  simulation.Inject(CarStallFault{.at_s = 99.0, .for_s = 1.0, .car = 0});  // at_s: now
  simulation.Finish();
  EXPECT_EQ(ResultSha256(simulation.record()), written);
  EXPECT_NE(ResultSha256(RunScenario(scenario)), written);
}

TEST(SimulationStepping, StepsOutsideTheRunAreRefused) {
  const LoadedScenario scenario = LoadStepped("[]", 2.0);
  Simulation simulation(scenario);
  simulation.AdvanceTo(FromSeconds(1.0));
  EXPECT_THROW(simulation.AdvanceTo(FromSeconds(0.5)), std::logic_error);
  EXPECT_THROW(simulation.AdvanceTo(FromSeconds(2.5)), std::logic_error);
  EXPECT_THROW(simulation.Inject(CarStallFault{.car = 9}), ConfigError);
  simulation.Finish();
  EXPECT_TRUE(simulation.finished());
  EXPECT_THROW(simulation.Finish(), std::logic_error);
  EXPECT_THROW(simulation.Run(), std::logic_error);
}

}  // namespace
}  // namespace autonomsim::sim
