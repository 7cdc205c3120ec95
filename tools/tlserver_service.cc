#include "tools/tlserver_service.h"

#include <spdlog/spdlog.h>

#include <nlohmann/json.hpp>
#include <stdexcept>

#include "world/validation.h"
#include "world/vtl_py.h"

namespace autonomsim::tlserver {
namespace {

using Json = nlohmann::json;
using sim::MqttMessage;

// Of "/vtl/request/car3" under base "/vtl/request": "car3"; of the base itself: "" ; else nullopt.
std::optional<std::string> Suffix(const std::string& topic, std::string_view base) {
  if (topic == base) return std::string();
  if (topic.size() > base.size() + 1 && topic.compare(0, base.size(), base) == 0 &&
      topic[base.size()] == '/') {
    return topic.substr(base.size() + 1);
  }
  return std::nullopt;
}

// "car<d>" → d.
std::optional<int> CarOfUser(const std::string& user) {
  if (user.size() == 4 && user.compare(0, 3, "car") == 0 && user[3] >= '0' && user[3] <= '9') {
    return user[3] - '0';
  }
  return std::nullopt;
}

// The payload as it may appear in a log line: other bytes than printable ASCII as \xNN.
std::string Printable(const std::string& text) {
  constexpr std::size_t kMaxShown = 40;
  std::string out;
  for (std::size_t i = 0; i < text.size() && i < kMaxShown; ++i) {
    const auto c = static_cast<unsigned char>(text[i]);
    if (c >= 0x20 && c < 0x7f && c != '\\') {
      out += static_cast<char>(c);
    } else {
      out += fmt::format("\\x{:02x}", c);
    }
  }
  return "'" + out + (text.size() > kMaxShown ? "...'" : "'");
}

std::string Describe(const world::Response& r) {
  return "car " + std::to_string(r.car) + (r.granted ? " granted" : " told occupied");
}

// A request or free from a car: decoded, and checked against the user that sent it (a topic
// "<base>/car<d>" speaks for car d only); `problem` says why it is not served.
struct CarMessage {
  std::optional<world::Request> request;
  std::optional<world::Free> free;
  int car{-1};
  std::string problem;
  bool refused{false};  // decoded, but the user may not send it
};

CarMessage DecodeCarMessage(const MqttMessage& message, bool request, const std::string& user,
                            std::string_view base) {
  CarMessage out;
  if (request) {
    const world::Decoded<world::Request> d = world::DecodeRequest(message.payload);
    if (d) {
      out.request = d.value();
      out.car = out.request->car;
    } else {
      out.problem = d.error();
    }
  } else {
    const world::Decoded<world::Free> d = world::DecodeFree(message.payload);
    if (d) {
      out.free = d.value();
      out.car = out.free->car;
    } else {
      out.problem = d.error();
    }
  }
  if (out.problem.empty() && !user.empty()) {
    const std::optional<int> owner = CarOfUser(user);
    if (!owner) {
      out.refused = true;
      out.problem = message.topic + " names no car (expected " + std::string(base) + "/car<0-9>)";
    } else if (*owner != out.car) {
      out.refused = true;
      out.problem = "car " + std::to_string(*owner) + " sent " + Printable(message.payload) +
                    ", which speaks for car " + std::to_string(out.car);
    }
  }
  return out;
}

}  // namespace

Service::Service(ServiceOptions options)
    : options_(std::move(options)),
      server_(options_.params, options_.intersections),
      intersections_(options_.intersections) {}

std::vector<std::string> Service::Subscriptions() {
  return {std::string(world::kVtlRequestTopic),  std::string(world::kVtlRequestTopic) + "/+",
          std::string(world::kVtlFreeTopic),     std::string(world::kVtlFreeTopic) + "/+",
          std::string(sim::kSimResetTopic),      std::string(sim::kSimClockTopic),
          std::string(sim::kSimDisconnectTopic), std::string(sim::kSimReconnectTopic)};
}

std::vector<MqttMessage> Service::OnMessage(const MqttMessage& message, Time wall_now) {
  if (exit_reason_) return {};  // vtl.py is dead
  std::vector<MqttMessage> out;
  if (Suffix(message.topic, world::kVtlRequestTopic)) {
    out = OnCarMessage(message, true, wall_now);
  } else if (Suffix(message.topic, world::kVtlFreeTopic)) {
    out = OnCarMessage(message, false, wall_now);
  } else if (message.topic == sim::kSimResetTopic) {
    out = OnReset(message);
  } else if (message.topic == sim::kSimClockTopic || message.topic == sim::kSimDisconnectTopic ||
             message.topic == sim::kSimReconnectTopic) {
    out = OnClock(message);
  } else {
    spdlog::debug("ignoring a message on {}", message.topic);
  }
  AppendStatusIfChanged(&out);
  return out;
}

bool Service::ReadStep(const MqttMessage& message, std::optional<sim::StepTag>* tag,
                       std::vector<MqttMessage>* answer) {
  if (const std::optional<std::string> text = message.Property(std::string(sim::kStepProperty))) {
    const world::Decoded<sim::StepTag> decoded = sim::DecodeStepTag(*text);
    if (!decoded) {
      ++counters_.malformed;
      spdlog::warn("rejected {} {}: {}", message.topic, Printable(message.payload),
                   decoded.error());
      return false;
    }
    if (options_.sim_clock) *tag = decoded.value();
  }
  if (!*tag) return true;
  std::string error;
  switch (Check(**tag, &error)) {
    case StepCheck::kRepeat:
      *answer = last_step_outputs_;
      return false;
    case StepCheck::kStale:
      return false;
    case StepCheck::kError:
      *answer = ErrorAck((*tag)->epoch, (*tag)->seq, error);
      return false;
    case StepCheck::kNew:
      break;
  }
  return true;
}

Time Service::ServiceTime(const MqttMessage& message, const sim::StepTag* tag, Time wall_now) {
  if (!options_.sim_clock) return wall_now;
  if (tag) return tag->now;
  ++counters_.unclocked;
  spdlog::warn("{} {} carries no simulation step; served at the last simulated time {} s",
               message.topic, Printable(message.payload), ToSeconds(last_now_));
  return last_now_;
}

std::vector<MqttMessage> Service::OnCarMessage(const MqttMessage& message, bool request,
                                               Time wall_now) {
  const std::string_view base = request ? world::kVtlRequestTopic : world::kVtlFreeTopic;
  const std::string user = *Suffix(message.topic, base);

  // a simulation's step: its tag says when, and a repeat is answered from the cache
  std::optional<sim::StepTag> tag;
  std::vector<MqttMessage> answer;
  if (!ReadStep(message, &tag, &answer)) return answer;

  // the lab's vtl.py (policy original) dies on what it cannot parse
  if (server_.params().policy == world::ServerPolicy::kOriginal) {
    if (const std::optional<std::string> reason =
            world::VtlPyExitReason(base, message.payload, intersections_)) {
      exit_reason_ = "vtl.py would have died on this message: " + message.topic + " " +
                     Printable(message.payload) + " (" + *reason + "); stopping as it did";
      return tag ? ErrorAck(tag->epoch, tag->seq, *exit_reason_) : std::vector<MqttMessage>{};
    }
  }

  // the payload, and whether this user may send it
  const CarMessage car = DecodeCarMessage(message, request, user, base);
  if (!car.problem.empty()) {
    ++(car.refused ? counters_.refused : counters_.malformed);
    spdlog::warn("{} {} {}: {}", car.refused ? "refused" : "rejected", message.topic,
                 Printable(message.payload), car.problem);
    return tag ? ErrorAck(tag->epoch, tag->seq, car.problem) : std::vector<MqttMessage>{};
  }

  const Time now = ServiceTime(message, tag ? &*tag : nullptr, wall_now);
  const std::vector<world::Response> responses =
      car.request ? server_.OnRequest(now, *car.request) : server_.OnFree(now, *car.free);
  const auto log_level = tag ? spdlog::level::debug : spdlog::level::info;
  if (car.request) {
    spdlog::log(log_level, "car {} requests intersection {}", car.request->car,
                car.request->intersection);
  } else {
    spdlog::log(log_level, "car {} frees", car.free->car);
  }
  for (const world::Response& r : responses) spdlog::log(log_level, "  -> {}", Describe(r));
  return Outputs(responses, tag ? &*tag : nullptr);
}

std::vector<MqttMessage> Service::OnReset(const MqttMessage& message) {
  const world::Decoded<sim::SimReset> decoded = sim::DecodeReset(message.payload);
  if (!decoded) {
    ++counters_.malformed;
    spdlog::warn("rejected {}: {}", message.topic, decoded.error());
    return {};
  }
  const sim::SimReset& reset = decoded.value();
  if (!options_.sim_clock) {
    return ErrorAck(reset.epoch, 0,
                    "this tlserver runs on the wall clock; start it with --sim-clock to serve a "
                    "simulation");
  }
  if (epoch_ == reset.epoch) {
    ++counters_.duplicates;
    return last_seq_ == 0 ? last_step_outputs_ : std::vector<MqttMessage>{};
  }
  try {
    server_ = world::TrafficLightServer(reset.params, reset.intersections);
    intersections_ = reset.intersections;
  } catch (const std::invalid_argument& e) {
    return ErrorAck(reset.epoch, 0, std::string("cannot reset the server: ") + e.what());
  }
  if (epoch_) spdlog::warn("simulation run {} replaces run {}", reset.epoch, *epoch_);
  std::string ids;
  for (int id : reset.intersections) ids += (ids.empty() ? "" : ",") + std::to_string(id);
  spdlog::info("simulation run {} drives the server: policy {}, lease {} s, intersections {}",
               reset.epoch, ToName(reset.params.policy), ToSeconds(reset.params.lease), ids);
  epoch_ = reset.epoch;
  last_seq_ = 0;
  last_now_ = kZeroTime;
  const sim::StepTag tag{reset.epoch, 0, kZeroTime};
  return Outputs({}, &tag);
}

std::vector<MqttMessage> Service::OnClock(const MqttMessage& message) {
  const world::Decoded<sim::StepTag> decoded = sim::DecodeStepTag(message.payload);
  if (!decoded) {
    ++counters_.malformed;
    spdlog::warn("rejected {} {}: {}", message.topic, Printable(message.payload), decoded.error());
    return {};
  }
  const sim::StepTag& tag = decoded.value();
  if (!options_.sim_clock) {
    return ErrorAck(tag.epoch, tag.seq,
                    "this tlserver runs on the wall clock; start it with --sim-clock");
  }
  std::string error;
  switch (Check(tag, &error)) {
    case StepCheck::kRepeat:
      return last_step_outputs_;
    case StepCheck::kStale:
      return {};
    case StepCheck::kError:
      return ErrorAck(tag.epoch, tag.seq, error);
    case StepCheck::kNew:
      break;
  }
  std::vector<world::Response> responses;
  if (message.topic == sim::kSimDisconnectTopic) {
    responses = server_.OnDisconnected(tag.now);
    spdlog::info("the simulated broker is away at {} s: leases paused", ToSeconds(tag.now));
  } else if (message.topic == sim::kSimReconnectTopic) {
    server_.OnReconnected(tag.now);
    spdlog::info("the simulated broker is back at {} s: full leases", ToSeconds(tag.now));
  } else {
    responses = server_.OnTick(tag.now);
  }
  for (const world::Response& r : responses) {
    spdlog::debug("lease tick at {} s -> {}", ToSeconds(tag.now), Describe(r));
  }
  return Outputs(responses, &tag);
}

Service::StepCheck Service::Check(const sim::StepTag& tag, std::string* error) {
  if (!epoch_ || tag.epoch != *epoch_) {
    *error = "step of run " + tag.epoch + ", but " +
             (epoch_ ? "run " + *epoch_ + " reset the server since"
                     : std::string("no run has reset the server (did tlserver restart?)"));
    return StepCheck::kError;
  }
  if (tag.seq == last_seq_) {
    ++counters_.duplicates;
    return StepCheck::kRepeat;
  }
  if (tag.seq < last_seq_) {
    ++counters_.duplicates;
    return StepCheck::kStale;
  }
  if (tag.seq != last_seq_ + 1) {
    *error = "step " + std::to_string(tag.seq) + " follows step " + std::to_string(last_seq_) +
             ": steps are missing";
    return StepCheck::kError;
  }
  if (tag.now < last_now_) {
    *error = "step " + Num(tag.seq) + " at " + Num(ToSeconds(tag.now)) +
             " s goes back in time from " + Num(ToSeconds(last_now_)) + " s";
    return StepCheck::kError;
  }
  return StepCheck::kNew;
}

std::vector<MqttMessage> Service::Outputs(const std::vector<world::Response>& responses,
                                          const sim::StepTag* tag) {
  std::vector<MqttMessage> out;
  sim::SimAck ack;
  // taken after every step, lock-step or not, so that the log never grows
  ack.records = server_.TakeRecords();
  for (std::size_t i = 0; i < responses.size(); ++i) {
    MqttMessage m{.topic = std::string(world::kVtlResponseTopic),
                  .payload = world::Encode(responses[i])};
    if (tag) {
      m.properties.emplace_back(std::string(sim::kResponseProperty),
                                sim::EncodeResponseTag({tag->epoch, tag->seq, i}));
    }
    ack.responses.push_back(m.payload);
    out.push_back(std::move(m));
  }
  if (tag) {
    ack.epoch = tag->epoch;
    ack.seq = tag->seq;
    ack.deadline = server_.NextDeadline();
    for (int id : intersections_) ack.holders.emplace_back(id, server_.Holder(id));
    ack.counters = server_.counters();
    out.push_back(
        MqttMessage{.topic = std::string(sim::kSimAckTopic), .payload = sim::EncodeAck(ack)});
    last_seq_ = tag->seq;
    last_now_ = tag->now;
    last_step_outputs_ = out;  // without the status: a repeat must not republish an old one
  }
  return out;
}

std::vector<MqttMessage> Service::ErrorAck(const std::string& epoch, std::uint64_t seq,
                                           const std::string& error) {
  ++counters_.step_errors;
  spdlog::error("simulation step {} of run {} not taken: {}", seq, epoch, error);
  sim::SimAck ack;
  ack.epoch = epoch;
  ack.seq = seq;
  ack.error = error;
  return {MqttMessage{.topic = std::string(sim::kSimAckTopic), .payload = sim::EncodeAck(ack)}};
}

std::vector<MqttMessage> Service::OnTimer(Time wall_now) {
  if (options_.sim_clock) return {};
  const std::vector<world::Response> responses = server_.OnTick(wall_now);
  for (const world::Response& r : responses) spdlog::info("lease expired -> {}", Describe(r));
  std::vector<MqttMessage> out = Outputs(responses, nullptr);
  AppendStatusIfChanged(&out);
  return out;
}

std::vector<MqttMessage> Service::OnConnection(bool up, Time wall_now) {
  if (options_.sim_clock || up == server_.connected()) return {};
  std::vector<world::Response> responses;
  if (up) {
    server_.OnReconnected(wall_now);
    spdlog::info("connected to the broker again: every holder has a full lease");
  } else {
    responses = server_.OnDisconnected(wall_now);
    spdlog::warn("lost the broker: leases paused until it is back");
  }
  std::vector<MqttMessage> out = Outputs(responses, nullptr);
  AppendStatusIfChanged(&out);
  return out;
}

std::optional<Time> Service::NextTimer() const {
  if (options_.sim_clock) return std::nullopt;
  return server_.NextDeadline();
}

nlohmann::json Service::StatusJson(bool online) const {
  Json intersections = Json::array();
  for (int id : intersections_) {
    const std::optional<int> holder = server_.Holder(id);
    intersections.push_back(Json{
        {"id", id}, {"holder", holder ? Json(*holder) : Json()}, {"queue", server_.Queue(id)}});
  }
  const world::TrafficLightServer::Counters c = server_.counters();
  return Json{{"online", online},
              {"clock", options_.sim_clock ? "simulation" : "wall"},
              {"policy", ToName(server_.params().policy)},
              {"lease_s", ToSeconds(server_.params().lease)},
              {"run", epoch_ ? Json(*epoch_) : Json()},
              {"intersections", intersections},
              {"counters",
               {{"requests", c.requests},
                {"grants", c.grants},
                {"denials", c.denials},
                {"frees", c.frees},
                {"lease_expiries", c.lease_expiries},
                {"unknown_intersection", c.unknown_intersection},
                {"queue_drops", c.queue_drops},
                {"malformed", counters_.malformed},
                {"refused", counters_.refused},
                {"duplicates", counters_.duplicates},
                {"unclocked", counters_.unclocked},
                {"step_errors", counters_.step_errors}}}};
}

MqttMessage Service::Status(bool online) const {
  return MqttMessage{.topic = std::string(sim::kVtlStatusTopic),
                     .payload = StatusJson(online).dump(),
                     .qos = 1,
                     .retain = true};
}

std::string Service::StatusKey() const {
  Json status = StatusJson(true);
  // On the wall clock every change is published (the lab sends a few messages a second); a
  // simulation's steps publish only what an operator watches (holders, queues, rejected traffic),
  // so that not every step costs a status message.
  if (options_.sim_clock) {
    status["counters"] = {{"malformed", counters_.malformed}, {"refused", counters_.refused}};
  }
  return status.dump();
}

void Service::AppendStatusIfChanged(std::vector<MqttMessage>* out) {
  std::string key = StatusKey();
  if (key == published_status_key_) return;
  published_status_key_ = std::move(key);
  out->push_back(Status(true));
}

}  // namespace autonomsim::tlserver
