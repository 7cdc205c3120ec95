#include "sim/v2i/traffic_light_node.h"

#include <stdexcept>
#include <type_traits>

#include "sim/core/priorities.h"

namespace autonomsim::sim {

TrafficLightNode::TrafficLightNode(Kernel* kernel, std::unique_ptr<TrafficLightEndpoint> endpoint,
                                   EventSink sink)
    : kernel_(kernel), endpoint_(std::move(endpoint)), sink_(std::move(sink)) {
  if (endpoint_ == nullptr) throw std::logic_error("TrafficLightNode: no endpoint");
}

TrafficLightNode::TrafficLightNode(Kernel* kernel, const world::TrafficLightServerParams& params,
                                   std::vector<int> intersection_ids, EventSink sink)
    : TrafficLightNode(
          kernel,
          std::make_unique<EmbeddedTrafficLightEndpoint>(params, std::move(intersection_ids)),
          std::move(sink)) {}

world::TrafficLightServer::Counters Sum(const world::TrafficLightServer::Counters& a,
                                        const world::TrafficLightServer::Counters& b) {
  return {.requests = a.requests + b.requests,
          .grants = a.grants + b.grants,
          .denials = a.denials + b.denials,
          .frees = a.frees + b.frees,
          .lease_expiries = a.lease_expiries + b.lease_expiries,
          .unknown_intersection = a.unknown_intersection + b.unknown_intersection,
          .queue_drops = a.queue_drops + b.queue_drops};
}

void EmbeddedTrafficLightEndpoint::Restart() {
  before_restarts_ = counters();
  server_ = world::TrafficLightServer(server_.params(), intersection_ids_);
}

world::TrafficLightServer::Counters EmbeddedTrafficLightEndpoint::counters() const {
  return Sum(before_restarts_, server_.counters());
}

void TrafficLightNode::Restart() {
  endpoint_->Restart();
  RescheduleTick();  // the new server has no lease running
}

void TrafficLightNode::BrokerDown() {
  Publish(endpoint_->OnDisconnected(kernel_->Now()));  // the link, itself down, loses them
  RescheduleTick();
}

void TrafficLightNode::BrokerUp() {
  Publish(endpoint_->OnReconnected(kernel_->Now()));
  RescheduleTick();
}

void TrafficLightNode::OnMessage(int from_car, const world::V2IMessage& message) {
  const world::Decoded<world::V2IPayload> decoded = world::Decode(message);
  // Simulated cars encode well-formed requests for their track's intersections, which the server
  // serves: nothing here would have made the lab's vtl.py exit (policy original; tlserver stops on
  // such a message, world/vtl_py.h). Whatever does not decode still is counted, not served.
  if (!decoded) {
    ++malformed_;
    sink_(Event{.t = kernel_->Now(),
                .type = EventKind::kV2iMalformed,
                .car = from_car,
                .detail = message.topic + " '" + message.payload + "': " + decoded.error()});
    return;
  }
  const Time now = kernel_->Now();
  std::vector<world::Response> responses;
  std::visit(
      [&](const auto& payload) {
        using T = std::decay_t<decltype(payload)>;
        if constexpr (std::is_same_v<T, world::Request>) {
          responses = endpoint_->OnRequest(now, payload);
        } else if constexpr (std::is_same_v<T, world::Free>) {
          responses = endpoint_->OnFree(now, payload);
        } else {
          // A response sent to the server is not for it: count it as malformed traffic.
          ++malformed_;
          sink_(Event{.t = now,
                      .type = EventKind::kV2iMalformed,
                      .car = from_car,
                      .detail = "a response was sent to the server"});
        }
      },
      decoded.value());
  Publish(responses);
  RescheduleTick();
}

void TrafficLightNode::Publish(const std::vector<world::Response>& responses) {
  if (link_ == nullptr) throw std::logic_error("TrafficLightNode: no V2I link set");
  for (world::ServerRecord& record : endpoint_->TakeRecords()) {
    Event event{.t = kernel_->Now(),
                .type = EventKindOf(record.kind),
                .car = record.car,
                .intersection = record.intersection};
    for (int id : record.also_released) {
      event.detail += (event.detail.empty() ? "also released " : ", ") + std::to_string(id);
    }
    sink_(std::move(event));
  }
  for (const world::Response& response : responses) link_->Broadcast(world::ToMessage(response));
}

void TrafficLightNode::RescheduleTick() {
  kernel_->Cancel(tick_);
  const std::optional<Time> deadline = endpoint_->NextDeadline();
  if (!deadline) return;
  tick_ = kernel_->ScheduleAt(
      std::max(*deadline, kernel_->Now()),
      [this] {
        Publish(endpoint_->OnTick(kernel_->Now()));
        RescheduleTick();
      },
      kPriorityServer);
}

}  // namespace autonomsim::sim
