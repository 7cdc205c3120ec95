#include "sim/mqtt/mqtt_lockstep.h"

#include <charconv>
#include <limits>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <utility>

namespace autonomsim::sim {
namespace {

using Json = nlohmann::json;

constexpr std::size_t kMaxEpochBytes = 64;

// Splits "a b c" into exactly `n` space-separated fields; empty when the count differs.
std::vector<std::string_view> Fields(std::string_view text, std::size_t n) {
  std::vector<std::string_view> out;
  std::size_t start = 0;
  while (start <= text.size()) {
    const std::size_t space = text.find(' ', start);
    const std::size_t end = space == std::string_view::npos ? text.size() : space;
    out.push_back(text.substr(start, end - start));
    if (space == std::string_view::npos) break;
    start = space + 1;
  }
  if (out.size() != n) out.clear();
  return out;
}

template <class T>
bool ParseInt(std::string_view text, T* out) {
  if (text.empty()) return false;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), *out);
  return ec == std::errc() && end == text.data() + text.size();
}

std::string Show(std::string_view text) {
  constexpr std::size_t kMaxShown = 80;
  std::string out(text.substr(0, kMaxShown));
  for (char& c : out) {
    if (static_cast<unsigned char>(c) < 0x20 || static_cast<unsigned char>(c) >= 0x7f) c = '?';
  }
  return "'" + out + (text.size() > kMaxShown ? "...'" : "'");
}

// A JSON integer that T holds exactly, else std::invalid_argument naming `key`. Never get<T>()
// alone: it casts a float (1e30, 2.5) or an integer too large for T without a word, and a float
// cast out of T's range is undefined behaviour (found by sim/mqtt/fuzz/lockstep_decode_fuzz.cc).
template <class T>
T Integer(const Json& j, const std::string& key) {
  if (j.is_number_unsigned()) {
    const auto value = j.get<std::uint64_t>();
    if (std::in_range<T>(value)) return static_cast<T>(value);
  } else if (j.is_number_integer()) {
    const auto value = j.get<std::int64_t>();
    if (std::in_range<T>(value)) return static_cast<T>(value);
  }
  throw std::invalid_argument(key + ": expected an integer in [" +
                              std::to_string(std::numeric_limits<T>::min()) + ", " +
                              std::to_string(std::numeric_limits<T>::max()) + "], got " +
                              (j.is_number() ? j.dump() : std::string(j.type_name())));
}

Json CountersToJson(const world::TrafficLightServer::Counters& c) {
  return Json{{"requests", c.requests},
              {"grants", c.grants},
              {"denials", c.denials},
              {"frees", c.frees},
              {"lease_expiries", c.lease_expiries},
              {"unknown_intersection", c.unknown_intersection},
              {"queue_drops", c.queue_drops}};
}

world::TrafficLightServer::Counters CountersFromJson(const Json& j) {
  world::TrafficLightServer::Counters c;
  const auto counter = [&j](const char* key) {
    return Integer<std::uint64_t>(j.at(key), std::string("counters.") + key);
  };
  c.requests = counter("requests");
  c.grants = counter("grants");
  c.denials = counter("denials");
  c.frees = counter("frees");
  c.lease_expiries = counter("lease_expiries");
  c.unknown_intersection = counter("unknown_intersection");
  c.queue_drops = counter("queue_drops");
  return c;
}

}  // namespace

bool IsValidEpoch(std::string_view epoch) {
  if (epoch.empty() || epoch.size() > kMaxEpochBytes) return false;
  for (char c : epoch) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                    c == '.' || c == '_' || c == '-';
    if (!ok) return false;
  }
  return true;
}

std::string EncodeStepTag(const StepTag& tag) {
  return tag.epoch + " " + std::to_string(tag.seq) + " " + std::to_string(tag.now.count());
}

world::Decoded<StepTag> DecodeStepTag(std::string_view text) {
  const std::vector<std::string_view> f = Fields(text, 3);
  StepTag tag;
  std::int64_t now_ns = 0;
  if (f.empty() || !IsValidEpoch(f[0]) || !ParseInt(f[1], &tag.seq) || !ParseInt(f[2], &now_ns) ||
      now_ns < 0) {
    return world::Decoded<StepTag>::Error("step tag " + Show(text) +
                                          ": expected '<epoch> <seq> <now_ns>'");
  }
  tag.epoch = std::string(f[0]);
  tag.now = Time{now_ns};
  return world::Decoded<StepTag>::Ok(std::move(tag));
}

std::string EncodeResponseTag(const ResponseTag& tag) {
  return tag.epoch + " " + std::to_string(tag.seq) + " " + std::to_string(tag.index);
}

