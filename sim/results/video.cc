#include "sim/results/video.h"

#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>
#include <stdexcept>
#include <vector>

#include "sim/core/random.h"
#include "sim/results/camera_views.h"
#include "sim/results/scene_views.h"
#include "sim/results/track_figure.h"

namespace autonomsim::sim {
namespace {

namespace fs = std::filesystem;

constexpr int kCameraPanelPx = 500;  // to the right of the figure, when cameras are shown
constexpr int kCameraWidthPx = 480;  // each camera view's width in the panel
constexpr int kScenePanelPx = 500;   // to the right of those, when 3D views are shown
const cv::Size kSceneViewSize(480, 300);
const cv::Scalar kVideoText(235, 235, 235), kQueueText(65, 179, 227);
constexpr int kVideoFont = cv::FONT_HERSHEY_SIMPLEX;

// Who holds an intersection and who waits at it, from the server's and the cars' events.
struct IntersectionState {
  int holder{-1};
  std::vector<int> queue;
};
struct IntersectionTimeline {
  std::vector<Time> since;
  std::vector<IntersectionState> states;
  const IntersectionState& At(Time t) const {
    const auto it = std::upper_bound(since.begin(), since.end(), t);
    return states[static_cast<std::size_t>(std::max<std::ptrdiff_t>(0, it - since.begin() - 1))];
  }
};

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

// Each car's samples in time order, and a cursor that moves forward with the frames.
struct CarTrack {
  int id{0};
  cv::Scalar colour;
  double length_m{0.0}, width_m{0.0};
  std::vector<const TrajectorySample*> samples;
  std::size_t now{0};  // the last sample at or before the frame's time
  void Advance(Time t) {
    while (now + 1 < samples.size() && samples[now + 1]->t <= t) ++now;
  }
};

void DrawCar(cv::Mat& image, const TrackFigureLayout& at, const CarTrack& car,
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

}  // namespace

std::size_t VideoFrameCount(const FinishedRun& run, const VideoOptions& options) {
  const double to = options.to_s.value_or(run.summary.sim_seconds);
  return static_cast<std::size_t>(
             std::floor((to - options.from_s) * options.fps / options.speed + 1e-9)) +
         1;
}

void WriteVideo(const FinishedRun& run, const VideoOptions& options, const fs::path& out) {
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
  std::optional<CarCameraViewer> viewer;
  if (options.camera_car) {
    const CarConfig* car = run.scenario.FindCar(*options.camera_car);
    if (car == nullptr || !car->has_board()) {
      throw std::invalid_argument(
          fmt::format("--cameras {}: the run has no car {} with a board (cameras and a stack)",
                      *options.camera_car, *options.camera_car));
    }
    viewer.emplace(run.track, run.scenario, *options.camera_car);
  }
  if (options.chase_car && run.scenario.FindCar(*options.chase_car) == nullptr) {
    throw std::invalid_argument(
        fmt::format("--chase {}: the run has no car {}", *options.chase_car, *options.chase_car));
  }
  std::optional<SceneViews> scene;
  if (options.chase_car || options.overview) scene.emplace(run.track, run.scenario);

  TrackFigureBase base = DrawTrackFigureBase(run.scenario, run.track, false);
  const int legend_end = DrawTrackLegend(base.image, run.scenario, base.legend_x, false);
  const TrackFigureLayout& at = base.layout;
  const int scene_x = base.image.cols + (viewer ? kCameraPanelPx : 0) + 10;
  int width = base.image.cols + (viewer ? kCameraPanelPx : 0) + (scene ? kScenePanelPx : 0);
  int height = base.image.rows;
  width += width % 2;  // encoders want even sizes
  height += height % 2;
  cv::Mat background(height, width, base.image.type(), base.image.at<cv::Vec3b>(0, 0));
  base.image.copyTo(background(cv::Rect(0, 0, base.image.cols, base.image.rows)));

  std::vector<CarTrack> cars;
  for (const CarConfig& c : run.scenario.cars) {
    cars.push_back(
        {c.id, CarColourBgr(run.scenario, c.id), c.vehicle.length_m, c.vehicle.width_m, {}, 0});
  }
  for (const TrajectorySample& s : run.record.trajectory) {
    for (CarTrack& car : cars) {
      if (car.id == s.car) car.samples.push_back(&s);
    }
  }
  const auto timelines = IntersectionTimelines(run);
  std::vector<std::pair<Time, int>> collisions;  // (t, car)
  for (const Event& e : run.record.events) {
    if (e.type == EventKind::kCollision) collisions.emplace_back(e.t, e.car);
  }

  const fs::path partial =
      out.parent_path() /
      (out.stem().string() + ".partial-" + std::to_string(::getpid()) + out.extension().string());
  cv::VideoWriter writer;
  for (const char* codec : {"avc1", "mp4v"}) {
    if (writer.open(partial.string(), cv::CAP_FFMPEG,
                    cv::VideoWriter::fourcc(codec[0], codec[1], codec[2], codec[3]), options.fps,
                    cv::Size(width, height))) {
      break;
    }
  }
  if (!writer.isOpened()) {
    throw std::runtime_error(out.string() +
                             ": OpenCV's video writer (FFmpeg) opens no MPEG-4 encoder");
  }
  const RngStreams streams(run.scenario.seed);
  const std::size_t frames = VideoFrameCount(run, options);
  cv::Mat frame;
  std::vector<cv::Point> collision_points;
  std::size_t next_collision = 0;
  try {
    for (std::size_t k = 0; k < frames; ++k) {
      const Time t =
          FromSeconds(options.from_s + static_cast<double>(k) * options.speed / options.fps);
      background.copyTo(frame);
      for (CarTrack& car : cars) car.Advance(t);
      // intersections: tinted in the holder's colour, the queue under the label
      for (const world::IntersectionSpec& i : run.track.spec().intersections) {
        const IntersectionState& state = timelines.at(i.id).At(t);
        const cv::Point top_left = at.ToPixel(i.area.x_min_m, i.area.y_max_m);
        if (state.holder >= 0) {
          const cv::Rect area(top_left, at.ToPixel(i.area.x_max_m, i.area.y_min_m));
          cv::Mat roi = frame(area & cv::Rect(0, 0, frame.cols, frame.rows));
          const cv::Mat tint(roi.size(), roi.type(), CarColourBgr(run.scenario, state.holder));
          cv::addWeighted(roi, 0.7, tint, 0.3, 0.0, roi);
          cv::putText(frame, fmt::format("held by car {}", state.holder),
                      top_left + cv::Point(4, 34), kVideoFont, 0.45, kVideoText, 1, cv::LINE_AA);
        }
        if (!state.queue.empty()) {
          cv::putText(frame, fmt::format("queue: car {}", fmt::join(state.queue, ", car ")),
                      top_left + cv::Point(4, 52), kVideoFont, 0.45, kQueueText, 1, cv::LINE_AA);
        }
      }
      for (const ObstacleConfig& o : run.scenario.obstacles) {
        if (o.PresentAt(t)) DrawObstacle(frame, at, o);
      }
      // trails, then collisions so far, then the cars on top
      for (const CarTrack& car : cars) {
        if (car.samples.empty()) continue;
        std::vector<cv::Point> trail;
        for (std::size_t j = car.now + 1; j-- > 0;) {
          if (ToSeconds(t - car.samples[j]->t) > options.trail_s) break;
          trail.push_back(at.ToPixel(car.samples[j]->x_m, car.samples[j]->y_m));
        }
        cv::polylines(frame, trail, false, car.colour, 2, cv::LINE_AA);
      }
      while (next_collision < collisions.size() && collisions[next_collision].first <= t) {
        for (const CarTrack& car : cars) {
          if (car.id != collisions[next_collision].second || car.samples.empty()) continue;
          const cv::Point p = at.ToPixel(car.samples[car.now]->x_m, car.samples[car.now]->y_m);
          if (collision_points.empty() || cv::norm(collision_points.back() - p) > 6.0) {
            collision_points.push_back(p);
          }
        }
        ++next_collision;
      }
      for (const cv::Point& p : collision_points) DrawCollisionMarker(frame, p);
      std::vector<world::Pose2> poses;
      for (const CarTrack& car : cars) {
        if (car.samples.empty()) {
          poses.emplace_back();
          continue;
        }
        DrawCar(frame, at, car, *car.samples[car.now]);
        poses.push_back(
            {car.samples[car.now]->x_m, car.samples[car.now]->y_m, car.samples[car.now]->yaw_rad});
      }
      cv::putText(frame, fmt::format("t = {:.2f} s", ToSeconds(t)),
                  {base.legend_x, legend_end + 20}, kVideoFont, 0.8, kVideoText, 2, cv::LINE_AA);
      cv::putText(frame, fmt::format("{:g}x real time", options.speed),
                  {base.legend_x, legend_end + 46}, kVideoFont, 0.5, kVideoText, 1, cv::LINE_AA);
      if (viewer) {
        const CameraViewImages views =
            viewer->Render(SnapshotWithPoses(run.scenario, poses, t), streams);
        int y = 56;
        const int x = base.image.cols + 10;
        cv::putText(frame, fmt::format("car {}: colour camera, lane detection", viewer->car_id()),
                    {x, y - 8}, kVideoFont, 0.5, kVideoText, 1, cv::LINE_AA);
        for (const cv::Mat* view : {&views.color, &views.depth}) {
          if (view->empty()) continue;
          const int h = view->rows * kCameraWidthPx / view->cols;
          cv::resize(*view, frame(cv::Rect(x, y, kCameraWidthPx, h)), cv::Size(kCameraWidthPx, h),
                     0, 0, cv::INTER_AREA);
          y += h + 10;
          if (view == &views.color) {
            cv::putText(frame, views.lane, {x, y + 8}, kVideoFont, 0.42, kVideoText, 1,
                        cv::LINE_AA);
            y += 36;
            cv::putText(frame, "depth camera", {x, y - 8}, kVideoFont, 0.5, kVideoText, 1,
                        cv::LINE_AA);
          }
        }
      }
      if (scene) {
        const WorldSnapshot snapshot = SnapshotWithPoses(run.scenario, poses, t);
        int y = 20;
        for (const bool chase : {true, false}) {
          if (chase ? !options.chase_car : !options.overview) continue;
          const cv::Mat view = chase ? scene->Chase(snapshot, *options.chase_car, kSceneViewSize)
                                     : scene->Overview(snapshot, kSceneViewSize);
          view.copyTo(frame(cv::Rect(cv::Point(scene_x, y), kSceneViewSize)));
          y += kSceneViewSize.height + 16;
        }
      }
      writer.write(frame);
      if (options.progress) options.progress(k + 1, frames);
    }
    writer.release();
    fs::rename(partial, out);
  } catch (...) {
    writer.release();
    std::error_code ignored;
    fs::remove(partial, ignored);
    throw;
  }
}

}  // namespace autonomsim::sim
