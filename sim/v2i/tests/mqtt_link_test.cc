// The mqtt link end to end: cars' V2I traffic (the scripted cars of scripted_cars.h) through a real
// mosquitto to a real `tlserver --sim-clock`, on a sim::Kernel with the modeled WLAN (latency,
// jitter, loss) of EmbeddedV2ILink, compared with the in-process server: same responses at the
// same simulated times, same state, same counters, also across broker restarts. What a message
// costs in wall time is bench/bench_mqtt.cc's to measure.
#include <gtest/gtest.h>

#include <condition_variable>
#include <iostream>
#include <mutex>
#include <sstream>
#include <thread>

#include "sim/core/priorities.h"
#include "sim/mqtt/tests/mqtt_fixture.h"
#include "sim/v2i/mqtt_endpoint.h"
#include "sim/v2i/tests/scripted_cars.h"
#include "sim/v2i/traffic_light_node.h"

namespace autonomsim::sim {
namespace {

using testing::Clock;
using testing::kScriptSeed;
using testing::ScriptedCars;

world::TrafficLightServerParams Params() { return testing::ScriptedServerParams(); }

const Time kEnd = std::chrono::seconds(60);

// `extra_events_s`: no-op kernel events, to match a run that has events of its own there.
std::string EmbeddedRun(const std::vector<int>& extra_events_s = {}) {
  ScriptedCars h(std::make_unique<EmbeddedTrafficLightEndpoint>(Params(), std::vector<int>{0, 1}),
                 kScriptSeed);
  for (int t_s : extra_events_s) {
    h.kernel().ScheduleAt(
        std::chrono::seconds(t_s), [] {}, kPriorityWorldChange);
  }
  return h.Run(kEnd);
}

TEST(MqttLinkTest, TheScriptExercisesQueuesLeasesAndLoss) {
  const std::string log = EmbeddedRun();
  EXPECT_NE(log.find("lost car"), std::string::npos);
  EXPECT_NE(log.find("car1 got 10"), std::string::npos);  // told occupied (queued) ...
  EXPECT_NE(log.find("car1 got 11"), std::string::npos);  // ... and granted later
  const std::size_t counters = log.find("counters ");
  ASSERT_NE(counters, std::string::npos);
  std::istringstream in(log.substr(counters + 9));
  std::uint64_t requests = 0, grants = 0, denials = 0, frees = 0, expiries = 0;
  in >> requests >> grants >> denials >> frees >> expiries;
  EXPECT_GT(frees, 3u);
  EXPECT_GE(expiries, 1u);  // car 2 went silent
}

TEST(MqttLinkTest, ARunThroughARealBrokerAndTlserverEqualsTheEmbeddedRun) {
  const std::string expected = EmbeddedRun();
  // broker: "" → the link starts a private mosquitto and tlserver, as a run does
  ScriptedCars h(MakeMqttEndpoint(MqttLinkConfig{}, Params(), {0, 1}), kScriptSeed);
  EXPECT_EQ(h.Run(kEnd), expected);
}

// The broker goes down and comes back twice while the run goes on: clients reconnect, sessions
// and queued QoS 1 messages survive (persistence), repeats are answered from the server's cache,
// and the run is still the embedded one.
TEST(MqttLinkTest, BrokerRestartsDuringTheRunLoseNothing) {
  const std::vector<int> restarts_s{15, 35};
  const std::string expected = EmbeddedRun(restarts_s);
  auto broker = testing::StartSecureBroker();
  auto tlserver = testing::StartTlserver(*broker, {"--sim-clock"});
  MqttOptions options;
  options.host = broker->host();
  options.port = broker->port();
  options.client_id = "autonomsim-restart-test";
  options.username = "autonomsim";
  options.password = "pw-autonomsim";
  auto endpoint = std::make_unique<MqttTrafficLightEndpoint>(
      MakeMosquittoClient(options), Params(), std::vector<int>{0, 1},
      MqttEndpointOptions{.epoch = NewEpoch(),
                          .timeout = std::chrono::seconds(30),
                          .broker_address = broker->address()});
  MqttTrafficLightEndpoint* raw = endpoint.get();
  ScriptedCars h(std::move(endpoint), kScriptSeed);

  // The broker's process must stay the child of a thread that lives until it is stopped
  // (PR_SET_PDEATHSIG), so one thread restarts it and stops it at the end.
  std::mutex mu;
  std::condition_variable cv;
  int restarts_requested = 0, restarts_done = 0;
  bool finished = false;
  std::thread restarter([&] {
    std::unique_lock lock(mu);
    for (;;) {
      cv.wait(lock, [&] { return finished || restarts_requested > restarts_done; });
      if (restarts_requested > restarts_done) {
        lock.unlock();
        broker->Restart();
        lock.lock();
        ++restarts_done;
        cv.notify_all();
        continue;
      }
      break;
    }
    lock.unlock();
    broker->Stop();
  });
  auto restart_async = [&] {
    std::lock_guard lock(mu);
    ++restarts_requested;
    cv.notify_all();
  };
  for (int t_s : restarts_s) {
    h.kernel().ScheduleAt(std::chrono::seconds(t_s), restart_async, kPriorityWorldChange);
  }
  std::string log;
  try {
    log = h.Run(kEnd);
  } catch (...) {
    {
      std::lock_guard lock(mu);
      finished = true;
      cv.notify_all();
    }
    restarter.join();
    throw;
  }
  {
    std::unique_lock lock(mu);
    cv.wait_for(lock, testing::kWait, [&] { return restarts_done == restarts_requested; });
    EXPECT_EQ(restarts_done, 2);
    finished = true;
    cv.notify_all();
  }
  restarter.join();
  EXPECT_EQ(log, expected);
  std::cout << "broker restarts: " << raw->stats().resends << " resends, " << raw->stats().ignored
            << " messages ignored, longest wait "
            << std::chrono::duration<double>(raw->stats().wait_max).count() << " s\n";
  EXPECT_TRUE(tlserver->Running()) << tlserver->LogTail();
}

TEST(MqttLinkTest, AWallClockTlserverRefusesToServeASimulation) {
  auto broker = testing::StartSecureBroker();
  auto tlserver = testing::StartTlserver(*broker, {});
  MqttOptions options;
  options.host = broker->host();
  options.port = broker->port();
  options.client_id = "autonomsim-wall-test";
  options.username = "autonomsim";
  options.password = "pw-autonomsim";
  try {
    MqttTrafficLightEndpoint endpoint(
        MakeMosquittoClient(options), Params(), {0, 1},
        MqttEndpointOptions{
            .epoch = NewEpoch(), .timeout = testing::kWait, .broker_address = broker->address()});
    FAIL() << "a wall-clock tlserver took a simulation";
  } catch (const MqttError& e) {
    EXPECT_NE(std::string(e.what()).find("--sim-clock"), std::string::npos) << e.what();
  }
}

TEST(MqttLinkTest, NoTlserverOnTheBrokerIsAClearErrorWithinTheTimeout) {
  auto broker = testing::StartSecureBroker();
  const std::string password_file = broker->PasswordFile("autonomsim").string();
  MqttLinkConfig config;
  config.broker = broker->address();
  config.password_file = password_file;
  config.timeout = std::chrono::seconds(1);
  const auto start = Clock::now();
  try {
    MakeMqttEndpoint(config, Params(), {0, 1});
    FAIL() << "no error";
  } catch (const MqttError& e) {
    EXPECT_NE(std::string(e.what()).find("is a `tlserver --sim-clock` serving this broker?"),
              std::string::npos)
        << e.what();
  }
  EXPECT_LT(Clock::now() - start, testing::kWait);
}

TEST(MqttLinkTest, WrongCredentialsAreRefusedAtOnce) {
  auto broker = testing::StartSecureBroker();
  MqttLinkConfig config;
  config.broker = broker->address();
  config.username = "car0";  // a car's user, with the simulation's password file
  config.password_file = broker->PasswordFile("autonomsim").string();
  try {
    MakeMqttEndpoint(config, Params(), {0, 1});
    FAIL() << "no error";
  } catch (const MqttError& e) {
    EXPECT_NE(std::string(e.what()).find("refused the connection"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace autonomsim::sim
