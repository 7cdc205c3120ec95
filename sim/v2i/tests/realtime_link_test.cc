// The real-time link through a real mosquitto (with the shipped ACL): what the simulated cars send
// is the lab's plain protocol and nothing more, a response reaches every simulated car at the
// simulated time of the slice in which it arrived, and a broker that cannot be used is an error
// that names it.
#include "sim/v2i/realtime_link.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>

#include "sim/mqtt/tests/mqtt_fixture.h"

namespace autonomsim::sim {
namespace {

using ::testing::HasSubstr;

MqttLinkConfig RealTimeConfig(const LocalBroker& broker) {
  MqttLinkConfig config;
  config.broker = broker.address();
  config.username = "autonomsim";
  config.password_file = broker.PasswordFile("autonomsim").string();
  return config;
}

struct Arrival {
  int car;
  std::string payload;
  Time t;
  friend bool operator==(const Arrival&, const Arrival&) = default;
};

TEST(RealTimeLinkTest, SendsThePlainProtocolAndDeliversResponsesAtTheSliceTime) {
  auto broker = testing::StartSecureBroker();
  auto server = testing::Connect(*broker, "tlserver", "server", {"/vtl/request", "/vtl/free"});
  auto monitor = testing::Connect(*broker, "monitor", "monitor", {"/vtl/#"});
  Kernel kernel;
  std::vector<Arrival> arrivals;
  auto link = ConnectRealTimeLink(RealTimeConfig(*broker), &kernel, {0, 1},
                                  [&](int car, const world::V2IMessage& m) {
                                    arrivals.push_back({car, m.payload, kernel.Now()});
                                  });
  kernel.RunUntil(std::chrono::seconds(2));

  // the cars' messages: the shared topics, the lab's payloads, QoS 1, no properties
  link->SendToServer(0, world::ToMessage(world::Request{.car = 0, .intersection = 1}));
  link->SendToServer(1, world::ToMessage(world::Free{.car = 1}));
  const std::optional<MqttMessage> request = testing::ReceiveOn(*server, "/vtl/request");
  ASSERT_TRUE(request);
  EXPECT_EQ(request->payload, "01");
  EXPECT_EQ(request->qos, 1);
  EXPECT_TRUE(request->properties.empty());
  const std::optional<MqttMessage> free = testing::ReceiveOn(*server, "/vtl/free");
  ASSERT_TRUE(free);
  EXPECT_EQ(free->payload, "1");
  EXPECT_EQ(link->sent(), 2u);

  // the server answers; a response for a real car (9) goes to the simulated cars too, who drop it
  for (const char* payload : {"01", "90"}) {
    server->Publish({.topic = "/vtl/response", .payload = payload, .qos = 1});
  }
  ASSERT_TRUE(testing::WaitUntil([&] {
    link->DeliverReceived();
    return link->received() == 2;
  }));
  EXPECT_TRUE(arrivals.empty());  // scheduled, not yet run
  kernel.RunUntil(std::chrono::seconds(2) + std::chrono::milliseconds(10));
  const Time at = std::chrono::seconds(2);
  EXPECT_EQ(arrivals,
            (std::vector<Arrival>{{0, "01", at}, {1, "01", at}, {0, "90", at}, {1, "90", at}}));

  // everything on the broker: the four messages above, nothing of the lock-step protocol
  std::vector<std::string> seen;
  while (std::optional<MqttMessage> m =
             monitor->Receive(testing::Clock::now() + std::chrono::milliseconds(500))) {
    if (m->topic == "/vtl/status") continue;  // none here, but a tlserver would publish it
    seen.push_back(m->topic + " " + m->payload);
    EXPECT_TRUE(m->properties.empty()) << m->topic;
  }
  EXPECT_EQ(seen, (std::vector<std::string>{"/vtl/request 01", "/vtl/free 1", "/vtl/response 01",
                                            "/vtl/response 90"}));
}

TEST(RealTimeLinkTest, NothingButRequestsAndFreesGoesOut) {
  auto broker = testing::StartSecureBroker();
  Kernel kernel;
  auto link = ConnectRealTimeLink(RealTimeConfig(*broker), &kernel, {0},
                                  [](int, const world::V2IMessage&) {});
  EXPECT_THROW(link->Broadcast(world::ToMessage(world::Response{.car = 0, .granted = true})),
               std::logic_error);
  EXPECT_THROW(link->SendToServer(0, world::ToMessage(world::Response{.car = 0, .granted = true})),
               std::logic_error);
  EXPECT_EQ(link->sent(), 0u);
  EXPECT_TRUE(link->Flush(std::chrono::seconds(5)));
}

TEST(RealTimeLinkTest, ABrokerThatCannotBeReachedOrRefusesUsIsAnErrorNamingIt) {
  auto broker = testing::StartSecureBroker();
  Kernel kernel;
  auto to_car = [](int, const world::V2IMessage&) {};

  // wrong password
  const std::filesystem::path wrong = broker->dir() / "wrong_password";
  std::ofstream(wrong) << "not-the-password\n";
  MqttLinkConfig refused = RealTimeConfig(*broker);
  refused.password_file = wrong.string();
  try {
    ConnectRealTimeLink(refused, &kernel, {0}, to_car);
    FAIL() << "no error";
  } catch (const MqttError& e) {
    EXPECT_THAT(e.what(), HasSubstr("real-time link"));
    EXPECT_THAT(e.what(), HasSubstr(broker->address()));
  }

  // nobody listening
  const testing::RefusingPort nobody;
  MqttLinkConfig gone = RealTimeConfig(*broker);
  gone.broker = nobody.address();
  gone.timeout = std::chrono::seconds(1);
  try {
    ConnectRealTimeLink(gone, &kernel, {0}, to_car);
    ADD_FAILURE() << "no error";
  } catch (const MqttError& e) {
    EXPECT_THAT(e.what(), HasSubstr("cannot reach the MQTT broker " + gone.broker));
  }
}

}  // namespace
}  // namespace autonomsim::sim
