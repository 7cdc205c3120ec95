// The numbers of a compute platform (scenarios/platforms/*.yaml) and how a run maps its nodes and
// topics onto it. Every figure lives in the profile file with its provenance (a Table I row, a
// datasheet, a documented default, or "assumed: why"); the defaults here only make an empty
// struct valid, they are not the ZCU104.
//
// CPU units: work is in core-seconds (one core busy for one second). CPU load is reported as the
// paper does, "CPU in % of 4 cores": 100 % = one core fully busy, 400 % = all four.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "sim/core/config.h"
#include "world/time.h"

namespace autonomsim::sim {

// CPU work of one software job (one callback run) of a node.
struct SwCost {
  double work_s{0.0};                   // core-seconds per job
  double work_ns_per_input_byte{0.0};   // plus this per byte of the message taken
  double work_ns_per_output_byte{0.0};  // plus this per byte of the messages published
  double max_parallelism{1.0};          // cores one job can use at once (threads it runs on)
  double jitter{0.0};  // each job's work is scaled by a uniform factor in [1 - jitter, 1 + jitter]

  template <class V>
  void Describe(V& v) {
    v("work_s", work_s);
    v("work_ns_per_input_byte", work_ns_per_input_byte);
    v("work_ns_per_output_byte", work_ns_per_output_byte);
    v("max_parallelism", max_parallelism);
    v("jitter", jitter);
  }
  void Validate() const;
};

// One job of a hardware node in a reconfigurable slot: the fabric computes and moves its input and
// output over the slot's memory interface; meanwhile its delegate thread (one CPU thread) serves
// the hardware thread's OS calls. The job ends when both are done.
struct HwCost {
  double compute_s{0.0};       // fabric time per job besides the memory transfers
  double delegate_cpu_s{0.0};  // core-seconds of the delegate thread per job (at most one core)
  double jitter{0.0};          // as SwCost::jitter, on compute_s and delegate_cpu_s
  // Its partial bitstream, what a slot loads to serve it (fpga.slot_policy executor); 0: none
  // given (the executor then refuses the node).
  int bitstream_bytes{0};

  template <class V>
  void Describe(V& v) {
    v("compute_s", compute_s);
    v("delegate_cpu_s", delegate_cpu_s);
    v("jitter", jitter);
    v("bitstream_bytes", bitstream_bytes);
  }
  void Validate() const;
};

// What one node costs in software and, if it has a hardware implementation, in a slot.
struct ComponentCost {
  std::optional<SwCost> sw;
  std::optional<HwCost> hw;

  template <class V>
  void Describe(V& v) {
    v("sw", sw);
    v("hw", hw);
  }
  void Validate() const;
};

struct CpuProfile {
  int cores{1};
  double memcpy_bytes_per_s{1e9};  // one core copying a large buffer (used by every "copy")
  // The OS scheduler's time slice when more threads want to run than there are cores: such a
  // thread runs one slice, then waits while the others have theirs (one woken after sleeping runs
  // at once). Only the DDS receive thread is scheduled so (sim/platform/dds_link.h; every other
  // job shares the cores as a fluid); 0: that thread too.
  Duration sched_slice{0};

  template <class V>
  void Describe(V& v) {
    v("cores", cores);
    v("memcpy_bytes_per_s", memcpy_bytes_per_s);
    v("sched_slice_s", sched_slice);
  }
  void Validate() const;
};

// How hardware nodes share the slots: `static`, one node per slot for the whole run (the lab's
// build); `executor`, any node in any slot, reconfigured as the ReconROS executor does
// (sim/platform/slot_executor.h).
enum class SlotPolicy { kStatic, kExecutor };

struct FpgaProfile {
  int slots{0};
  double memif_bytes_per_s{1e9};  // one slot's memory interface (bytes read + written)
  SlotPolicy slot_policy{SlotPolicy::kStatic};
  // executor: the configuration port's throughput (one reconfiguration at a time)
  double config_port_bytes_per_s{4e8};
  // executor: an idle slot agent's poll period; 0: it takes a callback the moment it is ready
  Duration agent_poll_period{0};

