// tlserver: its message handling alone (Service), then the real program on a real broker, driven
// with mosquitto_pub / mosquitto_sub as an operator would and with the ACL of tools/mosquitto/acl.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <spdlog/spdlog.h>

#include <csignal>
#include <iostream>
#include <nlohmann/json.hpp>
#include <thread>

#include "sim/mqtt/tests/mqtt_fixture.h"
#include "tools/tlserver_service.h"

namespace autonomsim::tlserver {
namespace {

using sim::MqttMessage;
using Json = nlohmann::json;
namespace t = sim::testing;

// ---------------------------------------------------------------------------------------------
// Service: no broker

class ServiceTest : public ::testing::Test {
 protected:
  void SetUp() override { spdlog::set_level(spdlog::level::off); }
  void TearDown() override { spdlog::set_level(spdlog::level::info); }

  static ServiceOptions Options(bool sim_clock = false) {
    ServiceOptions o;
    o.params.lease = std::chrono::seconds(2);
    o.sim_clock = sim_clock;
    return o;
  }
  static MqttMessage Msg(const std::string& topic, const std::string& payload) {
    return {.topic = topic, .payload = payload};
  }
  // The /vtl/response payloads among `out`.
  static std::vector<std::string> Responses(const std::vector<MqttMessage>& out) {
    std::vector<std::string> r;
    for (const MqttMessage& m : out) {
      if (m.topic == "/vtl/response") r.push_back(m.payload);
    }
    return r;
  }
  static std::optional<sim::SimAck> Ack(const std::vector<MqttMessage>& out) {
    for (const MqttMessage& m : out) {
      if (m.topic == sim::kSimAckTopic) return sim::DecodeAck(m.payload).value();
    }
    return std::nullopt;
  }
  static MqttMessage Step(const std::string& topic, const std::string& payload, std::uint64_t seq,
                          double t_s, const std::string& epoch = "run1") {
    MqttMessage m = Msg(topic, payload);
    m.properties.emplace_back(std::string(sim::kStepProperty),
                              sim::EncodeStepTag({epoch, seq, FromSeconds(t_s)}));
    return m;
  }
  static MqttMessage Reset(const std::string& epoch = "run1") {
    sim::SimReset reset{epoch, {}, {0, 1}};
    reset.params.lease = std::chrono::seconds(2);
    return Msg(std::string(sim::kSimResetTopic), sim::EncodeReset(reset));
  }
};

TEST_F(ServiceTest, SpeaksTheLabsTopicsAndPayloads) {
  Service s(Options());
  EXPECT_EQ(Responses(s.OnMessage(Msg("/vtl/request", "00"), FromSeconds(0.1))),
            (std::vector<std::string>{"01"}));
  EXPECT_EQ(Responses(s.OnMessage(Msg("/vtl/request", "10"), FromSeconds(0.2))),
            (std::vector<std::string>{"10"}));  // occupied: queued
  EXPECT_EQ(Responses(s.OnMessage(Msg("/vtl/free", "0"), FromSeconds(0.3))),
            (std::vector<std::string>{"11"}));  // the queued car is granted when 0 leaves
  EXPECT_EQ(s.server().Holder(0), 1);
}

TEST_F(ServiceTest, MalformedPayloadsAreCountedAndServingGoesOn) {
  Service s(Options());
  for (const char* bad : {"", "0", "123", "ab", "\xff\x01", "0 "}) {
    EXPECT_TRUE(Responses(s.OnMessage(Msg("/vtl/request", bad), FromSeconds(0.1))).empty());
  }
  EXPECT_TRUE(Responses(s.OnMessage(Msg("/vtl/free", "x"), FromSeconds(0.1))).empty());
  EXPECT_EQ(s.counters().malformed, 7u);
  EXPECT_EQ(Responses(s.OnMessage(Msg("/vtl/request", "21"), FromSeconds(0.2))),
            (std::vector<std::string>{"21"}));
  const Json status = Json::parse(s.Status(true).payload);
  EXPECT_EQ(status["counters"]["malformed"], 7);
}

TEST_F(ServiceTest, ACarsTopicCarriesOnlyThatCarsMessages) {
  Service s(Options());
  EXPECT_EQ(Responses(s.OnMessage(Msg("/vtl/request/car0", "01"), FromSeconds(0.1))),
            (std::vector<std::string>{"01"}));
  // car 0 asking (or freeing) in car 1's name is refused
  EXPECT_TRUE(Responses(s.OnMessage(Msg("/vtl/request/car0", "11"), FromSeconds(0.2))).empty());
  EXPECT_TRUE(Responses(s.OnMessage(Msg("/vtl/free/car1", "0"), FromSeconds(0.3))).empty());
  EXPECT_TRUE(Responses(s.OnMessage(Msg("/vtl/request/monitor", "21"), FromSeconds(0.3))).empty());
  EXPECT_EQ(s.counters().refused, 3u);
  EXPECT_EQ(s.server().Holder(1), 0);  // car 0 still holds it: the forged free did nothing
}

TEST_F(ServiceTest, TheWallClockExpiresLeasesThroughTheTimer) {
  Service s(Options());
  s.OnMessage(Msg("/vtl/request", "00"), FromSeconds(1));
  s.OnMessage(Msg("/vtl/request", "10"), FromSeconds(1.5));
  ASSERT_EQ(s.NextTimer(), FromSeconds(3));  // car 0's lease
  // car 1 keeps asking, car 0 is silent
  s.OnMessage(Msg("/vtl/request", "10"), FromSeconds(2.5));
  EXPECT_EQ(Responses(s.OnTimer(FromSeconds(3))), (std::vector<std::string>{"11"}));
  EXPECT_EQ(s.server().counters().lease_expiries, 1u);
}

TEST_F(ServiceTest, TheOriginalPolicyIsSelectable) {
  ServiceOptions o = Options();
  o.params.policy = world::ServerPolicy::kOriginal;
  Service s(o);
  s.OnMessage(Msg("/vtl/request", "00"), FromSeconds(1));
  EXPECT_EQ(Responses(s.OnMessage(Msg("/vtl/request", "10"), FromSeconds(1))),
            (std::vector<std::string>{"10"}));
  EXPECT_TRUE(Responses(s.OnMessage(Msg("/vtl/free", "0"), FromSeconds(2))).empty());  // no queue
  EXPECT_FALSE(s.NextTimer());                                                         // no lease
}

// vtl.py:27-28 (lab commit 02c5ab4) decodes and indexes a request unchecked, and an exception in
// a paho callback ends the script (reference §7). The original policy stops where vtl.py died;
// fifo counts and ignores the same messages (MalformedPayloadsAreCountedAndServingGoesOn).
TEST_F(ServiceTest, TheOriginalPolicyStopsOnAMessageVtlPyWouldHaveDiedOn) {
  ServiceOptions o = Options();
  o.params.policy = world::ServerPolicy::kOriginal;
  for (const char* fatal : {"0x", "02", "0", ""}) {
    Service s(o);
    EXPECT_EQ(Responses(s.OnMessage(Msg("/vtl/request", "00"), FromSeconds(0.1))),
              (std::vector<std::string>{"01"}));
    EXPECT_FALSE(s.exit_reason());
    EXPECT_TRUE(Responses(s.OnMessage(Msg("/vtl/request", fatal), FromSeconds(0.2))).empty());
    ASSERT_TRUE(s.exit_reason()) << fatal;
    EXPECT_THAT(*s.exit_reason(),
                ::testing::StartsWith(std::string("vtl.py would have died on this message: "
                                                  "/vtl/request '") +
                                      fatal + "' ("));
    // the script is gone: nothing more is served
    EXPECT_TRUE(Responses(s.OnMessage(Msg("/vtl/request", "11"), FromSeconds(0.3))).empty());
    EXPECT_EQ(s.server().Holder(1), std::nullopt);
  }
  // what vtl.py survives is served or, where we cannot read it, counted as under fifo
  Service s(o);
  EXPECT_TRUE(Responses(s.OnMessage(Msg("/vtl/free", "x"), FromSeconds(0.1))).empty());
  EXPECT_TRUE(Responses(s.OnMessage(Msg("/vtl/request/car0", "a1"), FromSeconds(0.1))).empty());
  EXPECT_EQ(s.counters().malformed, 2u);
  EXPECT_FALSE(s.exit_reason());
  // a free that is not UTF-8 is fatal too (vtl.py:15), on a car's topic as on the lab's
  s.OnMessage(Msg("/vtl/free/car0", "\xff"), FromSeconds(0.2));
  ASSERT_TRUE(s.exit_reason());
  EXPECT_THAT(*s.exit_reason(), ::testing::HasSubstr("/vtl/free/car0 '\\xff' (UnicodeDecodeError"));
}

TEST_F(ServiceTest, AStepThatWouldHaveKilledVtlPyIsAnsweredWithAnError) {
  ServiceOptions o = Options(true);
  o.params.policy = world::ServerPolicy::kOriginal;
  Service s(o);
  sim::SimReset reset{"run1", {}, {0, 1}};
  reset.params.policy = world::ServerPolicy::kOriginal;
  s.OnMessage(Msg(std::string(sim::kSimResetTopic), sim::EncodeReset(reset)), {});
  const std::optional<sim::SimAck> ack = Ack(s.OnMessage(Step("/vtl/request", "07", 1, 0.5), {}));
  ASSERT_TRUE(ack);
  EXPECT_THAT(ack->error, ::testing::HasSubstr("vtl.py would have died on this message"));
  EXPECT_TRUE(s.exit_reason());
}

TEST_F(ServiceTest, StatusIsRetainedAndPublishedWhenTheStateChanges) {
  Service s(Options());
  std::vector<MqttMessage> out = s.OnMessage(Msg("/vtl/request", "01"), FromSeconds(0.1));
  ASSERT_EQ(out.back().topic, "/vtl/status");
  EXPECT_TRUE(out.back().retain);
  const Json status = Json::parse(out.back().payload);
  EXPECT_EQ(status["online"], true);
  EXPECT_EQ(status["intersections"][1]["holder"], 0);
  EXPECT_EQ(status["intersections"][0]["holder"], nullptr);
  // on the wall clock, the counters of a renewal are news too
  out = s.OnMessage(Msg("/vtl/request", "01"), FromSeconds(0.2));
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(Json::parse(out.back().payload)["counters"]["requests"], 2);
  EXPECT_EQ(Json::parse(s.Status(false).payload)["online"], false);
}

TEST_F(ServiceTest, ASimulationsStepsPublishStatusOnlyWhenTheStateChanges) {
  Service s(Options(true));
  s.OnMessage(Reset(), {});
  std::vector<MqttMessage> out = s.OnMessage(Step("/vtl/request", "01", 1, 1.0), {});
  EXPECT_EQ(out.back().topic, "/vtl/status");  // the holder changed
  out = s.OnMessage(Step("/vtl/request", "01", 2, 1.5), {});
  EXPECT_NE(out.back().topic, "/vtl/status");  // a renewal: response and ack only
  EXPECT_EQ(out.size(), 2u);
}

TEST_F(ServiceTest, SimulationStepsAreTakenOnceInOrderAtTheirTime) {
  Service s(Options(true));
  std::optional<sim::SimAck> ack = Ack(s.OnMessage(Reset(), kZeroTime));
  ASSERT_TRUE(ack);
  EXPECT_EQ(ack->seq, 0u);
  EXPECT_TRUE(ack->error.empty());

  // wall time is ignored: the tag says 5 s
  std::vector<MqttMessage> out = s.OnMessage(Step("/vtl/request", "00", 1, 5.0), FromSeconds(99));
  ack = Ack(out);
  ASSERT_TRUE(ack);
  EXPECT_EQ(ack->responses, (std::vector<std::string>{"01"}));
  EXPECT_EQ(ack->deadline, FromSeconds(7));
  EXPECT_EQ(out.front().Property(std::string(sim::kResponseProperty)), "run1 1 0");

  // a repeat (QoS 1 after a reconnect, or a retry) is answered from the cache, not re-applied
  const std::vector<MqttMessage> again = s.OnMessage(Step("/vtl/request", "00", 1, 5.0), {});
  EXPECT_EQ(Responses(again), (std::vector<std::string>{"01"}));
  EXPECT_EQ(s.server().counters().requests, 1u);
  EXPECT_EQ(s.counters().duplicates, 1u);

  // the lease tick comes as a clock step
  ack = Ack(s.OnMessage(Step("/vtl/request", "10", 2, 6.0), {}));
  ack = Ack(s.OnMessage(Msg(std::string(sim::kSimClockTopic), "run1 3 7000000000"), {}));
  ASSERT_TRUE(ack);
  EXPECT_EQ(ack->responses, (std::vector<std::string>{"11"}));  // car 0 silent: car 1 next
  EXPECT_EQ(ack->holders, (std::vector<std::pair<int, std::optional<int>>>{{0, 1}, {1, {}}}));

  // older steps are dropped; gaps, time going back and other runs are errors
  EXPECT_TRUE(s.OnMessage(Step("/vtl/request", "00", 2, 6.0), {}).empty());
  EXPECT_NE(Ack(s.OnMessage(Step("/vtl/free", "1", 5, 8.0), {}))->error.find("missing"),
            std::string::npos);
  EXPECT_NE(Ack(s.OnMessage(Step("/vtl/free", "1", 4, 6.5), {}))->error.find("back in time"),
            std::string::npos);
  EXPECT_NE(Ack(s.OnMessage(Step("/vtl/free", "1", 4, 8.0, "other"), {}))->error.find("run1"),
            std::string::npos);
  // and none of them stopped the server
  EXPECT_EQ(Ack(s.OnMessage(Step("/vtl/free", "1", 4, 8.0), {}))->responses.size(), 0u);
  EXPECT_EQ(s.server().Holder(0), std::nullopt);
}

// Issue 33: leases pause while the broker is away, on the wall clock (tlserver polls its
// connection) and on a simulation's clock (its broker_outage fault as /vtl/sim/disconnect).
TEST_F(ServiceTest, NoLeaseRunsOutWhileTheBrokerIsAway) {
  Service wall(Options());
  wall.OnMessage(Msg("/vtl/request", "00"), FromSeconds(1));
  wall.OnMessage(Msg("/vtl/request", "10"), FromSeconds(1.5));
  EXPECT_TRUE(wall.OnConnection(true, FromSeconds(1.6)).empty());  // up as before: nothing
  wall.OnConnection(false, FromSeconds(2));
  EXPECT_EQ(wall.NextTimer(), std::nullopt);
  EXPECT_TRUE(Responses(wall.OnTimer(FromSeconds(4))).empty());
  wall.OnConnection(true, FromSeconds(5));
  EXPECT_EQ(wall.NextTimer(), FromSeconds(7));  // a full lease (2 s) from the reconnect
  EXPECT_EQ(wall.server().Holder(0), 0);

  Service sim(Options(true));
  sim.OnMessage(Reset(), kZeroTime);
  sim.OnMessage(Step("/vtl/request", "00", 1, 1.0), {});
  sim.OnMessage(Step("/vtl/request", "10", 2, 1.5), {});
  EXPECT_TRUE(sim.OnConnection(false, FromSeconds(1.7)).empty());  // ignored: the sim says
  std::optional<sim::SimAck> ack =
      Ack(sim.OnMessage(Msg(std::string(sim::kSimDisconnectTopic), "run1 3 2000000000"), {}));
  ASSERT_TRUE(ack);
  EXPECT_EQ(ack->deadline, std::nullopt);
  ack = Ack(sim.OnMessage(Msg(std::string(sim::kSimReconnectTopic), "run1 4 5000000000"), {}));
  ASSERT_TRUE(ack);
  EXPECT_EQ(ack->deadline, FromSeconds(7));
  EXPECT_EQ(ack->holders, (std::vector<std::pair<int, std::optional<int>>>{{0, 0}, {1, {}}}));
}

TEST_F(ServiceTest, ANewRunResetsTheServer) {
  Service s(Options(true));
  s.OnMessage(Reset("run1"), {});
  s.OnMessage(Step("/vtl/request", "00", 1, 5.0), {});
  ASSERT_EQ(s.server().Holder(0), 0);
  const std::optional<sim::SimAck> ack = Ack(s.OnMessage(Reset("run2"), {}));
  ASSERT_TRUE(ack);
  EXPECT_EQ(ack->epoch, "run2");
  EXPECT_EQ(s.server().Holder(0), std::nullopt);
  EXPECT_EQ(s.server().counters().requests, 0u);
  // time starts again at 0 for the new run
  EXPECT_TRUE(Ack(s.OnMessage(Step("/vtl/request", "10", 1, 0.5, "run2"), {}))->error.empty());
}

TEST_F(ServiceTest, UntaggedCarMessagesAreServedAtTheLastSimulatedTime) {
  Service s(Options(true));
  s.OnMessage(Reset(), {});
  s.OnMessage(Step("/vtl/request", "00", 1, 5.0), {});
  EXPECT_EQ(Responses(s.OnMessage(Msg("/vtl/request", "10"), FromSeconds(1000))),
            (std::vector<std::string>{"10"}));
  EXPECT_EQ(s.counters().unclocked, 1u);
}

TEST_F(ServiceTest, AWallClockServerAnswersASimulationWithAnError) {
  Service s(Options(false));
  const std::optional<sim::SimAck> ack = Ack(s.OnMessage(Reset(), {}));
  ASSERT_TRUE(ack);
  EXPECT_NE(ack->error.find("--sim-clock"), std::string::npos);
}

// ---------------------------------------------------------------------------------------------
// The program on a real broker

class TlserverProcessTest : public ::testing::Test {
 protected:
  void SetUp() override { broker_ = t::StartSecureBroker(); }

