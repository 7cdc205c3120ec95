// The car <-> traffic-light-server link. Messages are the /vtl/ topics and payloads of the real
// lab (world/v2i_protocol.h), so the same traffic can later go through a real MQTT broker.
#pragma once

#include <functional>
#include <vector>

#include "sim/core/kernel.h"
#include "sim/core/random.h"
#include "sim/scenario/scenario.h"
#include "world/v2i_protocol.h"

namespace autonomsim::sim {

class V2ILink {
 public:
  virtual ~V2ILink() = default;
  // A car publishes (request and free topics); the server endpoint receives it.
  virtual void SendToServer(int car_id, const world::V2IMessage& message) = 0;
  // The server publishes (response topic); every car receives it.
  virtual void Broadcast(const world::V2IMessage& message) = 0;
};

// In-process link with a modeled WLAN: each message, each direction and each car independently
// is lost with probability `loss` or delivered after latency + U(0, jitter), never overtaking an
// earlier message on the same path (MQTT runs over TCP, which keeps order).
class EmbeddedV2ILink final : public V2ILink {
 public:
  using ServerReceive = std::function<void(int car_id, const world::V2IMessage&)>;
  using CarReceive = std::function<void(int car_id, const world::V2IMessage&)>;
  using Lost = std::function<void(int car_id, const world::V2IMessage&)>;

  EmbeddedV2ILink(Kernel* kernel, const V2IConfig& config, const RngStreams& streams,
                  std::vector<int> car_ids, ServerReceive to_server, CarReceive to_car, Lost lost);

  void SendToServer(int car_id, const world::V2IMessage& message) override;
  void Broadcast(const world::V2IMessage& message) override;

  std::uint64_t sent() const { return sent_; }
  std::uint64_t delivered() const { return delivered_; }
  std::uint64_t lost() const { return lost_; }

 private:
  struct Path {
    Rng rng;
    Time last_delivery{0};
  };
  void Deliver(Path* path, int car_id, const world::V2IMessage& message, bool to_server);

  Kernel* kernel_;
  V2IConfig config_;
  std::vector<int> car_ids_;
  std::vector<Path> uplinks_;    // per car, in car_ids_ order
  std::vector<Path> downlinks_;  // per car
  ServerReceive to_server_;
  CarReceive to_car_;
  Lost on_lost_;
  std::uint64_t sent_{0}, delivered_{0}, lost_{0};
};

}  // namespace autonomsim::sim
