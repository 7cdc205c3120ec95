#include "sim/platform/slot_executor.h"

#include <memory>
#include <stdexcept>
#include <tuple>
#include <utility>

#include "sim/core/priorities.h"
#include "sim/platform/platform.h"

namespace autonomsim::sim {

SlotExecutor::SlotExecutor(Kernel& kernel, Platform& platform, int slots, Duration poll_period,
                           double port_bytes_per_s, double memcpy_bytes_per_s)
    : kernel_(kernel),
      platform_(platform),
      slots_(static_cast<std::size_t>(slots)),
      poll_period_(poll_period),
      port_bytes_per_s_(port_bytes_per_s),
      memcpy_bytes_per_s_(memcpy_bytes_per_s) {}

SlotsReport SlotExecutor::Report() const {
  SlotsReport report{.waits = waited_, .wait_s = wait_s_};
  for (const Slot& slot : slots_) report.slots.push_back(slot.stats);
  return report;
}

void SlotExecutor::Preload(int slot, const std::string& node) {
  if (slot < 0 || slot >= slots()) {
    throw std::invalid_argument("slot " + std::to_string(slot) + " does not exist (slots 0.." +
                                std::to_string(slots() - 1) + ")");
  }
  std::optional<std::string>& loaded = slots_[static_cast<std::size_t>(slot)].loaded;
  if (loaded && *loaded != node) {
    throw std::invalid_argument("slot " + std::to_string(slot) + " already holds node '" + *loaded +
                                "''s bitstream at the start");
  }
  loaded = node;
}

std::optional<std::pair<int, Time>> SlotExecutor::Choose(const std::string& node, Time now) const {
  std::optional<std::pair<int, Time>> best;
  // by: when its agent takes it, then holding the bitstream, then idle longest, then index
  std::tuple<Time, bool, Time> best_key{};
  for (int s = 0; s < slots(); ++s) {
    const Slot& slot = slots_[static_cast<std::size_t>(s)];
    if (!slot.idle) continue;
    Time take = now;
    if (poll_period_.count() > 0) {  // the agent's first poll at or after now
      const auto polls = (now - slot.idle_since + poll_period_ - Duration{1}) / poll_period_;
      take = slot.idle_since + polls * poll_period_;
    }
    const std::tuple<Time, bool, Time> key{take, !(slot.loaded && *slot.loaded == node),
                                           slot.idle_since};
    if (!best || key < best_key) {
      best = std::pair(s, take);
      best_key = key;
    }
  }
  return best;
}

void SlotExecutor::Submit(const std::string& node, int owner, std::int64_t bitstream_bytes,
                          Duration fabric, double delegate_core_s, std::function<void()> done) {
  Callback callback{.node = node,
                    .owner = owner,
                    .bitstream_bytes = bitstream_bytes,
                    .fabric = fabric,
                    .delegate_core_s = delegate_core_s,
                    .done = std::move(done),
                    .ready = kernel_.Now()};
  const auto choice = Choose(node, kernel_.Now());
  if (!choice) {
    ++waited_;
    waiting_.push_back(std::move(callback));
    return;
  }
  const auto [slot, take] = *choice;
  slots_[static_cast<std::size_t>(slot)].idle = false;
  if (take == kernel_.Now()) {
    Dispatch(slot, std::move(callback));
    return;
  }
  auto shared = std::make_shared<Callback>(std::move(callback));
  kernel_.ScheduleAt(
      take, [this, slot, shared] { Dispatch(slot, std::move(*shared)); }, kPriorityPlatform);
}

void SlotExecutor::Dispatch(int slot, Callback callback) {
  const Slot& s = slots_[static_cast<std::size_t>(slot)];
  if (s.loaded && *s.loaded == callback.node) {
    Run(slot, std::move(callback));
  } else {
    Reconfigure(slot, std::move(callback));
  }
}

// The copy into the DMA buffer (a core), then the transfer through the port while the driver
// busy-polls (a core), the port held from the copy's start to the transfer's end.
void SlotExecutor::Reconfigure(int slot, Callback callback) {
  auto shared = std::make_shared<Callback>(std::move(callback));
  if (port_busy_) {
    port_waiting_.push_back([this, slot, shared] { Reconfigure(slot, std::move(*shared)); });
    return;
  }
  port_busy_ = true;
  const Time start = kernel_.Now();
  const std::optional<std::string> replaced = slots_[static_cast<std::size_t>(slot)].loaded;
  if (on_begin_) {
    on_begin_(
        Reconfiguration{.slot = slot, .node = shared->node, .replaced = replaced, .begin = start});
  }
  const double bytes = static_cast<double>(shared->bitstream_bytes);
  const double transfer_s = bytes / port_bytes_per_s_;
  platform_.cpu().Start(shared->owner, bytes / memcpy_bytes_per_s_, 1.0, [=, this] {
    const Time transfer_begin = kernel_.Now();
    auto pending = std::make_shared<int>(2);
    auto finish = [=, this] {
      if (--*pending > 0) return;
      Slot& s = slots_[static_cast<std::size_t>(slot)];
      const Reconfiguration done{.slot = slot,
                                 .node = shared->node,
                                 .replaced = replaced,
                                 .begin = start,
                                 .transfer_begin = transfer_begin,
                                 .end = kernel_.Now()};
      s.loaded = shared->node;
      ++s.stats.reconfigurations;
      s.stats.reconfiguring_s += ToSeconds(kernel_.Now() - start);
      if (RunMetrics* metrics = platform_.metrics()) {  // the slot's trace track shows it
        metrics->Span(TraceLane::kSlot, slot, "reconfigure " + shared->node, start, done.end);
        metrics->Span(TraceLane::kConfigPort, 0,
                      "slot " + std::to_string(slot) + " <- " + shared->node, transfer_begin,
                      done.end);
      }
      if (on_reconfigured_) on_reconfigured_(done);
      PortFree();
      Run(slot, std::move(*shared));
    };
    kernel_.ScheduleIn(FromSeconds(transfer_s), finish, kPriorityPlatform);
    platform_.cpu().Start(shared->owner, transfer_s, 1.0, finish);  // the driver's busy-poll
  });
}

void SlotExecutor::PortFree() {
  port_busy_ = false;
  if (port_waiting_.empty()) return;
  std::function<void()> next = std::move(port_waiting_.front());
  port_waiting_.pop_front();
  next();
}

void SlotExecutor::Run(int slot, Callback callback) {
  Slot& s = slots_[static_cast<std::size_t>(slot)];
  ++s.stats.callbacks;
  platform_.fpga().Serve(slot, callback.node);
  platform_.RunHwJob(slot, callback.owner, callback.fabric, callback.delegate_core_s,
                     [this, slot, done = std::move(callback.done)] {
                       SlotFree(slot);  // before the node's next job: it may take this slot
                       done();
                     });
}

// The agent, free again, takes the callback that waited longest, else goes idle.
void SlotExecutor::SlotFree(int slot) {
  Slot& s = slots_[static_cast<std::size_t>(slot)];
  if (waiting_.empty()) {
    s.idle = true;
    s.idle_since = kernel_.Now();
    return;
  }
  Callback next = std::move(waiting_.front());
  waiting_.pop_front();
  wait_s_ += ToSeconds(kernel_.Now() - next.ready);
  Dispatch(slot, std::move(next));
}

}  // namespace autonomsim::sim
