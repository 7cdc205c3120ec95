// The lock-step protocol that lets a simulation drive `tlserver --sim-clock` through a real broker
// and stay deterministic. The cars' traffic keeps the lab's topics and payloads (reference §7);
// the simulation adds what a deterministic run needs as MQTT v5 user properties and on its own
// /vtl/sim/ topics, which the lab's cars never see:
//
//   /vtl/sim/reset  sim → server  JSON Reset: start a fresh server state for run `epoch` (its
//                                 policy, lease and intersections); answered by Ack seq 0.
//   /vtl/request,   sim → server  the car's payload, with user property autonomsim-step =
//   /vtl/free                     "<epoch> <seq> <now_ns>": handle it at simulated time now_ns.
//   /vtl/sim/clock  sim → server  "<epoch> <seq> <now_ns>": the lease deadline now_ns has come
//                                 (TrafficLightServer::OnTick).
//   /vtl/sim/disconnect, /vtl/sim/reconnect
//                   sim → server  "<epoch> <seq> <now_ns>": the simulated broker went away or came
//                                 back at now_ns (a broker_outage fault; TrafficLightServer::
//                                 OnDisconnected, OnReconnected). The real broker stays up.
//   /vtl/response   server → all  "<car><0|1>" as in the lab, with user property
//                                 autonomsim-response = "<epoch> <seq> <index>".
//   /vtl/sim/ack    server → sim  JSON Ack: step seq is done; its responses (which went out on
//                                 /vtl/response before it), the server's next deadline, holders
//                                 and counters; or the error that stopped it.
//
// The simulation sends step seq + 1 only after the Ack of seq, so the server sees one step at a
// time. Every message is QoS 1 (at least once: duplicates happen around a broker restart), so both
// sides deduplicate by (epoch, seq[, index]); a repeated step is answered again from the server's
// cache, which also makes a retry by the simulation safe.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "world/time.h"
#include "world/traffic_light_server.h"
#include "world/v2i_protocol.h"

namespace autonomsim::sim {

inline constexpr std::string_view kSimResetTopic = "/vtl/sim/reset";
inline constexpr std::string_view kSimClockTopic = "/vtl/sim/clock";
inline constexpr std::string_view kSimDisconnectTopic = "/vtl/sim/disconnect";
inline constexpr std::string_view kSimReconnectTopic = "/vtl/sim/reconnect";
inline constexpr std::string_view kSimAckTopic = "/vtl/sim/ack";
// Retained JSON: the server's state per intersection (holder, queue) and its counters.
inline constexpr std::string_view kVtlStatusTopic = "/vtl/status";
inline constexpr std::string_view kStepProperty = "autonomsim-step";
inline constexpr std::string_view kResponseProperty = "autonomsim-response";

// An epoch names one simulation run: 1..64 characters of [A-Za-z0-9._-].
bool IsValidEpoch(std::string_view epoch);

struct StepTag {
  std::string epoch;
  std::uint64_t seq{0};
  Time now{0};
  friend bool operator==(const StepTag&, const StepTag&) = default;
};

struct ResponseTag {
  std::string epoch;
  std::uint64_t seq{0};
  std::uint64_t index{0};
  friend bool operator==(const ResponseTag&, const ResponseTag&) = default;
};

struct SimReset {
  std::string epoch;
  world::TrafficLightServerParams params;
  std::vector<int> intersections;
};

struct SimAck {
  std::string epoch;
  std::uint64_t seq{0};
  std::vector<std::string> responses;  // /vtl/response payloads of this step, in order
  std::optional<Time> deadline;        // TrafficLightServer::NextDeadline after the step
  std::vector<std::pair<int, std::optional<int>>> holders;  // (intersection, holder)
  world::TrafficLightServer::Counters counters;
  // what the server did in this step, in order; each kind travels as world::ServerRecord::Kind's
  // value (the simulation and the tlserver it drives come from one build)
  std::vector<world::ServerRecord> records;
  std::string error;  // not empty: the server did not take the step, and why
};

std::string EncodeStepTag(const StepTag& tag);
world::Decoded<StepTag> DecodeStepTag(std::string_view text);
std::string EncodeResponseTag(const ResponseTag& tag);
world::Decoded<ResponseTag> DecodeResponseTag(std::string_view text);
std::string EncodeReset(const SimReset& reset);
world::Decoded<SimReset> DecodeReset(std::string_view json);
std::string EncodeAck(const SimAck& ack);
world::Decoded<SimAck> DecodeAck(std::string_view json);

}  // namespace autonomsim::sim
