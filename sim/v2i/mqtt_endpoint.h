// The simulation side of the mqtt V2I link: a TrafficLightEndpoint whose server logic runs in a
// `tlserver --sim-clock` process behind a real broker, driven in lock-step
// (sim/mqtt/mqtt_lockstep.h). Each call publishes the car's message (or a clock tick) tagged with
// the simulated time, blocks until the server's acknowledgement has arrived together with every
// /vtl/response it published for that step, and returns those responses; the node hands them to the
// modeled V2I link exactly as for the embedded server. The simulation therefore never advances past
// a message before the server has answered it, and a run gives the same result as with the embedded
// server.
//
// Waiting is bounded: without an answer the message is sent again (the server deduplicates) with
// a growing pause, and after `timeout` the call throws MqttError saying what is missing.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "sim/mqtt/mqtt_client.h"
#include "sim/mqtt/mqtt_link_config.h"
#include "sim/mqtt/mqtt_lockstep.h"
#include "sim/v2i/traffic_light_node.h"

namespace autonomsim::sim {

struct MqttEndpointOptions {
  std::string epoch;  // names this run on the broker (IsValidEpoch); see NewEpoch()
  std::chrono::milliseconds timeout{std::chrono::seconds(20)};
  // First re-send after this long without an answer, then doubling up to a second.
  std::chrono::milliseconds first_retry{std::chrono::milliseconds(250)};
  // Called while waiting; throws if something the link depends on has died (a private tlserver).
  std::function<void()> check_alive;
  std::string broker_address;  // for error messages
};

class MqttTrafficLightEndpoint final : public TrafficLightEndpoint {
 public:
  // Subscribes, waits for the connection and resets the server to `params` and
  // `intersection_ids` for this run. Throws MqttError if that fails within the timeout.
  MqttTrafficLightEndpoint(std::unique_ptr<MqttClient> client,
                           const world::TrafficLightServerParams& params,
                           std::vector<int> intersection_ids, MqttEndpointOptions options);

  std::vector<world::Response> OnRequest(Time now, const world::Request& request) override;
  std::vector<world::Response> OnFree(Time now, const world::Free& free) override;
  std::vector<world::Response> OnTick(Time now) override;
  std::vector<world::Response> OnDisconnected(Time now) override;
  std::vector<world::Response> OnReconnected(Time now) override;
  // Resets the tlserver under a new epoch (a fresh server); the counters go on.
  void Restart() override;
  std::optional<Time> NextDeadline() const override { return deadline_; }
  std::optional<int> Holder(int intersection) const override;
  world::TrafficLightServer::Counters counters() const override {
    return Sum(before_restarts_, counters_);
  }
  std::vector<world::ServerRecord> TakeRecords() override;

  struct Stats {
    std::uint64_t exchanges{0};  // steps answered, the reset included
    std::uint64_t resends{0};    // messages sent again for want of an answer
    std::uint64_t ignored{0};    // not for the step in progress: repeats, other runs, status
    std::chrono::nanoseconds wait_total{0};  // wall time from publishing to the complete answer
    std::chrono::nanoseconds wait_max{0};
  };
  const Stats& stats() const { return stats_; }

 private:
  std::vector<world::Response> Exchange(const MqttMessage& message);
  MqttMessage Tagged(std::string_view topic, std::string payload, Time now);
  // A step of the simulation's own (/vtl/sim/clock, disconnect, reconnect) at `now`.
  MqttMessage Step(std::string_view topic, Time now);
  void Reset();

  std::unique_ptr<MqttClient> client_;
  MqttEndpointOptions options_;
  world::TrafficLightServerParams params_;
  std::vector<int> intersection_ids_;
  world::TrafficLightServer::Counters before_restarts_;
  std::uint64_t seq_{0};
  std::optional<Time> deadline_;
  std::map<int, std::optional<int>> holders_;
  world::TrafficLightServer::Counters counters_;
  std::vector<world::ServerRecord> records_;
  Stats stats_;
};

// A name for one run on a broker, unique on this machine: process id, a counter and the clock.
std::string NewEpoch();

// The mqtt link of a run (v2i.link: mqtt): connects to `config.broker`, or starts a private
// broker and tlserver and stops them when the endpoint is destroyed. Throws MqttError (or
// std::runtime_error when a program is missing) naming what failed.
std::unique_ptr<TrafficLightEndpoint> MakeMqttEndpoint(
    const MqttLinkConfig& config, const world::TrafficLightServerParams& params,
    std::vector<int> intersection_ids);

// The ACL of a private broker: the one in tools/mosquitto/acl (a test keeps them equal).
std::string DefaultAcl();

}  // namespace autonomsim::sim
