// FPGA slots shared by time-multiplexing, as the ReconROS executor runs them (issue 37;
// `platform.slot_policy: executor`). The executor (Lienen, Nowosad, Platzner, arXiv 2201.07454;
// code Lien182/ReconROS_Executor @ 2a3ed69, "EXEC" below) has one hardware agent thread per slot.
// An idle agent takes a ready hardware callback, reconfigures its slot unless the slot ran that
// same callback last (hw_executor.c:35), starts the hardware thread and waits for it
// (hw_executor.c:25-62). Reconfigurations go one at a time: the bitstream write is under one
// global lock (zycap_linux.c:96-98), and the ZyCAP driver copies the bitstream into a DMA buffer
// and busy-polls the DMA until it is done, so a core is busy for the copy and the whole transfer.
// There is no queue of its own (events wait in the ROS queues) and no fallback to software.
//
// The model:
//   - a callback ready at t goes to an idle slot; with agent_poll_period 0 (the paper's
//   event-driven
//     executor) at t, else at the first poll of an idle agent (every period from when it went idle:
//     the code's `usleep(1000)`, hw_executor.c:31);
//   - which idle slot: the one that holds the callback's bitstream, else the one idle longest
//     (least recently used). The code has no rule: whichever idle agent polls first takes it, a
//     race; assumed here: the best case of that race (no needless reconfiguration), and least
//     recently used among the others, so that a slot just freed keeps its bitstream longest;
//   - none idle: the callback waits; waiting callbacks go first come, first served (assumed: the
//     executor's round robin over its callback list, callbacklist.c:203-259, is not modelled);
//   - a reconfiguration: the configuration port (one at a time, first come first served) moves
//     `bitstream_bytes` at fpga.config_port_bytes_per_s, after the CPU copied them at
//     cpu.memcpy_bytes_per_s; a core is busy for the copy and the transfer; the slot serves
//     nothing meanwhile;
//   - slots can hold a bitstream from t = 0 (Preload: the node's mapping names the slot).
#pragma once

#include <cstdint>
#include <deque>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "sim/core/kernel.h"
#include "sim/platform/node_metrics.h"

namespace autonomsim::sim {

class Platform;

class SlotExecutor {
 public:
  // What a reconfiguration did, for events and traces (begin and end of the slot's reconfiguring).
  struct Reconfiguration {
    int slot{0};
    std::string node;                     // whose bitstream it loads
    std::optional<std::string> replaced;  // whose bitstream it held
    Time begin{0};                        // the copy's start: the slot serves nothing from here
    Time transfer_begin{0};               // the port's transfer, after the CPU's copy
    Time end{0};
  };
  // What a slot did: callbacks run, reconfigurations, time reconfiguring (summary.json's form).
  using SlotStats = SlotsReport::Slot;

  SlotExecutor(Kernel& kernel, Platform& platform, int slots, Duration poll_period,
               double port_bytes_per_s, double memcpy_bytes_per_s);

  // `slot` holds `node`'s bitstream from t = 0 (std::invalid_argument: no such slot, or one that
  // already holds another's).
  void Preload(int slot, const std::string& node);
  // A hardware callback of `node` ready now: it runs `fabric` on a slot that holds its bitstream
  // (reconfigured first if need be) while its delegate does `delegate_core_s` on the CPU for
  // `owner`; `done` when both have finished.
  void Submit(const std::string& node, int owner, std::int64_t bitstream_bytes, Duration fabric,
              double delegate_core_s, std::function<void()> done);

  int slots() const { return static_cast<int>(slots_.size()); }
  const SlotStats& stats(int slot) const { return slots_.at(static_cast<std::size_t>(slot)).stats; }
  // Callbacks that waited for a slot (none idle when they were ready), and their total wait.
  std::uint64_t waited() const { return waited_; }
  double wait_s() const { return wait_s_; }
  std::size_t waiting() const { return waiting_.size(); }
  // Every slot's stats and the waits, as a board's report holds them.
  SlotsReport Report() const;
  // Called at each reconfiguration's begin (with begin set) and end (all set).
  void OnReconfigureBegin(std::function<void(const Reconfiguration&)> callback) {
    on_begin_ = std::move(callback);
  }
  void OnReconfigured(std::function<void(const Reconfiguration&)> callback) {
    on_reconfigured_ = std::move(callback);
  }

 private:
  struct Callback {
    std::string node;
    int owner{-1};
    std::int64_t bitstream_bytes{0};
    Duration fabric{0};
    double delegate_core_s{0.0};
    std::function<void()> done;
    Time ready{0};
  };
  struct Slot {
    std::optional<std::string> loaded;  // whose bitstream it holds
    bool idle{true};
    Time idle_since{0};
    SlotStats stats;
  };

  // The idle slot that takes a callback of `node` ready at `now`, and when its agent takes it.
  std::optional<std::pair<int, Time>> Choose(const std::string& node, Time now) const;
  void Dispatch(int slot, Callback callback);
  void Reconfigure(int slot, Callback callback);
  void Run(int slot, Callback callback);
  void SlotFree(int slot);
  void PortFree();

  Kernel& kernel_;
  Platform& platform_;
  std::vector<Slot> slots_;
  Duration poll_period_;
  double port_bytes_per_s_;
  double memcpy_bytes_per_s_;
  std::deque<Callback> waiting_;  // for a slot
  bool port_busy_{false};
  std::deque<std::function<void()>> port_waiting_;  // for the configuration port
  std::uint64_t waited_{0};
  double wait_s_{0.0};
  std::function<void(const Reconfiguration&)> on_begin_;
  std::function<void(const Reconfiguration&)> on_reconfigured_;
};

}  // namespace autonomsim::sim
