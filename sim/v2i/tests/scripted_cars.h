// Scripted cars around a TrafficLightNode on one kernel, over the modeled WLAN of EmbeddedV2ILink
// (20 ms latency, 5 ms jitter, 10 % loss): the V2I traffic of the mqtt link's tests
// (sim/v2i/tests/mqtt_link_test.cc) and of its benchmark (bench/bench_mqtt.cc). Each car asks for
// its intersection, re-asks every second until granted and while it holds it (keepalive), frees
// after holding it for a while, pauses, and asks again; car 2 falls silent once granted, so its
// lease expires. Everything a car sees and the server's state at each delivery go into a log.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "sim/core/kernel.h"
#include "sim/core/priorities.h"
#include "sim/core/random.h"
#include "sim/v2i/traffic_light_node.h"
#include "sim/v2i/v2i_link.h"

namespace autonomsim::sim::testing {

// The server's parameters for the script: leases of 3 s, so a silent car loses its grant.
inline world::TrafficLightServerParams ScriptedServerParams() {
  world::TrafficLightServerParams params;
  params.lease = std::chrono::seconds(3);
  return params;
}

inline constexpr std::uint64_t kScriptSeed = 7;

class ScriptedCars {
 public:
  ScriptedCars(std::unique_ptr<TrafficLightEndpoint> endpoint, std::uint64_t seed)
      : streams_(seed), node_(&kernel_, std::move(endpoint), [this](Event e) {
          Note(e.t, "event " + std::string(ToName(e.type)));
        }) {
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
        [this](int car, const world::V2IMessage& m, const std::string&) {
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

  // Runs the kernel until `end` (with whatever else was scheduled on it); returns the log and the
  // final counters of the server, the kernel and the link.
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

}  // namespace autonomsim::sim::testing
