#include "sim/results/video_frames.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <string>

namespace autonomsim::sim {
namespace {

constexpr int kCameraPanelPx = 500;  // to the right of the figure, when cameras are shown
constexpr int kCameraWidthPx = 480;  // each camera view's width in the panel
constexpr int kScenePanelPx = 500;   // to the right of those, when 3D views are shown
const cv::Size kSceneViewSize(480, 300);
const cv::Scalar kVideoText(235, 235, 235), kQueueText(65, 179, 227);
const cv::Scalar kFaultText(80, 80, 240);  // red (BGR), as collisions are marked
constexpr int kVideoFont = cv::FONT_HERSHEY_SIMPLEX;

void DrawCar(cv::Mat& image, const TrackFigureLayout& at, const detail::CarTrack& car,
             const TrajectorySample& s) {
  const double c = std::cos(s.yaw_rad), n = std::sin(s.yaw_rad);
  std::vector<cv::Point> body;
  for (const auto& [a, b] : {std::pair{1, 1}, {1, -1}, {-1, -1}, {-1, 1}}) {
    const double dx = a * car.length_m / 2, dy = b * car.width_m / 2;
    body.push_back(at.ToPixel(s.x_m + c * dx - n * dy, s.y_m + n * dx + c * dy));
  }
  cv::fillConvexPoly(image, body, car.colour, cv::LINE_AA);
  cv::polylines(image, body, true, cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
  const double tip = car.length_m / 2 + 0.12;
  cv::arrowedLine(image, at.ToPixel(s.x_m, s.y_m), at.ToPixel(s.x_m + c * tip, s.y_m + n * tip),
                  cv::Scalar(255, 255, 255), 2, cv::LINE_AA, 0, 0.35);
  const cv::Point label = at.ToPixel(s.x_m, s.y_m) + cv::Point(-6, -22);
  cv::putText(image, std::to_string(car.id), label, kVideoFont, 0.6, cv::Scalar(0, 0, 0), 4,
              cv::LINE_AA);
  cv::putText(image, std::to_string(car.id), label, kVideoFont, 0.6, kVideoText, 2, cv::LINE_AA);
}

std::vector<detail::CarTrack> CarTracks(const FinishedRun& run) {
  std::vector<detail::CarTrack> cars;
  for (const CarConfig& c : run.scenario.cars) {
    cars.push_back(
        {c.id, CarColourBgr(run.scenario, c.id), c.vehicle.length_m, c.vehicle.width_m, {}, 0});
  }
  for (const TrajectorySample& s : run.record.trajectory) {
    for (detail::CarTrack& car : cars) {
      if (car.id == s.car) car.samples.push_back(&s);
    }
  }
  return cars;
}

std::vector<std::pair<Time, int>> Collisions(const FinishedRun& run) {
  std::vector<std::pair<Time, int>> collisions;
  for (const Event& e : run.record.events) {
    if (e.type == EventKind::kCollision) collisions.emplace_back(e.t, e.car);
  }
  return collisions;
}

}  // namespace

std::size_t VideoFrameCount(const FinishedRun& run, const VideoOptions& options) {
  const double to = options.to_s.value_or(run.summary.sim_seconds);
  return static_cast<std::size_t>(
             std::floor((to - options.from_s) * options.fps / options.speed + 1e-9)) +
         1;
}

namespace detail {

void CheckVideoOptions(const FinishedRun& run, const VideoOptions& options) {
  const double end_s = run.summary.sim_seconds;
  const double to_s = options.to_s.value_or(end_s);
  if (!(options.fps > 0.0 && std::isfinite(options.fps))) {
    throw std::invalid_argument(fmt::format("--fps {}: must be > 0", options.fps));
  }
  if (!(options.speed > 0.0 && std::isfinite(options.speed))) {
    throw std::invalid_argument(fmt::format("--speed {}: must be > 0", options.speed));
  }
  if (!(options.from_s >= 0.0 && options.from_s <= to_s && to_s <= end_s)) {
    throw std::invalid_argument(
        fmt::format("--from {} --to {}: must satisfy 0 <= from <= to <= {} (the run's end)",
                    options.from_s, to_s, end_s));
  }
  if (options.camera_car) {
    const CarConfig* car = run.scenario.FindCar(*options.camera_car);
    if (car == nullptr || !car->has_board()) {
      throw std::invalid_argument(
          fmt::format("--cameras {}: the run has no car {} with a board (cameras and a stack)",
                      *options.camera_car, *options.camera_car));
    }
  }
  if (options.chase_car && run.scenario.FindCar(*options.chase_car) == nullptr) {
    throw std::invalid_argument(
        fmt::format("--chase {}: the run has no car {}", *options.chase_car, *options.chase_car));
  }
}

Time VideoFrameTime(const VideoOptions& options, std::size_t k) {
  return FromSeconds(options.from_s + static_cast<double>(k) * options.speed / options.fps);
}

const IntersectionState& IntersectionTimeline::At(Time t) const {
  const auto it = std::upper_bound(since.begin(), since.end(), t);
  return states[static_cast<std::size_t>(std::max<std::ptrdiff_t>(0, it - since.begin() - 1))];
}

std::map<int, IntersectionTimeline> IntersectionTimelines(const FinishedRun& run) {
  std::map<int, IntersectionTimeline> out;
  for (const world::IntersectionSpec& i : run.track.spec().intersections) {
    out[i.id] = {{kZeroTime}, {IntersectionState{}}};
  }
  for (const Event& e : run.record.events) {
    const auto it = out.find(e.intersection);
    if (it == out.end()) continue;
    IntersectionState next = it->second.states.back();
    if (e.type == EventKind::kGrant) next.holder = e.car;
    if ((e.type == EventKind::kFree && next.holder == e.car) || e.type == EventKind::kLeaseExpired)
      next.holder = -1;
    auto& q = next.queue;
    if (e.type == EventKind::kWait && std::find(q.begin(), q.end(), e.car) == q.end())
      q.push_back(e.car);
    if (e.type == EventKind::kGo || e.type == EventKind::kEnter)
      q.erase(std::remove(q.begin(), q.end(), e.car), q.end());
    it->second.since.push_back(e.t);
    it->second.states.push_back(std::move(next));
  }
  return out;
}

void CarTrack::Advance(Time t) {
  while (now + 1 < samples.size() && samples[now + 1]->t <= t) ++now;
}

std::vector<std::string> FaultTimeline::ActiveAt(Time t) const {
  std::vector<std::string> lines;
  for (const FaultSpan& f : spans) {
    if (f.begin > t || (f.end && *f.end <= t)) continue;
    lines.push_back(fmt::format("{}{} (since {:.1f} s)", ToName(f.kind),
                                f.car >= 0 ? fmt::format(", car {}", f.car) : "",
                                ToSeconds(f.begin)));
  }
  return lines;
}

FaultTimeline FaultsOfRun(const FinishedRun& run) { return {FaultSpans(run.record)}; }

std::vector<std::string> WrapToWidth(const std::string& text, int max_width_px, double scale,
                                     int thickness) {
  std::vector<std::string> lines;
  std::string line;
  std::size_t at = 0;
  while (at < text.size()) {
    const std::size_t space = text.find(' ', at);
    const std::string word = text.substr(at, space == std::string::npos ? space : space - at);
    at = space == std::string::npos ? text.size() : space + 1;
    const std::string wider = line.empty() ? word : line + " " + word;
    int baseline = 0;
    if (!line.empty() &&
        cv::getTextSize(wider, kVideoFont, scale, thickness, &baseline).width > max_width_px) {
      lines.push_back(line);
      line = word;
    } else {
      line = wider;
    }
  }
  if (!line.empty()) lines.push_back(line);
  return lines;
}

VideoFrames::VideoFrames(const FinishedRun& run, const VideoOptions& options)
    : run_(run),
      options_(options),
      streams_(run.scenario.seed),
      cars_(CarTracks(run)),
      timelines_(IntersectionTimelines(run)),
      collisions_(Collisions(run)),
      faults_(FaultsOfRun(run)) {
  if (options.camera_car) viewer_.emplace(run.track, run.scenario, *options.camera_car);
  if (options.chase_car || options.overview) scene_.emplace(run.track, run.scenario);
  TrackFigureBase base = DrawTrackFigureBase(run.scenario, run.track, false);
  legend_end_ = DrawTrackLegend(base.image, run.scenario, base.legend_x, false);
  legend_x_ = base.legend_x;
  at_ = base.layout;
  figure_cols_ = base.image.cols;
  int width = base.image.cols + (viewer_ ? kCameraPanelPx : 0) + (scene_ ? kScenePanelPx : 0);
  int height = base.image.rows;
  width += width % 2;  // encoders want even sizes
  height += height % 2;
  background_ = cv::Mat(height, width, base.image.type(), base.image.at<cv::Vec3b>(0, 0));
  base.image.copyTo(background_(cv::Rect(0, 0, base.image.cols, base.image.rows)));
}

const cv::Mat& VideoFrames::Draw(Time t) {
  background_.copyTo(frame_);
  for (CarTrack& car : cars_) car.Advance(t);
  DrawIntersections(t);
  for (const ObstacleConfig& o : run_.scenario.obstacles) {
    if (o.PresentAt(t)) DrawObstacle(frame_, at_, o);
  }
  // trails, then collisions so far, then the cars on top
  DrawTrailsAndCollisions(t);
  const std::vector<world::Pose2> poses = DrawCars();
  DrawClock(t);
  DrawFaults(t);
  if (viewer_) DrawCameraPanel(poses, t);
  if (scene_) DrawScenePanel(poses, t);
  return frame_;
}

// Each intersection tinted in its holder's colour, the queue under the label.
void VideoFrames::DrawIntersections(Time t) {
  for (const world::IntersectionSpec& i : run_.track.spec().intersections) {
    const IntersectionState& state = timelines_.at(i.id).At(t);
    const cv::Point top_left = at_.ToPixel(i.area.x_min_m, i.area.y_max_m);
    if (state.holder >= 0) {
      const cv::Rect area(top_left, at_.ToPixel(i.area.x_max_m, i.area.y_min_m));
      cv::Mat roi = frame_(area & cv::Rect(0, 0, frame_.cols, frame_.rows));
      const cv::Mat tint(roi.size(), roi.type(), CarColourBgr(run_.scenario, state.holder));
      cv::addWeighted(roi, 0.7, tint, 0.3, 0.0, roi);
      cv::putText(frame_, fmt::format("held by car {}", state.holder), top_left + cv::Point(4, 34),
                  kVideoFont, 0.45, kVideoText, 1, cv::LINE_AA);
    }
    if (!state.queue.empty()) {
      cv::putText(frame_, fmt::format("queue: car {}", fmt::join(state.queue, ", car ")),
                  top_left + cv::Point(4, 52), kVideoFont, 0.45, kQueueText, 1, cv::LINE_AA);
    }
  }
}

void VideoFrames::DrawTrailsAndCollisions(Time t) {
  for (const CarTrack& car : cars_) {
    if (car.samples.empty()) continue;
    std::vector<cv::Point> trail;
    for (std::size_t j = car.now + 1; j-- > 0;) {
      if (ToSeconds(t - car.samples[j]->t) > options_.trail_s) break;
      trail.push_back(at_.ToPixel(car.samples[j]->x_m, car.samples[j]->y_m));
    }
    cv::polylines(frame_, trail, false, car.colour, 2, cv::LINE_AA);
  }
  while (next_collision_ < collisions_.size() && collisions_[next_collision_].first <= t) {
    for (const CarTrack& car : cars_) {
      if (car.id != collisions_[next_collision_].second || car.samples.empty()) continue;
      const cv::Point p = at_.ToPixel(car.samples[car.now]->x_m, car.samples[car.now]->y_m);
      if (collision_points_.empty() || cv::norm(collision_points_.back() - p) > 6.0) {
        collision_points_.push_back(p);
      }
    }
    ++next_collision_;
  }
  for (const cv::Point& p : collision_points_) DrawCollisionMarker(frame_, p);
}

// The cars at their samples; their poses, in the scenario's order (the origin for a car with no
// samples), for the camera and 3D views.
std::vector<world::Pose2> VideoFrames::DrawCars() {
  std::vector<world::Pose2> poses;
  for (const CarTrack& car : cars_) {
    if (car.samples.empty()) {
      poses.emplace_back();
      continue;
    }
    DrawCar(frame_, at_, car, *car.samples[car.now]);
    poses.push_back(
        {car.samples[car.now]->x_m, car.samples[car.now]->y_m, car.samples[car.now]->yaw_rad});
  }
  return poses;
}

void VideoFrames::DrawClock(Time t) {
  cv::putText(frame_, fmt::format("t = {:.2f} s", ToSeconds(t)), {legend_x_, legend_end_ + 20},
              kVideoFont, 0.8, kVideoText, 2, cv::LINE_AA);
  cv::putText(frame_, fmt::format("{:g}x real time", options_.speed), {legend_x_, legend_end_ + 46},
              kVideoFont, 0.5, kVideoText, 1, cv::LINE_AA);
}

// The faults striking at t, in red under the clock, each line wrapped to the legend's width.
void VideoFrames::DrawFaults(Time t) {
  const std::vector<std::string> active = faults_.ActiveAt(t);
  if (active.empty()) return;
  const int width = figure_cols_ - legend_x_ - 8;
  int y = legend_end_ + 76;
  cv::putText(frame_, "fault:", {legend_x_, y}, kVideoFont, 0.5, kFaultText, 1, cv::LINE_AA);
  for (const std::string& fault : active) {
    for (const std::string& line : WrapToWidth(fault, width, 0.45, 1)) {
      y += 20;
      cv::putText(frame_, line, {legend_x_, y}, kVideoFont, 0.45, kFaultText, 1, cv::LINE_AA);
    }
  }
}

void VideoFrames::DrawCameraPanel(const std::vector<world::Pose2>& poses, Time t) {
  const CameraViewImages views =
      viewer_->Render(SnapshotWithPoses(run_.scenario, poses, t), streams_);
  int y = 56;
  const int x = figure_cols_ + 10;
  cv::putText(frame_, fmt::format("car {}: colour camera, lane detection", viewer_->car_id()),
              {x, y - 8}, kVideoFont, 0.5, kVideoText, 1, cv::LINE_AA);
  for (const cv::Mat* view : {&views.color, &views.depth}) {
    if (view->empty()) continue;
    const int h = view->rows * kCameraWidthPx / view->cols;
    cv::resize(*view, frame_(cv::Rect(x, y, kCameraWidthPx, h)), cv::Size(kCameraWidthPx, h), 0, 0,
               cv::INTER_AREA);
    y += h + 10;
    if (view == &views.color) {
      // the lane detector's words, wrapped to the panel (one line ran off the frame's edge)
      for (const std::string& line : WrapToWidth(views.lane, kCameraWidthPx, 0.42, 1)) {
        cv::putText(frame_, line, {x, y + 8}, kVideoFont, 0.42, kVideoText, 1, cv::LINE_AA);
        y += 18;
      }
      y += 18;
      cv::putText(frame_, "depth camera", {x, y - 8}, kVideoFont, 0.5, kVideoText, 1, cv::LINE_AA);
    }
  }
}

void VideoFrames::DrawScenePanel(const std::vector<world::Pose2>& poses, Time t) {
  const WorldSnapshot snapshot = SnapshotWithPoses(run_.scenario, poses, t);
  const int scene_x = figure_cols_ + (viewer_ ? kCameraPanelPx : 0) + 10;
  int y = 20;
  for (const bool chase : {true, false}) {
    if (chase ? !options_.chase_car : !options_.overview) continue;
    const cv::Mat view = chase ? scene_->Chase(snapshot, *options_.chase_car, kSceneViewSize)
                               : scene_->Overview(snapshot, kSceneViewSize);
    view.copyTo(frame_(cv::Rect(cv::Point(scene_x, y), kSceneViewSize)));
    y += kSceneViewSize.height + 16;
  }
}

}  // namespace detail
}  // namespace autonomsim::sim
