// `autonomsim run --realtime --broker HOST:PORT` (issue 18) end to end, on private brokers with the
// shipped ACL: a run paced to the wall clock whose cars speak the lab's plain /vtl/ protocol to a
// server outside it — our tlserver on the wall clock, and a stand-in of the lab's vtl.py written
// from the protocol alone (tools/tests/vtl_standin.py). These tests take their simulated duration
// in wall time (one of them 60 s), sleeping mostly; ctest gives them the label `realtime`.
//
// The pacing figures are reported, never judged: how far a run falls behind real time depends on
// the machine and its load.
#include <gtest/gtest.h>

#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <thread>
#include <utility>

#include "sim/mqtt/tests/mqtt_fixture.h"
#include "tools/tests/cli_testing.h"

namespace autonomsim {
namespace {

namespace fs = std::filesystem;
using sim::LocalBroker;

// The default scenario's expectations that hold at any duration (`completes` asks for 3 laps).
const char* const kExpectations =
    "'expect=[{no_collision: {}}, {intersection_mutex: {}}, {no_entry_without_grant: {}}]'";

struct RealTimeRun {
  testing::Result result;
  nlohmann::json summary;
  std::vector<nlohmann::json> events;
};

// The default scenario for `duration_s`, in real time against the server on `broker`.
RealTimeRun RunRealTime(const LocalBroker& broker, int duration_s, const fs::path& out) {
  RealTimeRun run;
  run.result =
      testing::Cli("run scenarios/lab_two_cars.yaml --realtime --broker " + broker.address() +
                   " --set v2i.mqtt.password_file=" + broker.PasswordFile("autonomsim").string() +
                   " --set duration_s=" + std::to_string(duration_s) + " --set " + kExpectations +
                   " --out " + out.string() + " --quiet");
  if (run.result.exit_code != 0) return run;
  run.summary = nlohmann::json::parse(testing::Read(out / "summary.json"));
  std::istringstream lines(testing::Read(out / "events.jsonl"));
  for (std::string line; std::getline(lines, line);) {
    if (!line.empty()) run.events.push_back(nlohmann::json::parse(line));
  }
  return run;
}

// (car, intersection) of every entry into an intersection area the car held.
std::set<std::pair<int, int>> GrantedEntries(const RealTimeRun& run) {
  std::set<std::pair<int, int>> entries;
  for (const nlohmann::json& e : run.events) {
    if (e.at("type") == "enter" && e.value("granted", false)) {
      entries.emplace(e.at("car").get<int>(), e.at("intersection").get<int>());
    }
  }
  return entries;
}

// The pacing figures are there and make sense; printed for whoever reads the test's output.
void ExpectPacingReported(const RealTimeRun& run, int duration_s) {
  ASSERT_TRUE(run.summary.contains("realtime")) << run.summary.dump(2);
  const nlohmann::json& rt = run.summary.at("realtime");
  EXPECT_EQ(rt.at("slice_s").get<double>(), 0.01);
  EXPECT_EQ(rt.at("slices").get<int>(), duration_s * 100);
  EXPECT_LE(rt.at("late_slices").get<int>(), rt.at("slices").get<int>());
  EXPECT_GE(rt.at("pacing_mean_lag_s").get<double>(), 0.0);
  EXPECT_GE(rt.at("pacing_max_lag_s").get<double>(), rt.at("pacing_mean_lag_s").get<double>());
  EXPECT_GT(rt.at("messages_sent").get<int>(), 0);
  EXPECT_GT(rt.at("messages_received").get<int>(), 0);
  EXPECT_NE(run.result.output.find("real time: lag behind the wall clock max"), std::string::npos)
      << run.result.output;
  std::cout << "pacing: " << rt.dump() << "\n";
  ::testing::Test::RecordProperty("realtime", rt.dump());
}

// What went over the broker: the lab's topics only, nothing of the lock-step protocol.
void ExpectPlainProtocol(const sim::testing::Sub& monitor) {
  const std::string seen = monitor.Output();
  EXPECT_NE(seen.find("/vtl/request "), std::string::npos) << seen;
  EXPECT_NE(seen.find("/vtl/response "), std::string::npos) << seen;
  EXPECT_EQ(seen.find("/vtl/sim/"), std::string::npos) << seen;
}

TEST(RealTimeCliTest, RealtimeWithoutABrokerIsUnusableInput) {
  const fs::path dir = testing::Scratch("realtime");
  const testing::Result r =
      testing::Cli("run scenarios/lab_two_cars.yaml --realtime --out " + (dir / "run").string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("--realtime needs --broker"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(dir / "run"));
  // the scenario key alone, likewise
  const testing::Result key = testing::Cli(
      "run scenarios/lab_two_cars.yaml --set v2i.link=realtime --out " + (dir / "run").string());
  EXPECT_EQ(key.exit_code, 2) << key.output;
  EXPECT_NE(key.output.find("link 'realtime' needs mqtt.broker"), std::string::npos) << key.output;
}

TEST(RealTimeCliTest, ABrokerThatIsNotThereExitsTwoNamingIt) {
  const fs::path dir = testing::Scratch("realtime");
  const sim::testing::RefusingPort nobody;
  const std::string address = nobody.address();
  const testing::Result r =
      testing::Cli("run scenarios/lab_two_cars.yaml --realtime --broker " + address +
                   " --set v2i.mqtt.timeout_s=1 --out " + (dir / "run").string() + " --quiet");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("cannot reach the MQTT broker " + address), std::string::npos)
      << r.output;
  EXPECT_FALSE(fs::exists(dir / "run"));
}

TEST(RealTimeCliTest, CarsAreGrantedByATlserverOnTheWallClock) {
  const fs::path dir = testing::Scratch("realtime");
  auto broker = sim::testing::StartSecureBroker();
  auto tlserver = sim::testing::StartTlserver(*broker, {});  // no --sim-clock
  sim::testing::Sub monitor(*broker, "monitor", {"/vtl/#"}, "monitor");
  // car 1 reaches intersection 0 at ≈ 11 s, car 0 at ≈ 21 s
  constexpr int kDuration_s = 25;
  const RealTimeRun run = RunRealTime(*broker, kDuration_s, dir / "run");
  ASSERT_EQ(run.result.exit_code, 0) << run.result.output << tlserver->LogTail();
  const std::set<std::pair<int, int>> entries = GrantedEntries(run);
  EXPECT_TRUE(entries.count({0, 0})) << run.result.output;
  EXPECT_TRUE(entries.count({1, 0})) << run.result.output;
  ExpectPacingReported(run, kDuration_s);
  // the server is outside the run: no server events or counters of its own
  EXPECT_EQ(run.summary.at("server").at("requests"), 0);
  EXPECT_EQ(run.summary.at("v2i").at("sent"), run.summary.at("realtime").at("messages_sent"));
  ExpectPlainProtocol(monitor);
  EXPECT_TRUE(tlserver->Running());
}

TEST(RealTimeCliTest, SixtySecondsAgainstAStandInOfTheLabsServer) {
  if (!fs::exists("/usr/bin/python3")) {
    GTEST_SKIP() << "/usr/bin/python3 is not installed: it runs the stand-in of the lab's server";
  }
  if (testing::Shell("/usr/bin/python3 -c 'import paho.mqtt.client'").exit_code != 0) {
    GTEST_SKIP() << "paho-mqtt is not installed for /usr/bin/python3 (Debian: "
                    "python3-paho-mqtt; tools/install_deps.sh installs it)";
  }
  const fs::path dir = testing::Scratch("realtime");
  auto broker = sim::testing::StartSecureBroker();
  const fs::path log = broker->dir() / "standin.log";
  sim::ChildProcess standin({"/usr/bin/python3", "tools/tests/vtl_standin.py", broker->host(),
                             std::to_string(broker->port()), "tlserver", "pw-tlserver"},
                            log);
  ASSERT_TRUE(sim::testing::WaitUntil([&] {
    return sim::testing::ReadText(log).find("ready") != std::string::npos;
  })) << sim::testing::ReadText(log);
  sim::testing::Sub monitor(*broker, "monitor", {"/vtl/#"}, "monitor");

  // the acceptance of issue 18: in 60 s both cars cross both intersections, granted
  constexpr int kDuration_s = 60;
  const RealTimeRun run = RunRealTime(*broker, kDuration_s, dir / "run");
  ASSERT_EQ(run.result.exit_code, 0) << run.result.output << sim::testing::ReadText(log);
  const std::set<std::pair<int, int>> entries = GrantedEntries(run);
  for (int car : {0, 1}) {
    for (int intersection : {0, 1}) {
      EXPECT_TRUE(entries.count({car, intersection}))
          << "car " << car << " did not cross intersection " << intersection << " granted\n"
          << run.result.output;
    }
  }
  ExpectPacingReported(run, kDuration_s);
  ExpectPlainProtocol(monitor);
  const std::string served = sim::testing::ReadText(log);
  EXPECT_NE(served.find("granted"), std::string::npos) << served;
  EXPECT_TRUE(standin.Running()) << served;
}

// Issue 33, item 1 on the real programs: car 1 stalls inside intersection 0 from 6 s to 18 s
// (lab_two_cars_oracle: car 0 queues behind it for the same intersection), and the broker between
// them and tlserver is killed with SIGKILL for 4 s meanwhile (what the reviewer did: a collision in
// 1 of 2 timings). Neither car may enter while the other is inside, and no car without its grant.
// Two tries, the broker killed at 6.9 s and at 7.4 s of the run. For more tries:
//   build/bin/realtime_cli_tests --gtest_filter='*BrokerKilled*' --gtest_repeat=10
TEST(RealTimeCliTest, ABrokerKilledWhileACarStandsInsideAdmitsNoSecondCar) {
  for (const double kill_at_s : {6.9, 7.4}) {
    const fs::path dir = testing::Scratch("realtime-kill");
    auto broker = sim::testing::StartSecureBroker();
    auto tlserver = sim::testing::StartTlserver(*broker, {});  // no --sim-clock
    testing::Result result;
    std::thread run([&] {
      result = testing::Cli(
          "run scenarios/lab_two_cars_oracle.yaml --realtime --broker " + broker->address() +
          " --set v2i.mqtt.password_file=" + broker->PasswordFile("autonomsim").string() +
          " --set duration_s=25 --set 'faults=[car_stall: {car: 1, at_s: 6.0, for_s: 12}]'"
          " --set " +
          kExpectations + " --out " + (dir / "run").string() + " --quiet");
    });
    std::this_thread::sleep_for(std::chrono::duration<double>(kill_at_s));
    broker->Kill();
    std::this_thread::sleep_for(std::chrono::seconds(4));
    broker->Start();
    run.join();
    EXPECT_EQ(result.exit_code, 0) << "broker killed at " << kill_at_s << " s\n"
                                   << result.output << tlserver->LogTail();
    // the situation arose: car 0 was waiting at intersection 0 when the broker died, and the
    // server saw the outage (it kept its leases)
    bool car0_waiting = false;
    std::istringstream events(testing::Read(dir / "run" / "events.jsonl"));
    for (std::string line; std::getline(events, line);) {
      const nlohmann::json e = nlohmann::json::parse(line);
      car0_waiting |= e.at("type") == "wait" && e.value("car", -1) == 0 &&
                      e.value("intersection", -1) == 0 && e.at("t_s").get<double>() < kill_at_s;
    }
    EXPECT_TRUE(car0_waiting) << result.output;
    EXPECT_NE(tlserver->LogTail(20000).find("leases paused"), std::string::npos)
        << tlserver->LogTail();
    EXPECT_TRUE(tlserver->Running());
  }
}

}  // namespace
}  // namespace autonomsim
