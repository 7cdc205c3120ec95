// The thin node around the traffic-light server's pure logic: decodes /vtl/ messages, calls the
// server, broadcasts its answers, and wakes it exactly when the next lease can expire.
#pragma once

#include <functional>
#include <vector>

#include "sim/kernel.h"
#include "sim/run_record.h"
#include "sim/v2i_link.h"
#include "world/traffic_light_server.h"

namespace autonomsim::sim {

class TrafficLightNode {
 public:
  using EventSink = std::function<void(Event)>;

  TrafficLightNode(Kernel* kernel, const world::TrafficLightServerParams& params,
                   std::vector<int> intersection_ids, EventSink sink);

  void set_link(V2ILink* link) { link_ = link; }
  // A message from `from_car` (as the link saw it) arrives at the server.
  void OnMessage(int from_car, const world::V2IMessage& message);

  const world::TrafficLightServer& server() const { return server_; }
  std::uint64_t malformed() const { return malformed_; }

 private:
  void Publish(const std::vector<world::Response>& responses);
  void RescheduleTick();

  Kernel* kernel_;
  world::TrafficLightServer server_;
  EventSink sink_;
  V2ILink* link_{nullptr};
  EventId tick_;
  std::uint64_t malformed_{0};
};

}  // namespace autonomsim::sim
