// The car <-> traffic-light-server link. Messages are the /vtl/ topics and payloads of the real
// lab (world/v2i_protocol.h), so the same traffic can later go through a real MQTT broker.
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <utility>
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

// A fault on the link (sim/loop/faults.h): while it is on, messages of `car` (every car if empty)
// in the directions it names are lost with probability `loss` (1: the path is cut), on top of the
// modeled loss. A cut also loses what is in flight on the path when it arrives.
struct V2ILinkFault {
  std::optional<int> car;
  bool up{true};    // car → server (/vtl/request, /vtl/free)
  bool down{true};  // server → car (/vtl/response)
  double loss{1.0};
  std::string cause;  // for the v2i_lost event, e.g. "v2i_partition"
};

// In-process link with a modeled WLAN: each message, each direction and each car independently
// is lost with probability `loss` or delivered after latency + U(0, jitter), never overtaking an
// earlier message on the same path (MQTT runs over TCP, which keeps order). Faults add losses
// (V2ILinkFault) and can take the server down (messages arriving at it are lost); the random draws
// are the same with and without them, so a fault changes only what it strikes.
class EmbeddedV2ILink final : public V2ILink {
 public:
  using ServerReceive = std::function<void(int car_id, const world::V2IMessage&)>;
  using CarReceive = std::function<void(int car_id, const world::V2IMessage&)>;
  // `cause`: empty for the modeled loss, else the fault's (V2ILinkFault::cause, "server down").
  using Lost = std::function<void(int car_id, const world::V2IMessage&, const std::string& cause)>;

  EmbeddedV2ILink(Kernel* kernel, const V2IConfig& config, const RngStreams& streams,
                  std::vector<int> car_ids, ServerReceive to_server, CarReceive to_car, Lost lost);

  void SendToServer(int car_id, const world::V2IMessage& message) override;
  void Broadcast(const world::V2IMessage& message) override;

  // Returns a handle for RemoveFault.
  int AddFault(V2ILinkFault fault);
  void RemoveFault(int handle);
  // While down, messages arriving at the server are lost (cause "server down").
  void set_server_down(bool down) { server_down_ = down; }

  std::uint64_t sent() const { return sent_; }
  std::uint64_t delivered() const { return delivered_; }
  std::uint64_t lost() const { return lost_; }

 private:
  struct Path {
    Rng rng;
    Time last_delivery{0};
  };
  void Deliver(Path* path, int car_id, const world::V2IMessage& message, bool to_server);
  // The cause of the first active fault on this path that loses a message drawn `u`, if any.
  const V2ILinkFault* FaultLosing(int car_id, bool to_server, double u) const;
  void Lose(int car_id, const world::V2IMessage& message, const std::string& cause);

  Kernel* kernel_;
  V2IConfig config_;
  std::vector<int> car_ids_;
  std::vector<Path> uplinks_;    // per car, in car_ids_ order
  std::vector<Path> downlinks_;  // per car
  ServerReceive to_server_;
  CarReceive to_car_;
  Lost on_lost_;
  std::vector<std::pair<int, V2ILinkFault>> faults_;  // active, by handle
  int next_fault_{0};
  bool server_down_{false};
  std::uint64_t sent_{0}, delivered_{0}, lost_{0};
};

}  // namespace autonomsim::sim
