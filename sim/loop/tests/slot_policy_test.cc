// slot_policy executor in the closed loop (sim/platform/slot_executor.h): with every hardware node
// in a slot of its own that holds its bitstream from the start it drives exactly as static; with
// one slot for three hardware nodes, each callback reconfigures and the lane detection falls
// behind by at least the reconfigurations on its way.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "sim/car/perception_config.h"
#include "sim/loop/simulation.h"
#include "sim/platform/slot_executor.h"

namespace autonomsim::sim {
namespace {

// Tells the test each board's slot executor.
struct Executors : RunObserver {
  void OnBoard(int /*car_id*/, Board& board, const SensorSuite& /*sensors*/) override {
    executors.push_back(board.platform().slot_executor());
  }
  std::vector<SlotExecutor*> executors;
};

std::vector<std::string> Executor(const std::string& car, std::vector<std::string> more = {}) {
  more.push_back(car + ".platform.slot_policy=executor");
  return more;
}

double LaneLatencyMs(const RunRecord& record, std::size_t board) {
  return record.boards.at(board).report.FindTopic(kLanePointsTopic)->latency_ms.mean;
}

TEST(SlotPolicy, ExecutorWithEachNodeInItsPreloadedSlotDrivesAsStatic) {
  const std::vector<std::string> base = {"duration_s=30"};
  const RunRecord fixed = RunScenario(LoadScenario("scenarios/lab_two_cars.yaml", base));
  std::vector<std::string> both = Executor("cars[0]", base);
  both = Executor("cars[1]", both);
  const LoadedScenario loaded = LoadScenario("scenarios/lab_two_cars.yaml", both);
  Simulation simulation(loaded);
  Executors executors;
  simulation.AddObserver(&executors);
  simulation.Run();
  ASSERT_EQ(executors.executors.size(), 2u);
  ASSERT_NE(executors.executors[0], nullptr);
  EXPECT_EQ(TrajectoryCsv(simulation.record()), TrajectoryCsv(fixed));
  EXPECT_EQ(EventsJsonl(simulation.record()), EventsJsonl(fixed));
  for (int slot = 0; slot < 3; ++slot) {
    EXPECT_EQ(executors.executors[0]->stats(slot).reconfigurations, 0u);
    EXPECT_GT(executors.executors[0]->stats(slot).callbacks, 800u);  // ~30 Hz for 30 s
  }
}

TEST(SlotPolicy, OneSlotForThreeHardwareNodesReconfiguresAndDelaysTheLanes) {
  // car 0's three hardware nodes (obstacle detection, lane planner, polynomial fit) on one slot.
  // Each reconfiguration: copy 2 MB at 1.5 GB/s (1.33 ms) + transfer at 400 MB/s (5 ms).
  std::vector<std::string> one = Executor("cars[0]", {"duration_s=20", "cars[0].platform.slots=1"});
  for (const char* node : {"obstacle_detection", "lane_planner", "poly_fit"}) {
    one.push_back(std::string("cars[0].platform.mapping.") + node + ".target=hw");
    one.push_back(std::string("cars[0].platform.mapping.") + node + ".slot=any");
  }
  const RunRecord fixed =
      RunScenario(LoadScenario("scenarios/lab_two_cars.yaml", {"duration_s=20"}));
  const LoadedScenario loaded = LoadScenario("scenarios/lab_two_cars.yaml", one);
  Simulation simulation(loaded);
  Executors executors;
  simulation.AddObserver(&executors);
  simulation.Run();
  const SlotExecutor::SlotStats& slot = executors.executors.at(0)->stats(0);
  // the three nodes take turns: almost every callback finds another node's bitstream
  EXPECT_GT(slot.reconfigurations, slot.callbacks * 9 / 10);
  // each at least its 6.33 ms; more where the busy cores share them with the copy and the
  // driver's busy-poll (it notices the transfer's end when it runs again)
  const double mean_ms = 1e3 * slot.reconfiguring_s / static_cast<double>(slot.reconfigurations);
  EXPECT_GE(mean_ms, 6.333);
  EXPECT_LT(mean_ms, 7.0);
  // a lane result waits for at least the lane planner's and the polynomial fit's reconfigurations
  const double slower_ms = LaneLatencyMs(simulation.record(), 0) - LaneLatencyMs(fixed, 0);
  EXPECT_GT(slower_ms, 2 * 6.333);
  // car 1 keeps its static slots
  EXPECT_EQ(executors.executors.at(1), nullptr);
}

}  // namespace
}  // namespace autonomsim::sim

