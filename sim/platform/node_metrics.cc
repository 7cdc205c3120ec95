#include "sim/platform/node_metrics.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <iterator>
#include <optional>
#include <set>
#include <sstream>
#include <string_view>

#include "world/validation.h"

namespace autonomsim::sim {
namespace {

// Trace process ids: per board, four processes from 10 * (board index + 1).
constexpr int kPidCpu = 0;
constexpr int kPidExecutors = 1;
constexpr int kPidReceive = 2;
constexpr int kPidSlots = 3;
constexpr int kPidsPerBoard = 10;
constexpr int kConfigPortTid = 1000;  // the configuration port's track among the slots

int PidOf(TraceLane lane) {
  switch (lane) {
    case TraceLane::kExecutor:
      return kPidExecutors;
    case TraceLane::kReceive:
      return kPidReceive;
    case TraceLane::kSlot:
    case TraceLane::kConfigPort:
      return kPidSlots;
  }
  return kPidExecutors;
}

// With no sample (a node without jobs, a topic that never published) every statistic is null,
// not Stats' 0: a sweep's table and plots leave it out rather than draw a perfect 0 ms.
nlohmann::json StatsJson(const Stats& s) {
  const auto measured = [&s](double value) {
    return s.count > 0 ? nlohmann::json(value) : nlohmann::json();
  };
  return {{"count", s.count},       {"min", measured(s.min)}, {"p50", measured(s.p50)},
          {"p95", measured(s.p95)}, {"p99", measured(s.p99)}, {"max", measured(s.max)}};
}

}  // namespace

RunMetrics::RunMetrics(const MetricsOptions& options) : options_(options) {
  if (options_.load_bin.count() <= 0) throw std::invalid_argument("load_bin must be > 0");
}

int RunMetrics::AddNode(const std::string& name, const std::string& mapping) {
  nodes_.push_back(NodeData{.name = name, .mapping = mapping});
  return static_cast<int>(nodes_.size()) - 1;
}

int RunMetrics::AddTopic(const std::string& name, const std::string& transport, std::int64_t bytes,
                         int depth) {
  topics_.push_back(
      TopicData{.name = name, .transport = transport, .bytes = bytes, .depth = depth});
  return static_cast<int>(topics_.size()) - 1;
}

double RunMetrics::MeasuredSeconds(Time t0, Time t1) const {
  const Time from = std::max(t0, options_.measure_from);
  return t1 > from ? ToSeconds(t1 - from) : 0.0;
}

void RunMetrics::AddCpu(int node, Time t0, Time t1, double cores) {
  nodes_.at(static_cast<std::size_t>(node)).cpu_core_s += cores * MeasuredSeconds(t0, t1);
}

void RunMetrics::AddBusy(Time t0, Time t1, double cores) {
  busy_core_s_ += cores * MeasuredSeconds(t0, t1);
  if (options_.trace && options_.trace_busy_period.count() > 0) SampleBusy(t0, t1, cores);
  if (cores <= 0.0 || t1 <= t0) return;
  // Spread over the load bins (whole run, not only the window).
  const std::int64_t bin_ns = options_.load_bin.count();
  std::int64_t t = t0.count();
  while (t < t1.count()) {
    const std::size_t bin = static_cast<std::size_t>(t / bin_ns);
    const std::int64_t bin_end = (static_cast<std::int64_t>(bin) + 1) * bin_ns;
    const std::int64_t until = std::min(bin_end, t1.count());
    if (load_bins_core_ns_.size() <= bin) load_bins_core_ns_.resize(bin + 1, 0.0);
    load_bins_core_ns_[bin] += cores * static_cast<double>(until - t);
    t = until;
  }
}

void RunMetrics::BusyChanged(Time t, double cores) {
  if (options_.trace_busy_period.count() > 0 || cores == last_busy_) return;
  last_busy_ = cores;
  AddTrace({'C', kPidCpu, 0, TraceName("busy cores"), t.count(), 0, cores});
}

void RunMetrics::SampleBusy(Time t0, Time t1, double cores) {
  const std::int64_t period = options_.trace_busy_period.count();
  std::int64_t at = t0.count();
  const std::int64_t end = t1.count();
  while (at < end) {
    const std::int64_t index = at / period;
    if (index != busy_period_) {
      CloseBusyPeriod();
      busy_period_ = index;
    }
    const std::int64_t period_end = (index + 1) * period;
    if (at == index * period && end >= period_end) {
      // whole periods at `cores` (an idle stretch, a long job): their mean is `cores`, written once
      const std::int64_t whole = (end - at) / period;
      WriteBusy(index, cores);
      busy_period_ = index + whole;  // opens empty
      at += whole * period;
      continue;
    }
    const std::int64_t until = std::min(end, period_end);
    busy_area_core_ns_ += cores * static_cast<double>(until - at);
    at = until;
  }
}

void RunMetrics::CloseBusyPeriod() {
  if (busy_period_ < 0) return;
  WriteBusy(busy_period_,
            busy_area_core_ns_ / static_cast<double>(options_.trace_busy_period.count()));
  busy_area_core_ns_ = 0.0;
}

void RunMetrics::WriteBusy(std::int64_t period_index, double mean_cores) {
  // to 0.001 cores: finer is noise of the sum, and each digit is text in every event
  const double cores = std::round(mean_cores * 1000.0) / 1000.0;
  if (cores == last_busy_) return;
  last_busy_ = cores;
  AddTrace({'C', kPidCpu, 0, TraceName("busy cores"),
            period_index * options_.trace_busy_period.count(), 0, cores});
}

void RunMetrics::JobDone(int node, Time start, Time end, double nominal_core_s, bool timed) {
  if (!Measured(start)) return;
  NodeData& n = nodes_.at(static_cast<std::size_t>(node));
  ++n.jobs;
  n.job_core_s += nominal_core_s;
  if (timed) {
    n.turnaround.Add(end - start);
  } else {
    ++n.callbacks;
  }
}

void RunMetrics::ReceiveDone(int node, Time t, double core_s) {
  if (Measured(t)) nodes_.at(static_cast<std::size_t>(node)).receive_core_s += core_s;
}

void RunMetrics::Arrival(int node, int /*topic*/, Time t) {
  if (Measured(t)) ++nodes_.at(static_cast<std::size_t>(node)).arrivals;
}

void RunMetrics::Dropped(int node, int topic, Time t) {
  if (!Measured(t)) return;
  ++nodes_.at(static_cast<std::size_t>(node)).drops;
  ++topics_.at(static_cast<std::size_t>(topic)).drops;
}

void RunMetrics::LoanFailed(int node, int topic, Time t) {
  if (!Measured(t)) return;
  ++nodes_.at(static_cast<std::size_t>(node)).loan_failures;
  ++topics_.at(static_cast<std::size_t>(topic)).loan_failures;
}

void RunMetrics::TimerFired(int node, Time t) {
  if (Measured(t)) ++nodes_.at(static_cast<std::size_t>(node)).timer_ticks;
}

void RunMetrics::TimerOverrun(int node, Time t) {
  if (Measured(t)) ++nodes_.at(static_cast<std::size_t>(node)).timer_overruns;
}

void RunMetrics::Published(int /*node*/, int topic, Time t, Time stamp) {
  TopicData& d = topics_.at(static_cast<std::size_t>(topic));
  const std::size_t bin = static_cast<std::size_t>(t.count() / options_.load_bin.count());
  if (d.bin_count.size() <= bin) {
    d.bin_count.resize(bin + 1, 0);
    d.bin_sum_ns.resize(bin + 1, 0.0);
    d.bin_max_ns.resize(bin + 1, 0.0);
  }
  const double latency_ns = static_cast<double>((t - stamp).count());
  ++d.bin_count[bin];
  d.bin_sum_ns[bin] += latency_ns;
  d.bin_max_ns[bin] = std::max(d.bin_max_ns[bin], latency_ns);
  if (!Measured(t)) return;
  ++d.published;
  d.latency.Add(t - stamp);
}

void RunMetrics::Span(TraceLane lane, int id, const std::string& name, Time start, Time end) {
  if (lane == TraceLane::kReceive && !options_.trace_receive) return;
  const int tid = lane == TraceLane::kConfigPort ? kConfigPortTid : id;
  AddTrace({'X', PidOf(lane), tid, TraceName(name), start.count(), (end - start).count(), 0.0});
}

int RunMetrics::TraceName(const std::string& name) {
  // Few distinct names (one per node, slot, topic); a linear search from the back is enough.
  for (std::size_t i = trace_names_.size(); i-- > 0;) {
    if (trace_names_[i] == name) return static_cast<int>(i);
  }
  trace_names_.push_back(name);
  return static_cast<int>(trace_names_.size()) - 1;
}

void RunMetrics::AddTrace(const TraceEvent& event) {
  if (!options_.trace) return;
  if (trace_.size() >= options_.trace_max_events) {
    if (!trace_truncated_) trace_truncated_at_ = kZeroTime + std::chrono::nanoseconds(event.ts_ns);
    trace_truncated_ = true;
    return;
  }
  trace_.push_back(event);
}

std::vector<double> HistogramEdgesMs() {
  const int decades =
      static_cast<int>(std::lround(std::log10(kHistogramMax_ms / kHistogramMin_ms)));
  std::vector<double> edges;
  for (int i = 0; i <= decades * kHistogramBinsPerDecade; ++i) {
    edges.push_back(kHistogramMin_ms *
                    std::pow(10.0, static_cast<double>(i) / kHistogramBinsPerDecade));
  }
  return edges;
}

const NodeReport* MetricsReport::FindNode(const std::string& name) const {
  for (const NodeReport& n : nodes) {
    if (n.name == name) return &n;
  }
  return nullptr;
}

const TopicReport* MetricsReport::FindTopic(const std::string& name) const {
  for (const TopicReport& t : topics) {
    if (t.name == name) return &t;
  }
  return nullptr;
}

MetricsReport BuildReport(const RunMetrics& metrics, Time end) {
  MetricsReport report;
  const Time from = metrics.options().measure_from;
  report.window_s = end > from ? ToSeconds(end - from) : 0.0;
  report.cores = metrics.cores();
  report.load_bin = metrics.options().load_bin;
  report.trace = {.recorded = metrics.options().trace,
                  .events = metrics.trace_events().size(),
                  .max_events = metrics.options().trace_max_events};
  if (const std::optional<Time> cut = metrics.trace_truncated_at()) {
    report.trace.cut_at_s = ToSeconds(*cut - kZeroTime);
  }
  const double window = report.window_s > 0.0 ? report.window_s : 1.0;
  report.cpu_percent = 100.0 * metrics.busy_core_s() / window;
  const double bin_ns = static_cast<double>(report.load_bin.count());
  for (double core_ns : metrics.load_bins_core_ns()) {
    report.cpu_load_percent.push_back(100.0 * core_ns / bin_ns);
  }
  for (const RunMetrics::NodeData& n : metrics.nodes()) {
    NodeReport r;
    r.name = n.name;
    r.mapping = n.mapping;
    r.jobs = n.jobs - n.callbacks;
    r.callbacks = n.callbacks;
    r.arrivals = n.arrivals;
    r.timer_ticks = n.timer_ticks;
    r.drops = n.drops;
    r.loan_failures = n.loan_failures;
    r.timer_overruns = n.timer_overruns;
    r.input_hz = static_cast<double>(n.arrivals + n.timer_ticks) / window;
    r.rate_hz = static_cast<double>(r.jobs) / window;
    r.turnaround_ms = n.turnaround.ComputeStats();
    r.turnaround_histogram = n.turnaround.Counts(HistogramEdgesMs());
    r.cpu_percent = 100.0 * n.cpu_core_s / window;
    const double per_job = n.jobs > 0 ? n.job_core_s / static_cast<double>(n.jobs) : 0.0;
    const double triggers = static_cast<double>(n.arrivals + n.timer_ticks);
    r.demand_percent = 100.0 * (per_job * triggers + n.receive_core_s) / window;
    report.cpu_demand_percent += r.demand_percent;
    report.nodes.push_back(std::move(r));
  }
  for (const RunMetrics::TopicData& t : metrics.topics()) {
    TopicReport r;
    r.name = t.name;
    r.transport = t.transport;
    r.bytes = t.bytes;
    r.depth = t.depth;
    r.published = t.published;
    r.drops = t.drops;
    r.loan_failures = t.loan_failures;
    r.rate_hz = static_cast<double>(t.published) / window;
    r.latency_ms = t.latency.ComputeStats();
    for (std::size_t bin = 0; bin < t.bin_count.size(); ++bin) {
      if (t.bin_count[bin] == 0) {
        r.latency_mean_ms_per_bin.emplace_back();
        r.latency_max_ms_per_bin.emplace_back();
        continue;
      }
      r.latency_mean_ms_per_bin.emplace_back(t.bin_sum_ns[bin] / t.bin_count[bin] * 1e-6);
      r.latency_max_ms_per_bin.emplace_back(t.bin_max_ns[bin] * 1e-6);
    }
    report.topics.push_back(std::move(r));
  }
  return report;
}

std::string NodesCsv(const std::vector<BoardReport>& boards) {
  std::string csv =
      "board,node,mapping,jobs,input_hz,rate_hz,turnaround_min_ms,turnaround_p50_ms,"
      "turnaround_p95_ms,turnaround_max_ms,cpu_percent,demand_percent,arrivals,timer_ticks,"
      "drops,loan_failures,timer_overruns,callbacks\n";
  for (const BoardReport& b : boards) {
    for (const NodeReport& n : b.report.nodes) {
      csv += fmt::format("{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}\n", b.board, n.name,
                         n.mapping, n.jobs, n.input_hz, n.rate_hz, n.turnaround_ms.min,
                         n.turnaround_ms.p50, n.turnaround_ms.p95, n.turnaround_ms.max,
                         n.cpu_percent, n.demand_percent, n.arrivals, n.timer_ticks, n.drops,
                         n.loan_failures, n.timer_overruns, n.callbacks);
    }
  }
  return csv;
}

std::string TopicsCsv(const std::vector<BoardReport>& boards) {
  std::string csv =
      "board,topic,transport,bytes,depth,published,rate_hz,latency_count,latency_min_ms,"
      "latency_p50_ms,latency_p95_ms,latency_p99_ms,latency_max_ms,latency_mean_ms,drops,"
      "loan_failures,dds_samples_written,dds_write_timeouts,dds_samples_delivered,"
      "dds_samples_lost,dds_datagrams_sent,dds_datagrams_retransmitted,dds_datagrams_dropped,"
      "dds_nacks\n";
  for (const BoardReport& b : boards) {
    for (const TopicReport& t : b.report.topics) {
      csv += fmt::format("{},{},{},{},{},{},{},{},", b.board, t.name, t.transport, t.bytes, t.depth,
                         t.published, t.rate_hz, t.latency_ms.count);
      const Stats& l = t.latency_ms;
      csv += l.count == 0
                 ? std::string(",,,,,,")
                 : fmt::format("{},{},{},{},{},{},", l.min, l.p50, l.p95, l.p99, l.max, l.mean);
      csv += fmt::format("{},{},", t.drops, t.loan_failures);
      if (t.dds) {
        const DdsLinkStats& d = *t.dds;
        csv += fmt::format("{},{},{},{},{},{},{},{}\n", d.samples_written, d.write_timeouts,
                           d.samples_delivered, d.samples_lost, d.datagrams_sent,
                           d.datagrams_retransmitted, d.datagrams_dropped, d.nacks);
      } else {
        csv += ",,,,,,,\n";
      }
    }
  }
  return csv;
}

namespace {
nlohmann::json OptionalSeries(const std::vector<std::optional<double>>& series) {
  nlohmann::json out = nlohmann::json::array();
  for (const std::optional<double>& v : series) out.push_back(v ? nlohmann::json(*v) : nullptr);
  return out;
}
}  // namespace

namespace {
nlohmann::json SlotsJson(const SlotsReport& report) {
  nlohmann::json slots = nlohmann::json::array();
  std::uint64_t reconfigurations = 0;
  double reconfiguring_s = 0.0;
  for (const SlotsReport::Slot& s : report.slots) {
    slots.push_back({{"callbacks", s.callbacks},
                     {"reconfigurations", s.reconfigurations},
                     {"reconfiguring_s", s.reconfiguring_s}});
    reconfigurations += s.reconfigurations;
    reconfiguring_s += s.reconfiguring_s;
  }
  return {{"policy", "executor"},
          {"reconfigurations", reconfigurations},
          {"reconfiguring_s", reconfiguring_s},
          {"waits", report.waits},
          {"wait_s", report.wait_s},
          {"per_slot", slots}};
}
}  // namespace

nlohmann::json ReportJson(const MetricsReport& report) {
  nlohmann::json nodes = nlohmann::json::array();
  for (const NodeReport& n : report.nodes) {
    nodes.push_back({{"name", n.name},
                     {"mapping", n.mapping},
                     {"jobs", n.jobs},
                     {"callbacks", n.callbacks},
                     {"input_hz", n.input_hz},
                     {"rate_hz", n.rate_hz},
                     {"turnaround_ms", StatsJson(n.turnaround_ms)},
                     {"turnaround_histogram_ms",
                      {{"edges", HistogramEdgesMs()}, {"counts", n.turnaround_histogram}}},
                     {"cpu_percent", n.cpu_percent},
                     {"demand_percent", n.demand_percent},
                     {"arrivals", n.arrivals},
                     {"timer_ticks", n.timer_ticks},
                     {"drops", n.drops},
                     {"loan_failures", n.loan_failures},
                     {"timer_overruns", n.timer_overruns}});
  }
  nlohmann::json topics = nlohmann::json::array();
  for (const TopicReport& t : report.topics) {
    topics.push_back({{"name", t.name},
                      {"transport", t.transport},
                      {"bytes", t.bytes},
                      {"depth", t.depth},
                      {"published", t.published},
                      {"rate_hz", t.rate_hz},
                      {"latency_ms", StatsJson(t.latency_ms)},
                      {"latency_per_bin_ms",
                       {{"mean", OptionalSeries(t.latency_mean_ms_per_bin)},
                        {"max", OptionalSeries(t.latency_max_ms_per_bin)}}},
                      {"drops", t.drops},
                      {"loan_failures", t.loan_failures}});
    if (t.dds) {
      const DdsLinkStats& d = *t.dds;
      topics.back()["dds"] = {{"samples_written", d.samples_written},
                              {"write_timeouts", d.write_timeouts},
                              {"samples_delivered", d.samples_delivered},
                              {"samples_lost", d.samples_lost},
                              {"datagrams_sent", d.datagrams_sent},
                              {"datagrams_retransmitted", d.datagrams_retransmitted},
                              {"datagrams_dropped", d.datagrams_dropped},
                              {"nacks", d.nacks}};
    }
  }
  nlohmann::json out = {
      {"cores", report.cores},
      {"window_s", report.window_s},
      {"cpu_percent", report.cpu_percent},
      {"cpu_demand_percent", report.cpu_demand_percent},
      {"load_bin_s", ToSeconds(report.load_bin)},
      {"cpu_load_percent", report.cpu_load_percent},
      {"nodes", nodes},
      {"topics", topics},
      {"trace",
       {{"recorded", report.trace.recorded},
        {"events", report.trace.events},
        {"max_events", report.trace.max_events},
        {"cut_at_s",
         report.trace.cut_at_s ? nlohmann::json(*report.trace.cut_at_s) : nlohmann::json()}}}};
  if (report.slots) out["slots"] = SlotsJson(*report.slots);
  return out;
}

namespace detail {
WholeMicroseconds ToWholeMicroseconds(std::int64_t start_ns, std::int64_t end_ns) {
  const std::int64_t ts_us = start_ns / 1000;
  return {ts_us, end_ns / 1000 - ts_us};
}
}  // namespace detail

namespace {

// A little more than one trace event's text takes (the default scenario's trace.json: 31.2 MB for
// its two boards' 204 k events each, some 77 bytes an event): what TraceJson reserves per event.
constexpr std::size_t kTypicalTraceEventBytes = 88;

// The events are most of the file: appended piece by piece, the times from integers, each after
// a comma (they follow their board's names).
void AppendTraceEvents(const RunMetrics& metrics, int base, std::string* out_ptr) {
  using namespace std::string_view_literals;  // each piece's length known when compiled
  std::string& out = *out_ptr;
  std::vector<std::string> names;  // JSON-quoted
  for (const std::string& name : metrics.trace_names()) {
    names.push_back(nlohmann::json(name).dump());
  }
  out.reserve(out.size() + metrics.trace_events().size() * kTypicalTraceEventBytes);
  const auto append_int = [&out](std::int64_t value) {
    const fmt::format_int text(value);
    out.append(text.data(), text.size());
  };
  for (const RunMetrics::TraceEvent& e : metrics.trace_events()) {
    out += ",{\"name\":"sv;
    out += names[static_cast<std::size_t>(e.name)];
    if (e.phase == 'C') {
      out += ",\"ph\":\"C\",\"pid\":"sv;
      append_int(base + e.pid);
      out += ",\"ts\":"sv;
      append_int(e.ts_ns / 1000);
      out += ",\"args\":{\"cores\":"sv;
      fmt::format_to(std::back_inserter(out), "{}", e.value);
      out += "}}"sv;
    } else {
      out += ",\"ph\":\"X\",\"pid\":"sv;
      append_int(base + e.pid);
      out += ",\"tid\":"sv;
      append_int(e.tid);
      const detail::WholeMicroseconds us = detail::ToWholeMicroseconds(e.ts_ns, e.ts_ns + e.dur_ns);
      out += ",\"ts\":"sv;
      append_int(us.ts_us);
      out += ",\"dur\":"sv;
      append_int(us.dur_us);
      out += '}';
    }
  }
}

// trace.json's "traceEvents", event by event rather than through a JSON document: a run's trace
// holds up to trace_max_events per board, and a document of them takes ~1 KB per event.
class TraceWriter {
 public:
  explicit TraceWriter(std::string* out) : out_(*out) {}

