#include "sim/platform/platform_profile.h"

#include <cmath>
#include <set>
#include <stdexcept>

#include "world/validation.h"

namespace autonomsim::sim {
namespace {

void RequireNonNegative(Duration d, const std::string& key) {
  Require(d.count() >= 0, key + " must be >= 0, got " + Num(ToSeconds(d)));
}

void RequireJitter(double jitter) {
  Require(jitter >= 0.0 && jitter < 1.0, "jitter must be in [0, 1), got " + Num(jitter));
}

}  // namespace

void SwCost::Validate() const {
  Require(work_s >= 0.0, "work_s must be >= 0, got " + Num(work_s));
  Require(work_ns_per_input_byte >= 0.0,
          "work_ns_per_input_byte must be >= 0, got " + Num(work_ns_per_input_byte));
  Require(work_ns_per_output_byte >= 0.0,
          "work_ns_per_output_byte must be >= 0, got " + Num(work_ns_per_output_byte));
  Require(max_parallelism > 0.0, "max_parallelism must be > 0, got " + Num(max_parallelism));
  RequireJitter(jitter);
}

void HwCost::Validate() const {
  Require(compute_s >= 0.0, "compute_s must be >= 0, got " + Num(compute_s));
  Require(delegate_cpu_s >= 0.0, "delegate_cpu_s must be >= 0, got " + Num(delegate_cpu_s));
  RequireJitter(jitter);
}

void ComponentCost::Validate() const {
  Require(sw.has_value() || hw.has_value(), "a component needs a 'sw' or an 'hw' cost");
}

void CpuProfile::Validate() const {
  Require(cores >= 1, "cores must be >= 1, got " + std::to_string(cores));
  Require(memcpy_bytes_per_s > 0.0,
          "memcpy_bytes_per_s must be > 0, got " + Num(memcpy_bytes_per_s));
  RequireNonNegative(sched_slice, "sched_slice_s");
}

void FpgaProfile::Validate() const {
  Require(slots >= 0, "slots must be >= 0, got " + std::to_string(slots));
  Require(memif_bytes_per_s > 0.0, "memif_bytes_per_s must be > 0, got " + Num(memif_bytes_per_s));
  Require(config_port_bytes_per_s > 0.0,
          "config_port_bytes_per_s must be > 0, got " + Num(config_port_bytes_per_s));
  RequireNonNegative(agent_poll_period, "agent_poll_period_s");
}

void DdsSideCost::Validate() const {
  RequireNonNegative(fixed, "fixed_s");
  Require(copies >= 0, "copies must be >= 0, got " + std::to_string(copies));
  RequireNonNegative(per_datagram, "per_datagram_s");
  RequireNonNegative(per_fragment, "per_fragment_s");
}

void DdsProfile::Validate() const {
  const auto positive = [](int value, const char* key) {
    Require(value > 0, std::string(key) + " must be > 0, got " + std::to_string(value));
  };
  positive(fragment_bytes, "fragment_bytes");
  positive(max_message_bytes, "max_message_bytes");
  positive(receive_buffer_bytes, "receive_buffer_bytes");
  positive(host_rmem_max_bytes, "host_rmem_max_bytes");
  positive(whc_high_bytes, "whc_high_bytes");
  positive(max_queued_rexmit_bytes, "max_queued_rexmit_bytes");
  Require(socket_overhead_bytes >= 0,
          "socket_overhead_bytes must be >= 0, got " + std::to_string(socket_overhead_bytes));
  Require(whc_low_bytes >= 0 && whc_low_bytes <= whc_high_bytes,
          "whc_low_bytes must be between 0 and whc_high_bytes (" + std::to_string(whc_high_bytes) +
              "), got " + std::to_string(whc_low_bytes));
  RequireNonNegative(latency, "latency_s");
  Require(heartbeat_interval > Duration{0}, "heartbeat_interval_s must be > 0");
  RequireNonNegative(nack_delay, "nack_delay_s");
  if (max_blocking) RequireNonNegative(*max_blocking, "max_blocking_s");
}

void MempoolConfig::Validate() const {
  Require(chunk_bytes > 0, "chunk_bytes must be > 0, got " + std::to_string(chunk_bytes));
  Require(chunks > 0, "chunks must be > 0, got " + std::to_string(chunks));
}

void ZeroCopyProfile::Validate() const {
  RequireNonNegative(publish, "publish_s");
  RequireNonNegative(take, "take_s");
  RequireNonNegative(latency, "latency_s");
  Require(non_loaned_take_copies >= 0,
          "non_loaned_take_copies must be >= 0, got " + std::to_string(non_loaned_take_copies));
  Require(max_subscribers >= 1,
          "max_subscribers must be >= 1, got " + std::to_string(max_subscribers));
  Require(max_loans_per_publisher >= 1,
          "max_loans_per_publisher must be >= 1, got " + std::to_string(max_loans_per_publisher));
  Require(!mempools.empty(), "mempools must list at least one pool");
  for (std::size_t i = 1; i < mempools.size(); ++i) {
    Require(mempools[i].chunk_bytes > mempools[i - 1].chunk_bytes,
            "mempools must be listed by increasing chunk_bytes (entry " + std::to_string(i) + ": " +
                std::to_string(mempools[i].chunk_bytes) + " after " +
                std::to_string(mempools[i - 1].chunk_bytes) + ")");
  }
}

void BackgroundLoadConfig::Validate() const {
  Require(!name.empty(), "a background load needs a name");
  Require(cpu_percent >= 0.0, "cpu_percent must be >= 0, got " + Num(cpu_percent));
  Require(period.count() > 0, "period_s must be > 0, got " + Num(ToSeconds(period)));
  Require(max_parallelism > 0.0, "max_parallelism must be > 0, got " + Num(max_parallelism));
  Require(cpu_percent <= 100.0 * max_parallelism, "cpu_percent " + Num(cpu_percent) +
                                                      " needs more than max_parallelism " +
                                                      Num(max_parallelism) + " cores");
}

void PlatformProfile::Validate() const {
  Require(!name.empty(), "a platform profile needs a name");
  std::set<std::string> names;
  for (const BackgroundLoadConfig& load : background) {
    Require(names.insert(load.name).second, "background load '" + load.name + "' appears twice");
  }
}

const ComponentCost& PlatformProfile::Component(const std::string& cost_name) const {
  const auto it = components.find(cost_name);
  if (it == components.end()) {
    std::string known;
    for (const auto& [key, unused] : components) known += (known.empty() ? "" : ", ") + key;
    throw ConfigError("platform profile '" + name + "': components." + cost_name +
                      ": no such component cost (known: " + known + ")");
  }
  return it->second;
}

PlatformProfile LoadPlatformProfile(const std::filesystem::path& file,
                                    const std::vector<std::string>& overrides) {
  YAML::Node root = LoadYamlFile(file);
  ConfigSource source{file.string(), {}};
  BreakAliases(root);
  for (const std::string& assignment : overrides) ApplyOverride(root, assignment, &source);
  return ReadConfig<PlatformProfile>(root, source);
}

void ReadScalar(const YAML::Node& node, FpgaSlot& out, const std::string& path,
                const ConfigSource& source) {
  if (node.IsScalar() && node.Scalar() == "any") {
    out = FpgaSlot::Any();
    return;
  }
  if (!node.IsScalar()) {
    detail::Fail(node, path, source,
                 "expected a slot number or `any`, got " + detail::Describe(node));
  }
  int index = 0;
  try {
    detail::ReadScalar(node, index, path, source);
  } catch (const ConfigError&) {
    detail::Fail(node, path, source,
                 "expected a slot number or `any`, got '" + node.Scalar() + "'");
  }
  out = FpgaSlot(index);
}

void to_json(nlohmann::json& j, const FpgaSlot& slot) {
  j = slot.index ? nlohmann::json(*slot.index) : nlohmann::json("any");
}

std::string ToString(const FpgaSlot& slot) {
  return slot.index ? std::to_string(*slot.index) : "any";
}

void NodeMappingConfig::Validate() const {
  if (target == Target::kHw) Require(slot.has_value(), "a node mapped to 'hw' needs a 'slot'");
  if (target == Target::kSw) Require(!slot.has_value(), "'slot' is only for target 'hw'");
  if (slot && slot->index) {
    Require(*slot->index >= 0, "slot must be >= 0, got " + std::to_string(*slot->index));
  }
}

void TopicTransportConfig::Validate() const {
  if (depth) Require(*depth >= 1, "depth must be >= 1, got " + std::to_string(*depth));
  const auto positive = [](const std::optional<int>& value, const char* key) {
    if (value)
      Require(*value > 0, std::string(key) + " must be > 0, got " + std::to_string(*value));
  };
  positive(receive_buffer_bytes, "receive_buffer_bytes");
  positive(fragment_bytes, "fragment_bytes");
  positive(max_message_bytes, "max_message_bytes");
  const bool dds_only =
      reliability || history || receive_buffer_bytes || fragment_bytes || max_message_bytes;
  Require(!dds_only || transport == Transport::kDds,
          "reliability, history, receive_buffer_bytes, fragment_bytes and max_message_bytes are "
          "DDS settings: they need transport: dds");
}

void CostDistributionConfig::Validate() const {
  const std::string name(ToName(distribution));
  auto need = [&name](const std::optional<double>& value, const char* key) {
    Require(value.has_value(), "distribution '" + name + "' needs " + key);
    Require(std::isfinite(*value) && *value >= 0.0,
            std::string(key) + " must be finite and >= 0, got " + Num(*value));
  };
  auto forbid = [&name](const std::optional<double>& value, const char* key) {
    Require(!value.has_value(), "distribution '" + name + "' takes no " + key);
  };
  switch (distribution) {
    case CostDistribution::kFixed:
      need(value_s, "value_s");
      forbid(min_s, "min_s");
      forbid(max_s, "max_s");
      forbid(mean_s, "mean_s");
      forbid(stddev_s, "stddev_s");
      return;
    case CostDistribution::kUniform:
      need(min_s, "min_s");
      need(max_s, "max_s");
      Require(*min_s <= *max_s, "min_s must be <= max_s, got " + Num(*min_s) + " > " + Num(*max_s));
      forbid(value_s, "value_s");
      forbid(mean_s, "mean_s");
      forbid(stddev_s, "stddev_s");
      return;
    case CostDistribution::kNormal:
    case CostDistribution::kLognormal:
      need(mean_s, "mean_s");
      need(stddev_s, "stddev_s");
      Require(distribution == CostDistribution::kNormal || *mean_s > 0.0,
              "lognormal needs mean_s > 0");
      forbid(value_s, "value_s");
      forbid(min_s, "min_s");
      forbid(max_s, "max_s");
      return;
  }
}

void PlatformConfig::Validate() const {
  Require(!profile.empty(), "profile must name a platform profile file");
  Require(!cores || *cores >= 1, "cores must be >= 1, got " + std::to_string(cores.value_or(0)));
  Require(!slots || *slots >= 1, "slots must be >= 1, got " + std::to_string(slots.value_or(0)));
  Require(!config_port_bytes_per_s || *config_port_bytes_per_s > 0.0,
          "config_port_bytes_per_s must be > 0, got " + Num(config_port_bytes_per_s.value_or(0.0)));
  Require(
      !host_rmem_max_bytes || *host_rmem_max_bytes > 0,
      "host_rmem_max_bytes must be > 0, got " + std::to_string(host_rmem_max_bytes.value_or(0)));
  for (const auto& [node, scale] : cost_scale) {
    Require(std::isfinite(scale) && scale > 0.0,
            "cost_scale." + node + " must be finite and > 0, got " + Num(scale));
  }
  Require(load_bin.count() > 0, "load_bin_s must be > 0, got " + Num(ToSeconds(load_bin)));
  Require(trace_max_events >= 0,
          "trace_max_events must be >= 0, got " + std::to_string(trace_max_events));
  Require(trace_busy_period.count() >= 0, "trace_busy_period_s must be >= 0");
}

}  // namespace autonomsim::sim
