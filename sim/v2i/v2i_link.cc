#include "sim/v2i/v2i_link.h"

#include <algorithm>
#include <stdexcept>

#include "sim/core/priorities.h"

namespace autonomsim::sim {

EmbeddedV2ILink::EmbeddedV2ILink(Kernel* kernel, const V2IConfig& config, const RngStreams& streams,
                                 std::vector<int> car_ids, ServerReceive to_server,
                                 CarReceive to_car, Lost lost)
    : kernel_(kernel),
      config_(config),
      car_ids_(std::move(car_ids)),
      to_server_(std::move(to_server)),
      to_car_(std::move(to_car)),
      on_lost_(std::move(lost)) {
  for (int id : car_ids_) {
    const std::string car = "car" + std::to_string(id);
    uplinks_.push_back(Path{streams.Stream(car + "/v2i_up"), Time{0}});
    downlinks_.push_back(Path{streams.Stream(car + "/v2i_down"), Time{0}});
  }
}

void EmbeddedV2ILink::SendToServer(int car_id, const world::V2IMessage& message) {
  const auto it = std::find(car_ids_.begin(), car_ids_.end(), car_id);
  if (it == car_ids_.end()) throw std::logic_error("V2I: unknown car " + std::to_string(car_id));
  Deliver(&uplinks_[static_cast<std::size_t>(it - car_ids_.begin())], car_id, message, true);
}

void EmbeddedV2ILink::Broadcast(const world::V2IMessage& message) {
  for (std::size_t i = 0; i < car_ids_.size(); ++i) {
    Deliver(&downlinks_[i], car_ids_[i], message, false);
  }
}

int EmbeddedV2ILink::AddFault(V2ILinkFault fault) {
  faults_.emplace_back(next_fault_, std::move(fault));
  return next_fault_++;
}

void EmbeddedV2ILink::RemoveFault(int handle) {
  std::erase_if(faults_, [handle](const auto& f) { return f.first == handle; });
}

const V2ILinkFault* EmbeddedV2ILink::FaultLosing(int car_id, bool to_server, double u) const {
  for (const auto& [handle, f] : faults_) {
    if (f.car && *f.car != car_id) continue;
    if (!(to_server ? f.up : f.down)) continue;
    if (u < f.loss) return &f;
  }
  return nullptr;
}

void EmbeddedV2ILink::Lose(int car_id, const world::V2IMessage& message, const std::string& cause) {
  ++lost_;
  if (on_lost_) on_lost_(car_id, message, cause);
}

void EmbeddedV2ILink::Deliver(Path* path, int car_id, const world::V2IMessage& message,
                              bool to_server) {
  ++sent_;
  // Draw both numbers every time, so that a change of `loss` (or a fault) does not shift the
  // delays.
  const double u = path->rng.Uniform01();
  const double jitter_fraction = path->rng.Uniform01();
  if (u < config_.loss) return Lose(car_id, message, "");
  if (const V2ILinkFault* fault = FaultLosing(car_id, to_server, u)) {
    return Lose(car_id, message, fault->cause);
  }
  const Duration jitter{
      static_cast<std::int64_t>(jitter_fraction * static_cast<double>(config_.jitter.count()))};
  const Time at = std::max(kernel_->Now() + config_.latency + jitter, path->last_delivery);
  path->last_delivery = at;
  kernel_->ScheduleAt(
      at,
      [this, car_id, message, to_server] {
        // a cut path (loss 1) loses what is in flight on it too
        if (const V2ILinkFault* fault = FaultLosing(car_id, to_server, 1.0 - 0x1.0p-53)) {
          return Lose(car_id, message, fault->cause);
        }
        if (to_server && server_down_) return Lose(car_id, message, "server down");
        ++delivered_;
        if (to_server) {
          to_server_(car_id, message);
        } else {
          to_car_(car_id, message);
        }
      },
      kPriorityV2IDelivery);
}

}  // namespace autonomsim::sim
