// Whole scenario runs with v2i.link: mqtt, through a real mosquitto and a real tlserver: the same
// trajectories, events and counters as with the embedded server, bit for bit.
#include <gtest/gtest.h>

#include "sim/loop/simulation.h"
#include "sim/mqtt/tests/mqtt_fixture.h"
#include "sim/scenario/run_record.h"

namespace autonomsim::sim {
namespace {

void ExpectSameRun(const std::string& file, const std::vector<std::string>& overrides) {
  const RunRecord embedded = RunScenario(LoadScenario(file, overrides));
  std::vector<std::string> mqtt_overrides = overrides;
  mqtt_overrides.push_back("v2i.link=mqtt");
  const RunRecord mqtt = RunScenario(LoadScenario(file, mqtt_overrides));
  ASSERT_GT(embedded.server.requests, 0u);
  EXPECT_EQ(EventsJsonl(mqtt), EventsJsonl(embedded));
  EXPECT_EQ(TrajectoryCsv(mqtt), TrajectoryCsv(embedded));
  EXPECT_EQ(ResultSha256(mqtt), ResultSha256(embedded));
  EXPECT_EQ(mqtt.kernel_events, embedded.kernel_events);
  EXPECT_EQ(mqtt.server.requests, embedded.server.requests);
  EXPECT_EQ(mqtt.server.grants, embedded.server.grants);
  EXPECT_EQ(mqtt.server.denials, embedded.server.denials);
  EXPECT_EQ(mqtt.server.frees, embedded.server.frees);
  EXPECT_EQ(mqtt.server.lease_expiries, embedded.server.lease_expiries);
}

TEST(MqttSimulationTest, TheDefaultScenarioGivesTheSameResultOverMqtt) {
  ExpectSameRun("scenarios/lab_two_cars_oracle.yaml", {});
}

TEST(MqttSimulationTest, AConflictWithLossGivesTheSameResultOverMqtt) {
  ExpectSameRun("scenarios/intersection_conflict.yaml", {"v2i.loss=0.2", "seed=3"});
}

TEST(MqttSimulationTest, TheOriginalPolicyGivesTheSameResultOverMqtt) {
  ExpectSameRun("scenarios/intersection_conflict.yaml", {"traffic_lights.policy=original"});
}

TEST(MqttSimulationTest, AnExternalBrokerAndTlserverServeARun) {
  auto broker = testing::StartSecureBroker();
  auto tlserver = testing::StartTlserver(*broker, {"--sim-clock"});
  const std::string file = "scenarios/intersection_conflict.yaml";
  const RunRecord embedded = RunScenario(LoadScenario(file));
  const RunRecord mqtt = RunScenario(LoadScenario(
      file, {"v2i.link=mqtt", "v2i.mqtt.broker=" + broker->address(),
             "v2i.mqtt.password_file=" + broker->PasswordFile("autonomsim").string()}));
  EXPECT_EQ(ResultSha256(mqtt), ResultSha256(embedded));
  // and a second run on the same tlserver starts from a fresh server state
  const RunRecord again = RunScenario(LoadScenario(
      file, {"v2i.link=mqtt", "v2i.mqtt.broker=" + broker->address(),
             "v2i.mqtt.password_file=" + broker->PasswordFile("autonomsim").string()}));
  EXPECT_EQ(ResultSha256(again), ResultSha256(embedded));
  EXPECT_TRUE(tlserver->Running());
}

}  // namespace
}  // namespace autonomsim::sim
