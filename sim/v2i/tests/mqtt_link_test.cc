// The mqtt link end to end: cars' V2I traffic through a real mosquitto to a real `tlserver
// --sim-clock`, on a sim::Kernel with the modeled WLAN (latency, jitter, loss) of
// EmbeddedV2ILink, compared with the in-process server: same responses at the same simulated
// times, same state, same counters, also across broker restarts.
#include <gtest/gtest.h>

#include <condition_variable>
#include <iostream>
#include <map>
#include <mutex>
#include <sstream>
#include <thread>

#include "sim/core/kernel.h"
#include "sim/core/priorities.h"
#include "sim/core/random.h"
#include "sim/mqtt/tests/mqtt_fixture.h"
#include "sim/v2i/mqtt_endpoint.h"
#include "sim/v2i/traffic_light_node.h"
#include "sim/v2i/v2i_link.h"

namespace autonomsim::sim {
namespace {

using testing::Clock;

world::TrafficLightServerParams Params() {
  world::TrafficLightServerParams params;
  params.lease = std::chrono::seconds(3);
  return params;
}

// Scripted cars around a TrafficLightNode on one kernel. Each car asks for its intersection,
// re-asks every second until granted and while it holds it (keepalive), frees after holding it
// for a while, pauses, and asks again; car 2 falls silent once granted, so its lease expires.
// Everything a car sees and the server's state at each delivery go into a log.
class Harness {
 public:
  Harness(std::unique_ptr<TrafficLightEndpoint> endpoint, std::uint64_t seed)
      : streams_(seed),
        node_(&kernel_, std::move(endpoint), [this](Event e) { Note(e.t, "event " + e.type); }) {
    V2IConfig v2i;
    v2i.latency = std::chrono::milliseconds(20);
    v2i.jitter = std::chrono::milliseconds(5);
    v2i.loss = 0.1;
    link_ = std::make_unique<EmbeddedV2ILink>(
        &kernel_, v2i, streams_, std::vector<int>{0, 1, 2},
        [this](int car, const world::V2IMessage& m) {
          ++to_server_;
          node_.OnMessage(car, m);
        },
        [this](int car, const world::V2IMessage& m) { Receive(car, m); },
        [this](int car, const world::V2IMessage& m) {
          Note(kernel_.Now(), "lost car" + std::to_string(car) + " " + m.topic + " " + m.payload);
        });
    node_.set_link(link_.get());
    for (int car : {0, 1, 2}) {
      cars_[car] = Car{.intersection = car == 1 ? 0 : car % 2, .silent_when_granted = car == 2};
      kernel_.SchedulePeriodic(
          std::chrono::milliseconds(100 + 37 * car), std::chrono::seconds(1),
          [this, car] { StepCar(car); }, kPriorityClient);
    }
  }

  // Runs until `end`, calling `at(t)` hooks scheduled before.
  std::string Run(Time end) {
    kernel_.RunUntil(end);
    const world::TrafficLightServer::Counters c = node_.counters();
    std::ostringstream out;
    out << log_.str() << "counters " << c.requests << " " << c.grants << " " << c.denials << " "
        << c.frees << " " << c.lease_expiries << " " << c.queue_drops << " kernel "
        << kernel_.executed() << " link " << link_->sent() << " " << link_->lost() << "\n";
    return out.str();
  }
  Kernel& kernel() { return kernel_; }
  // Messages the cars' uplinks delivered to the server.
  std::uint64_t messages() const { return to_server_; }

 private:
  struct Car {
    int intersection{0};
    bool silent_when_granted{false};
    bool granted{false};
    int held_s{0};
    int pause_s{0};
  };

  void Note(Time t, const std::string& what) {
    log_ << t.count() << " " << what << " | h0=" << Show(node_.Holder(0))
         << " h1=" << Show(node_.Holder(1)) << "\n";
  }
  static std::string Show(std::optional<int> h) { return h ? std::to_string(*h) : "-"; }

  void StepCar(int id) {
    Car& car = cars_[id];
    if (car.pause_s > 0) {
      --car.pause_s;
      return;
    }
    if (car.granted && car.silent_when_granted) return;
    if (car.granted && ++car.held_s >= 3) {
      link_->SendToServer(id, world::ToMessage(world::Free{id}));
      car.granted = false;
      car.held_s = 0;
      car.pause_s = 2;
      car.intersection = 1 - car.intersection;
      return;
    }
    link_->SendToServer(id, world::ToMessage(world::Request{id, car.intersection}));
  }

  void Receive(int id, const world::V2IMessage& m) {
    const world::Decoded<world::Response> r = world::DecodeResponse(m.payload);
    if (!r || r.value().car != id) return;
    Note(kernel_.Now(), "car" + std::to_string(id) + " got " + m.payload);
    if (r.value().granted) cars_[id].granted = true;
  }

  Kernel kernel_;
  RngStreams streams_;
  TrafficLightNode node_;
  std::unique_ptr<EmbeddedV2ILink> link_;
  std::map<int, Car> cars_;
  std::ostringstream log_;
  std::uint64_t to_server_{0};
};

constexpr std::uint64_t kSeed = 7;
const Time kEnd = std::chrono::seconds(60);

// `extra_events_s`: no-op kernel events, to match a run that has events of its own there.
std::string EmbeddedRun(const std::vector<int>& extra_events_s = {}) {
  Harness h(std::make_unique<EmbeddedTrafficLightEndpoint>(Params(), std::vector<int>{0, 1}),
            kSeed);
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
  Harness h(MakeMqttEndpoint(MqttLinkConfig{}, Params(), {0, 1}), kSeed);
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
  Harness h(std::move(endpoint), kSeed);

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

// Not a check of speed (that would depend on the machine): prints what one V2I message costs in
// wall time over the mqtt link, for the record.
TEST(MqttLinkTest, ReportsTheWallTimeCostPerMessage) {
  auto wall = [](const std::function<void()>& f) {
    const auto start = Clock::now();
    f();
    return std::chrono::duration<double>(Clock::now() - start).count();
  };
  const Time end = std::chrono::seconds(300);
  std::uint64_t messages = 0;
  const double embedded_s = wall([&] {
    Harness h(std::make_unique<EmbeddedTrafficLightEndpoint>(Params(), std::vector<int>{0, 1}),
              kSeed);
    h.Run(end);
    messages = h.messages();
  });
  std::unique_ptr<TrafficLightEndpoint> endpoint;
  const double setup_s = wall([&] { endpoint = MakeMqttEndpoint({}, Params(), {0, 1}); });
  double mqtt_s = 0;
  {
    Harness h(std::move(endpoint), kSeed);
    mqtt_s = wall([&] { h.Run(end); });
  }
  std::cout << "mqtt link: " << messages << " V2I messages in " << ToSeconds(end)
            << " s simulated; embedded " << embedded_s * 1e3 << " ms, mqtt " << mqtt_s * 1e3
            << " ms (+ " << setup_s * 1e3 << " ms to start broker and tlserver): "
            << (mqtt_s - embedded_s) / static_cast<double>(messages) * 1e6
            << " us per V2I message delivered to the server (lease ticks included)\n";
  SUCCEED();
}

}  // namespace
}  // namespace autonomsim::sim
