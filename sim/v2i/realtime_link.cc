#include "sim/v2i/realtime_link.h"

#include <stdexcept>

#include "sim/core/priorities.h"
#include "sim/v2i/mqtt_endpoint.h"  // NewEpoch
#include "world/validation.h"       // Num

namespace autonomsim::sim {

RealTimeV2ILink::RealTimeV2ILink(Kernel* kernel, std::unique_ptr<MqttClient> client,
                                 std::vector<int> car_ids, CarReceive to_car)
    : kernel_(kernel),
      client_(std::move(client)),
      car_ids_(std::move(car_ids)),
      to_car_(std::move(to_car)) {
  if (kernel_ == nullptr || client_ == nullptr || !to_car_) {
    throw std::logic_error("RealTimeV2ILink: needs a kernel, a client and a receiver");
  }
  client_->Subscribe(std::string(world::kVtlResponseTopic), 1);
}

void RealTimeV2ILink::SendToServer(int car_id, const world::V2IMessage& message) {
  if (message.topic != world::kVtlRequestTopic && message.topic != world::kVtlFreeTopic) {
    throw std::logic_error("real-time link: car " + std::to_string(car_id) + " cannot send on " +
                           message.topic);
  }
  // reference §7: QoS 1 from cars, no retain, no properties
  client_->Publish(MqttMessage{.topic = message.topic, .payload = message.payload, .qos = 1});
  ++sent_;
}

void RealTimeV2ILink::Broadcast(const world::V2IMessage& message) {
  throw std::logic_error(
      "real-time link: the server is outside the run; nothing in it may "
      "broadcast (" +
      message.topic + " '" + message.payload + "')");
}

void RealTimeV2ILink::DeliverReceived() {
  // a deadline in the past: take what is there, never wait
  while (std::optional<MqttMessage> m = client_->Receive(std::chrono::steady_clock::time_point{})) {
    if (m->topic != world::kVtlResponseTopic) continue;
    ++received_;
    kernel_->ScheduleAt(
        kernel_->Now(),
        [this, message = world::V2IMessage{m->topic, m->payload}] {
          for (int id : car_ids_) to_car_(id, message);
        },
        kPriorityV2IDelivery);
  }
}

bool RealTimeV2ILink::Flush(std::chrono::milliseconds timeout) {
  return client_->Flush(std::chrono::steady_clock::now() + timeout);
}

std::unique_ptr<RealTimeV2ILink> ConnectRealTimeLink(const MqttLinkConfig& config, Kernel* kernel,
                                                     std::vector<int> car_ids,
                                                     RealTimeV2ILink::CarReceive to_car) {
  config.Validate();
  if (config.broker.empty()) {
    throw MqttError("real-time link: no broker given (v2i.mqtt.broker, or run --broker HOST:PORT)");
  }
  std::unique_ptr<MqttClient> client =
      MakeMosquittoClient(GivenBrokerOptions(config, "autonomsim-rt-" + NewEpoch()));
  MqttClient& connection = *client;
  auto link = std::make_unique<RealTimeV2ILink>(kernel, std::move(client), std::move(car_ids),
                                                std::move(to_car));
  bool ready = false;
  try {
    ready = connection.WaitReady(std::chrono::steady_clock::now() + config.timeout);
  } catch (const MqttError& e) {  // refused: it names the broker, the user and the reason
    throw MqttError(std::string("real-time link: ") + e.what());
  }
  if (!ready) {
    throw MqttError("real-time link: cannot reach the MQTT broker " + config.broker + " within " +
                    Num(ToSeconds(config.timeout)) +
                    " s (v2i.mqtt.timeout_s): is it running, and is the address right?");
  }
  return link;
}

}  // namespace autonomsim::sim