  template <class V>
  void Describe(V& v) {
    v("slots", slots);
    v("memif_bytes_per_s", memif_bytes_per_s);
    v("slot_policy", slot_policy);
    v("config_port_bytes_per_s", config_port_bytes_per_s);
    v("agent_poll_period_s", agent_poll_period);
  }
  void Validate() const;
};

// CPU cost of one side of a DDS transfer of a B-byte sample:
//   fixed + copies * B / memcpy + ceil(B / max_message_bytes) * per_datagram
//         + ceil(B / fragment_bytes) * per_fragment
struct DdsSideCost {
  Duration fixed{0};
  int copies{0};  // passes over the B bytes at cpu.memcpy_bytes_per_s
  Duration per_datagram{0};
  Duration per_fragment{0};

  template <class V>
  void Describe(V& v) {
    v("fixed_s", fixed);
    v("copies", copies);
    v("per_datagram_s", per_datagram);
    v("per_fragment_s", per_fragment);
  }
  void Validate() const;
};

// Whether a DDS topic repairs lost datagrams (reliable: heartbeats, NACKs, retransmission, a
// writer that can block) or loses the sample (best_effort).
enum class Reliability { kReliable, kBestEffort };
// A DDS writer's history: keep_last (the topic's depth) or keep_all (unbounded; the WHC's
// high-water mark then throttles the writer).
enum class History { kKeepLast, kKeepAll };

// DDS over loopback UDP (Cyclone DDS). `write` is paid by the publishing job (publish is
// synchronous), `receive` by the subscriber's DDS receive thread for every datagram that arrives,
// `take` by the subscriber's job (deserialization into its message). The rest are Cyclone's
// settings and the host's socket accounting, which decide how a large sample crosses
// (sim/platform/dds_link.h).
struct DdsProfile {
  int max_message_bytes{14720};  // a datagram's payload at most (Cyclone MaxMessageSize)
  int fragment_bytes{1344};      // Cyclone FragmentSize
  DdsSideCost write;
  DdsSideCost receive;
  DdsSideCost take;
  Duration latency{0};                // wire time on top of the receive processing
  int receive_buffer_bytes{1048576};  // SO_RCVBUF Cyclone requests
  int host_rmem_max_bytes{212992};    // the host kernel's net.core.rmem_max
  int socket_overhead_bytes{0};       // kernel bookkeeping per datagram (truesize)
  Duration heartbeat_interval{std::chrono::milliseconds(100)};
  Duration nack_delay{std::chrono::milliseconds(100)};
  int whc_high_bytes{500000};
  int whc_low_bytes{1000};
  int max_queued_rexmit_bytes{512000};
  // A reliable write's max_blocking_time; unset: infinite, as rmw_cyclonedds gives every reliable
  // ROS 2 publisher (rmw_node.cpp:1843-1850, galactic).
  std::optional<Duration> max_blocking;
  Reliability reliability{Reliability::kReliable};  // a topic's unless it says otherwise
  History history{History::kKeepLast};              // a topic's unless it says otherwise

  template <class V>
  void Describe(V& v) {
    v("max_message_bytes", max_message_bytes);
    v("fragment_bytes", fragment_bytes);
    v("write", write);
    v("receive", receive);
    v("take", take);
    v("latency_s", latency);
    v("receive_buffer_bytes", receive_buffer_bytes);
    v("host_rmem_max_bytes", host_rmem_max_bytes);
    v("socket_overhead_bytes", socket_overhead_bytes);
    v("heartbeat_interval_s", heartbeat_interval);
    v("nack_delay_s", nack_delay);
    v("whc_high_bytes", whc_high_bytes);
    v("whc_low_bytes", whc_low_bytes);
    v("max_queued_rexmit_bytes", max_queued_rexmit_bytes);
    v("max_blocking_s", max_blocking);
    v("reliability", reliability);
    v("history", history);
  }
  void Validate() const;
};

struct MempoolConfig {
  int chunk_bytes{1024};
  int chunks{1};

  template <class V>
  void Describe(V& v) {
    v("chunk_bytes", chunk_bytes);
    v("chunks", chunks);
  }
  void Validate() const;
};

// Zero-copy shared memory (Iceoryx under CycloneDDS): near-constant cost per message, and its
// limits, which the graph enforces.
struct ZeroCopyProfile {
  Duration publish{0};             // CPU of loan + publish on the publisher
  Duration take{0};                // CPU of take-loaned + return on a subscriber
  int non_loaned_take_copies{1};   // a subscriber without the loan API gets a copy of the sample
  Duration latency{0};             // publish to the subscriber's wake-up
  int max_subscribers{127};        // per topic
  int max_loans_per_publisher{8};  // loaned, not yet published, per publisher
  std::vector<MempoolConfig> mempools;  // shared memory chunks; a sample uses the smallest fitting

