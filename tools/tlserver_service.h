// What `tlserver` does with each MQTT message, without the MQTT: messages and the time go in, the
// messages to publish come out, in order. The server logic itself is world::TrafficLightServer.
//
// Topics (reference §7 and sim/mqtt/mqtt_lockstep.h):
//   /vtl/request, /vtl/free           the lab's cars, unchanged
//   /vtl/request/<user>, /vtl/free/<user>
//                                     cars behind the ACL of tools/mosquitto/acl: the user must be
//                                     car<d> and the payload must name car d, else refused
//   /vtl/response                     our answers, as in the lab
//   /vtl/status                       retained JSON: per intersection holder and queue, counters
//   /vtl/sim/{reset,clock,ack},       the lock-step of a simulation (--sim-clock only)
//   /vtl/sim/{disconnect,reconnect}
//
// Clocks: on the wall clock (default) `now` is the time since the service started and lease
// expiries come from OnTimer at NextTimer(). With sim_clock, time is what the simulation's step
// tags say and nothing happens between steps; car messages without a tag are still served, at the
// last simulated time, and counted as unclocked.
//
// Nothing a client sends stops the service: a malformed payload, a refused one and a step out of
// order are logged and counted, and a simulation's step is answered with an error instead. Except
// under policy original, which is the lab's vtl.py: a /vtl/request or /vtl/free payload (on the
// lab's topic or a car's) that vtl.py would have died on (world/vtl_py.h) ends the service, as it
// ended vtl.py: it is not served, exit_reason() says why, nothing is served after it (a
// simulation's step is answered with an error first), and tlserver exits.
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "sim/mqtt/mqtt_client.h"
#include "sim/mqtt/mqtt_lockstep.h"
#include "world/time.h"
#include "world/traffic_light_server.h"

namespace autonomsim::tlserver {

struct ServiceOptions {
  world::TrafficLightServerParams params;
  std::vector<int> intersections{0, 1};  // reference §1: the lab track has two intersections
  bool sim_clock{false};
};

struct ServiceCounters {
  std::uint64_t malformed{0};    // payloads (or step tags) that are not the protocol
  std::uint64_t refused{0};      // well-formed but not allowed: another car's id on a car's topic
  std::uint64_t duplicates{0};   // simulation steps received again (QoS 1), answered from cache
  std::uint64_t unclocked{0};    // car messages without a step tag while on the simulation clock
  std::uint64_t step_errors{0};  // simulation steps answered with an error
};

class Service {
 public:
  // Throws std::invalid_argument for invalid params or intersection ids.
  explicit Service(ServiceOptions options);

  // The topic filters to subscribe to.
  static std::vector<std::string> Subscriptions();

  // Handles one received message; `wall_now` is the time since start (ignored with sim_clock).
  std::vector<sim::MqttMessage> OnMessage(const sim::MqttMessage& message, Time wall_now);
  // Wall clock: applies the lease expiries due at `wall_now`.
  std::vector<sim::MqttMessage> OnTimer(Time wall_now);
  // Wall clock: when OnTimer must run next; nullopt when nothing is pending or with sim_clock.
  std::optional<Time> NextTimer() const;
  // Wall clock: our connection to the broker is up or down since `wall_now` (tlserver polls it).
  // While it is down no lease runs out; on reconnecting every holder and queued car has a full
  // lease (TrafficLightServer::OnDisconnected). With sim_clock the simulation says when its
  // modelled broker is away (/vtl/sim/disconnect): this is ignored.
  std::vector<sim::MqttMessage> OnConnection(bool up, Time wall_now);

  // The retained status message (also the MQTT will, with online false).
  sim::MqttMessage Status(bool online) const;

  const ServiceCounters& counters() const { return counters_; }
  // Policy original: the line saying which message vtl.py would have died on; nullopt otherwise.
  const std::optional<std::string>& exit_reason() const { return exit_reason_; }
  const world::TrafficLightServer& server() const { return server_; }
  bool sim_clock() const { return options_.sim_clock; }

 private:
  enum class StepCheck { kNew, kRepeat, kStale, kError };

  std::vector<sim::MqttMessage> OnCarMessage(const sim::MqttMessage& message, bool request,
                                             Time wall_now);
  // The message's simulation step, kept in *tag with sim_clock. False when the message is answered
  // already: a malformed tag or a stale step (no answer), a repeated step (the cached answer), a
  // step out of order (an error ack), in *answer.
  bool ReadStep(const sim::MqttMessage& message, std::optional<sim::StepTag>* tag,
                std::vector<sim::MqttMessage>* answer);
  // When a car's message is served: the wall time, or with sim_clock its step's time (the last
  // simulated time for a message without a step, counted as unclocked).
  Time ServiceTime(const sim::MqttMessage& message, const sim::StepTag* tag, Time wall_now);
  std::vector<sim::MqttMessage> OnReset(const sim::MqttMessage& message);
  // A simulation step on /vtl/sim/clock, /vtl/sim/disconnect or /vtl/sim/reconnect.
  std::vector<sim::MqttMessage> OnClock(const sim::MqttMessage& message);
  StepCheck Check(const sim::StepTag& tag, std::string* error);
  // The responses (tagged when `tag` is given) and the ack of the step.
  std::vector<sim::MqttMessage> Outputs(const std::vector<world::Response>& responses,
                                        const sim::StepTag* tag);
  std::vector<sim::MqttMessage> ErrorAck(const std::string& epoch, std::uint64_t seq,
                                         const std::string& error);
  void AppendStatusIfChanged(std::vector<sim::MqttMessage>* out);
  nlohmann::json StatusJson(bool online) const;
  // What must change for a new status message to go out.
  std::string StatusKey() const;

  ServiceOptions options_;
  world::TrafficLightServer server_;
  std::vector<int> intersections_;  // of server_
  ServiceCounters counters_;
  // the simulation driving us (sim_clock)
  std::optional<std::string> epoch_;
  std::uint64_t last_seq_{0};
  Time last_now_{0};
  std::vector<sim::MqttMessage> last_step_outputs_;  // answered again for a repeated step
  std::string published_status_key_;
  std::optional<std::string> exit_reason_;
};

}  // namespace autonomsim::tlserver