  // The names of a board's processes (CPU, executors, receive threads, slots) and threads.
  void AppendBoardNames(const RunMetrics& metrics, const std::string& board, int base) {
    Meta(base + kPidCpu, std::nullopt, "process_name",
         fmt::format("{}: CPU ({} cores; busy cores, 1.0 = one core)", board, metrics.cores()));
    Meta(base + kPidExecutors, std::nullopt, "process_name",
         board + ": node executors (jobs on the cores or in a slot)");
    const bool receive = metrics.options().trace_receive;
    if (receive) {
      Meta(base + kPidReceive, std::nullopt, "process_name", board + ": DDS receive threads");
    }
    Meta(base + kPidSlots, std::nullopt, "process_name", board + ": FPGA slots");
    for (std::size_t i = 0; i < metrics.nodes().size(); ++i) {
      const auto& n = metrics.nodes()[i];
      Meta(base + kPidExecutors, static_cast<int>(i), "thread_name",
           n.name + " (" + n.mapping + ")");
      if (receive) {
        Meta(base + kPidReceive, static_cast<int>(i), "thread_name", n.name + " receive");
      }
    }
    std::set<int> slots;
    for (const RunMetrics::TraceEvent& e : metrics.trace_events()) {
      if (e.pid == kPidSlots) slots.insert(e.tid);
    }
    for (int slot : slots) {
      Meta(base + kPidSlots, slot, "thread_name",
           slot == kConfigPortTid ? std::string("configuration port")
                                  : fmt::format("slot {}", slot));
    }
  }

