// The real-time V2I link (v2i.link: realtime, `autonomsim run --realtime --broker HOST:PORT`): the
// simulated cars speak the lab's plain /vtl/ protocol (reference §7, world/v2i_protocol.h) through
// a real MQTT broker to a traffic-light server outside the run (the lab's vtl.py, or `tlserver`
// without --sim-clock), possibly beside real cars on the same broker.
//
// A car's request or free is published at once on the shared topic (/vtl/request, /vtl/free), QoS
// 1, with no lock-step tags and nothing on /vtl/sim/. Every /vtl/response the broker delivers is
// handed to every simulated car (each keeps only its own, as a real car does, so responses for real
// cars are ignored) at the simulated time of the slice in which it arrived (DeliverReceived, called
// between the slices of sim/v2i/realtime_pacing.h). The simulation never waits for the server: the
// run is paced to the wall clock instead. What a car is told, and when, therefore depends on when
// messages arrive on the wall clock, and a real-time run is not reproducible bit for bit.
//
// The network is real, so the link adds no modeled latency, jitter or loss. There is no server in
// the simulation: a run on this link has no server events (request, grant, ...) or counters.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "sim/core/kernel.h"
#include "sim/mqtt/mqtt_client.h"
#include "sim/mqtt/mqtt_link_config.h"
#include "sim/v2i/v2i_link.h"

namespace autonomsim::sim {

class RealTimeV2ILink final : public V2ILink {
 public:
  using CarReceive = std::function<void(int car_id, const world::V2IMessage&)>;

  // Subscribes `client` (connected or still connecting) to /vtl/response. `car_ids`: the simulated
  // cars, each of which receives every response; `to_car` delivers one to one car.
  RealTimeV2ILink(Kernel* kernel, std::unique_ptr<MqttClient> client, std::vector<int> car_ids,
                  CarReceive to_car);

  // Publishes the car's request or free as it is, QoS 1 (queued by the client while the broker is
  // away). Throws std::logic_error for anything else: a car sends nothing else.
  void SendToServer(int car_id, const world::V2IMessage& message) override;
  // Throws std::logic_error: the server is outside the run, nothing in it broadcasts.
  void Broadcast(const world::V2IMessage& message) override;

  // Schedules every /vtl/response received since the last call for delivery to the cars at the
  // kernel's Now(), in arrival order. Call it between kernel runs (the pacer's before_slice).
  // Never waits.
  void DeliverReceived();
  // Waits up to `timeout` (wall time) until the broker has acknowledged every message sent, e.g.
  // the cars' last frees at the end of a run; false if it has not.
  bool Flush(std::chrono::milliseconds timeout);

  std::uint64_t sent() const { return sent_; }
  std::uint64_t received() const { return received_; }

 private:
  Kernel* kernel_;
  std::unique_ptr<MqttClient> client_;
  std::vector<int> car_ids_;
  CarReceive to_car_;
  std::uint64_t sent_{0}, received_{0};
};

// Connects to the broker `config.broker` (HOST:PORT, not empty) as `config.username` with its
// password file and TLS settings, and waits up to `config.timeout` (wall time) until it is
// connected and subscribed. Throws MqttError naming the broker if it cannot be reached in that time
// or refuses us.
std::unique_ptr<RealTimeV2ILink> ConnectRealTimeLink(const MqttLinkConfig& config, Kernel* kernel,
                                                     std::vector<int> car_ids,
                                                     RealTimeV2ILink::CarReceive to_car);

}  // namespace autonomsim::sim
