// The thin node around the traffic-light server's logic: decodes /vtl/ messages, calls the server,
// broadcasts its answers, and wakes it exactly when the next lease can expire.
//
// The server logic sits behind TrafficLightEndpoint, with the contract of
// world::TrafficLightServer: in process (EmbeddedTrafficLightEndpoint), or in a `tlserver` process
// behind a real broker (sim/v2i/mqtt_endpoint.h), which answers each call before it returns. The
// node does the same calls in the same order either way, so both give the same run.
#pragma once

#include <functional>
#include <memory>
#include <optional>
#include <vector>

#include "sim/core/kernel.h"
#include "sim/scenario/run_record.h"
#include "sim/v2i/v2i_link.h"
#include "world/traffic_light_server.h"

namespace autonomsim::sim {

class TrafficLightEndpoint {
 public:
  virtual ~TrafficLightEndpoint() = default;
  // As world::TrafficLightServer: the responses to broadcast, in order.
  virtual std::vector<world::Response> OnRequest(Time now, const world::Request& request) = 0;
  virtual std::vector<world::Response> OnFree(Time now, const world::Free& free) = 0;
  virtual std::vector<world::Response> OnTick(Time now) = 0;
  // The broker is away from `now` / back at `now` (a broker_outage fault): the server's leases
  // pause while it is away (world::TrafficLightServer::OnDisconnected, OnReconnected).
  virtual std::vector<world::Response> OnDisconnected(Time now) = 0;
  virtual std::vector<world::Response> OnReconnected(Time now) = 0;
  // The server restarts (a fault): every holder, queue and lease is forgotten, as the lab's server
  // forgets them (vtl.py keeps its slots in memory only); the counters go on.
  virtual void Restart() = 0;
  // The server's state after the last call.
  virtual std::optional<Time> NextDeadline() const = 0;
  virtual std::optional<int> Holder(int intersection) const = 0;
  virtual world::TrafficLightServer::Counters counters() const = 0;
  // What the server did since the last call (world::ServerRecord), oldest first.
  virtual std::vector<world::ServerRecord> TakeRecords() = 0;
};

class EmbeddedTrafficLightEndpoint final : public TrafficLightEndpoint {
 public:
  EmbeddedTrafficLightEndpoint(const world::TrafficLightServerParams& params,
                               std::vector<int> intersection_ids)
      : server_(params, intersection_ids), intersection_ids_(std::move(intersection_ids)) {}

  std::vector<world::Response> OnRequest(Time now, const world::Request& request) override {
    return server_.OnRequest(now, request);
  }
  std::vector<world::Response> OnFree(Time now, const world::Free& free) override {
    return server_.OnFree(now, free);
  }
  std::vector<world::Response> OnTick(Time now) override { return server_.OnTick(now); }
  std::vector<world::Response> OnDisconnected(Time now) override {
    return server_.OnDisconnected(now);
  }
  std::vector<world::Response> OnReconnected(Time now) override {
    server_.OnReconnected(now);
    return {};
  }
  void Restart() override;
  std::optional<Time> NextDeadline() const override { return server_.NextDeadline(); }
  std::optional<int> Holder(int intersection) const override {
    return server_.Holder(intersection);
  }
  world::TrafficLightServer::Counters counters() const override;
  std::vector<world::ServerRecord> TakeRecords() override { return server_.TakeRecords(); }

  const world::TrafficLightServer& server() const { return server_; }

 private:
  world::TrafficLightServer server_;
  std::vector<int> intersection_ids_;
  world::TrafficLightServer::Counters before_restarts_;  // what the servers before this one did
};

// a + b, field by field (counters of a server and of its restarted successor).
world::TrafficLightServer::Counters Sum(const world::TrafficLightServer::Counters& a,
                                        const world::TrafficLightServer::Counters& b);

class TrafficLightNode {
 public:
  using EventSink = std::function<void(Event)>;

  TrafficLightNode(Kernel* kernel, std::unique_ptr<TrafficLightEndpoint> endpoint, EventSink sink);
  // With an EmbeddedTrafficLightEndpoint.
  TrafficLightNode(Kernel* kernel, const world::TrafficLightServerParams& params,
                   std::vector<int> intersection_ids, EventSink sink);

  void set_link(V2ILink* link) { link_ = link; }
  // A server_restart fault: the server forgets its state now (TrafficLightEndpoint::Restart).
  void Restart();
  // A broker_outage fault begins / ends now: the server's leases pause meanwhile.
  void BrokerDown();
  void BrokerUp();
  // A message from `from_car` (as the link saw it) arrives at the server.
  void OnMessage(int from_car, const world::V2IMessage& message);

  std::optional<int> Holder(int intersection) const { return endpoint_->Holder(intersection); }
  world::TrafficLightServer::Counters counters() const { return endpoint_->counters(); }
  const TrafficLightEndpoint& endpoint() const { return *endpoint_; }
  std::uint64_t malformed() const { return malformed_; }

 private:
  // Emits the server's records as events, then broadcasts the responses.
  void Publish(const std::vector<world::Response>& responses);
  void RescheduleTick();

  Kernel* kernel_;
  std::unique_ptr<TrafficLightEndpoint> endpoint_;
  EventSink sink_;
  V2ILink* link_{nullptr};
  EventId tick_;
  std::uint64_t malformed_{0};
};

}  // namespace autonomsim::sim
