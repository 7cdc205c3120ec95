// What the node graph and the platform did during a run, and the reports made from it: per node
// rate, turnaround (min/p50/p95/max), CPU and drops; per topic rate and latency from the sensor
// stamp (the end-to-end latency of a chain is the latency of its last topic); platform CPU load
// over time; nodes.csv; a Chrome trace (trace.json) that opens in Perfetto (ui.perfetto.dev) or
// chrome://tracing.
//
// CPU is in the paper's unit: 100 % = one core fully busy, 400 % = all four cores of the ZCU104.
// Rates, CPU, turnaround and latency count only what happens from `measure_from` on (warm-up
// excluded); the load-over-time series and the trace cover the whole run.
#pragma once

#include <cstddef>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "sim/platform/dds_stats.h"
#include "sim/platform/duration_histogram.h"
#include "world/time.h"

namespace autonomsim::sim {

struct MetricsOptions {
  Time measure_from{0};
  Duration load_bin{std::chrono::seconds(1)};
  bool trace{true};
  std::size_t trace_max_events{400000};
  // The DDS receive threads' spans: a third of a DDS-heavy trace's events, off unless asked (their
  // CPU is in the busy counter and in each node's cpu_percent either way).
  bool trace_receive{false};
  // The trace's busy-cores counter: the mean over each period (to 0.001 cores), written when it
  // changes; zero: a value at every change (1.28 M of the default run's 1.75 M events).
  Duration trace_busy_period{std::chrono::milliseconds(10)};
};

// Where a trace span is drawn: a node's executor (its jobs, on the CPU or in its slot), a node's
// DDS receive thread, or an FPGA slot.
// kConfigPort: the FPGA's configuration port (slot_policy executor), a track of the slots' process.
enum class TraceLane { kExecutor, kReceive, kSlot, kConfigPort };

class RunMetrics {
 public:
  explicit RunMetrics(const MetricsOptions& options = {});

  const MetricsOptions& options() const { return options_; }

  // Registration; the returned index names the node (also the CPU owner) or the topic below.
  int AddNode(const std::string& name, const std::string& mapping);
  // `depth`: the topic's keep-last QoS depth (TopicSpec::depth).
  int AddTopic(const std::string& name, const std::string& transport, std::int64_t bytes,
               int depth);
  void SetCores(int cores) { cores_ = cores; }

  // CPU accounting: `cores` of the CPU were busy for `node` from t0 to t1 (a node owns its jobs and
  // its DDS receive thread). AddBusy is the platform total.
  void AddCpu(int node, Time t0, Time t1, double cores);
  void AddBusy(Time t0, Time t1, double cores);
  void BusyChanged(Time t, double cores);  // trace counter, if trace_busy_period is zero

  // Node activity. `nominal_core_s` is the CPU a job was given to do (independent of contention).
  // `timed`: false for a callback with its own cost that only keeps its message (its CPU counts,
  // its turnaround would only blur the node's own jobs').
  void JobDone(int node, Time start, Time end, double nominal_core_s, bool timed = true);
  void ReceiveDone(int node, Time t, double core_s);
  void Arrival(int node, int topic, Time t);
  void Dropped(int node, int topic, Time t);
  void LoanFailed(int node, int topic, Time t);
  void TimerFired(int node, Time t);
  void TimerOverrun(int node, Time t);
  void Published(int node, int topic, Time t, Time stamp);

  void Span(TraceLane lane, int id, const std::string& name, Time start, Time end);

  struct NodeData {
    std::string name;
    std::string mapping;
    std::uint64_t jobs{0}, arrivals{0}, drops{0}, loan_failures{0}, timer_ticks{0},
        timer_overruns{0};
    std::uint64_t callbacks{0};    // of `jobs`, those not timed (a callback that keeps a message)
    DurationHistogram turnaround;  // of the timed jobs
    double cpu_core_s{0.0};
    double job_core_s{0.0};      // nominal, summed over jobs counted in `jobs`
    double receive_core_s{0.0};  // DDS receive thread
  };
  struct TopicData {
    std::string name;
    std::string transport;
    std::int64_t bytes{0};
    int depth{0};
    std::uint64_t published{0}, drops{0}, loan_failures{0};
    DurationHistogram latency;  // publish time minus the sensor stamp
    // Latency over time, per load bin from t = 0 (whole run): count, sum and max in ns.
    std::vector<std::uint32_t> bin_count;
    std::vector<double> bin_sum_ns, bin_max_ns;
  };
  struct TraceEvent {
    char phase;  // 'X' span, 'C' counter
    int pid;
    int tid;
    int name;  // index into trace_names
    std::int64_t ts_ns;
    std::int64_t dur_ns;
    double value;
  };