  template <class V>
  void Describe(V& v) {
    v("publish_s", publish);
    v("take_s", take);
    v("non_loaned_take_copies", non_loaned_take_copies);
    v("latency_s", latency);
    v("max_subscribers", max_subscribers);
    v("max_loans_per_publisher", max_loans_per_publisher);
    v("mempools", mempools);
  }
  void Validate() const;
};

// Load on the CPU from parts of the stack that are not modelled node by node: a periodic job of
// cpu_percent / 100 * period core-seconds. A load stands in for the nodes in `replaced_by`: it is
// left out of a board that runs any of them (a car driven by the modelled stack).
struct BackgroundLoadConfig {
  std::string name;
  double cpu_percent{0.0};  // 100 = one core
  Duration period{std::chrono::milliseconds(50)};
  double max_parallelism{1.0};
  std::vector<std::string> replaced_by;  // node names

  template <class V>
  void Describe(V& v) {
    v("name", name);
    v("cpu_percent", cpu_percent);
    v("period_s", period);
    v("max_parallelism", max_parallelism);
    v("replaced_by", replaced_by);
  }
  void Validate() const;
};

struct PlatformProfile {
  std::string name;
  std::string description;
  CpuProfile cpu;
  FpgaProfile fpga;
  DdsProfile dds;
  ZeroCopyProfile zero_copy;
  std::map<std::string, ComponentCost> components;  // by cost name (usually the node's name)
  std::vector<BackgroundLoadConfig> background;

  template <class V>
  void Describe(V& v) {
    v("name", name);
    v("description", description);
    v("cpu", cpu);
    v("fpga", fpga);
    v("dds", dds);
    v("zero_copy", zero_copy);
    v("components", components);
    v("background", background);
  }
  void Validate() const;

  // The cost entry `name`; throws ConfigError naming the profile and the missing key.
  const ComponentCost& Component(const std::string& name) const;
};

// Reads a profile file strictly (sim/core/config.h); `overrides` are --set style key=value pairs.
PlatformProfile LoadPlatformProfile(const std::filesystem::path& file,
                                    const std::vector<std::string>& overrides = {});

// ---- How a run uses the platform: the fields a scenario embeds as `platform:` ----

// Where a node runs: on the CPU cores, or in an FPGA slot.
enum class Target { kSw, kHw };
// How a topic is carried: DDS over loopback sockets, or zero-copy shared memory (Iceoryx).
enum class Transport { kDds, kZeroCopy };

}  // namespace autonomsim::sim

namespace autonomsim {
template <>
struct NameTable<sim::SlotPolicy> {
  static constexpr std::array<std::pair<sim::SlotPolicy, std::string_view>, 2> kEntries{
      {{sim::SlotPolicy::kStatic, "static"}, {sim::SlotPolicy::kExecutor, "executor"}}};
};
template <>
struct NameTable<sim::Target> {
  static constexpr std::array<std::pair<sim::Target, std::string_view>, 2> kEntries{
      {{sim::Target::kSw, "sw"}, {sim::Target::kHw, "hw"}}};
};
template <>
struct NameTable<sim::History> {
  static constexpr std::array<std::pair<sim::History, std::string_view>, 2> kEntries{
      {{sim::History::kKeepLast, "keep_last"}, {sim::History::kKeepAll, "keep_all"}}};
};
template <>
struct NameTable<sim::Reliability> {
  static constexpr std::array<std::pair<sim::Reliability, std::string_view>, 2> kEntries{
      {{sim::Reliability::kReliable, "reliable"}, {sim::Reliability::kBestEffort, "best_effort"}}};
};
template <>
struct NameTable<sim::Transport> {
  static constexpr std::array<std::pair<sim::Transport, std::string_view>, 2> kEntries{
      {{sim::Transport::kDds, "dds"}, {sim::Transport::kZeroCopy, "zero_copy"}}};
};
}  // namespace autonomsim

