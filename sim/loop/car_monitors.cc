#include "sim/loop/car_monitors.h"

#include <algorithm>
#include <cmath>

namespace autonomsim::sim {
namespace {

// An open route ends this far before its last point: the car parks there (its motor brakes it
// within ≈ v·τ ≈ 0.15 m).
constexpr double kArrivalMargin_m = 0.2;
// How far a car may move along its route between two physics steps, for the local projection.
constexpr double kTrackingWindow_m = 0.5;

}  // namespace

RouteMonitor::RouteMonitor(const Params& params, double start_s_m)
    : params_(params), route_s_m_(start_s_m) {}

void RouteMonitor::Observe(Time t, const world::Pose2& pose, double speed_mps, Duration step,
                           const std::function<bool(int)>& holds, const EmitEvent& emit,
                           CarMetrics* metrics) {
  const world::Polyline& path = params_.route->path;
  // progress and lateral error along the route
  const world::Polyline::Projection on =
      path.ProjectNear(pose.position(), route_s_m_, kTrackingWindow_m);
  double ds = on.s_m - route_s_m_;
  if (path.cyclic()) ds = world::Remainder(ds, path.length_m());
  route_s_m_ = on.s_m;
  progress_m_ += ds;
  lateral_error_m_ = on.lateral_m;
  metrics->max_lateral_error_m = std::max(metrics->max_lateral_error_m, std::abs(on.lateral_m));
  lateral_sq_sum_ += on.lateral_m * on.lateral_m;
  ++lateral_samples_;
  metrics->distance_m += std::abs(speed_mps) * ToSeconds(step);
  CountLaps(t, emit, metrics);
  WatchAreas(t, pose, holds, emit, metrics);
}

// laps, and the end of the drive
void RouteMonitor::CountLaps(Time t, const EmitEvent& emit, CarMetrics* metrics) {
  const world::Polyline& path = params_.route->path;
  const double length = path.length_m();
  const int id = params_.car_id;
  if (path.cyclic()) {
    while (progress_m_ >= (metrics->laps + 1) * length) {
      ++metrics->laps;
      metrics->lap_times_s.push_back(ToSeconds(t));
      emit(Event{.t = t, .type = EventKind::kLap, .car = id, .lap = metrics->laps});
      if (!parked_ && params_.laps && metrics->laps >= *params_.laps) {
        parked_ = true;
        emit(Event{.t = t, .type = EventKind::kParked, .car = id, .detail = "laps done"});
      }
    }
  } else if (!parked_ && route_s_m_ >= length - kArrivalMargin_m) {
    parked_ = true;
    emit(Event{.t = t, .type = EventKind::kParked, .car = id, .detail = "route end"});
  }
}

// ground truth: entering and leaving intersection areas
void RouteMonitor::WatchAreas(Time t, const world::Pose2& pose,
                              const std::function<bool(int)>& holds, const EmitEvent& emit,
                              CarMetrics* metrics) {
  const world::IntersectionSpec* inside = params_.track->IntersectionAt(pose.position());
  const int area = inside ? inside->id : -1;
  if (area == area_) return;
  const int id = params_.car_id;
  if (area_ >= 0) emit(Event{.t = t, .type = EventKind::kExit, .car = id, .intersection = area_});
  if (area >= 0) {
    emit(Event{.t = t,
               .type = EventKind::kEnter,
               .car = id,
               .intersection = area,
               .granted = holds(area)});
    ++metrics->intersection_entries;
  }
  area_ = area;
}

void RouteMonitor::Finish(CarMetrics* metrics) const {
  if (lateral_samples_ > 0) {
    metrics->rms_lateral_error_m =
        std::sqrt(lateral_sq_sum_ / static_cast<double>(lateral_samples_));
  }
}

void WaitMonitor::Observe(Time now, bool waiting, int intersection, int car_id,
                          const EmitEvent& emit, CarMetrics* metrics) {
  const bool was_waiting = waiting_;
  waiting_ = waiting;
  if (!was_waiting && waiting_) {
    started_ = now;
    waiting_for_ = intersection;
    emit(Event{.t = now, .type = EventKind::kWait, .car = car_id, .intersection = waiting_for_});
  }
  if (was_waiting && !waiting_) {
    emit(Event{.t = now, .type = EventKind::kGo, .car = car_id, .intersection = waiting_for_});
    if (started_) {
      const double wait_s = ToSeconds(now - *started_);
      metrics->total_wait_s += wait_s;
      metrics->max_wait_s = std::max(metrics->max_wait_s, wait_s);
      ++metrics->waits;
      started_.reset();
    }
  }
}

void LaneMonitor::OnFrame(Time stamp, const world::Pose2& pose) {
  frames_.emplace_back(stamp, pose);
  if (frames_.size() > kRecentFrames) frames_.pop_front();
}

void LaneMonitor::OnLanes(const LaneJudgeParams& params, const world::Track& track,
                          const world::Route& route, const stack::LanePoints& lanes, Time stamp,
                          PerceptionMetrics* metrics) {
  ++metrics->lane_frames;
  if (lanes.valid == 0) return;
  ++metrics->lane_valid_frames;
  // the car's pose when the frame was taken
  const auto frame = std::find_if(frames_.rbegin(), frames_.rend(),
                                  [stamp](const auto& f) { return f.first == stamp; });
  if (frame == frames_.rend()) return;
  const std::optional<double> error =
      LaneDetectionError(params, track, route.path, frame->second, lanes);
  if (!error) return;
  metrics->lane_error_max_m = std::max(metrics->lane_error_max_m.value_or(0.0), *error);
  error_sq_sum_ += *error * *error;
  ++metrics->lane_error_samples;
}

void LaneMonitor::Finish(PerceptionMetrics* metrics) const {
  if (metrics->lane_error_samples > 0) {
    metrics->lane_error_rms_m =
        std::sqrt(error_sq_sum_ / static_cast<double>(metrics->lane_error_samples));
  }
}

}  // namespace autonomsim::sim
