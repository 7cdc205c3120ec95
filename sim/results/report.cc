#include "sim/results/report.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <numbers>
#include <set>
#include <string_view>

#include "sim/car/stack_config.h"
#include "sim/core/files.h"
#include "sim/core/random.h"
#include "sim/results/camera_views.h"
#include "sim/results/image_encoding.h"
#include "sim/results/report/report_assets.h"
#include "sim/results/scene_views.h"
#include "sim/results/track_figure.h"
#include "world/floor_raster.h"

namespace autonomsim::sim {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// Values are rounded to what the page can show: positions to 0.1 mm, angles to 0.1 mrad.
double Round(double value, int decimals) {
  if (!std::isfinite(value)) return value;
  const double scale = std::pow(10.0, decimals);
  return std::round(value * scale) / scale;
}

std::string Base64(const std::vector<std::uint8_t>& bytes) {
  static constexpr std::string_view kAlphabet =
      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  for (std::size_t i = 0; i < bytes.size(); i += 3) {
    const std::uint32_t n = (std::uint32_t{bytes[i]} << 16) |
                            (i + 1 < bytes.size() ? std::uint32_t{bytes[i + 1]} << 8 : 0) |
                            (i + 2 < bytes.size() ? std::uint32_t{bytes[i + 2]} : 0);
    out += kAlphabet[(n >> 18) & 63];
    out += kAlphabet[(n >> 12) & 63];
    out += i + 1 < bytes.size() ? kAlphabet[(n >> 6) & 63] : '=';
    out += i + 2 < bytes.size() ? kAlphabet[n & 63] : '=';
  }
  return out;
}

// The camera views' JPEG quality: the page's size against the pictures' artefacts.
constexpr int kReportJpegQuality = 88;

std::string DataUrl(const cv::Mat& image, const std::string& format) {
  const std::vector<std::uint8_t> bytes =
      format == "jpeg" ? EncodeJpeg(image, kReportJpegQuality) : EncodePng(image);
  return "data:image/" + format + ";base64," + Base64(bytes);
}

json BoxJson(const world::Box& b) {
  return {{"x_min_m", b.x_min_m},
          {"x_max_m", b.x_max_m},
          {"y_min_m", b.y_min_m},
          {"y_max_m", b.y_max_m}};
}

// The report keeps at most this many trajectory samples (all cars together): the default
// scenario has 8000; a run over ~25 min at 20 Hz and two cars is shown at every `stride`-th sample
// of each car, so that its page stays a few MB.
constexpr std::size_t kMostReportSamples = 60000;

std::size_t TrajectoryStride(const RunRecord& record) {
  return (record.trajectory.size() + kMostReportSamples - 1) / kMostReportSamples;
}

json MetaJson(const FinishedRun& run) {
  const RunSummary& s = run.summary;
  json meta = {
      {"scenario", s.scenario},
      {"scenario_file", s.scenario_file},
      {"run_dir", run.dir.filename().string()},
      {"seed", s.seed},
      {"sim_seconds", s.sim_seconds},
      {"wall_seconds", s.wall_seconds},
      {"passed", s.passed},
      {"result_sha256", s.result_sha256},
      {"scenario_sha256", s.scenario_sha256},
      {"kernel_events", s.kernel_events},
      {"autonomsim", s.versions.autonomsim},
      {"preset", run.scenario.stack.preset ? json(ToName(*run.scenario.stack.preset)) : json()}};
  if (s.real_time_factor) meta["real_time_factor"] = *s.real_time_factor;
  meta["trajectory_stride"] = TrajectoryStride(run.record);
  return meta;
}

json FloorJson(const world::Track& track) {
  const world::FloorRaster raster = world::RasterizeFloor(track);
  const cv::Mat image(raster.height_px, raster.width_px, CV_8UC3,
                      const_cast<std::uint8_t*>(raster.bgr.data()));
  return {{"image", DataUrl(image, "png")}, {"x0_m", raster.origin_m.x()},
          {"y0_m", raster.origin_m.y()},    {"m_per_px", raster.m_per_px},
          {"width_px", raster.width_px},    {"height_px", raster.height_px}};
}

json TrackJson(const world::Track& track) {
  json intersections = json::array();
  for (const world::IntersectionSpec& i : track.spec().intersections) {
    json zones = json::array();
    for (const world::Box& z : i.stop_zones) zones.push_back(BoxJson(z));
    intersections.push_back(
        {{"id", i.id}, {"name", i.name}, {"area", BoxJson(i.area)}, {"stop_zones", zones}});
  }
  return {{"name", track.spec().name},
          {"size_m", track.spec().size_m},
          {"intersections", intersections}};
}

json ObstaclesJson(const Scenario& scenario) {
  json out = json::array();
  for (const ObstacleConfig& o : scenario.obstacles) {
    out.push_back({{"name", o.name},
                   {"x_m", o.x_m},
                   {"y_m", o.y_m},
                   {"yaw_rad", o.yaw_deg * std::numbers::pi / 180.0},
                   {"length_m", o.length_m},
                   {"width_m", o.width_m},
                   {"appear_s", o.appear_s},
                   {"disappear_s", o.disappear_s ? json(*o.disappear_s) : json()}});
  }
  return out;
}

json CarsJson(const FinishedRun& run) {
  json out = json::array();
  for (const CarConfig& car : run.scenario.cars) {
    json c = {{"id", car.id},
              {"colour", ColourHex(CarColourBgr(run.scenario, car.id))},
              {"length_m", car.vehicle.length_m},
              {"width_m", car.vehicle.width_m},
              {"route", car.route ? json(*car.route) : json()},
              {"driver", ToName(car.driver)},
              {"has_board", car.has_board()},
              {"preset", car.stack.preset ? json(ToName(*car.stack.preset)) : json()}};
    for (const CarMetrics& m : run.summary.cars) {
      if (m.id != car.id) continue;
      c["laps"] = m.laps;
      c["lap_times_s"] = m.lap_times_s;
      c["collisions"] = m.collisions;
      c["max_lateral_error_m"] = m.max_lateral_error_m;
      c["distance_m"] = m.distance_m;
      c["waits"] = m.waits;
      c["max_wait_s"] = m.max_wait_s;
    }
    out.push_back(std::move(c));
  }
  return out;
}

// Per car, columns of its samples: {"<id>": {t, x, y, yaw, speed, steering, throttle, curvature,
// lateral_error}}, every `stride`-th sample of each car (its last one always).
json TrajectoryJson(const RunRecord& record, std::size_t stride) {
  std::map<int, std::array<json, 9>> columns;
  std::map<int, std::size_t> seen;  // samples of each car so far
  std::map<int, std::size_t> total;
  for (const TrajectorySample& s : record.trajectory) ++total[s.car];
  for (const TrajectorySample& s : record.trajectory) {
    const std::size_t k = seen[s.car]++;
    if (k % stride != 0 && k + 1 != total[s.car]) continue;
    auto& c = columns[s.car];
    if (c[0].is_null()) {
      for (json& column : c) column = json::array();
    }
    c[0].push_back(Round(ToSeconds(s.t), 3));
    c[1].push_back(Round(s.x_m, 4));
    c[2].push_back(Round(s.y_m, 4));
    c[3].push_back(Round(s.yaw_rad, 4));
    c[4].push_back(Round(s.speed_mps, 3));
    c[5].push_back(Round(s.steering_rad, 4));
    c[6].push_back(Round(s.throttle, 3));
    c[7].push_back(Round(s.curvature_cmd_per_m, 3));
    c[8].push_back(Round(s.lateral_error_m, 4));
  }
  static constexpr std::array<const char*, 9> kNames{
      "t", "x", "y", "yaw", "speed", "steering", "throttle", "curvature", "lateral_error"};
  json out = json::object();
  for (auto& [car, c] : columns) {
    json car_json = json::object();
    for (std::size_t i = 0; i < kNames.size(); ++i) car_json[kNames[i]] = std::move(c[i]);
    out[std::to_string(car)] = std::move(car_json);
  }
  return out;
}

json EventsJson(const RunRecord& record) {
  json out = json::array();
  for (const Event& e : record.events) {
    json j = EventJson(e);  // as events.jsonl has it, but its time as "t", to 0.1 ms
    j.erase("t_s");
    j["t"] = Round(ToSeconds(e.t), 4);
    out.push_back(std::move(j));
  }
  return out;
}

json ExpectationsJson(const RunSummary& summary) {
  json out = json::array();
  for (const ExpectationResult& e : summary.expectations) {
    json j = {{"name", e.name}, {"passed", e.passed}, {"detail", e.detail}};
    if (e.at_s) j["at_s"] = *e.at_s;
    if (e.car) j["car"] = *e.car;
    out.push_back(std::move(j));
  }
  return out;
}

// Per board: its CPU load and the end-to-end latency of its command topic over time (summary.json
// platform.<board>: cpu_load_percent, and topics[/carcontrol/command].latency_per_bin_ms).
json BoardsJson(const RunSummary& summary) {
  json out = json::object();
  if (!summary.platform) return out;
  for (const auto& [board, report] : *summary.platform) {
    json b = {{"cores", report.value("cores", 0)},
              {"load_bin_s", report.value("load_bin_s", 1.0)},
              {"cpu_load_percent", report.value("cpu_load_percent", json::array())}};
    for (const json& topic : report.value("topics", json::array())) {
      if (topic.value("name", "") != kCarCommandTopic || !topic.contains("latency_per_bin_ms")) {
        continue;
      }
      b["e2e_topic"] = kCarCommandTopic;
      b["e2e_mean_ms"] = topic["latency_per_bin_ms"]["mean"];
      b["e2e_max_ms"] = topic["latency_per_bin_ms"]["max"];
    }
    out[board] = std::move(b);
  }
  return out;
}

// The 3D views (scene_views.h), made on first use; or, where no OpenGL ES context can be made,
// the reason, which the page shows in their place.
class LazySceneViews {
 public:
  explicit LazySceneViews(const FinishedRun& run) : run_(run) {}
  SceneViews* get() {
    if (!tried_) {
      tried_ = true;
      try {
        views_.emplace(run_.track, run_.scenario);
      } catch (const vehicle::GlUnavailable& e) {
        unavailable_ = e.what();
      }
    }
    return views_ ? &*views_ : nullptr;
  }
  const std::string& unavailable() const { return unavailable_; }