namespace autonomsim::sim {

// Where one node runs: "sw" on the CPU cores, or "hw" in FPGA slot `slot`. `cost` names the
// profile's components entry (default: the node's name).
// A hardware node's slot as a mapping names it: its index, or `any` (slot_policy executor: the slot
// the executor gives each callback; with an index, the slot that holds its bitstream at t = 0).
struct FpgaSlot {
  static constexpr const char* kTypeName = "integer \\| any";
  FpgaSlot() = default;
  FpgaSlot(int index_) : index(index_) {}  // NOLINT: `.slot = 1` reads as the slot it names
  static FpgaSlot Any() { return FpgaSlot{}; }
  std::optional<int> index;  // empty: any
  bool any() const { return !index; }
  friend bool operator==(const FpgaSlot&, const FpgaSlot&) = default;
  friend bool operator==(const FpgaSlot& s, int i) { return s.index == i; }
};
// The config reader's and writer's forms: an integer, or the name `any`.
void ReadScalar(const YAML::Node& node, FpgaSlot& out, const std::string& path,
                const ConfigSource& source);
void to_json(nlohmann::json& j, const FpgaSlot& slot);
std::string ToString(const FpgaSlot& slot);

struct NodeMappingConfig {
  Target target{Target::kSw};
  std::optional<FpgaSlot> slot;
  std::optional<std::string> cost;

  template <class V>
  void Describe(V& v) {
    v("target", target, "where the node runs: `sw` on the CPU cores, `hw` in an FPGA slot");
    v("slot", slot,
      "`hw`: the FPGA slot; with slot_policy executor `any`, or the slot that holds the node's "
      "bitstream at the start");
    v("cost", cost, "the profile's `components` entry to cost it by (default: the node's name)");
  }
  void Validate() const;
};

// How one topic is carried: "dds" (loopback sockets) or "zero_copy" (Iceoryx), and its QoS
// history depth (keep-last). A DDS topic's own Cyclone settings, each unset one the profile's
// dds section's (the same names as `autonomsim transport --set dds.KEY`): its reliability and
// history QoS, the receive buffer its subscribers' sockets request, and how a sample is cut.
struct TopicTransportConfig {
  Transport transport{Transport::kZeroCopy};
  std::optional<int> depth;
  std::optional<Reliability> reliability;
  std::optional<History> history;
  std::optional<int> receive_buffer_bytes;
  std::optional<int> fragment_bytes;
  std::optional<int> max_message_bytes;

  template <class V>
  void Describe(V& v) {
    v("transport", transport,
      "how the topic is carried: `dds` (loopback sockets) or `zero_copy` (Iceoryx shared memory)");
    v("depth", depth, "its keep-last history depth");
    v("reliability", reliability, "`dds`: the QoS reliability (default: the profile's)");
    v("history", history, "`dds`: the QoS history (default: the profile's)");
    v("receive_buffer_bytes", receive_buffer_bytes,
      "`dds`: the receive buffer its subscribers' sockets ask for");
    v("fragment_bytes", fragment_bytes, "`dds`: Cyclone's fragment size");
    v("max_message_bytes", max_message_bytes, "`dds`: Cyclone's largest datagram payload");
  }
  void Validate() const;
};

// A distribution that replaces a node's per-job compute cost (PlatformConfig::cost_override):
// "fixed" (value_s), "uniform" (min_s, max_s), "normal" (mean_s, stddev_s; a draw below 0 counts
// as 0) or "lognormal" (mean_s and stddev_s of the cost itself, not of its logarithm). Seconds are
// core-seconds of work for a software node and fabric seconds for a hardware node.
enum class CostDistribution { kFixed, kUniform, kNormal, kLognormal };

}  // namespace autonomsim::sim

namespace autonomsim {
template <>
struct NameTable<sim::CostDistribution> {
  using K = sim::CostDistribution;
  static constexpr std::array<std::pair<K, std::string_view>, 4> kEntries{
      {{K::kFixed, "fixed"},
       {K::kUniform, "uniform"},
       {K::kNormal, "normal"},
       {K::kLognormal, "lognormal"}}};
};
}  // namespace autonomsim

namespace autonomsim::sim {

struct CostDistributionConfig {
  CostDistribution distribution{CostDistribution::kFixed};
  std::optional<double> value_s;
  std::optional<double> min_s;
  std::optional<double> max_s;
  std::optional<double> mean_s;
  std::optional<double> stddev_s;

