#include "world/traffic_light_server.h"

#include <algorithm>
#include <stdexcept>
#include <utility>

#include "world/validation.h"

namespace autonomsim::world {
namespace {

void CheckId(int id, const char* what) {
  if (id < 0 || id > kMaxV2IId) {
    throw std::invalid_argument(std::string(what) + " id must be a single digit 0..9, got " +
                                std::to_string(id));
  }
}

}  // namespace

void TrafficLightServerParams::Validate() const {
  if (lease <= Duration::zero()) {
    throw std::invalid_argument("lease_s must be > 0 s, got " + Num(ToSeconds(lease)) + " s");
  }
}

TrafficLightServer::TrafficLightServer(TrafficLightServerParams params,
                                       std::vector<int> intersection_ids)
    : params_(std::move(params)) {
  params_.Validate();
  fifo_ = params_.policy == ServerPolicy::kFifo;
  if (intersection_ids.empty()) {
    throw std::invalid_argument("intersection_ids must not be empty");
  }
  for (int id : intersection_ids) {
    CheckId(id, "intersection");
    if (!slots_.emplace(id, Slot{.id = id}).second) {
      throw std::invalid_argument("intersection id " + std::to_string(id) + " is repeated");
    }
  }
}

void TrafficLightServer::AdvanceTo(Time now) {
  if (last_now_ && now < *last_now_) {
    throw std::invalid_argument("time went backwards: " + Num(ToSeconds(now)) + " s after " +
                                Num(ToSeconds(*last_now_)) + " s");
  }
  last_now_ = now;
}

bool TrafficLightServer::IsDead(const Slot& slot, int car, Time now) const {
  const auto heard = slot.last_request.find(car);
  return heard == slot.last_request.end() || now >= heard->second + params_.lease;
}

void TrafficLightServer::GrantHeadIfFree(Slot* slot, std::vector<Response>* out) {
  if (slot->holder || slot->queue.empty()) return;
  slot->holder = slot->queue.front();
  slot->queue.pop_front();
  ++counters_.grants;
  records_.push_back({ServerRecord::Kind::kGrant, *slot->holder, slot->id});
  out->push_back(Response{*slot->holder, true});
}

void TrafficLightServer::Expire(Time now, std::vector<Response>* out) {
  if (!fifo_ || !connected_) return;
  // Drop every dead queued car first, so that an expiry never grants a car that is itself dead.
  for (auto& entry : slots_) {
    Slot& slot = entry.second;  // not a structured binding: clang < 16 can't capture it
    const auto before = slot.queue.size();
    std::erase_if(slot.queue, [&](int car) {
      if (!IsDead(slot, car, now)) return false;
      slot.last_request.erase(car);
      records_.push_back({ServerRecord::Kind::kQueueDrop, car, slot.id});
      return true;
    });
    counters_.queue_drops += before - slot.queue.size();
  }
  for (auto& [id, slot] : slots_) {
    if (slot.holder && IsDead(slot, *slot.holder, now)) {
      records_.push_back({ServerRecord::Kind::kLeaseExpired, *slot.holder, id});
      slot.last_request.erase(*slot.holder);
      slot.holder.reset();
      ++counters_.lease_expiries;
    }
    GrantHeadIfFree(&slot, out);
  }
}

std::vector<Response> TrafficLightServer::OnRequest(Time now, const Request& request) {
  CheckId(request.car, "car");
  CheckId(request.intersection, "intersection");
  AdvanceTo(now);
  std::vector<Response> out;
  Expire(now, &out);
  ++counters_.requests;
  records_.push_back({ServerRecord::Kind::kRequest, request.car, request.intersection});

  auto it = slots_.find(request.intersection);
  if (it == slots_.end()) {
    ++counters_.unknown_intersection;
    ++counters_.denials;
    records_.push_back({ServerRecord::Kind::kDenied, request.car, request.intersection});
    out.push_back(Response{request.car, false});
    return out;
  }
  Slot& slot = it->second;
  if (fifo_) slot.last_request[request.car] = now;
  if (!slot.holder) {
    // Invariant: a free slot has an empty queue (every release grants the head at once).
    slot.holder = request.car;
    ++counters_.grants;
    records_.push_back({ServerRecord::Kind::kGrant, request.car, request.intersection});
    out.push_back(Response{request.car, true});
  } else if (*slot.holder == request.car) {
    out.push_back(Response{request.car, true});  // renewal
  } else {
    if (fifo_ && std::find(slot.queue.begin(), slot.queue.end(), request.car) == slot.queue.end()) {
      slot.queue.push_back(request.car);
    }
    ++counters_.denials;
    records_.push_back({ServerRecord::Kind::kDenied, request.car, request.intersection});
    out.push_back(Response{request.car, false});
  }
  return out;
}

std::vector<Response> TrafficLightServer::OnFree(Time now, const Free& free) {
  CheckId(free.car, "car");
  AdvanceTo(now);
  std::vector<Response> out;
  Expire(now, &out);
  ++counters_.frees;
  // the free's record goes before the grants it causes
  ServerRecord record{ServerRecord::Kind::kFree, free.car, -1};
  for (const auto& [id, slot] : slots_) {
    if (slot.holder != free.car) continue;
    if (record.intersection < 0) {
      record.intersection = id;
    } else if (fifo_) {
      record.also_released.push_back(id);
    }
  }
  records_.push_back(record);
  if (!fifo_) {
    // vtl.py:15-22: if/elif over slot 0, then slot 1: the first slot the car holds, only
    if (record.intersection >= 0) slots_.at(record.intersection).holder.reset();
    return out;
  }
  for (auto& [id, slot] : slots_) {
    std::erase(slot.queue, free.car);
    slot.last_request.erase(free.car);
    if (slot.holder == free.car) {
      slot.holder.reset();
      GrantHeadIfFree(&slot, &out);
    }
  }
  return out;
}

std::vector<Response> TrafficLightServer::OnTick(Time now) {
  AdvanceTo(now);
  std::vector<Response> out;
  Expire(now, &out);
  return out;
}

std::vector<Response> TrafficLightServer::OnDisconnected(Time now) {
  AdvanceTo(now);
  std::vector<Response> out;
  Expire(now, &out);
  connected_ = false;
  return out;
}

void TrafficLightServer::OnReconnected(Time now) {
  AdvanceTo(now);
  if (connected_) return;
  connected_ = true;
  for (auto& entry : slots_) {
    for (auto& heard : entry.second.last_request) heard.second = now;
  }
}

std::vector<ServerRecord> TrafficLightServer::TakeRecords() {
  std::vector<ServerRecord> taken;
  taken.swap(records_);
  return taken;
}

std::optional<Time> TrafficLightServer::NextDeadline() const {
  if (!fifo_ || !connected_) return std::nullopt;
  std::optional<Time> earliest;
  for (const auto& [id, slot] : slots_) {
    for (const auto& [car, heard] : slot.last_request) {
      const Time deadline = heard + params_.lease;
      if (!earliest || deadline < *earliest) earliest = deadline;
    }
  }
  return earliest;
}

std::optional<int> TrafficLightServer::Holder(int intersection) const {
  auto it = slots_.find(intersection);
  if (it == slots_.end()) return std::nullopt;
  return it->second.holder;
}

std::vector<int> TrafficLightServer::Queue(int intersection) const {
  auto it = slots_.find(intersection);
  if (it == slots_.end()) return {};
  return {it->second.queue.begin(), it->second.queue.end()};
}

}  // namespace autonomsim::world
