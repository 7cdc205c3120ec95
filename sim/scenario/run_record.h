// What a run leaves behind, in memory: the events, the trajectory samples and the per-car
// metrics, and their canonical text and hash. Outputs (sim/results/outputs.h) and expectations
// (sim/results/expectations.h) read only this.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <ostream>
#include <string>
#include <string_view>
#include <vector>

#include "sim/core/vocabulary.h"
#include "sim/platform/node_metrics.h"
#include "world/time.h"

namespace autonomsim::sim {

// One line of events.jsonl: its kind (`type`, sim/core/vocabulary.h; docs/outputs.md#events
// says what each kind means) and the fields it has (-1, empty or 0: absent from the line):
//   request, free, grant, denied, lease_expired, queue_drop: what the traffic-light server
//     received and did, with the intersection (world::ServerRecord): one event per count of
//     summary.json's server counters; a renewal is a request, not a grant; a free names the
//     intersection it released (-1: none);
//   wait, go: a car's intersection client stopped it in a stop zone of `intersection` until
//     granted, and let it go again;
//   enter, exit: ground truth: the car's chassis centre entered or left an intersection area;
//     `granted` says whether the server held the intersection for it then;
//   collision, lap, parked, behavior, obstacle_appear, obstacle_disappear, v2i_lost,
//   v2i_malformed;
//   fault_begin, fault_end: a scenario's fault (`fault` names its kind; `car` the car it strikes,
//     if one) began or ended (sim/loop/faults.h); a fault without fault_end lasts to the run's end.
struct Event {
  Time t{0};
  EventKind type{EventKind::kRequest};
  int car{-1};
  int intersection{-1};
  int other_car{-1};
  std::string obstacle;
  std::optional<bool> granted;
  int lap{0};
  std::optional<FaultKind> fault;  // fault_begin, fault_end: the fault's kind
  std::string detail;
};

struct TrajectorySample {
  Time t{0};
  int car{0};
  double x_m{0.0};
  double y_m{0.0};
  double yaw_rad{0.0};
  double speed_mps{0.0};
  double steering_rad{0.0};
  double throttle{0.0};
  double curvature_cmd_per_m{0.0};
  double lateral_error_m{0.0};
  double route_progress_m{0.0};
};

// What a car's perception saw, against ground truth (cars with perception only).
struct PerceptionMetrics {
  std::uint64_t lane_frames{0};        // lane detection results
  std::uint64_t lane_valid_frames{0};  // of them, valid
  // The detected lane centre 0.5 m ahead against the route's lane centre: its distance from it,
  // over the valid results that reach 0.5 m. Empty without such a result (no sample): a 0 would
  // read as a perfect detector in tables and plots.
  std::uint64_t lane_error_samples{0};
  std::optional<double> lane_error_max_m;
  std::optional<double> lane_error_rms_m;
  std::uint64_t grid_frames{0};           // obstacle grids
  std::uint64_t grid_obstacle_frames{0};  // of them, with a cell the costmap layer marks lethal
};

// What the stack did (driver: stack).
struct StackMetrics {
  std::uint64_t control_cycles{0};      // controller server cycles that drove (not held)
  std::uint64_t follow_path_cycles{0};  // of which FollowPath (inside stop boxes/intersections)
  std::uint64_t collision_cycles{0};    // of which failed FollowPath by a collision ahead
  int recoveries{0};                    // recovery actions (clear a costmap, wait)
  bool navigation_failed{false};        // retries exhausted
  // The EKF's map-frame position against the true chassis centre, at each estimate; empty before
  // the first estimate (none measured).
  std::optional<double> max_localization_error_m;
  std::optional<double> final_localization_error_m;
};

struct CarMetrics {
  int id{0};
  std::string route;
  double route_length_m{0.0};
  int laps{0};
  std::vector<double> lap_times_s;  // sim time at which each lap completed
  int collisions{0};
  double max_lateral_error_m{0.0};
  double rms_lateral_error_m{0.0};
  double distance_m{0.0};
  double mean_speed_mps{0.0};
  int intersection_entries{0};  // times the chassis centre entered an intersection area
  int waits{0};                 // times the car stopped in a stop zone until granted
  double total_wait_s{0.0};
  double max_wait_s{0.0};
  // Ground truth: the least free distance between the car's footprint and a present obstacle,
  // over the run (only obstacles within kObstacleGapHorizon_m count; nullopt if none came near).
  std::optional<double> min_obstacle_gap_m;
  std::optional<PerceptionMetrics> perception;
  std::optional<StackMetrics> stack;
};

inline constexpr double kObstacleGapHorizon_m = 2.0;

// A real-time run (v2i.link: realtime, sim/v2i/realtime_pacing.h): how far the simulation fell
// behind the wall clock, and what went through the broker. A slice's lag is the wall time at which
// its computation ended minus the wall time at which its last instant was due, 0 when it was in
// time; a slice with a lag above 0 is late.
struct RealTimeMetrics {
  double slice_s{0.0};  // the pacing slice, simulated (= wall) seconds
  std::uint64_t slices{0};
  std::uint64_t late_slices{0};
  double pacing_max_lag_s{0.0};
  double pacing_mean_lag_s{0.0};       // over all slices, those in time counting 0
  std::uint64_t messages_sent{0};      // requests and frees the cars published
  std::uint64_t messages_received{0};  // /vtl/response messages, other cars' included
};

class Sha256;

// Where a run's trajectory samples and events go when they are not kept in RunRecord's vectors:
// a store written as the run goes (files: sim/scenario/record_files.h), so that a run of any length
// holds none of them in memory, and read back in order by outputs and expectations.
class RecordStore {
 public:
  virtual ~RecordStore() = default;
  virtual void Append(const TrajectorySample& sample) = 0;
  virtual void Append(const Event& event) = 0;
  // After the run's last Append: makes what was appended readable.
  virtual void Close() = 0;
  virtual void ForEachSample(const std::function<void(const TrajectorySample&)>& visit) const = 0;
  virtual void ForEachEvent(const std::function<void(const Event&)>& visit) const = 0;
  // Feeds the text of trajectory.csv, then of events.jsonl, to `hash`.
  virtual void HashText(Sha256* hash) const = 0;
  // Where the run writes its trace.json as it makes it (before Close), so that the trace is never
  // held in memory whole; null where the store keeps no files (then RunRecord::trace_json has it).
  virtual std::ostream* OpenTrace() { return nullptr; }
};

struct RunRecord {
  Duration sim_duration{0};
  std::uint64_t kernel_events{0};
  // The run's events and trajectory samples, in the order they were made: in these vectors, or in
  // `store` when the run was given one (then both vectors stay empty). Read them with ForEachEvent
  // and ForEachSample below, which serve either.
  std::vector<Event> events;
  std::vector<TrajectorySample> trajectory;
  std::shared_ptr<const RecordStore> store;
  std::vector<CarMetrics> cars;
  struct ServerCounters {
    std::uint64_t requests{0}, grants{0}, denials{0}, frees{0}, lease_expiries{0}, malformed{0};
  } server;
  struct LinkCounters {
    std::uint64_t sent{0}, delivered{0}, lost{0};
  } v2i;
  // A real-time run only (v2i.link: realtime): its pacing and its traffic through the broker.
  std::optional<RealTimeMetrics> realtime;
  // The cars' compute boards (those that have one): per-node and platform metrics, and the
  // Chrome trace of their jobs (empty when no board records one).
  std::vector<BoardReport> boards;
  std::string trace_json;  // empty where it went to `store` (RecordStore::OpenTrace)
};

void ForEachEvent(const RunRecord& record, const std::function<void(const Event&)>& visit);
void ForEachSample(const RunRecord& record,
                   const std::function<void(const TrajectorySample&)>& visit);

// The record's canonical text: the run folder's trajectory.csv and events.jsonl, whole or line by
// line (a header, then one line per sample or event, each ending in a newline), and back.
std::string TrajectoryCsv(const RunRecord& record);
std::string EventsJsonl(const RunRecord& record);
std::string TrajectoryCsvHeader();
std::string TrajectoryCsvLine(const TrajectorySample& sample);
std::string EventJsonLine(const Event& event);
// One event as events.jsonl writes it (t_s, type, and the fields it has), as JSON.
nlohmann::json EventJson(const Event& event);
// Throw std::invalid_argument for a line these functions did not write.
TrajectorySample ParseTrajectoryCsvLine(std::string_view line);
Event ParseEventJsonLine(std::string_view line);
// SHA-256 over trajectory.csv, events.jsonl and (with boards) nodes.csv: equal hashes mean
// bit-identical results (summary.json's result_sha256).
std::string ResultSha256(const RunRecord& record);

}  // namespace autonomsim::sim
