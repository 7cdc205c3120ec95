// The compute platform a node graph runs on: N CPU cores shared by every running software job
// (processor sharing), FPGA slots each serving one hardware node, the costs of the two transports
// (DDS over loopback and zero-copy shared memory) and the zero-copy shared-memory chunk pools.
// Numbers come from a PlatformProfile; nothing here reads the wall clock, so host speed never
// changes a simulated time.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "sim/core/kernel.h"
#include "sim/core/priorities.h"
#include "sim/core/random.h"
#include "sim/platform/node_metrics.h"
#include "sim/platform/platform_profile.h"
#include "sim/platform/slot_executor.h"

namespace autonomsim::sim {

// The graph's and the platform's events run at kPriorityPlatform (sim/core/priorities.h): after the
// V2I deliveries, the intersection clients and the sensors, before the drivers read their inputs.

// ---- Transport costs (pure functions of the profile and the message size) ----

// a / b rounded up, for a >= 0 and b > 0 (0 for a <= 0): datagrams and fragments of a sample.
inline std::int64_t CeilDiv(std::int64_t a, std::int64_t b) { return a <= 0 ? 0 : (a + b - 1) / b; }

// Core-seconds of `copies` memcpy passes over `bytes`.
double CopyCoreSeconds(const CpuProfile& cpu, std::int64_t bytes, int copies = 1);
// Core-seconds of one side of a DDS transfer (DdsSideCost's formula): its fixed cost, its copies
// of the bytes, and its cost per datagram and per fragment. The first form counts the sample's
// datagrams and fragments with the profile's sizes.
double DdsSideCoreSeconds(const PlatformProfile& profile, const DdsSideCost& side,
                          std::int64_t bytes);
double DdsSideCoreSeconds(const DdsSideCost& side, double memcpy_bytes_per_s, std::int64_t bytes,
                          std::int64_t datagrams, std::int64_t fragments);

// What sending one message costs, per transport.
struct TransportCost {
  double publish_core_s{0.0};  // in the publishing job
  double receive_core_s{0.0};  // per subscriber, on its DDS receive thread (0 for zero-copy)
  double take_core_s{0.0};     // per subscriber, in its job
  Duration latency{0};         // after the publish (and, for DDS, after the receive processing)
};
TransportCost DdsCost(const PlatformProfile& profile, std::int64_t bytes);
// `loaned_take`: the subscriber uses the loan API; otherwise it gets a copy of the sample.
TransportCost ZeroCopyCost(const PlatformProfile& profile, std::int64_t bytes, bool loaned_take);

// One draw of a cost_override distribution (seconds, >= 0; a normal draw below 0 counts as 0).
double DrawCostSeconds(const CostDistributionConfig& distribution, Rng& rng);

// The profile a board runs on: `profile` with the config's what-if overrides (cores,
// host_rmem_max_bytes).
PlatformProfile WithConfigOverrides(PlatformProfile profile, const PlatformConfig& config);

// ---- CPU: N cores, processor sharing ----

// Every running job has remaining work (core-seconds) and a maximum parallelism p (the cores it
// can use at once). The cores are shared by water-filling: jobs ordered by p get
// min(p, remaining cores / remaining jobs) each, so nobody gets more than it can use and, when the
// sum of the demands exceeds N, the others share equally. On every start and completion the rates
// are recomputed and the next completion is rescheduled on the kernel (Cancel + ScheduleAt), so a
// job's end time always reflects the load it actually saw.
class Cpu {
 public:
  using JobId = std::uint64_t;

  // `metrics` may be null; it receives per-owner and total busy time.
  Cpu(Kernel& kernel, int cores, RunMetrics* metrics);
  Cpu(const Cpu&) = delete;
  Cpu& operator=(const Cpu&) = delete;
  ~Cpu();

  // Starts a job of `work_core_s` (>= 0) for `owner` (a node index of the metrics, or -1). `done`
  // runs at its completion, from a kernel event (never from inside Start).
  JobId Start(int owner, double work_core_s, double max_parallelism, std::function<void()> done);

  int cores() const { return cores_; }
  double busy_cores() const;  // sum of the running jobs' shares now
  // The cores the running jobs would use if they had them (the sum of their parallelism).
  double demand() const;
  std::size_t running() const { return jobs_.size(); }
  // The cores job `id` gets now (0 if it is not running); for tests and traces.
  double share(JobId id) const;
  // The core-seconds the jobs have had from t = 0 to `now` (>= the last change of load), for an
  // observer's mean load over an interval (sim/results/mcap_recording.h). Looks, changes nothing.
  double BusyCoreSecondsAt(Time now) const;