  // Starts tlserver and waits until its retained status is online.
  std::unique_ptr<sim::ChildProcess> Start(std::vector<std::string> args) {
    auto server =
        t::StartTlserver(*broker_, std::move(args), "tlserver" + std::to_string(started_++));
    const bool online = t::WaitUntil([&] {
      const t::ToolResult r = t::RunTool(*broker_, "mosquitto_sub", "monitor",
                                         {"-t", "/vtl/status", "-C", "1", "-W", "2"});
      return r.output.find("\"online\":true") != std::string::npos;
    });
    EXPECT_TRUE(online) << server->LogTail();
    return server;
  }
  std::string Status() {
    return t::RunTool(*broker_, "mosquitto_sub", "monitor",
                      {"-t", "/vtl/status", "-C", "1", "-W", "5"})
        .output;
  }
  // A mosquitto_sub of /vtl/response (and the retained status, which tells that it listens).
  std::unique_ptr<t::Sub> Watch(const std::string& name) {
    auto sub = std::make_unique<t::Sub>(
        *broker_, "monitor", std::vector<std::string>{"/vtl/status", "/vtl/response"}, name);
    EXPECT_TRUE(sub->WaitFor("/vtl/status"));
    return sub;
  }

  // The counters of the retained status.
  Json Counters() {
    const std::string text = Status();
    const Json status = Json::parse(text, nullptr, false);
    return status.is_object() ? status["counters"] : Json::object();
  }

