#include "sim/scenario/scenario.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <set>
#include <sstream>
#include <tuple>
#include <utility>
#include <variant>

#include "sim/core/hash.h"
#include "sim/core/track_loader.h"
#include "world/validation.h"

namespace autonomsim::sim {
namespace {

// A ConfigError located at `keys` of the scenario file (line and column when the key is there).
ConfigError ErrorAt(const YAML::Node& root, const ConfigSource& source,
                    const LoadedScenario::KeyPath& keys, const std::string& message) {
  YAML::Node node;
  node.reset(root);
  std::string path;
  for (const auto& key : keys) {
    YAML::Node child;
    if (std::holds_alternative<std::string>(key)) {
      path = detail::JoinPath(path, std::get<std::string>(key));
      if (node.IsMap() && node[std::get<std::string>(key)])
        child = node[std::get<std::string>(key)];
    } else {
      path = detail::JoinIndex(path, std::get<std::size_t>(key));
      if (node.IsSequence() && std::get<std::size_t>(key) < node.size()) {
        child = node[std::get<std::size_t>(key)];
      }
    }
    if (!child.IsDefined() || child.IsNull()) break;
    node.reset(child);
  }
  return ConfigError(detail::Where(node, path, source) + message);
}

[[noreturn]] void FailAt(const YAML::Node& root, const ConfigSource& source,
                         const LoadedScenario::KeyPath& keys, const std::string& message) {
  throw ErrorAt(root, source, keys, message);
}

}  // namespace

void CarConfig::Validate() const {
  Require(id >= 0 && id <= 9,
          "id must be a single digit 0..9 (the /vtl/ protocol sends one character), got " +
              std::to_string(id));
  Require(route.has_value() != lanes.has_value(), "give exactly one of route or lanes");
  Require(!(start.has_value() && start_s_m.has_value()), "give at most one of start or start_s_m");
  Require(!laps || *laps >= 1, "laps must be >= 1, got " + std::to_string(laps.value_or(0)));
  Require(driver == "oracle" || driver == "stack",
          "driver must be 'oracle' (ground-truth lane following) or 'stack' (the AutonomROS "
          "stack on the car's board), got '" +
              driver + "'");
  Require(driver != "stack" || perception.enabled,
          "driver 'stack' drives on the perception nodes' lanes and obstacles: set "
          "perception.enabled: true");
}

void ObstacleConfig::Validate() const {
  Require(!name.empty(), "obstacle needs a name");
  Require(length_m > 0 && width_m > 0 && height_m > 0,
          "length_m, width_m and height_m must be > 0, got " + Num(length_m) + ", " + Num(width_m) +
              ", " + Num(height_m));
  // instants within a run's longest duration (24 h) and then some; beyond, they never come
  constexpr double kLatest_s = 1e6;
  Require(appear_s >= 0.0 && appear_s <= kLatest_s,
          "appear_s must be in [0, " + Num(kLatest_s) + "] s, got " + Num(appear_s));
  Require(!disappear_s || *disappear_s > appear_s,
          "disappear_s must be after appear_s, got " + Num(disappear_s.value_or(0.0)));
  Require(!disappear_s || *disappear_s <= kLatest_s,
          "disappear_s must be <= " + Num(kLatest_s) + " s, got " + Num(disappear_s.value_or(0.0)));
}

void V2IConfig::Validate() const {
  Require(link == "embedded" || link == "mqtt" || link == "realtime",
          "link must be 'embedded', 'mqtt' or 'realtime', got '" + link + "'");
  Require(link != "realtime" || !mqtt.broker.empty(),
          "link 'realtime' needs mqtt.broker, the HOST:PORT of the broker its traffic-light "
          "server listens on (autonomsim run --realtime --broker HOST:PORT): a real-time run "
          "starts no broker or server of its own");
  Require(latency >= kZeroTime, "latency_s must be >= 0");
  Require(jitter >= kZeroTime, "jitter_s must be >= 0");
  Require(loss >= 0.0 && loss < 1.0, "loss must be in [0, 1), got " + Num(loss));
}

void OutputConfig::Validate() const {
  Require(trajectory_period > kZeroTime, "trajectory_period_s must be > 0");
}

std::string ExpectClause::kind() const {
  if (no_collision) return "no_collision";
  if (intersection_mutex) return "intersection_mutex";
  if (no_entry_without_grant) return "no_entry_without_grant";
  if (completes) return "completes";
  if (max_lateral_error) return "max_lateral_error";
  if (node_rate) return "node_rate";
  if (cpu_demand) return "cpu_demand";
  if (no_gridlock) return "no_gridlock";
  if (max_wait) return "max_wait";
  if (min_throughput) return "min_throughput";
  if (recovers_within) return "recovers_within";
  return "min_obstacle_gap";
}

const ExpectArgs& ExpectClause::args() const {
  for (const auto* args : {&no_collision, &intersection_mutex, &no_entry_without_grant, &completes,
                           &max_lateral_error, &min_obstacle_gap, &node_rate, &cpu_demand,
                           &no_gridlock, &max_wait, &min_throughput, &recovers_within}) {
    if (args->has_value()) return **args;
  }
  throw std::logic_error("ExpectClause::args on an empty clause");
}

void ExpectClause::Validate() const {
  const int count = no_collision.has_value() + intersection_mutex.has_value() +
                    no_entry_without_grant.has_value() + completes.has_value() +
                    max_lateral_error.has_value() + min_obstacle_gap.has_value() +
                    node_rate.has_value() + cpu_demand.has_value() + no_gridlock.has_value() +
                    max_wait.has_value() + min_throughput.has_value() + recovers_within.has_value();
  Require(count == 1,
          "an expect entry names exactly one expectation, e.g. '- no_collision: {}'; "
          "got " +
              std::to_string(count));
  const std::string k = kind();
  const ExpectArgs& a = args();
  auto forbid = [&](bool present, const char* key) {
    Require(!present, "'" + k + "' takes no key '" + key + "'");
  };
  forbid((k == "intersection_mutex" || k == "min_throughput") && a.car.has_value(), "car");
  forbid(k != "no_gridlock" && k != "max_wait" && k != "recovers_within" && a.max_s.has_value(),
         "max_s");
  forbid(k != "max_wait" && k != "min_throughput" && a.intersection.has_value(), "intersection");
  forbid(k != "min_throughput" && a.per_minute.has_value(), "per_minute");
  forbid(k != "completes" && a.laps.has_value(), "laps");
  forbid(k != "completes" && a.within_s.has_value(), "within_s");
  forbid(k != "max_lateral_error" && a.max_m.has_value(), "max_m");
  forbid(k != "min_obstacle_gap" && a.min_m.has_value(), "min_m");
  forbid(k != "node_rate" && a.node.has_value(), "node");
  forbid(k != "node_rate" && a.min_hz.has_value(), "min_hz");
  forbid(k != "node_rate" && a.max_hz.has_value(), "max_hz");
  forbid(k != "cpu_demand" && a.min_percent.has_value(), "min_percent");
  forbid(k != "cpu_demand" && a.max_percent.has_value(), "max_percent");
  if (k == "node_rate") {
    Require(a.car.has_value() && a.node.has_value(), "node_rate needs car and node");
    Require(a.min_hz.has_value() || a.max_hz.has_value(), "node_rate needs min_hz or max_hz");
  }
  if (k == "cpu_demand") {
    Require(a.car.has_value(), "cpu_demand needs car");
    Require(a.min_percent.has_value() || a.max_percent.has_value(),
            "cpu_demand needs min_percent or max_percent");
  }
  if (k == "completes") {
    Require(a.laps.has_value() && *a.laps >= 1, "completes needs laps >= 1");
    Require(!a.within_s || *a.within_s > 0.0, "within_s must be > 0");
  }
  if (k == "max_lateral_error") {
    Require(a.max_m.has_value() && *a.max_m > 0.0, "max_lateral_error needs max_m > 0");
  }
  if (k == "min_obstacle_gap") {
    Require(a.min_m.has_value() && *a.min_m >= 0.0, "min_obstacle_gap needs min_m >= 0");
  }
  if (k == "no_gridlock") Require(!a.max_s || *a.max_s > 0.0, "max_s must be > 0");
  if (k == "max_wait") Require(a.max_s.has_value() && *a.max_s > 0.0, "max_wait needs max_s > 0");
  if (k == "recovers_within") {
    Require(a.max_s.has_value() && *a.max_s > 0.0, "recovers_within needs max_s > 0");
  }
  if (k == "min_throughput") {
    Require(a.per_minute.has_value() && *a.per_minute >= 0.0,
            "min_throughput needs per_minute >= 0");
  }
  Require(!a.intersection || (*a.intersection >= 0 && *a.intersection <= 9),
          "intersection must be an id 0..9");
}

namespace {
// The clause's entries as Describe lists them (read only: the visitors do not write).
template <class Visit>
void ForEachFaultKind(const FaultClause& clause, Visit visit) {
  auto each = [&](const char* key, const std::optional<FaultArgs>& args) { visit(key, args); };
  const_cast<FaultClause&>(clause).Describe(each);
}
}  // namespace

std::string FaultClause::kind() const {
  std::string found;
  ForEachFaultKind(*this, [&](const char* key, const std::optional<FaultArgs>& args) {
    if (found.empty() && args.has_value()) found = key;
  });
  if (found.empty()) throw std::logic_error("FaultClause::kind on an empty clause");
  return found;
}

const FaultArgs& FaultClause::args() const {
  const FaultArgs* found = nullptr;
  ForEachFaultKind(*this, [&](const char*, const std::optional<FaultArgs>& args) {
    if (found == nullptr && args.has_value()) found = &*args;
  });
  if (found == nullptr) throw std::logic_error("FaultClause::args on an empty clause");
  return *found;
}

void FaultClause::Validate() const {
  int count = 0;
  ForEachFaultKind(
      *this, [&](const char*, const std::optional<FaultArgs>& args) { count += args.has_value(); });
  Require(count == 1,
          "a faults entry names exactly one fault, e.g. '- car_stall: {car: 1, at_s: 20}'; got " +
              std::to_string(count));
  const std::string k = kind();
  const FaultArgs& a = args();
  auto forbid = [&](bool present, const char* key) {
    Require(!present, "'" + k + "' takes no key '" + key + "'");
  };
  const bool on_link = k == "v2i_partition" || k == "v2i_loss_burst";
  const bool fleet_wide = k == "server_restart" || k == "broker_outage";
  const bool on_node = k == "node_crash" || k == "node_hang";
  const bool on_camera = k == "camera_freeze" || k == "camera_blackout";
  forbid(fleet_wide && a.car.has_value(), "car");
  forbid(k == "node_crash" && a.for_s.has_value(),
         "for_s' (a crashed node stays down; node_hang has for_s");
  forbid(k == "localization_jump" && a.for_s.has_value(), "for_s' (a jump is instantaneous");
  forbid(k != "v2i_partition" && a.direction.has_value(), "direction");
  forbid(k != "v2i_loss_burst" && a.loss.has_value(), "loss");
  forbid(!on_node && a.node.has_value(), "node");
  forbid(!on_camera && a.camera.has_value(), "camera");
  forbid(k != "imu_bias_step" && a.gyro_bias_rad_per_s.has_value(), "gyro_bias_rad_per_s");
  forbid(k != "localization_jump" && a.dx_m.has_value(), "dx_m");
  forbid(k != "localization_jump" && a.dy_m.has_value(), "dy_m");
  forbid(k != "localization_jump" && a.dyaw_deg.has_value(), "dyaw_deg");
  Require(std::isfinite(a.at_s) && a.at_s >= 0.0, "at_s must be >= 0, got " + Num(a.at_s));
  Require(!a.for_s || (std::isfinite(*a.for_s) && *a.for_s > 0.0),
          "for_s must be > 0 (leave it out for a fault that lasts to the end of the run)");
  if (!on_link && !fleet_wide) Require(a.car.has_value(), k + " needs car");
  if (on_node) Require(a.node.has_value() && !a.node->empty(), k + " needs node");
  if (a.direction) {
    Require(*a.direction == "up" || *a.direction == "down" || *a.direction == "both",
            "direction must be 'up' (car to server), 'down' or 'both', got '" + *a.direction + "'");
  }
  if (k == "v2i_loss_burst") {
    Require(a.loss.has_value() && *a.loss > 0.0 && *a.loss <= 1.0,
            "v2i_loss_burst needs loss in (0, 1]");
  }
  if (a.camera) {
    Require(*a.camera == "color" || *a.camera == "depth",
            "camera must be 'color' or 'depth', got '" + *a.camera + "'");
  }
  if (k == "imu_bias_step") {
    Require(a.gyro_bias_rad_per_s.has_value() && std::isfinite(*a.gyro_bias_rad_per_s) &&
                *a.gyro_bias_rad_per_s != 0.0,
            "imu_bias_step needs gyro_bias_rad_per_s, finite and not 0");
  }
  if (k == "localization_jump") {
    Require(a.dx_m || a.dy_m || a.dyaw_deg,
            "localization_jump needs at least one of dx_m, dy_m, dyaw_deg");
    for (const auto& v : {a.dx_m, a.dy_m, a.dyaw_deg}) {
      Require(!v || std::isfinite(*v), "the jump must be finite");
    }
  }
}

void Scenario::Validate() const {
  Require(duration > kZeroTime && duration <= std::chrono::hours(24),
          "duration_s must be in (0, 86400] s, got " + Num(ToSeconds(duration)));
  Require(!cars.empty(), "cars must not be empty");
  std::set<int> ids;
  for (const CarConfig& car : cars) {
    Require(ids.insert(car.id).second, "duplicate car id " + std::to_string(car.id));
  }
  ParseCameraBackend(camera_backend);
  std::set<std::string> names;
  for (const ObstacleConfig& obstacle : obstacles) {
    Require(names.insert(obstacle.name).second, "duplicate obstacle name '" + obstacle.name + "'");
  }
}

namespace {

// Where a scenario's errors are reported: the file's YAML and its source (file, overrides).
struct ScenarioSite {
  const YAML::Node& root;
  const ConfigSource& source;
};

// A file a scenario names (its track, a board's profile), relative to the scenario's folder; if it
// is not there, relative to the shipped scenarios/ folder, so that a scenario copied anywhere still
// finds tracks/lab.yaml and platforms/zcu104.yaml. An absolute path is taken as it is.
std::filesystem::path ResolveScenarioFile(const std::filesystem::path& folder,
                                          const std::string& name) {
  namespace fs = std::filesystem;
  const fs::path given(name);
  const fs::path local = folder / given;
  if (given.is_absolute() || fs::exists(local)) return local;
  const fs::path shipped = fs::path(AUTONOMSIM_SCENARIOS_DIR) / given;
  if (!name.empty() && fs::exists(shipped)) return shipped;
  throw ConfigError(local.string() + ": no such file (nor " + shipped.string() +
                    " among the shipped ones)");
}

// The track the scenario names (relative to its folder). An error of the track file's own (a
// missing file, a bad key in it) is reported at the scenario's `track:` too: the track file's
// name alone does not say which scenario line chose it.
world::Track LoadScenarioTrack(const Scenario& scenario, const std::filesystem::path& folder,
                               const ScenarioSite& site) {
  try {
    return LoadTrack(ResolveScenarioFile(folder, scenario.track));
  } catch (const ConfigError& e) {
    FailAt(site.root, site.source, {"track"}, e.what());
  }
}

// Where car `i` starts on its route: its named start pose (which must lie on the route, heading
// along it) or its distance along the route.
std::pair<double, world::Pose2> ResolveStart(const CarConfig& car, std::size_t i,
                                             const world::Track& track, const world::Route& route,
                                             const ScenarioSite& site) {
  const world::Polyline& path = route.path;
  if (car.start) {
    const std::optional<world::Pose2> named = track.StartPose(*car.start);
    if (!named) {
      FailAt(site.root, site.source, {"cars", i, "start"},
             "unknown start pose '" + *car.start + "'");
    }
    const world::Polyline::Projection on = path.Project(named->position());
    const double heading_error = world::WrapAngle(path.HeadingAt(on.s_m) - named->yaw_rad);
    if (on.distance_m > 0.1 || std::abs(heading_error) > std::numbers::pi / 6) {
      FailAt(site.root, site.source, {"cars", i, "start"},
             "start pose '" + *car.start + "' is not on route (" + Num(on.distance_m) +
                 " m away, heading off by " + Num(heading_error * 180 / std::numbers::pi) +
                 " deg)");
    }
    return {on.s_m, *named};
  }
  const double s = car.start_s_m.value_or(0.0);
  if (s < 0.0 || s >= path.length_m()) {
    FailAt(site.root, site.source, {"cars", i, "start_s_m"},
           "start_s_m must be in [0, " + Num(path.length_m()) + ") m (the route's length), got " +
               Num(s));
  }
  const world::Vec2 p = path.PointAt(s);
  return {s, world::Pose2{p.x(), p.y(), path.HeadingAt(s)}};
}

// Car `i`'s route, start and board profile, checked against the track and the server's lease.
struct ResolvedCar {
  world::Route route;
  double start_s_m{0.0};
  world::Pose2 start_pose;
  std::optional<PlatformProfile> profile;
};
ResolvedCar ResolveCar(const Scenario& scenario, std::size_t i, const world::Track& track,
                       const std::filesystem::path& folder, const ScenarioSite& site) {
  const CarConfig& car = scenario.cars[i];
  ResolvedCar resolved;
  try {
    resolved.route = car.route ? track.RouteByName(*car.route)
                               : world::MakeRoute(track.road_graph(),
                                                  "car" + std::to_string(car.id), *car.lanes);
  } catch (const std::invalid_argument& e) {
    FailAt(site.root, site.source, {"cars", i, car.route ? "route" : "lanes"}, e.what());
  }
  std::tie(resolved.start_s_m, resolved.start_pose) =
      ResolveStart(car, i, track, resolved.route, site);
  try {
    stack::ValidateAgainstLease(car.intersection_client, scenario.traffic_lights.lease);
  } catch (const std::invalid_argument& e) {
    FailAt(site.root, site.source, {"cars", i, "intersection_client"}, e.what());
  }
  if (car.laps && !resolved.route.cyclic) {
    FailAt(site.root, site.source, {"cars", i, "laps"}, "laps needs a route that is a loop");
  }
  if (car.has_board()) {
    try {
      resolved.profile = LoadPlatformProfile(ResolveScenarioFile(folder, car.platform.profile));
    } catch (const ConfigError& e) {
      FailAt(site.root, site.source, {"cars", i, "platform", "profile"}, e.what());
    }
  }
  return resolved;
}

// A car without a board (perception off) runs no nodes: platform settings naming nodes or topics
// would be ignored without a word, typos included. (A board's names are checked when it is built.)
void CheckPlatformSettingsApply(const Scenario& scenario, const ScenarioSite& site) {
  for (std::size_t i = 0; i < scenario.cars.size(); ++i) {
    const CarConfig& car = scenario.cars[i];
    if (car.has_board()) continue;
    const PlatformConfig& p = car.platform;
    for (const auto& [field, name] :
         {std::pair{"mapping", p.mapping.empty() ? "" : p.mapping.begin()->first},
          std::pair{"transport", p.transport.empty() ? "" : p.transport.begin()->first},
          std::pair{"cost_scale", p.cost_scale.empty() ? "" : p.cost_scale.begin()->first},
          std::pair{"cost_override",
                    p.cost_override.empty() ? "" : p.cost_override.begin()->first}}) {
      if (name.empty()) continue;
      FailAt(site.root, site.source, {"cars", i, "platform", field, name},
             "car " + std::to_string(car.id) +
                 " has no board (perception.enabled is false), so it runs no nodes for platform "
                 "settings to apply to; remove them or enable perception");
    }
  }
}

// Every obstacle on the track's floor and smaller than it, before Box2D sees it (an obstacle at
// 1e39 m aborted in Box2D's IsValid assertion; one 9 m off a 5 m floor was accepted).
void CheckObstaclesOnFloor(const Scenario& scenario, double floor_size_m,
                           const ScenarioSite& site) {
  const double half_floor_m = 0.5 * floor_size_m;
  for (std::size_t i = 0; i < scenario.obstacles.size(); ++i) {
    const ObstacleConfig& o = scenario.obstacles[i];
    for (const auto& [key, value] : {std::pair{"x_m", o.x_m}, std::pair{"y_m", o.y_m}}) {
      if (std::abs(value) > half_floor_m) {
        FailAt(site.root, site.source, {"obstacles", i, key},
               std::string(key) + " " + Num(value) + " m is off the track's floor (|" + key +
                   "| <= " + Num(half_floor_m) + " m)");
      }
    }
    for (const auto& [key, value] :
         {std::pair{"length_m", o.length_m}, std::pair{"width_m", o.width_m},
          std::pair{"height_m", o.height_m}}) {
      if (value > 2.0 * half_floor_m) {
        FailAt(site.root, site.source, {"obstacles", i, key},
               std::string(key) + " " + Num(value) + " m is larger than the track's floor (" +
                   Num(2.0 * half_floor_m) + " m)");
      }
    }
  }
}

}  // namespace

LoadedScenario LoadScenario(const std::filesystem::path& file,
                            const std::vector<std::string>& overrides,
                            std::optional<std::uint64_t> seed) {
  YAML::Node root = LoadYamlFile(file);
  ConfigSource source{file.string(), {}};
  // before any --set: a file that is not a mapping is the file's error, not the override's
  if (!root.IsMap())
    detail::Fail(root, "", source, "expected a mapping, got " + detail::Describe(root));
  BreakAliases(root);
  for (const std::string& assignment : overrides) ApplyOverride(root, assignment, &source);
  if (seed) ApplyOverride(root, "seed=" + std::to_string(*seed), &source);
  ApplyStackPresets(root, source);
  const ScenarioSite site{root, source};

  Scenario read = ReadConfig<Scenario>(root, source);
  if (read.name.empty()) read.name = file.stem().string();
  world::Track track = LoadScenarioTrack(read, file.parent_path(), site);
  LoadedScenario loaded{.file = file, .scenario = std::move(read), .track = std::move(track)};
  const Scenario& scenario = loaded.scenario;

  std::set<int> car_ids;
  for (std::size_t i = 0; i < scenario.cars.size(); ++i) {
    car_ids.insert(scenario.cars[i].id);
    ResolvedCar car = ResolveCar(scenario, i, loaded.track, file.parent_path(), site);
    loaded.routes.push_back(std::move(car.route));
    loaded.start_s_m.push_back(car.start_s_m);
    loaded.start_poses.push_back(car.start_pose);
    loaded.profiles.push_back(std::move(car.profile));
  }
  CheckObstaclesOnFloor(scenario, loaded.track.spec().size_m, site);
  CheckPlatformSettingsApply(scenario, site);
  for (std::size_t i = 0; i < scenario.expect.size(); ++i) {
    const ExpectArgs& args = scenario.expect[i].args();
    if (args.car && car_ids.count(*args.car) == 0) {
      FailAt(root, source, {"expect", i}, "no car with id " + std::to_string(*args.car));
    }
    const auto& crossings = loaded.track.spec().intersections;
    if (args.intersection &&
        std::none_of(crossings.begin(), crossings.end(), [&](const world::IntersectionSpec& x) {
          return x.id == *args.intersection;
        })) {
      FailAt(root, source, {"expect", i, scenario.expect[i].kind(), "intersection"},
             "the track has no intersection " + std::to_string(*args.intersection));
    }
    // a deadline past the run's end could never be judged (it would fail, or pass, on less time)
    if (args.within_s && *args.within_s > ToSeconds(scenario.duration)) {
      FailAt(root, source, {"expect", i, scenario.expect[i].kind(), "within_s"},
             "within_s " + Num(*args.within_s) + " s is past duration_s " +
                 Num(ToSeconds(scenario.duration)) +
                 " s: the run ends before it can be judged; lower within_s, raise duration_s, "
                 "or drop the expectation (e.g. --set 'expect=[]')");
    }
  }

  for (std::size_t i = 0; i < scenario.faults.size(); ++i) {
    const std::string kind = scenario.faults[i].kind();
    const FaultArgs& args = scenario.faults[i].args();
    if (args.car && car_ids.count(*args.car) == 0) {
      FailAt(root, source, {"faults", i, kind, "car"},
             "no car with id " + std::to_string(*args.car));
    }
    if (args.at_s >= ToSeconds(scenario.duration)) {
      FailAt(root, source, {"faults", i, kind, "at_s"},
             "at_s " + Num(args.at_s) + " s is not before the run's end (duration_s " +
                 Num(ToSeconds(scenario.duration)) + " s): the fault would never strike");
    }
    if (scenario.v2i.link == "realtime" &&
        (kind.starts_with("v2i_") || kind == "server_restart" || kind == "broker_outage")) {
      FailAt(root, source, {"faults", i, kind},
             kind +
                 " acts on the modeled V2I link and the server in the run; with v2i.link: "
                 "realtime (run --realtime) both are real and outside the run");
    }
    const CarConfig* car = args.car ? scenario.FindCar(*args.car) : nullptr;
    const bool needs_stack = kind == "localization_jump" || kind == "imu_bias_step";
    const bool needs_board = args.node || kind.starts_with("camera_");
    if (car && needs_stack && !car->drives_by_stack()) {
      FailAt(root, source, {"faults", i, kind, "car"},
             "car " + std::to_string(*args.car) +
                 " does not drive by its stack (driver: oracle drives on ground truth), so "
                 "nothing reads its localization or IMU");
    }
    if (car && needs_board && !car->has_board()) {
      FailAt(root, source, {"faults", i, kind, "car"},
             "car " + std::to_string(*args.car) + " runs no nodes (perception.enabled is false)");
    }
  }

  loaded.resolved = {{"scenario", ToJson(scenario)}, {"track", ToJson(loaded.track.spec())}};
  for (std::size_t i = 0; i < loaded.profiles.size(); ++i) {  // a board's profile is in the run
    if (loaded.profiles[i]) {
      loaded.resolved["platforms"]["car" + std::to_string(scenario.cars[i].id)] =
          ToJson(*loaded.profiles[i]);
    }
  }
  loaded.sha256 = Sha256Hex(loaded.resolved.dump());
  loaded.error_at = [root, source](const LoadedScenario::KeyPath& keys,
                                   const std::string& message) {
    return ErrorAt(root, source, keys, message);
  };
  return loaded;
}

}  // namespace autonomsim::sim