  const std::vector<NodeData>& nodes() const { return nodes_; }
  const std::vector<TopicData>& topics() const { return topics_; }
  int cores() const { return cores_; }
  double busy_core_s() const { return busy_core_s_; }
  const std::vector<double>& load_bins_core_ns() const { return load_bins_core_ns_; }
  const std::vector<TraceEvent>& trace_events() const { return trace_; }
  const std::vector<std::string>& trace_names() const { return trace_names_; }
  bool trace_truncated() const { return trace_truncated_; }
  // The time of the first event the trace left out (trace_max_events reached); none if it kept all.
  std::optional<Time> trace_truncated_at() const { return trace_truncated_at_; }

 private:
  bool Measured(Time t) const { return t >= options_.measure_from; }
  // Seconds of [t0, t1] inside the measurement window.
  double MeasuredSeconds(Time t0, Time t1) const;
  int TraceName(const std::string& name);
  void AddTrace(const TraceEvent& event);
  // The busy-cores counter by period (trace_busy_period): AddBusy's intervals, which follow each
  // other without gaps, summed into the open period; a period's mean is written when a later one
  // opens.
  void SampleBusy(Time t0, Time t1, double cores);
  void CloseBusyPeriod();
  void WriteBusy(std::int64_t period_index, double mean_cores);

  MetricsOptions options_;
  int cores_{1};
  std::vector<NodeData> nodes_;
  std::vector<TopicData> topics_;
  double busy_core_s_{0.0};
  std::vector<double> load_bins_core_ns_;
  std::vector<TraceEvent> trace_;
  std::vector<std::string> trace_names_;
  bool trace_truncated_{false};
  std::optional<Time> trace_truncated_at_;
  double last_busy_{-1.0};
  std::int64_t busy_period_{-1};   // the open period's index; -1: none yet
  double busy_area_core_ns_{0.0};  // busy cores × ns in the open period so far
};

// A histogram of milliseconds on log-spaced bins, kHistogramBinsPerDecade per decade from
// kHistogramMin_ms to kHistogramMax_ms: bin i holds [edge i, edge i+1); the first bin also holds
// what is below the range, the last what is above it (so the counts sum to the sample's size).
inline constexpr int kHistogramBinsPerDecade = 5;
inline constexpr double kHistogramMin_ms = 0.1;
inline constexpr double kHistogramMax_ms = 10000.0;
std::vector<double> HistogramEdgesMs();  // bins + 1 edges

struct NodeReport {
  std::string name;
  std::string mapping;
  // jobs: the node's own work (its timer's, its subscriptions'); callbacks: those of a
  // subscription that only keeps its message at a cost of its own (the planner's map and odometry)
  std::uint64_t jobs{0}, callbacks{0}, arrivals{0}, timer_ticks{0}, drops{0}, loan_failures{0},
      timer_overruns{0};
  double input_hz{0.0};  // messages arrived and timer ticks per second
  double rate_hz{0.0};   // jobs (not callbacks) completed per second
  Stats turnaround_ms;   // take to publish of one job, including waiting for a CPU share
  std::vector<std::uint64_t> turnaround_histogram;  // on HistogramEdgesMs()
  double cpu_percent{0.0};
  // CPU the node would need to serve every message and timer tick at its cost per job, plus its
  // DDS receive thread: above cpu_percent when it drops or falls behind.
  double demand_percent{0.0};
};

struct TopicReport {
  std::string name;
  std::string transport;
  std::int64_t bytes{0};
  int depth{0};  // keep-last QoS depth of its subscriptions
  std::uint64_t published{0}, drops{0}, loan_failures{0};
  double rate_hz{0.0};
  Stats latency_ms;  // publish time minus the sensor stamp it derives from
  // Latency over time, per load bin from t = 0 (the whole run, as cpu_load_percent): mean and
  // max of the messages published in the bin; empty where none was.
  std::vector<std::optional<double>> latency_mean_ms_per_bin, latency_max_ms_per_bin;
  // DDS: what its links counted over the whole run, every publisher to every subscription
  // (NodeGraph::dds_stats; Board::Report fills it in)
  std::optional<DdsLinkStats> dds;
};

// What the board's trace.json holds: whether it records one, how many events, and, when it reached
// trace_max_events, from when on it holds nothing (the trace is cut there).
struct TraceCoverage {
  bool recorded{false};
  std::size_t events{0};
  std::size_t max_events{0};
  std::optional<double> cut_at_s;  // the first event left out
};

// slot_policy executor (sim/platform/slot_executor.h): what each slot did over the whole run.
struct SlotsReport {
  struct Slot {
    std::uint64_t callbacks{0};
    std::uint64_t reconfigurations{0};
    double reconfiguring_s{0.0};  // the slot being reconfigured (copy and transfer)
  };
  std::vector<Slot> slots;
  std::uint64_t waits{0};  // callbacks that found no idle slot
  double wait_s{0.0};      // their time waiting, summed
};

struct MetricsReport {
  double window_s{0.0};
  int cores{1};
  double cpu_percent{0.0};         // platform busy, 100 = one core
  double cpu_demand_percent{0.0};  // sum of the nodes' demand
  Duration load_bin{std::chrono::seconds(1)};
  std::vector<double> cpu_load_percent;  // per bin from t = 0
  std::vector<NodeReport> nodes;
  std::vector<TopicReport> topics;
  TraceCoverage trace;
  std::optional<SlotsReport> slots;  // slot_policy executor only