 private:
  struct Job {
    JobId id;
    int owner;
    double remaining_core_ns;
    double max_parallelism;
    double rate{0.0};  // cores
    std::function<void()> done;
  };
  void Advance();     // charges the time since the last update to every running job
  void Reallocate();  // water-filling
  void ScheduleNext();
  void OnCompletion();

  Kernel& kernel_;
  int cores_;
  RunMetrics* metrics_;
  std::vector<Job> jobs_;  // in start order
  // scratch, kept for its memory: Reallocate's order of the jobs, OnCompletion's finished jobs
  std::vector<std::size_t> order_;
  std::vector<std::function<void()>> finished_;
  Time last_update_{0};
  double busy_core_s_{0.0};  // the core-seconds charged up to last_update_
  EventId next_event_;
  JobId next_id_{1};
};

// ---- FPGA slots ----

class Fpga {
 public:
  Fpga(Kernel& kernel, const FpgaProfile& profile, RunMetrics* metrics);

  // Gives `slot` to `node` for the whole run; a ConfigError if the slot does not exist or already
  // serves another node (one hardware node per slot).
  void Claim(int slot, const std::string& node);
  // `slot` now serves `node` (slot_policy executor: the slots change hands; names its trace spans).
  void Serve(int slot, const std::string& node);
  // Time to move `bytes` (read + written) over one slot's memory interface.
  Duration TransferTime(std::int64_t bytes) const;
  // Occupies `slot` for `duration`, then calls `done`. The slot must be free.
  void Run(int slot, Duration duration, std::function<void()> done);

  int slots() const { return profile_.slots; }
  bool busy(int slot) const;

 private:
  Kernel& kernel_;
  FpgaProfile profile_;
  RunMetrics* metrics_;
  std::vector<std::string> owner_;  // per slot; empty if unclaimed
  std::vector<bool> busy_;
};

// ---- Zero-copy shared memory chunks (Iceoryx RouDi mempools) ----

class ChunkPools {
 public:
  explicit ChunkPools(const std::vector<MempoolConfig>& pools);

  // The pool serving `bytes` (the smallest chunk that fits), or nullopt if none is large enough.
  std::optional<int> PoolFor(std::int64_t bytes) const;
  bool Acquire(int pool);  // false when every chunk of the pool is in use
  void Release(int pool);
  int in_use(int pool) const { return in_use_.at(static_cast<std::size_t>(pool)); }

 private:
  std::vector<MempoolConfig> pools_;
  std::vector<int> in_use_;
};

// A chunk held by a published zero-copy sample; returned to its pool when the last reference (the
// publisher's, a subscriber queue's, a running job's) goes away.
class ChunkLease {
 public:
  ChunkLease(std::shared_ptr<ChunkPools> pools, int pool) : pools_(std::move(pools)), pool_(pool) {}
  ChunkLease(const ChunkLease&) = delete;
  ChunkLease& operator=(const ChunkLease&) = delete;
  ~ChunkLease() { pools_->Release(pool_); }

 private:
  std::shared_ptr<ChunkPools> pools_;
  int pool_;
};

// ---- The platform ----

class Platform {
 public:
  Platform(Kernel& kernel, PlatformProfile profile, RunMetrics* metrics);
  ~Platform();
  Platform(const Platform&) = delete;
  Platform& operator=(const Platform&) = delete;

  const PlatformProfile& profile() const { return profile_; }
  Kernel& kernel() { return kernel_; }
  Cpu& cpu() { return cpu_; }
  Fpga& fpga() { return fpga_; }
  // The slots' executor (fpga.slot_policy executor), else null.
  SlotExecutor* slot_executor() { return slot_executor_.get(); }
  const SlotExecutor* slot_executor() const { return slot_executor_.get(); }
  const std::shared_ptr<ChunkPools>& chunk_pools() { return chunk_pools_; }
  RunMetrics* metrics() { return metrics_; }

  // A hardware job: `slot` busy for `fabric` while the delegate thread does `delegate_core_s` of
  // CPU work (at most one core) for `owner`; `done` runs when both have finished.
  void RunHwJob(int slot, int owner, Duration fabric, double delegate_core_s,
                std::function<void()> done);

 private:
  Kernel& kernel_;
  PlatformProfile profile_;
  RunMetrics* metrics_;
  Cpu cpu_;
  Fpga fpga_;
  std::shared_ptr<ChunkPools> chunk_pools_;
  std::unique_ptr<SlotExecutor> slot_executor_;
};

}  // namespace autonomsim::sim