  std::unique_ptr<sim::LocalBroker> broker_;
  int started_{0};
};

TEST_F(TlserverProcessTest, ServesCarsOverTheBrokerWithQueueAndLaterGrant) {
  auto server = Start({"--lease-s", "600"});  // no expiry however slow the machine
  auto sub = Watch("responses");
  EXPECT_EQ(t::Pub(*broker_, "car0", "/vtl/request/car0", "00").exit_code, 0);
  EXPECT_TRUE(sub->WaitFor("/vtl/response 01")) << sub->Output();
  EXPECT_EQ(t::Pub(*broker_, "car1", "/vtl/request/car1", "10").exit_code, 0);
  EXPECT_TRUE(sub->WaitFor("/vtl/response 10")) << sub->Output();
  EXPECT_EQ(t::Pub(*broker_, "car0", "/vtl/free/car0", "0").exit_code, 0);
  EXPECT_TRUE(sub->WaitFor("/vtl/response 11")) << sub->Output();
  EXPECT_NE(Status().find("\"holder\":1"), std::string::npos);
}

TEST_F(TlserverProcessTest, MalformedPayloadsAreRejectedLoggedCountedAndServingGoesOn) {
  auto server = Start({});
  auto sub = Watch("responses");
  for (const char* bad : {"abc", "0", "123", "9x"}) {
    EXPECT_EQ(t::Pub(*broker_, "car0", "/vtl/request/car0", bad).exit_code, 0);
  }
  EXPECT_EQ(
      t::RunTool(*broker_, "mosquitto_pub", "car0", {"-q", "1", "-t", "/vtl/request/car0", "-n"})
          .exit_code,
      0);  // an empty payload
  EXPECT_EQ(t::Pub(*broker_, "autonomsim", "/vtl/sim/clock", "garbage").exit_code, 0);
  EXPECT_EQ(t::Pub(*broker_, "car0", "/vtl/request/car0", "01").exit_code, 0);
  EXPECT_TRUE(sub->WaitFor("/vtl/response 01")) << sub->Output();
  EXPECT_TRUE(t::WaitUntil([&] { return Status().find("\"malformed\":6") != std::string::npos; }))
      << Status();
  EXPECT_NE(server->LogTail(20000).find("rejected /vtl/request/car0 'abc'"), std::string::npos)
      << server->LogTail();
  EXPECT_TRUE(server->Running());
}

TEST_F(TlserverProcessTest, ASilentCarLosesItsGrantAfterTheLease) {
  auto server = Start({"--lease-s", "0.5"});
  auto sub = Watch("responses");
  t::Pub(*broker_, "car0", "/vtl/request/car0", "01");
  EXPECT_TRUE(sub->WaitFor("/vtl/response 01"));
  t::Pub(*broker_, "car1", "/vtl/request/car1", "11");
  EXPECT_TRUE(sub->WaitFor("/vtl/response 10"));
  // car 0 says nothing more; car 1 keeps asking until its lease-driven grant
  EXPECT_TRUE(t::WaitUntil([&] {
    t::Pub(*broker_, "car1", "/vtl/request/car1", "11");
    return sub->Output().find("/vtl/response 11") != std::string::npos;
  })) << sub->Output();
  EXPECT_TRUE(t::WaitUntil([&] { return Counters().value("lease_expiries", 0) >= 1; })) << Status();
}

TEST_F(TlserverProcessTest, TheOriginalPolicyNeverGrantsADeniedCarUnlessItAsksAgain) {
  auto server = Start({"--policy", "original"});
  auto sub = Watch("responses");
  t::Pub(*broker_, "car0", "/vtl/request/car0", "00");
  t::Pub(*broker_, "car1", "/vtl/request/car1", "10");
  EXPECT_TRUE(sub->WaitFor("/vtl/response 10"));
  t::Pub(*broker_, "car0", "/vtl/free/car0", "0");
  // the free is processed before the next request, and it granted nobody
  t::Pub(*broker_, "car2", "/vtl/request/car2", "21");
  EXPECT_TRUE(sub->WaitFor("/vtl/response 21"));
  EXPECT_EQ(sub->Output().find("/vtl/response 11"), std::string::npos) << sub->Output();
}

// vtl.py:28 (lab commit 02c5ab4): int('x') raises in the callback, and the script ends.
TEST_F(TlserverProcessTest, TheOriginalPolicyExitsOnAMessageVtlPyWouldHaveDiedOn) {
  auto server = Start({"--policy", "original"});
  auto sub = Watch("responses");
  t::Pub(*broker_, "car0", "/vtl/request/car0", "00");
  EXPECT_TRUE(sub->WaitFor("/vtl/response 01")) << sub->Output();
  t::Pub(*broker_, "car0", "/vtl/request/car0", "0x");
  const std::optional<int> code = server->Wait(t::kWait);
  ASSERT_TRUE(code) << server->LogTail();
  EXPECT_EQ(*code, 1) << server->LogTail();
  EXPECT_NE(server->LogTail().find("vtl.py would have died on this message: /vtl/request/car0 "
                                   "'0x' (ValueError: invalid literal for int() with base 10: "
                                   "'x' (vtl.py:28)); stopping as it did"),
            std::string::npos)
      << server->LogTail();
  EXPECT_NE(Status().find("\"online\":false"), std::string::npos);
}

TEST_F(TlserverProcessTest, ForgedResponsesAndRequestsForAnotherCarAreRefused) {
  auto server = Start({"--lease-s", "600"});
  auto observer = t::Connect(*broker_, "monitor", "observer", {"/vtl/response"});

  // a car may not publish responses (nor status, nor drive the clock): the broker refuses
  for (const char* topic : {"/vtl/response", "/vtl/status", "/vtl/sim/clock"}) {
    const t::ToolResult forged = t::Pub(*broker_, "car1", topic, "11", {"-V", "5"});
    EXPECT_EQ(forged.exit_code, 0) << forged.output;  // logged in, but the message was refused
    EXPECT_NE(forged.output.find("Not authorized"), std::string::npos) << topic << forged.output;
  }
  // a car may not publish on another car's topic, nor on the lab's shared topics
  for (const char* topic : {"/vtl/request/car0", "/vtl/request", "/vtl/free/car0"}) {
    const t::ToolResult other = t::Pub(*broker_, "car1", topic, "00", {"-V", "5"});
    EXPECT_EQ(other.exit_code, 0) << other.output;
    EXPECT_NE(other.output.find("Not authorized"), std::string::npos) << topic << other.output;
  }
  // on its own topic, a request in another car's name: the server refuses it
  EXPECT_EQ(t::Pub(*broker_, "car1", "/vtl/request/car1", "00").exit_code, 0);
  // a real request: its grant is the first response anyone sees, so nothing forged got through
  EXPECT_EQ(t::Pub(*broker_, "car0", "/vtl/request/car0", "01").exit_code, 0);
  const std::optional<MqttMessage> first = t::ReceiveOn(*observer, "/vtl/response");
  ASSERT_TRUE(first);
  EXPECT_EQ(first->payload, "01");
  EXPECT_TRUE(t::WaitUntil([&] { return Status().find("\"refused\":1") != std::string::npos; }))
      << Status();
  // and a wrong password does not get in at all
  const t::ToolResult intruder = t::RunTool(*broker_, "mosquitto_pub", "car0",
                                            {"-P", "guess", "-t", "/vtl/request", "-m", "0"});
  EXPECT_NE(intruder.exit_code, 0);
}

TEST_F(TlserverProcessTest, ShutsDownCleanlyOnSigtermAndSigint) {
  for (int signal_number : {SIGTERM, SIGINT}) {
    auto server = Start({});
    server->Signal(signal_number);
    const std::optional<int> code = server->Wait(t::kWait);
    ASSERT_TRUE(code) << server->LogTail();
    EXPECT_EQ(*code, 0) << server->LogTail();
    EXPECT_NE(server->LogTail().find("tlserver stopped"), std::string::npos) << server->LogTail();
    EXPECT_NE(Status().find("\"online\":false"), std::string::npos);
  }
}

TEST_F(TlserverProcessTest, RefusedCredentialsAndBadOptionsExitWithCode2) {
  sim::ChildProcess wrong(
      {sim::FindTlserver().string(), "--host", broker_->host(), "--port",
       std::to_string(broker_->port()), "--username", "tlserver", "--password", "wrong"},
      broker_->dir() / "wrong.log");
  EXPECT_EQ(wrong.Wait(t::kWait), 2) << wrong.LogTail();
  sim::ChildProcess bad({sim::FindTlserver().string(), "--intersections", "0,0"},
                        broker_->dir() / "bad.log");
  EXPECT_EQ(bad.Wait(t::kWait), 2) << bad.LogTail();
}

// No request, grant or free is lost over a broker restart: a car's QoS 1 request published
// while the broker is down reaches tlserver afterwards, and its grant reaches the car.
TEST_F(TlserverProcessTest, ABrokerRestartLosesNoRequestGrantOrFree) {
  auto server = Start({"--lease-s", "600"});
  auto car0 = t::Connect(*broker_, "car0", "car0-session", {"/vtl/response"});
  car0->Publish({.topic = "/vtl/request/car0", .payload = "00"});
  std::optional<MqttMessage> r = t::ReceiveOn(*car0, "/vtl/response");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->payload, "01");

