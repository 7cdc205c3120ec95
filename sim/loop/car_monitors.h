// The loop's monitors of one car: what a run judges the car by, from ground truth the car's own
// stack never sees. Each owns its state and the part of the car's metrics it measures, and hands
// the events it makes to an emit callback; the loop calls them at their instants (simulation.cc).
#pragma once

#include <cstdint>
#include <deque>
#include <functional>
#include <optional>
#include <utility>

#include "sim/loop/lane_judge.h"
#include "sim/scenario/run_record.h"
#include "world/time.h"
#include "world/track.h"

namespace autonomsim::sim {

using EmitEvent = std::function<void(Event)>;

// Along the car's route: progress, lateral error, laps and the drive's end (parked), and entering
// and leaving intersection areas (enter events say whether the car held the intersection then).
class RouteMonitor {
 public:
  struct Params {
    int car_id{0};
    const world::Route* route{nullptr};
    const world::Track* track{nullptr};
    std::optional<int> laps;  // park after this many laps (a loop)
  };
  RouteMonitor() = default;
  RouteMonitor(const Params& params, double start_s_m);

  // The car at t (after a physics step of `step`), at `pose` and `speed_mps`; `holds(area)` says
  // whether the car holds that intersection now. Updates `metrics` (laps, lap times, lateral
  // error, distance, intersection entries) and emits lap, parked, enter and exit events.
  void Observe(Time t, const world::Pose2& pose, double speed_mps, Duration step,
               const std::function<bool(int)>& holds, const EmitEvent& emit, CarMetrics* metrics);
  // The RMS lateral error into `metrics`, at the run's end.
  void Finish(CarMetrics* metrics) const;

  double route_s_m() const { return route_s_m_; }
  double progress_m() const { return progress_m_; }
  double lateral_error_m() const { return lateral_error_m_; }
  bool parked() const { return parked_; }

 private:
  void CountLaps(Time t, const EmitEvent& emit, CarMetrics* metrics);
  void WatchAreas(Time t, const world::Pose2& pose, const std::function<bool(int)>& holds,
                  const EmitEvent& emit, CarMetrics* metrics);

  Params params_;
  double route_s_m_{0.0};
  double progress_m_{0.0};
  double lateral_error_m_{0.0};
  double lateral_sq_sum_{0.0};
  std::uint64_t lateral_samples_{0};
  bool parked_{false};
  int area_{-1};  // the intersection whose area holds the chassis centre, or -1
};

// The car's stops in stop zones, as its intersection client orders them: wait and go events, and
// the waits' count, total and longest.
class WaitMonitor {
 public:
  // The client's order at `now`: hold (waiting for `intersection`) or go.
  void Observe(Time now, bool waiting, int intersection, int car_id, const EmitEvent& emit,
               CarMetrics* metrics);
  bool waiting() const { return waiting_; }

 private:
  bool waiting_{false};
  std::optional<Time> started_;
  int waiting_for_{-1};  // the intersection of the current (or last) wait
};

// The car's lane detection against ground truth: the colour camera's recent frames (stamp, the
// car's pose then) and the error of each valid result (sim/loop/lane_judge.h).
class LaneMonitor {
 public:
  // Frames remembered (≈ 2 s at 30 fps).
  static constexpr std::size_t kRecentFrames = 64;

  void OnFrame(Time stamp, const world::Pose2& pose);
  void OnLanes(const LaneJudgeParams& params, const world::Track& track, const world::Route& route,
               const stack::LanePoints& lanes, Time stamp, PerceptionMetrics* metrics);
  void Finish(PerceptionMetrics* metrics) const;

 private:
  std::deque<std::pair<Time, world::Pose2>> frames_;
  double error_sq_sum_{0.0};
};

}  // namespace autonomsim::sim