 private:
  const FinishedRun& run_;
  bool tried_{false};
  std::optional<SceneViews> views_;
  std::string unavailable_;
};

const cv::Size kReportViewSize(480, 300);

// The overview at the run's end: {t, overview} or {note} without OpenGL ES.
json SceneJson(const FinishedRun& run, LazySceneViews& views) {
  const Time end = run.record.trajectory.empty() ? kZeroTime : run.record.trajectory.back().t;
  if (SceneViews* v = views.get()) {
    return {{"t", ToSeconds(end)},
            {"overview", DataUrl(v->Overview(SnapshotOf(run, end), kReportViewSize), "jpeg")}};
  }
  return {{"note",
           "no 3D views: no OpenGL ES context could be made here (" + views.unavailable() + ")"}};
}

// The failing instants worth a picture: each failed expectation pinned to a car with a board,
// at the car's last sample at or before the instant; one snapshot per (instant, car), with the
// car's cameras and, where OpenGL ES is available, the chase and overview views then.
json SnapshotsJson(const FinishedRun& run, const ReportOptions& options, LazySceneViews& scene) {
  std::map<std::pair<Time, int>, std::vector<std::string>> wanted;  // (t, car) -> expectations
  std::set<int> with_board;
  for (const CarConfig& car : run.scenario.cars) {
    if (car.has_board()) with_board.insert(car.id);
  }
  for (const ExpectationResult& e : run.summary.expectations) {
    if (e.passed || !e.at_s || !e.car || !with_board.count(*e.car)) continue;
    const Time at = FromSeconds(*e.at_s);
    Time sample{-1};
    for (const TrajectorySample& s : run.record.trajectory) {
      if (s.car == *e.car && s.t <= at) sample = s.t;
    }
    if (sample < kZeroTime) continue;
    wanted[{sample, *e.car}].push_back(e.name);
  }
  json out = json::array();
  std::map<int, std::unique_ptr<CarCameraViewer>> viewers;
  const RngStreams streams(run.scenario.seed);
  for (const auto& [key, reasons] : wanted) {
    if (static_cast<int>(out.size()) >= options.max_snapshots) break;
    const auto& [t, car] = key;
    auto& viewer = viewers[car];
    if (!viewer) viewer = std::make_unique<CarCameraViewer>(run.track, run.scenario, car);
    const WorldSnapshot world = SnapshotOf(run, t);
    const CameraViewImages views = viewer->Render(world, streams);
    json snapshot = {{"t", ToSeconds(t)}, {"car", car}, {"reasons", reasons}, {"lane", views.lane}};
    if (!views.color.empty()) snapshot["color"] = DataUrl(views.color, "jpeg");
    if (!views.depth.empty()) snapshot["depth"] = DataUrl(views.depth, "jpeg");
    if (SceneViews* v = scene.get()) {
      snapshot["chase"] = DataUrl(v->Chase(world, car, kReportViewSize), "jpeg");
      snapshot["overview"] = DataUrl(v->Overview(world, kReportViewSize), "jpeg");
    }
    out.push_back(std::move(snapshot));
  }
  return out;
}

}  // namespace