  broker_->Stop();
  car0->Publish({.topic = "/vtl/free/car0", .payload = "0"});      // while the broker is down
  car0->Publish({.topic = "/vtl/request/car0", .payload = "01"});  // ditto
  broker_->Start();
  r = t::ReceiveOn(*car0, "/vtl/response");
  ASSERT_TRUE(r) << server->LogTail();
  EXPECT_EQ(r->payload, "01");
  EXPECT_TRUE(t::WaitUntil([&] {
    const std::string s = Status();
    return s.find("\"frees\":1") != std::string::npos &&
           s.find("\"requests\":2") != std::string::npos;
  })) << Status();
  EXPECT_TRUE(server->Running());
}

// Issue 15: the broker crashes (SIGKILL) and the cars' frees are lost with it; each car still holds
// one intersection and keeps asking for the other's. The lease ends each stale grant one lease
// after its holder's last request for it (under per-car liveness they waited as long as they
// talked).
TEST_F(TlserverProcessTest, AfterABrokerCrashLosesTheFreesEveryIntersectionIsGrantedAgain) {
  auto server = Start({"--lease-s", "2"});
  auto car1 = t::Connect(*broker_, "car1", "car1-session", {"/vtl/response"});
  auto car2 = t::Connect(*broker_, "car2", "car2-session", {"/vtl/response"});
  car1->Publish({.topic = "/vtl/request/car1", .payload = "10"});
  car2->Publish({.topic = "/vtl/request/car2", .payload = "21"});
  EXPECT_TRUE(t::WaitUntil([&] {
    const std::string s = Status();
    return s.find("\"grants\":2") != std::string::npos;
  })) << Status();

  broker_->Kill();  // the frees the cars would send now are lost
  broker_->Start();
  const auto restarted = std::chrono::steady_clock::now();
  bool car1_granted = false, car2_granted = false;
  t::WaitUntil([&] {
    car1->Publish({.topic = "/vtl/request/car1", .payload = "11"});  // the other's intersection
    car2->Publish({.topic = "/vtl/request/car2", .payload = "20"});
    const auto until = std::chrono::steady_clock::now() + std::chrono::milliseconds(500);
    while (std::optional<MqttMessage> m = car1->Receive(until)) {
      if (m->topic == "/vtl/response" && m->payload == "11") car1_granted = true;
      if (m->topic == "/vtl/response" && m->payload == "21") car2_granted = true;
    }
    return car1_granted && car2_granted;
  });
  EXPECT_TRUE(car1_granted && car2_granted) << Status() << server->LogTail();
  std::cout << "both intersections granted again "
            << std::chrono::duration<double>(std::chrono::steady_clock::now() - restarted).count()
            << " s after the broker's restart (lease 2 s)\n";
  EXPECT_TRUE(server->Running());
}

// Issue 33: the broker is killed while car 0 holds intersection 0 and car 1 waits for it, and
// stays away longer than the lease. Before, car 0's lease ran out meanwhile and car 1, asking
// again after the restart, was granted an intersection car 0 might still be inside. Now the lease
// pauses: car 1 is denied until car 0 has been silent for a lease after the broker came back.
TEST_F(TlserverProcessTest, ALeaseDoesNotRunOutWhileTheBrokerIsAway) {
  auto server = Start({"--lease-s", "2"});
  auto car1 = t::Connect(*broker_, "car1", "car1-session", {"/vtl/response"});
  // car 1's next answer on /vtl/response (the broadcast carries every car's)
  const auto answer_to_car1 = [&](std::chrono::milliseconds within) {
    const auto until = std::chrono::steady_clock::now() + within;
    while (std::optional<MqttMessage> m = car1->Receive(until)) {
      if (m->topic == "/vtl/response" && m->payload.rfind('1', 0) == 0) return m->payload;
    }
    return std::string("none");
  };
  auto car0 = t::Connect(*broker_, "car0", "car0-session", {"/vtl/response"});
  car0->Publish({.topic = "/vtl/request/car0", .payload = "00"});
  std::optional<MqttMessage> r = t::ReceiveOn(*car0, "/vtl/response");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->payload, "01");
  car1->Publish({.topic = "/vtl/request/car1", .payload = "10"});
  EXPECT_EQ(answer_to_car1(std::chrono::seconds(2)), "10");