world::Decoded<ResponseTag> DecodeResponseTag(std::string_view text) {
  const std::vector<std::string_view> f = Fields(text, 3);
  ResponseTag tag;
  if (f.empty() || !IsValidEpoch(f[0]) || !ParseInt(f[1], &tag.seq) ||
      !ParseInt(f[2], &tag.index)) {
    return world::Decoded<ResponseTag>::Error("response tag " + Show(text) +
                                              ": expected '<epoch> <seq> <index>'");
  }
  tag.epoch = std::string(f[0]);
  return world::Decoded<ResponseTag>::Ok(std::move(tag));
}

std::string EncodeReset(const SimReset& reset) {
  return Json{{"epoch", reset.epoch},
              {"policy", ToName(reset.params.policy)},
              {"lease_ns", reset.params.lease.count()},
              {"intersections", reset.intersections}}
      .dump();
}

world::Decoded<SimReset> DecodeReset(std::string_view json) {
  try {
    const Json j = Json::parse(json);
    SimReset reset;
    reset.epoch = j.at("epoch").get<std::string>();
    if (!IsValidEpoch(reset.epoch)) throw std::invalid_argument("bad epoch " + Show(reset.epoch));
    const std::string policy = j.at("policy").get<std::string>();
    const std::optional<world::ServerPolicy> named = FromName<world::ServerPolicy>(policy);
    if (!named) throw std::invalid_argument("policy: unknown " + Show(policy));
    reset.params.policy = *named;
    reset.params.lease = Duration{Integer<std::int64_t>(j.at("lease_ns"), "lease_ns")};
    const Json& intersections = j.at("intersections");
    if (!intersections.is_array()) throw std::invalid_argument("intersections: expected a list");
    for (const Json& id : intersections) {
      reset.intersections.push_back(Integer<int>(id, "intersections[]"));
    }
    return world::Decoded<SimReset>::Ok(std::move(reset));
  } catch (const std::exception& e) {
    return world::Decoded<SimReset>::Error("reset " + Show(json) + ": " + e.what());
  }
}

std::string EncodeAck(const SimAck& ack) {
  Json holders = Json::array();
  for (const auto& [intersection, holder] : ack.holders) {
    holders.push_back(Json::array({intersection, holder ? Json(*holder) : Json()}));
  }
  Json records = Json::array();
  for (const world::ServerRecord& r : ack.records) {
    records.push_back(
        Json::array({static_cast<int>(r.kind), r.car, r.intersection, r.also_released}));
  }
  Json j{{"epoch", ack.epoch},
         {"seq", ack.seq},
         {"responses", ack.responses},
         {"deadline_ns", ack.deadline ? Json(ack.deadline->count()) : Json()},
         {"holders", holders},
         {"counters", CountersToJson(ack.counters)},
         {"records", records}};
  if (!ack.error.empty()) j["error"] = ack.error;
  return j.dump();
}

world::Decoded<SimAck> DecodeAck(std::string_view json) {
  try {
    const Json j = Json::parse(json);
    SimAck ack;
    ack.epoch = j.at("epoch").get<std::string>();
    ack.seq = Integer<std::uint64_t>(j.at("seq"), "seq");
    if (j.contains("error")) ack.error = j.at("error").get<std::string>();
    if (!ack.error.empty()) return world::Decoded<SimAck>::Ok(std::move(ack));
    ack.responses = j.at("responses").get<std::vector<std::string>>();
    const Json& deadline = j.at("deadline_ns");
    if (!deadline.is_null()) ack.deadline = Time{Integer<std::int64_t>(deadline, "deadline_ns")};
    for (const Json& h : j.at("holders")) {
      const Json& holder = h.at(1);
      ack.holders.emplace_back(
          Integer<int>(h.at(0), "holders[][0]"),
          holder.is_null() ? std::nullopt : std::optional(Integer<int>(holder, "holders[][1]")));
    }
    ack.counters = CountersFromJson(j.at("counters"));
    for (const Json& r : j.at("records")) {
      const int kind = Integer<int>(r.at(0), "records[][0]");
      if (kind < 0 || kind > static_cast<int>(world::ServerRecord::Kind::kQueueDrop)) {
        throw std::invalid_argument("records[][0]: unknown kind " + r.at(0).dump());
      }
      world::ServerRecord record{.kind = static_cast<world::ServerRecord::Kind>(kind),
                                 .car = Integer<int>(r.at(1), "records[][1]"),
                                 .intersection = Integer<int>(r.at(2), "records[][2]")};
      for (const Json& id : r.at(3)) {
        record.also_released.push_back(Integer<int>(id, "records[][3][]"));
      }
      ack.records.push_back(std::move(record));
    }
    return world::Decoded<SimAck>::Ok(std::move(ack));
  } catch (const std::exception& e) {
    return world::Decoded<SimAck>::Error("ack " + Show(json) + ": " + e.what());
  }
}

}  // namespace autonomsim::sim
