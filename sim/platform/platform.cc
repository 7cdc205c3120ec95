#include "sim/platform/platform.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "sim/core/config.h"
#include "world/validation.h"

namespace autonomsim::sim {
namespace {}  // namespace

double CopyCoreSeconds(const CpuProfile& cpu, std::int64_t bytes, int copies) {
  return static_cast<double>(copies) * static_cast<double>(bytes) / cpu.memcpy_bytes_per_s;
}

double DdsSideCoreSeconds(const PlatformProfile& profile, const DdsSideCost& side,
                          std::int64_t bytes) {
  return DdsSideCoreSeconds(side, profile.cpu.memcpy_bytes_per_s, bytes,
                            CeilDiv(bytes, profile.dds.max_message_bytes),
                            CeilDiv(bytes, profile.dds.fragment_bytes));
}

double DdsSideCoreSeconds(const DdsSideCost& side, double memcpy_bytes_per_s, std::int64_t bytes,
                          std::int64_t datagrams, std::int64_t fragments) {
  return ToSeconds(side.fixed) +
         static_cast<double>(side.copies) * static_cast<double>(bytes) / memcpy_bytes_per_s +
         static_cast<double>(datagrams) * ToSeconds(side.per_datagram) +
         static_cast<double>(fragments) * ToSeconds(side.per_fragment);
}

TransportCost DdsCost(const PlatformProfile& profile, std::int64_t bytes) {
  return {.publish_core_s = DdsSideCoreSeconds(profile, profile.dds.write, bytes),
          .receive_core_s = DdsSideCoreSeconds(profile, profile.dds.receive, bytes),
          .take_core_s = DdsSideCoreSeconds(profile, profile.dds.take, bytes),
          .latency = profile.dds.latency};
}

TransportCost ZeroCopyCost(const PlatformProfile& profile, std::int64_t bytes, bool loaned_take) {
  const ZeroCopyProfile& zc = profile.zero_copy;
  double take = ToSeconds(zc.take);
  if (!loaned_take) take += CopyCoreSeconds(profile.cpu, bytes, zc.non_loaned_take_copies);
  return {.publish_core_s = ToSeconds(zc.publish),
          .receive_core_s = 0.0,
          .take_core_s = take,
          .latency = zc.latency};
}

// ---- Cpu ----

Cpu::Cpu(Kernel& kernel, int cores, RunMetrics* metrics)
    : kernel_(kernel), cores_(cores), metrics_(metrics), last_update_(kernel.Now()) {
  if (cores < 1) throw std::invalid_argument("Cpu: cores must be >= 1");
  if (metrics_) metrics_->SetCores(cores);
}

Cpu::~Cpu() { kernel_.Cancel(next_event_); }

Cpu::JobId Cpu::Start(int owner, double work_core_s, double max_parallelism,
                      std::function<void()> done) {
  if (!(work_core_s >= 0.0) || !std::isfinite(work_core_s)) {
    throw std::invalid_argument("Cpu::Start: work must be finite and >= 0, got " +
                                Num(work_core_s));
  }
  if (!(max_parallelism > 0.0)) {
    throw std::invalid_argument("Cpu::Start: max_parallelism must be > 0, got " +
                                Num(max_parallelism));
  }
  Advance();
  const JobId id = next_id_++;
  jobs_.push_back(Job{.id = id,
                      .owner = owner,
                      .remaining_core_ns = work_core_s * 1e9,
                      .max_parallelism = max_parallelism,
                      .done = std::move(done)});
  Reallocate();
  ScheduleNext();
  return id;
}

double Cpu::busy_cores() const {
  double busy = 0.0;
  for (const Job& job : jobs_) busy += job.rate;
  return busy;
}

double Cpu::BusyCoreSecondsAt(Time now) const {
  return busy_core_s_ + busy_cores() * ToSeconds(std::max(now - last_update_, Duration{0}));
}

double Cpu::demand() const {
  double demand = 0.0;
  for (const Job& job : jobs_) demand += job.max_parallelism;
  return demand;
}

double Cpu::share(JobId id) const {
  for (const Job& job : jobs_) {
    if (job.id == id) return job.rate;
  }
  return 0.0;
}

void Cpu::Advance() {
  const Time now = kernel_.Now();
  if (now <= last_update_) {
    last_update_ = now;
    return;
  }
  const double dt_ns = static_cast<double>((now - last_update_).count());
  double busy = 0.0;
  for (Job& job : jobs_) {
    job.remaining_core_ns -= job.rate * dt_ns;
    busy += job.rate;
    if (metrics_ && job.owner >= 0 && job.rate > 0.0) {
      metrics_->AddCpu(job.owner, last_update_, now, job.rate);
    }
  }
  if (metrics_) metrics_->AddBusy(last_update_, now, busy);
  busy_core_s_ += busy * dt_ns * 1e-9;
  last_update_ = now;
}

void Cpu::Reallocate() {
  // the jobs by max_parallelism, ties in start order: an insertion sort (stable; a handful of
  // jobs), into memory kept from call to call
  order_.clear();
  for (std::size_t i = 0; i < jobs_.size(); ++i) {
    std::size_t k = order_.size();
    order_.push_back(i);
    for (; k > 0 && jobs_[i].max_parallelism < jobs_[order_[k - 1]].max_parallelism; --k) {
      order_[k] = order_[k - 1];
    }
    order_[k] = i;
  }
  double capacity = static_cast<double>(cores_);
  std::size_t left = jobs_.size();
  for (std::size_t i : order_) {
    const double fair = capacity / static_cast<double>(left);
    const double rate = std::min(jobs_[i].max_parallelism, fair);
    jobs_[i].rate = rate;
    capacity -= rate;
    --left;
  }
  if (metrics_) metrics_->BusyChanged(kernel_.Now(), busy_cores());
}

void Cpu::ScheduleNext() {
  kernel_.Cancel(next_event_);
  next_event_ = EventId{};
  if (jobs_.empty()) return;
  double soonest_ns = std::numeric_limits<double>::infinity();
  for (const Job& job : jobs_) {
    if (job.rate <= 0.0) continue;
    soonest_ns = std::min(soonest_ns, std::max(0.0, job.remaining_core_ns) / job.rate);
  }
  if (!std::isfinite(soonest_ns)) {
    throw std::logic_error("Cpu: running jobs but none gets a share of the cores");
  }
  // Rounding up: the event never comes before the job's exact end, so it is done when it fires.
  const Time at = kernel_.Now() + Duration{static_cast<std::int64_t>(std::ceil(soonest_ns))};
  next_event_ = kernel_.ScheduleAt(
      at, [this] { OnCompletion(); }, kPriorityPlatform);
}

void Cpu::OnCompletion() {
  next_event_ = EventId{};
  Advance();
  // Done: nothing left but rounding (less than half a nanosecond of its current share). The
  // others keep their order; the memory of both lists is kept from call to call (a done callback
  // may start jobs, so the finished list is taken out of the member while they run).
  std::vector<std::function<void()>> finished = std::move(finished_);
  finished.clear();
  std::size_t kept = 0;
  for (Job& job : jobs_) {
    if (job.remaining_core_ns <= 0.5 * job.rate) {
      finished.push_back(std::move(job.done));
    } else {
      if (&jobs_[kept] != &job) jobs_[kept] = std::move(job);
      ++kept;
    }
  }
  jobs_.erase(jobs_.begin() + static_cast<std::ptrdiff_t>(kept), jobs_.end());
  Reallocate();
  ScheduleNext();
  for (auto& done : finished) {
    if (done) done();
  }
  finished.clear();
  if (finished.capacity() > finished_.capacity()) finished_ = std::move(finished);
}

// ---- Fpga ----

Fpga::Fpga(Kernel& kernel, const FpgaProfile& profile, RunMetrics* metrics)
    : kernel_(kernel),
      profile_(profile),
      metrics_(metrics),
      owner_(static_cast<std::size_t>(profile.slots)),
      busy_(static_cast<std::size_t>(profile.slots), false) {}

void Fpga::Claim(int slot, const std::string& node) {
  if (slot < 0 || slot >= profile_.slots) {
    throw ConfigError("node '" + node + "' is mapped to FPGA slot " + std::to_string(slot) +
                      ", but the platform has slots 0.." + std::to_string(profile_.slots - 1));
  }
  std::string& owner = owner_[static_cast<std::size_t>(slot)];
  if (!owner.empty()) {
    throw ConfigError("node '" + node + "' is mapped to FPGA slot " + std::to_string(slot) +
                      ", which already serves node '" + owner + "' (one hardware node per slot)");
  }
  owner = node;
}

void Fpga::Serve(int slot, const std::string& node) {
  owner_.at(static_cast<std::size_t>(slot)) = node;
}

Duration Fpga::TransferTime(std::int64_t bytes) const {
  return FromSeconds(static_cast<double>(bytes) / profile_.memif_bytes_per_s);
}

bool Fpga::busy(int slot) const { return busy_.at(static_cast<std::size_t>(slot)); }

void Fpga::Run(int slot, Duration duration, std::function<void()> done) {
  if (busy_.at(static_cast<std::size_t>(slot))) {
    throw std::logic_error("Fpga::Run: slot " + std::to_string(slot) + " is busy");
  }
  busy_[static_cast<std::size_t>(slot)] = true;
  const Time start = kernel_.Now();
  kernel_.ScheduleIn(
      duration,
      [this, slot, start, done = std::move(done)] {
        busy_[static_cast<std::size_t>(slot)] = false;
        if (metrics_) {
          metrics_->Span(TraceLane::kSlot, slot, owner_[static_cast<std::size_t>(slot)], start,
                         kernel_.Now());
        }
        done();
      },
      kPriorityPlatform);
}

// ---- ChunkPools ----

ChunkPools::ChunkPools(const std::vector<MempoolConfig>& pools)
    : pools_(pools), in_use_(pools.size(), 0) {}

std::optional<int> ChunkPools::PoolFor(std::int64_t bytes) const {
  for (std::size_t i = 0; i < pools_.size(); ++i) {
    if (bytes <= pools_[i].chunk_bytes) return static_cast<int>(i);
  }
  return std::nullopt;
}

bool ChunkPools::Acquire(int pool) {
  const std::size_t i = static_cast<std::size_t>(pool);
  if (in_use_.at(i) >= pools_.at(i).chunks) return false;
  ++in_use_[i];
  return true;
}

void ChunkPools::Release(int pool) {
  const std::size_t i = static_cast<std::size_t>(pool);
  if (in_use_.at(i) <= 0) throw std::logic_error("ChunkPools::Release: pool has no chunk in use");
  --in_use_[i];
}

// ---- Platform ----

Platform::Platform(Kernel& kernel, PlatformProfile profile, RunMetrics* metrics)
    : kernel_(kernel),
      profile_(std::move(profile)),
      metrics_(metrics),
      cpu_(kernel, profile_.cpu.cores, metrics),
      fpga_(kernel, profile_.fpga, metrics),
      chunk_pools_(std::make_shared<ChunkPools>(profile_.zero_copy.mempools)) {
  if (profile_.fpga.slot_policy == SlotPolicy::kExecutor) {
    slot_executor_ = std::make_unique<SlotExecutor>(
        kernel, *this, profile_.fpga.slots, profile_.fpga.agent_poll_period,
        profile_.fpga.config_port_bytes_per_s, profile_.cpu.memcpy_bytes_per_s);
  }
}

Platform::~Platform() = default;

double DrawCostSeconds(const CostDistributionConfig& d, Rng& rng) {
  switch (d.distribution) {
    case CostDistribution::kFixed:
      return *d.value_s;
    case CostDistribution::kUniform:
      return rng.Uniform(*d.min_s, *d.max_s);
    case CostDistribution::kNormal:
      return std::max(0.0, rng.Normal(*d.mean_s, *d.stddev_s));
    case CostDistribution::kLognormal: {
      // mean m and standard deviation s of the cost: sigma^2 = ln(1 + s^2/m^2),
      // mu = ln m - sigma^2/2
      const double ratio = *d.stddev_s / *d.mean_s;
      const double sigma2 = std::log1p(ratio * ratio);
      return std::exp(rng.Normal(std::log(*d.mean_s) - 0.5 * sigma2, std::sqrt(sigma2)));
    }
  }
  throw std::logic_error("DrawCostSeconds: not a distribution");
}

PlatformProfile WithConfigOverrides(PlatformProfile profile, const PlatformConfig& config) {
  if (config.cores) profile.cpu.cores = *config.cores;
  if (config.slots) profile.fpga.slots = *config.slots;
  if (config.slot_policy) profile.fpga.slot_policy = *config.slot_policy;
  if (config.config_port_bytes_per_s) {
    profile.fpga.config_port_bytes_per_s = *config.config_port_bytes_per_s;
  }
  if (config.host_rmem_max_bytes) profile.dds.host_rmem_max_bytes = *config.host_rmem_max_bytes;
  return profile;
}

void Platform::RunHwJob(int slot, int owner, Duration fabric, double delegate_core_s,
                        std::function<void()> done) {
  // Both halves report to one counter; the second to finish calls `done`.
  auto pending = std::make_shared<int>(2);
  auto shared_done = std::make_shared<std::function<void()>>(std::move(done));
  auto join = [pending, shared_done] {
    if (--*pending == 0) (*shared_done)();
  };
  fpga_.Run(slot, fabric, join);
  cpu_.Start(owner, delegate_core_s, 1.0, join);
}

}  // namespace autonomsim::sim