  template <class V>
  void Describe(V& v) {
    v("distribution", distribution,
      "each job's cost drawn from: `fixed` (value_s), `uniform` (min_s, max_s), `normal` or "
      "`lognormal` (mean_s, stddev_s)");
    v("value_s", value_s, "`fixed`: the cost");
    v("min_s", min_s, "`uniform`: the least cost");
    v("max_s", max_s, "`uniform`: the largest cost");
    v("mean_s", mean_s, "`normal`, `lognormal`: the cost's mean");
    v("stddev_s", stddev_s, "`normal`, `lognormal`: the cost's standard deviation");
  }
  void Validate() const;
};

struct PlatformConfig {
  std::string profile{"platforms/zcu104.yaml"};           // relative to the scenario's folder
  std::map<std::string, NodeMappingConfig> mapping;       // by node name; others keep defaults
  std::map<std::string, TopicTransportConfig> transport;  // by topic name; others keep defaults
  // What-if knobs (sweeps). cores: the CPU's core count instead of the profile's cpu.cores.
  // cost_scale: by node name, a factor on each job's compute cost (software: its core-seconds of
  // work; hardware: its fabric time, memory transfers included, not its delegate thread's CPU).
  // cost_override: by node name, each job's compute cost drawn from a distribution instead of the
  // profile's (software: core-seconds of work; hardware: fabric compute time, memory transfers
  // still added), from the seeded stream "<board>/platform/<node>/cost_override"; cost_scale
  // applies on top. Neither touches a subscription's own cost or the transports.
  // host_rmem_max_bytes: the host kernel's net.core.rmem_max (a sysctl) instead of the profile's
  // dds.host_rmem_max_bytes: the cap on every DDS socket's receive buffer.
  std::optional<int> cores;
  std::optional<int> slots;                       // the FPGA's slots instead of the profile's
  std::optional<SlotPolicy> slot_policy;          // instead of the profile's fpga.slot_policy
  std::optional<double> config_port_bytes_per_s;  // instead of the profile's fpga one
  std::optional<int> host_rmem_max_bytes;
  std::map<std::string, double> cost_scale;
  std::map<std::string, CostDistributionConfig> cost_override;
  bool background_loads{true};                 // add the profile's background loads
  Duration load_bin{std::chrono::seconds(1)};  // CPU load over time: one value per bin
  bool trace{true};                            // record trace.json
  int trace_max_events{400000};                // then stop recording (noted in it)
  bool trace_receive_threads{false};           // also each DDS receive thread's spans
  // the busy-cores counter: its mean over each period; 0: every change (MetricsOptions)
  Duration trace_busy_period{std::chrono::milliseconds(10)};

  template <class V>
  void Describe(V& v) {
    v("profile", profile,
      "the board's profile file (relative to the scenario, else the shipped one): costs, cores, "
      "transports");
    v("mapping", mapping,
      "by node name: where the node runs; nodes not named keep the default (a wrong name lists the "
      "board's nodes)");
    v("transport", transport,
      "by topic name: how the topic is carried; topics not named keep the default");
    v("cores", cores, "the CPU's cores instead of the profile's");
    v("slots", slots, "the FPGA's slots instead of the profile's");
    v("slot_policy", slot_policy,
      "how hardware nodes share the slots instead of the profile's fpga.slot_policy: `static` "
      "(one node per slot, the lab's build) or `executor` (reconfigured on demand, as the "
      "ReconROS executor does)");
    v("config_port_bytes_per_s", config_port_bytes_per_s,
      "slot_policy executor: the configuration port's throughput instead of the profile's");
    v("host_rmem_max_bytes", host_rmem_max_bytes,
      "the host's net.core.rmem_max instead of the profile's: the cap on every DDS socket's "
      "receive buffer");
    v("cost_scale", cost_scale, "by node name: a factor on each job's compute cost");
    v("cost_override", cost_override,
      "by node name: each job's compute cost drawn from a distribution instead of the profile's");
    v("background_loads", background_loads, "add the profile's background CPU loads");
    v("load_bin_s", load_bin, "CPU load over time: one value per bin");
    v("trace", trace, "record trace.json");
    v("trace_max_events", trace_max_events,
      "stop recording the trace after this many events (noted in it)");
    v("trace_receive_threads", trace_receive_threads,
      "also record each DDS receive thread's spans in the trace");
    v("trace_busy_period_s", trace_busy_period,
      "the trace's busy-cores counter: its mean over each period; 0: a value at every change");
  }
  void Validate() const;
};

}  // namespace autonomsim::sim