  // The events follow their board's names, so each comes after another entry.
  void AppendEvents(const RunMetrics& metrics, int base) {
    Require(!first_, "TraceWriter: a board's events before its names");
    AppendTraceEvents(metrics, base, &out_);
  }

 private:
  void Separate() {
    if (!first_) out_ += ',';
    first_ = false;
  }
  void Meta(int pid, std::optional<int> tid, const char* what, const std::string& name) {
    nlohmann::json e = {{"name", what}, {"ph", "M"}, {"pid", pid}, {"args", {{"name", name}}}};
    if (tid) e["tid"] = *tid;
    Separate();
    out_ += e.dump();
  }

  std::string& out_;
  bool first_{true};
};

}  // namespace

std::string TraceJson(const std::vector<BoardMetrics>& boards) {
  std::ostringstream out;
  WriteTraceJson(boards, out);
  return std::move(out).str();
}

void WriteTraceJson(const std::vector<BoardMetrics>& boards, std::ostream& stream) {
  std::string out = "{\"displayTimeUnit\":\"ms\",\"traceEvents\":[";
  TraceWriter writer(&out);
  std::vector<std::string> truncated;
  for (std::size_t b = 0; b < boards.size(); ++b) {
    const RunMetrics& metrics = *boards[b].metrics;
    const std::string& board = boards[b].board;
    const int base = kPidsPerBoard * (static_cast<int>(b) + 1);
    writer.AppendBoardNames(metrics, board, base);
    writer.AppendEvents(metrics, base);
    stream << out;  // the board's text; the writer goes on in the emptied buffer
    out.clear();
    if (metrics.trace_truncated()) {
      truncated.push_back(fmt::format("{}: recording stopped after {} events", board,
                                      metrics.options().trace_max_events));
    }
  }
  out += ']';
  if (!truncated.empty()) {
    out += ",\"otherData\":" + nlohmann::json({{"truncated", truncated}}).dump();
  }
  out += "}\n";
  stream << out;
}

}  // namespace autonomsim::sim