  broker_->Kill();
  std::this_thread::sleep_for(std::chrono::seconds(3));  // longer than the lease
  broker_->Start();
  std::string first_answer = "none";
  t::WaitUntil([&] {
    car1->Publish({.topic = "/vtl/request/car1", .payload = "10"});
    first_answer = answer_to_car1(std::chrono::milliseconds(300));
    return first_answer != "none";
  });
  EXPECT_EQ(first_answer, "10") << server->LogTail();  // car 0 keeps its grant
  EXPECT_NE(server->LogTail().find("leases paused"), std::string::npos) << server->LogTail();
  // car 0 stays silent: one lease after the broker came back, car 1 is granted
  bool granted = false;
  t::WaitUntil([&] {
    car1->Publish({.topic = "/vtl/request/car1", .payload = "10"});
    granted = answer_to_car1(std::chrono::milliseconds(500)) == "11";
    return granted;
  });
  EXPECT_TRUE(granted) << Status() << server->LogTail();
  EXPECT_TRUE(server->Running());
}

// The shipped broker setup (tools/mosquitto/mosquitto.conf, acl, passwords.example), moved to a
// free loopback port and a private directory, works as its README says.
TEST(ShippedBrokerConfigTest, StartsAndEnforcesTheAcl) {
  sim::TempDir files("autonomsim-shipped-conf-");
  const std::string dir = files.path().string() + "/";
  std::string conf = t::ReadText("tools/mosquitto/mosquitto.conf");
  ASSERT_FALSE(conf.empty());
  auto replace_all = [&](const std::string& from, const std::string& to) {
    for (std::size_t at = conf.find(from); at != std::string::npos;
         at = conf.find(from, at + to.size())) {
      conf.replace(at, from.size(), to);
    }
  };
  replace_all("listener 1883\n", "");  // LocalBroker listens on a free loopback port
  replace_all("/etc/mosquitto/vtl/", dir);
  replace_all("/var/lib/mosquitto/", dir);
  std::ofstream(dir + "acl") << t::ReadText("tools/mosquitto/acl");
  std::ofstream(dir + "passwords") << t::ReadText("tools/mosquitto/passwords.example");
  sim::ChildProcess hash(
      {sim::FindProgram("mosquitto_passwd", "mosquitto").string(), "-U", dir + "passwords"},
      dir + "mosquitto_passwd.log");
  ASSERT_EQ(hash.Wait(t::kWait), 0) << hash.LogTail();
  sim::LocalBroker broker(sim::LocalBrokerOptions{.config = conf});
  // (a second -P overrides the fixture's password)
  auto pub = [&](const std::string& user, const std::string& topic) {
    return t::RunTool(broker, "mosquitto_pub", user,
                      {"-P", "change-me-" + user, "-V", "5", "-q", "1", "-t", topic, "-m", "01"});
  };
  for (const auto& [user, topic] :
       {std::pair{"car0", "/vtl/request/car0"}, std::pair{"tlserver", "/vtl/response"}}) {
    const t::ToolResult allowed = pub(user, topic);
    EXPECT_EQ(allowed.exit_code, 0) << allowed.output;
    EXPECT_EQ(allowed.output.find("Not authorized"), std::string::npos) << allowed.output;
  }
  const t::ToolResult denied = pub("car0", "/vtl/response");
  EXPECT_EQ(denied.exit_code, 0) << denied.output;  // connected, but the message was refused
  EXPECT_NE(denied.output.find("Not authorized"), std::string::npos) << denied.output;
  EXPECT_NE(
      t::RunTool(broker, "mosquitto_pub", "car0", {"-t", "/vtl/request/car0", "-m", "0"}).exit_code,
      0);  // the fixture's password is not the shipped example's
}