  const NodeReport* FindNode(const std::string& name) const;
  const TopicReport* FindTopic(const std::string& name) const;
};

// `end` is the time the run stopped (the window is [measure_from, end]).
MetricsReport BuildReport(const RunMetrics& metrics, Time end);

// A run may have several boards (one ZCU104 per car); outputs name the board on every line.
struct BoardReport {
  std::string board;  // e.g. "car0"
  MetricsReport report;
};
struct BoardMetrics {
  std::string board;
  const RunMetrics* metrics;
};

// nodes.csv: one row per board and node: board, node, mapping, jobs, input_hz, rate_hz,
// turnaround_{min,p50,p95,max}_ms, cpu_percent, demand_percent, arrivals, timer_ticks, drops,
// loan_failures, timer_overruns, callbacks.
std::string NodesCsv(const std::vector<BoardReport>& boards);
// topics.csv: one row per board and topic: board, topic, transport, bytes, depth, published,
// rate_hz, latency_{count,min,p50,p95,p99,max,mean}_ms (empty when nothing was published),
// drops, loan_failures, and for a DDS topic (empty otherwise) dds_samples_written,
// dds_write_timeouts, dds_samples_delivered, dds_samples_lost, dds_datagrams_sent,
// dds_datagrams_retransmitted, dds_datagrams_dropped, dds_nacks.
std::string TopicsCsv(const std::vector<BoardReport>& boards);
// For summary.json, per board: {cores, window_s, cpu_percent, cpu_demand_percent, load_bin_s,
// cpu_load_percent: [...], nodes: [{name, mapping, jobs, input_hz, rate_hz, turnaround_ms: {count,
// min, p50, p95, p99, max}, turnaround_histogram_ms: {edges, counts}, cpu_percent, demand_percent,
// arrivals, timer_ticks, drops, loan_failures, timer_overruns}], topics: [{name, transport, bytes,
// depth, published, rate_hz, latency_ms: {...}, latency_per_bin_ms: {mean: [...], max: [...]} (null
// for a bin without messages), drops, loan_failures, dds (DDS topics, whole run): {samples_written,
// write_timeouts, samples_delivered, samples_lost, datagrams_sent, datagrams_retransmitted,
// datagrams_dropped, nacks}}]}. A statistics object of no sample (count 0: a node without jobs, a
// topic never published) has null for each statistic; nodes.csv keeps Stats' zeros.
nlohmann::json ReportJson(const MetricsReport& report);
// trace.json in the Chrome trace event format (times in whole microseconds), for Perfetto
// (ui.perfetto.dev) or chrome://tracing: per board a CPU busy-cores counter, one track per node
// executor (its jobs, on the cores or in its slot), per FPGA slot and (trace_receive) per DDS
// receive thread.
std::string TraceJson(const std::vector<BoardMetrics>& boards);
// The same text written to `out` a board at a time, so that a long run's trace is never held in
// memory whole.
void WriteTraceJson(const std::vector<BoardMetrics>& boards, std::ostream& out);

namespace detail {
// A span from start_ns to end_ns (>= start_ns >= 0) in the trace's whole microseconds: both ends
// rounded down, so spans that follow each other on a track never overlap (a viewer nests
// overlapping spans), and a span's text is some 8 bytes shorter than with three decimals.
struct WholeMicroseconds {
  std::int64_t ts_us;
  std::int64_t dur_us;
};
WholeMicroseconds ToWholeMicroseconds(std::int64_t start_ns, std::int64_t end_ns);
}  // namespace detail

}  // namespace autonomsim::sim