namespace autonomsim::sim {
namespace {

// car 0's board: its mean load over [from_s, to_s) from the 1 s bins.
double MeanLoad(const RunRecord& record, int from_s, int to_s) {
  const std::vector<double>& bins = record.boards.at(0).report.cpu_load_percent;
  double sum = 0.0;
  for (int b = from_s; b < to_s; ++b) sum += bins.at(static_cast<std::size_t>(b));
  return sum / (to_s - from_s);
}

// A remap fault moves car 0's point cloud between software and hardware at run time. Its
// software job is 12.96 ms at 30 Hz (39 % of a core), its hardware delegate 1.96 ms (5.9 %):
// the board's load changes by ~33 points at the instant, and the move to hardware first loads
// the empty slot 0 with its bitstream.
TEST(SlotPolicy, ARemapMovesANodeBetweenSoftwareAndHardwareAtItsInstant) {
  const std::vector<std::string> pc_sw = {
      "duration_s=30", "cars[0].platform.slot_policy=executor",
      "cars[0].platform.mapping.point_cloud.target=sw",
      "cars[0].platform.mapping.obstacle_detection.target=sw",
      "faults=[{remap: {car: 0, node: point_cloud, target: hw, at_s: 10}},"
      " {remap: {car: 0, node: point_cloud, target: sw, at_s: 20}}]"};
  const RunRecord record = RunScenario(LoadScenario("scenarios/lab_two_cars.yaml", pc_sw));
  const double sw_before = MeanLoad(record, 2, 10);
  const double hw = MeanLoad(record, 11, 20);
  const double sw_after = MeanLoad(record, 21, 30);
  EXPECT_NEAR(sw_before - hw, 33.1, 6.0);
  EXPECT_NEAR(sw_after - hw, 33.1, 6.0);
  std::vector<Event> reconfigurations;
  ForEachEvent(record, [&](const Event& e) {
    if (e.type == EventKind::kReconfigureBegin) reconfigurations.push_back(e);
  });
  ASSERT_EQ(reconfigurations.size(), 1u);  // slot 0, at the first hardware job after 10 s
  EXPECT_GE(reconfigurations[0].t, FromSeconds(10.0));
  EXPECT_LT(reconfigurations[0].t, FromSeconds(10.05));
  EXPECT_EQ(reconfigurations[0].detail, "slot 0: point_cloud");
}

TEST(SlotPolicy, ARemapThatCannotRunThereIsRefusedAtItsKey) {
  try {  // lane_planner has no software cost; moving to hw needs the executor
    LoadedScenario loaded =
        LoadScenario("scenarios/lab_two_cars.yaml",
                     {"faults=[{remap: {car: 0, node: lane_planner, target: sw, at_s: 1}}]"});
    Simulation simulation(loaded);
    FAIL() << "expected a ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("faults[0].remap.target"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("has no sw cost"), std::string::npos) << e.what();
  }
  try {
    LoadedScenario loaded =
        LoadScenario("scenarios/lab_two_cars.yaml",
                     {"cars[0].platform.mapping.point_cloud.target=sw",
                      "cars[0].platform.mapping.obstacle_detection.target=sw",
                      "faults=[{remap: {car: 0, node: point_cloud, target: hw, at_s: 1}}]"});
    Simulation simulation(loaded);
    FAIL() << "expected a ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("slot_policy: executor"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace autonomsim::sim