// TLS: a broker that speaks only TLS, with a certificate from a CA made for the test; tlserver
// and a car connect with --cafile, a client without TLS does not get in.
TEST(TlserverTlsTest, ServesOverTls) {
  sim::TempDir certs("autonomsim-tls-test-");
  const std::string dir = certs.path().string() + "/";
  auto openssl = [&](std::vector<std::string> args) {
    args.insert(args.begin(), sim::FindProgram("openssl", "openssl").string());
    sim::ChildProcess p(args, dir + "openssl.log");
    ASSERT_EQ(p.Wait(t::kWait), 0) << p.LogTail();
  };
  std::ofstream(dir + "san.ext") << "subjectAltName=IP:127.0.0.1\n";
  const std::vector<std::string> ec_key{"-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1",
                                        "-nodes"};
  std::vector<std::string> ca{
      "req",     "-x509",        "-days", "1",           "-subj", "/CN=autonomsim test CA",
      "-keyout", dir + "ca.key", "-out",  dir + "ca.crt"};
  ca.insert(ca.begin() + 1, ec_key.begin(), ec_key.end());
  openssl(ca);
  std::vector<std::string> csr{
      "req", "-subj", "/CN=127.0.0.1", "-keyout", dir + "server.key", "-out", dir + "server.csr"};
  csr.insert(csr.begin() + 1, ec_key.begin(), ec_key.end());
  openssl(csr);
  openssl({"x509", "-req", "-days", "1", "-in", dir + "server.csr", "-CA", dir + "ca.crt", "-CAkey",
           dir + "ca.key", "-CAcreateserial", "-extfile", dir + "san.ext", "-out",
           dir + "server.crt"});
  if (::testing::Test::HasFatalFailure()) return;

  sim::LocalBroker broker(
      sim::LocalBrokerOptions{.users = t::AclUsers(),
                              .acl = t::ShippedAcl(),
                              .listener_config = "cafile " + dir + "ca.crt\ncertfile " + dir +
                                                 "server.crt\nkeyfile " + dir + "server.key"});
  auto server = t::StartTlserver(broker, {"--cafile", dir + "ca.crt"});
  sim::MqttOptions options;
  options.host = broker.host();
  options.port = broker.port();
  options.client_id = "car0-tls";
  options.username = "car0";
  options.password = "pw-car0";
  options.cafile = dir + "ca.crt";
  auto car0 = sim::MakeMosquittoClient(options);
  car0->Subscribe("/vtl/response", 1);
  car0->Subscribe("/vtl/status", 1);
  ASSERT_TRUE(car0->WaitReady(t::Clock::now() + t::kWait));
  // once tlserver is online (its retained status says so), ask
  ASSERT_TRUE(t::WaitUntil([&] {
    const std::optional<MqttMessage> status =
        t::ReceiveOn(*car0, "/vtl/status", std::chrono::milliseconds(100));
    return status && status->payload.find("\"online\":true") != std::string::npos;
  })) << server->LogTail();
  car0->Publish({.topic = "/vtl/request/car0", .payload = "01"});
  const std::optional<MqttMessage> grant = t::ReceiveOn(*car0, "/vtl/response");
  ASSERT_TRUE(grant) << server->LogTail();
  EXPECT_EQ(grant->payload, "01");

  // without TLS: no connection
  const t::ToolResult plain =
      t::RunTool(broker, "mosquitto_pub", "car0", {"-t", "/vtl/request/car0", "-m", "01"});
  EXPECT_NE(plain.exit_code, 0) << plain.output;
  const t::ToolResult tls =
      t::RunTool(broker, "mosquitto_pub", "car0",
                 {"--cafile", dir + "ca.crt", "-q", "1", "-t", "/vtl/request/car0", "-m", "01"});
  EXPECT_EQ(tls.exit_code, 0) << tls.output;
}

}  // namespace
}  // namespace autonomsim::tlserver