json ReportData(const FinishedRun& run, const ReportOptions& options) {
  LazySceneViews scene(run);
  json snapshots = SnapshotsJson(run, options, scene);
  return {{"meta", MetaJson(run)},
          {"floor", FloorJson(run.track)},
          {"track", TrackJson(run.track)},
          {"obstacles", ObstaclesJson(run.scenario)},
          {"cars", CarsJson(run)},
          {"trajectory", TrajectoryJson(run.record, TrajectoryStride(run.record))},
          {"events", EventsJson(run.record)},
          {"expectations", ExpectationsJson(run.summary)},
          {"boards", BoardsJson(run.summary)},
          {"snapshots", std::move(snapshots)},
          {"scene", SceneJson(run, scene)}};
}

std::string JsonForScript(const json& data) {
  // inside <script>, "</" would end the element early: JSON allows "<\\/" for it
  std::string text = data.dump();
  for (std::size_t at = text.find("</"); at != std::string::npos; at = text.find("</", at + 3)) {
    text.replace(at, 2, "<\\/");
  }
  return text;
}

std::string XmlEscape(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&apos;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

void ReplacePlaceholder(std::string& page, std::string_view placeholder, std::string_view with) {
  const std::size_t at = page.find(placeholder);
  if (at == std::string::npos) {
    throw std::logic_error("page template: no " + std::string(placeholder));
  }
  page.replace(at, placeholder.size(), with);
}

std::string ReportHtml(const json& data) {
  std::string page = report_assets::kHtml;
  const std::string data_text = JsonForScript(data);
  ReplacePlaceholder(page, "@TITLE@", XmlEscape(data["meta"].value("scenario", "run")));
  ReplacePlaceholder(page, "/*@UPLOT_CSS@*/", report_assets::kUplotCss);
  ReplacePlaceholder(page, "/*@REPORT_CSS@*/", report_assets::kCss);
  ReplacePlaceholder(page, "/*@UPLOT_JS@*/", report_assets::kUplotJs);
  ReplacePlaceholder(page, "/*@KINDS_JS@*/", report_assets::kKindsJs);
  ReplacePlaceholder(page, "/*@REPORT_JS@*/", report_assets::kJs);
  ReplacePlaceholder(page, "@DATA@", data_text);
  return page;
}

fs::path WriteReport(const fs::path& run_dir, const fs::path& out, bool force,
                     const ReportOptions& options) {
  const FinishedRun run = ReadFinishedRun(run_dir);
  const fs::path target = CheckOutputFile(
      out.empty() ? (run_dir / kReportFileName).string() : out.string(), force, kReportSignature);
  WriteFileAtomically(target, ReportHtml(ReportData(run, options)));
  return target;
}

}  // namespace autonomsim::sim
