#include "sim/scenario/scenario.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <numbers>
#include <set>
#include <sstream>
#include <tuple>
#include <utility>
#include <variant>

#include "sim/core/hash.h"
#include "sim/core/track_loader.h"
#include "world/floor_raster.h"
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
  Require(driver != Driver::kStack || perception.enabled,
          "driver 'stack' drives on the perception nodes' lanes and obstacles: set "
          "perception.enabled: true");
}

void ObstacleConfig::Validate() const {
  Require(!name.empty(), "obstacle needs a name");
  // one check per key, each message opening with its key: the reader reports it at that key's line
  for (const auto& [key, value] : {std::pair{"length_m", length_m}, std::pair{"width_m", width_m},
                                   std::pair{"height_m", height_m}}) {
    Require(value > 0, std::string(key) + " must be > 0, got " + Num(value));
  }
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
  Require(link != V2ILinkKind::kRealtime || !mqtt.broker.empty(),
          "link 'realtime' needs mqtt.broker, the HOST:PORT of the broker its traffic-light "
          "server listens on (autonomsim run --realtime --broker HOST:PORT): a real-time run "
          "starts no broker or server of its own");
  Require(latency >= kZeroTime, "latency_s must be >= 0");
  Require(jitter >= kZeroTime, "jitter_s must be >= 0");
  Require(loss >= 0.0 && loss < 1.0, "loss must be in [0, 1), got " + Num(loss));
}

void LimitsConfig::Validate() const {
  Require(grid_cells >= 1, "grid_cells must be >= 1");
  Require(trajectory_rows >= 1, "trajectory_rows must be >= 1");
}

void OutputConfig::Validate() const {
  Require(trajectory_period > kZeroTime, "trajectory_period_s must be > 0");
}

void Scenario::Validate() const {
  Require(duration > kZeroTime && duration <= std::chrono::hours(24),
          "duration_s must be in (0, 86400] s, got " + Num(ToSeconds(duration)));
  Require(!cars.empty(), "cars must not be empty");
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
  const fs::path shipped = ShippedScenarioFile(name);
  if (!name.empty() && fs::exists(shipped)) return shipped;
  throw ConfigError(local.string() + ": no such file (nor " + shipped.string() +
                    " among the shipped ones)");
}

}  // namespace

std::filesystem::path ShippedScenarioFile(const std::string& name) {
  return std::filesystem::path(AUTONOMSIM_SCENARIOS_DIR) / name;
}

bool StartPlacement::on() const {
  return distance_m <= 0.1 && std::abs(heading_error_rad) <= std::numbers::pi / 6;
}

StartPlacement PlaceStart(const world::Pose2& pose, const world::Route& route) {
  const world::Polyline::Projection on = route.path.Project(pose.position());
  return {.s_m = on.s_m,
          .distance_m = on.distance_m,
          .heading_error_rad = world::WrapAngle(route.path.HeadingAt(on.s_m) - pose.yaw_rad)};
}

std::filesystem::path ResolveShippedFile(const std::string& given) {
  namespace fs = std::filesystem;
  const fs::path path(given);
  if (given.empty() || path.is_absolute() || fs::exists(path)) return path;
  const fs::path shipped(AUTONOMSIM_SCENARIOS_DIR);
  for (const fs::path& candidate : {shipped.parent_path() / path, shipped / path}) {
    if (fs::exists(candidate)) return candidate;
  }
  return path;
}

namespace {

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

// "unknown start pose 'real_cra' (did you mean 'real_car'?); known start poses: gazebo, real_car":
// what the track offers in place of a name it lacks, `kind` naming what the name is of.
template <class Value>
std::string UnknownName(const std::string& kind, const std::string& name,
                        const std::map<std::string, Value>& known) {
  std::vector<std::string> names;
  std::string list;
  for (const auto& [known_name, value] : known) {
    names.push_back(known_name);
    list += (list.empty() ? "" : ", ") + known_name;
  }
  const std::string closest = detail::ClosestName(name, names);
  return fmt::format("unknown {} '{}'{}; known {}s: {}", kind, name,
                     closest.empty() ? "" : " (did you mean '" + closest + "'?)", kind,
                     list.empty() ? "(none)" : list);
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
             UnknownName("start pose", *car.start, track.spec().start_poses));
    }
    const StartPlacement placed = PlaceStart(*named, route);
    if (!placed.on()) {
      FailAt(site.root, site.source, {"cars", i, "start"},
             "start pose '" + *car.start + "' is not on route (" + Num(placed.distance_m) +
                 " m away, heading off by " +
                 Num(placed.heading_error_rad * 180 / std::numbers::pi) + " deg)");
    }
    return {placed.s_m, *named};
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
// The car's board profile comes from its file (platform.profile, relative to `folder`), or, with
// `resolved_platforms`, from a scenario.resolved.json's "platforms" (LoadResolvedScenario).
LoadedCar ResolveCar(const Scenario& scenario, std::size_t i, const world::Track& track,
                     const std::filesystem::path& folder, const ScenarioSite& site,
                     const nlohmann::json* resolved_platforms = nullptr) {
  const CarConfig& car = scenario.cars[i];
  LoadedCar resolved{.config = &car};
  if (car.route && track.spec().routes.count(*car.route) == 0) {
    FailAt(site.root, site.source, {"cars", i, "route"},
           UnknownName("route", *car.route, track.spec().routes));
  }
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
  if (car.has_board() && resolved_platforms) {
    const std::string board = "car" + std::to_string(car.id);
    if (!resolved_platforms->contains(board)) {
      FailAt(site.root, site.source, {"cars", i, "platform"},
             "no \"platforms\": {\"" + board + "\": ...} in the resolved file");
    }
    const ConfigSource source{site.source.file + ": platforms." + board, {}};
    resolved.profile =
        ReadConfig<PlatformProfile>(YAML::Load(resolved_platforms->at(board).dump()), source);
  } else if (car.has_board()) {
    try {
      resolved.profile = LoadPlatformProfile(ResolveScenarioFile(folder, car.platform.profile));
    } catch (const ConfigError& e) {
      FailAt(site.root, site.source, {"cars", i, "platform", "profile"}, e.what());
    }
  }
  return resolved;
}

// No two cars share an id and no two obstacles a name, reported at the second one's key, naming
// the first. Returns the cars' ids.
std::set<int> CheckNamesUnique(const Scenario& scenario, const ScenarioSite& site) {
  std::map<int, std::size_t> car_of_id;
  for (std::size_t i = 0; i < scenario.cars.size(); ++i) {
    const auto [first, inserted] = car_of_id.emplace(scenario.cars[i].id, i);
    if (!inserted) {
      FailAt(site.root, site.source, {"cars", i, "id"},
             fmt::format("duplicate car id {}: cars[{}] has it too (each car needs its own id)",
                         scenario.cars[i].id, first->second));
    }
  }
  std::map<std::string, std::size_t> obstacle_of_name;
  for (std::size_t i = 0; i < scenario.obstacles.size(); ++i) {
    const auto [first, inserted] = obstacle_of_name.emplace(scenario.obstacles[i].name, i);
    if (!inserted) {
      FailAt(site.root, site.source, {"obstacles", i, "name"},
             fmt::format("duplicate obstacle name '{}': obstacles[{}] has it too",
                         scenario.obstacles[i].name, first->second));
    }
  }
  std::set<int> ids;
  for (const auto& [id, index] : car_of_id) ids.insert(id);
  return ids;
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

// No two cars start overlapping: they would "collide" in the first step (two cars 0.1 m apart ran
// and failed "car 1 hit car 2 at t=0.002 s"). Reported at the later car's start, naming both.
void CheckStartsApart(const LoadedScenario& loaded, const ScenarioSite& site) {
  const auto box = [&loaded](std::size_t i) {
    const vehicle::CarParams& v = loaded.scenario.cars[i].vehicle;
    return world::OrientedBox{loaded.cars[i].start_pose, v.length_m, v.width_m};
  };
  for (std::size_t j = 1; j < loaded.cars.size(); ++j) {
    for (std::size_t i = 0; i < j; ++i) {
      if (world::Distance(box(i), box(j)) > 0.0) continue;
      const CarConfig& a = loaded.scenario.cars[i];
      const CarConfig& b = loaded.scenario.cars[j];
      const world::Vec2 pa = loaded.cars[i].start_pose.position();
      const world::Vec2 pb = loaded.cars[j].start_pose.position();
      FailAt(site.root, site.source, {"cars", j, b.start ? "start" : "start_s_m"},
             fmt::format("car {} starts overlapping car {} (at ({:.2f}, {:.2f}) and ({:.2f}, "
                         "{:.2f}), {:.3f} m apart, {} m cars): move one of them along its route "
                         "(start_s_m) or to another start",
                         b.id, a.id, pb.x(), pb.y(), pa.x(), pa.y(), (pb - pa).norm(),
                         Num(b.vehicle.length_m)));
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

// Each expectation's car and intersection exist. A deadline past the run's end is a warning, as a
// fault after the end is (CheckFaults): a sweep over duration_s, or a shorter --set duration_s,
// cuts it off; the expectation is then judged on the time the run has.
void CheckExpectations(const LoadedScenario& loaded, const std::set<int>& car_ids,
                       const ScenarioSite& site, std::vector<std::string>* warnings) {
  const Scenario& scenario = loaded.scenario;
  const auto& crossings = loaded.track.spec().intersections;
  for (std::size_t i = 0; i < scenario.expect.size(); ++i) {
    const ExpectClause& expectation = scenario.expect[i];
    const std::string kind(ToName(KindOf(expectation)));
    const std::optional<int> car = ExpectedCar(expectation);
    if (car && car_ids.count(*car) == 0) {
      FailAt(site.root, site.source, {"expect", i}, "no car with id " + std::to_string(*car));
    }
    const std::optional<int> intersection = ExpectedIntersection(expectation);
    if (intersection &&
        std::none_of(crossings.begin(), crossings.end(),
                     [&](const world::IntersectionSpec& x) { return x.id == *intersection; })) {
      FailAt(site.root, site.source, {"expect", i, kind, "intersection"},
             "the track has no intersection " + std::to_string(*intersection));
    }
    const std::optional<double> within_s = ExpectedWithin_s(expectation);
    if (within_s && *within_s > ToSeconds(scenario.duration)) {
      warnings->push_back(ErrorAt(site.root, site.source, {"expect", i, kind, "within_s"},
                                  "within_s " + Num(*within_s) +
                                      " s is past the run's end "
                                      "(duration_s " +
                                      Num(ToSeconds(scenario.duration)) +
                                      " s): it is judged on the run's " +
                                      Num(ToSeconds(scenario.duration)) + " s")
                              .what());
    }
  }
}

// ---- The sizes a scenario asks for, against its limits (issue 33, item 3) ----

// Cells of a grid of side_x × side_y at `cell` (as the grids round: up to whole cells), in double
// so that no size overflows.
double GridCells(double side_x, double side_y, double cell) {
  return std::ceil(side_x / cell) * std::ceil(side_y / cell);
}

// "16.8 M", "37.4 G": a count in millions, or in billions from a thousand million on.
std::string Millions(double count) {
  return count < 1e9 ? fmt::format("{:.3g} M", count / 1e6) : fmt::format("{:.3g} G", count / 1e9);
}

// A grid of `cells` beyond limits.grid_cells: the error at `keys`, saying what the grid is, its
// size and how to lower or raise it.
void CheckGrid(double cells, const std::string& what, const ScenarioSite& site,
               const LoadedScenario::KeyPath& keys, std::uint64_t limit) {
  if (cells <= static_cast<double>(limit)) return;
  FailAt(
      site.root, site.source, keys,
      fmt::format("{} has {} cells; the limit is limits.grid_cells = {} ({}): lower it, or raise "
                  "limits.grid_cells in the scenario if the machine has the memory",
                  what, Millions(cells), limit, Millions(static_cast<double>(limit))));
}

// Every grid the run would allocate, and trajectory.csv's rows, within the scenario's limits.
void CheckSizes(const LoadedScenario& loaded, const ScenarioSite& site) {
  const Scenario& scenario = loaded.scenario;
  const world::TrackSpec& track = loaded.track.spec();
  const std::uint64_t limit = scenario.limits.grid_cells;
  CheckGrid(GridCells(track.size_m, track.size_m, world::kFloorTexel_m),
            fmt::format("the track's floor raster (size_m {} m at {} m per texel)",
                        Num(track.size_m), Num(world::kFloorTexel_m)),
            site, {"track"}, limit);
  const double map_m = track.planner_map_size_m.value_or(track.size_m);
  for (std::size_t i = 0; i < scenario.cars.size(); ++i) {
    const CarConfig& car = scenario.cars[i];
    const std::string name = "car " + std::to_string(car.id);
    const double resolution_m = car.stack.global_costmap.resolution_m;
    CheckGrid(GridCells(map_m, map_m, resolution_m),
              fmt::format("{}'s planner map (the track's planner_map_size_m {} m at "
                          "global_costmap.resolution_m {} m)",
                          name, Num(map_m), Num(resolution_m)),
              site, {"cars", i, "stack", "global_costmap", "resolution_m"}, limit);
    const stack::LocalCostmapParams& local = car.stack.local_costmap;
    CheckGrid(GridCells(local.width_m, local.height_m, local.resolution_m),
              name + "'s local costmap", site, {"cars", i, "stack", "local_costmap"}, limit);
    const stack::ObstacleGridParams& grid = car.perception.obstacle_grid;
    CheckGrid(GridCells(grid.x_max_m - grid.x_min_m, grid.y_max_m - grid.y_min_m, grid.cell_size_m),
              name + "'s obstacle grid", site, {"cars", i, "perception", "obstacle_grid"}, limit);
    for (const auto& [key, stream] : {std::pair{"color_camera", &car.sensors.color_camera},
                                      std::pair{"depth_camera", &car.sensors.depth_camera}}) {
      const vehicle::CameraParams& camera = stream->camera;
      CheckGrid(
          static_cast<double>(camera.width_px) * camera.height_px,
          fmt::format("{}'s {} image ({} × {} px)", name, key, camera.width_px, camera.height_px),
          site, {"cars", i, "sensors", key, "camera"}, limit);
    }
  }
  const double rows =
      std::ceil(ToSeconds(scenario.duration) / ToSeconds(scenario.output.trajectory_period)) *
      static_cast<double>(scenario.cars.size());
  if (rows > static_cast<double>(scenario.limits.trajectory_rows)) {
    FailAt(site.root, site.source, {"output", "trajectory_period_s"},
           fmt::format("trajectory.csv would have {} rows (duration_s {} s / trajectory_period_s "
                       "{} s × {} cars, about 180 bytes each); the limit is "
                       "limits.trajectory_rows = {}: raise trajectory_period_s, or raise "
                       "limits.trajectory_rows if the disk has the room",
                       Millions(rows), Num(ToSeconds(scenario.duration)),
                       Num(ToSeconds(scenario.output.trajectory_period)), scenario.cars.size(),
                       scenario.limits.trajectory_rows));
  }
}

// What a fault acts on: the modeled link and server (not with a real-time link), a car's stack
// (localization, IMU), a car's board (nodes, cameras).
bool ActsOnModeledLink(FaultKind kind) {
  return kind == FaultKind::kV2iPartition || kind == FaultKind::kV2iLossBurst ||
         kind == FaultKind::kServerRestart || kind == FaultKind::kBrokerOutage;
}
bool NeedsStack(FaultKind kind) {
  return kind == FaultKind::kLocalizationJump || kind == FaultKind::kImuBiasStep;
}
bool NeedsBoard(FaultKind kind) {
  return kind == FaultKind::kNodeCrash || kind == FaultKind::kNodeHang ||
         kind == FaultKind::kRemap || kind == FaultKind::kCameraFreeze ||
         kind == FaultKind::kCameraBlackout;
}

// Each fault's car exists and has what the fault strikes, and the fault starts within the run.
// A fault that starts at or after the run's end is a warning, not an error: a sweep over
// duration_s may cut one off in some of its points.
void CheckFaults(const Scenario& scenario, const std::set<int>& car_ids, const ScenarioSite& site,
                 std::vector<std::string>* warnings) {
  for (std::size_t i = 0; i < scenario.faults.size(); ++i) {
    const FaultKind kind = KindOf(scenario.faults[i]);
    const std::string name(ToName(kind));
    const std::optional<int> car_id = FaultCar(scenario.faults[i]);
    const double at_s = FaultStart_s(scenario.faults[i]);
    const auto fail = [&](const std::string& key, const std::string& message) {
      LoadedScenario::KeyPath path{"faults", i, name};
      if (!key.empty()) path.emplace_back(key);
      FailAt(site.root, site.source, path, message);
    };
    if (car_id && car_ids.count(*car_id) == 0) {
      fail("car", "no car with id " + std::to_string(*car_id));
    }
    if (at_s >= ToSeconds(scenario.duration)) {
      warnings->push_back(
          ErrorAt(site.root, site.source, {"faults", i, name, "at_s"},
                  "at_s " + Num(at_s) + " s is not before the run's end (duration_s " +
                      Num(ToSeconds(scenario.duration)) + " s): the fault never strikes")
              .what());
    }
    if (scenario.v2i.link == V2ILinkKind::kRealtime && ActsOnModeledLink(kind)) {
      fail("", name +
                   " acts on the modeled V2I link and the server in the run; with v2i.link: "
                   "realtime (run --realtime) both are real and outside the run");
    }
    const CarConfig* car = car_id ? scenario.FindCar(*car_id) : nullptr;
    if (car && NeedsStack(kind) && !car->drives_by_stack()) {
      fail("car", "car " + std::to_string(*car_id) +
                      " does not drive by its stack (driver: oracle drives on ground truth), so "
                      "nothing reads its localization or IMU");
    }
    if (car && NeedsBoard(kind) && !car->has_board()) {
      fail("car",
           "car " + std::to_string(*car_id) + " runs no nodes (perception.enabled is false)");
    }
  }
}

// Where each key that names a node or topic of a car's board stands in the file, for the errors
// found when the board is built (LoadedScenario::ErrorAt).
std::map<std::string, std::string> BoardNameLocations(const Scenario& scenario,
                                                      const ScenarioSite& site) {
  std::map<std::string, std::string> where;
  const auto add = [&](const LoadedScenario::KeyPath& keys) {
    const ConfigError located = ErrorAt(site.root, site.source, keys, "");
    std::string path;
    for (const auto& key : keys) {
      path = std::holds_alternative<std::string>(key)
                 ? detail::JoinPath(path, std::get<std::string>(key))
                 : detail::JoinIndex(path, std::get<std::size_t>(key));
    }
    where[path] = located.what();
  };
  for (std::size_t i = 0; i < scenario.cars.size(); ++i) {
    const PlatformConfig& p = scenario.cars[i].platform;
    for (const auto& [name, mapping] : p.mapping) add({"cars", i, "platform", "mapping", name});
    for (const auto& [name, t] : p.transport) add({"cars", i, "platform", "transport", name});
    for (const auto& [name, c] : p.cost_scale) add({"cars", i, "platform", "cost_scale", name});
    for (const auto& [name, c] : p.cost_override) {
      add({"cars", i, "platform", "cost_override", name});
    }
  }
  for (std::size_t i = 0; i < scenario.faults.size(); ++i) {
    add({"faults", i, std::string(ToName(KindOf(scenario.faults[i]))), "node"});
  }
  return where;
}

// The scenario, its track and its boards' profiles with every default: what the run's
// scenario.resolved.json holds and its scenario_sha256 hashes, all but `limits`: a limit decides
// whether a scenario loads, not what its run does, so raising one keeps the hash (and a sweep's
// run ids) as they were.
void Resolve(LoadedScenario* loaded) {
  loaded->resolved = {{"scenario", ToJson(loaded->scenario)},
                      {"track", ToJson(loaded->track.spec())}};
  for (const LoadedCar& car : loaded->cars) {  // a board's profile is in the run
    if (car.profile) {
      loaded->resolved["platforms"]["car" + std::to_string(car.config->id)] = ToJson(*car.profile);
    }
  }
  nlohmann::json hashed = loaded->resolved;
  hashed["scenario"].erase("limits");
  loaded->sha256 = Sha256Hex(hashed.dump());
}

}  // namespace

LoadedScenario::LoadedScenario(std::filesystem::path file_, Scenario scenario_, world::Track track_)
    : file(std::move(file_)), scenario(std::move(scenario_)), track(std::move(track_)) {}

LoadedScenario::LoadedScenario(const LoadedScenario& other)
    : file(other.file),
      scenario(other.scenario),
      track(other.track),
      cars(other.cars),
      sha256(other.sha256),
      resolved(other.resolved),
      key_locations(other.key_locations) {
  for (std::size_t i = 0; i < cars.size(); ++i) cars[i].config = &scenario.cars[i];
}

LoadedScenario& LoadedScenario::operator=(const LoadedScenario& other) {
  if (this != &other) *this = LoadedScenario(other);
  return *this;
}

ConfigError LoadedScenario::ErrorAt(const std::string& key_path, const std::string& message) const {
  const auto where = key_locations.find(key_path);
  return ConfigError((where != key_locations.end() ? where->second : key_path + ": ") + message);
}

LoadedScenario LoadScenario(const std::filesystem::path& file,
                            const std::vector<std::string>& overrides,
                            std::optional<std::uint64_t> seed) {
  YAML::Node root = LoadYamlFile(file);
  ConfigSource source{file.string(), {}};
  // before any --set: a file that is not a mapping is the file's error, not the override's
  if (!root.IsMap())
    detail::Fail(root, "", source, "expected a mapping, got " + detail::Describe(root));
  // a study file (sim/study) given where a scenario goes: say what it is, not "unknown key"
  if (root["scenario"] && !root["cars"]) {
    detail::Fail(root["scenario"], "scenario", source,
                 "this is a study file (a `scenario:` to vary), not a scenario: run it with "
                 "`autonomsim sweep " +
                     file.string() + "`");
  }
  BreakAliases(root);
  // a car's start pose by name or by arc length: --set of one replaces the file's other
  const AlternativeKeys alternatives = {{"start", "start_s_m"}};
  for (const std::string& assignment : overrides) {
    ApplyOverride(root, assignment, &source, alternatives);
  }
  if (seed) ApplyOverride(root, "seed=" + std::to_string(*seed), &source);
  std::vector<PresetOverride> preset_overrides = ApplyStackPresets(root, source);
  const ScenarioSite site{root, source};

  Scenario read = ReadConfig<Scenario>(root, source);
  if (read.name.empty()) read.name = file.stem().string();
  world::Track track = LoadScenarioTrack(read, file.parent_path(), site);
  LoadedScenario loaded(file, std::move(read), std::move(track));
  const Scenario& scenario = loaded.scenario;

  const std::set<int> car_ids = CheckNamesUnique(scenario, site);
  for (std::size_t i = 0; i < scenario.cars.size(); ++i) {
    loaded.cars.push_back(ResolveCar(scenario, i, loaded.track, file.parent_path(), site));
  }
  CheckSizes(loaded, site);
  CheckStartsApart(loaded, site);
  CheckObstaclesOnFloor(scenario, loaded.track.spec().size_m, site);
  CheckPlatformSettingsApply(scenario, site);
  loaded.warnings = StackMixWarnings(scenario);
  CheckExpectations(loaded, car_ids, site, &loaded.warnings);
  CheckFaults(scenario, car_ids, site, &loaded.warnings);
  loaded.key_locations = BoardNameLocations(scenario, site);
  loaded.preset_overrides = std::move(preset_overrides);
  Resolve(&loaded);
  return loaded;
}

ResolvedScenarioFile ReadResolvedScenarioFile(const std::filesystem::path& file) {
  std::ifstream in(file);
  if (!in) throw ConfigError(file.string() + ": cannot read");
  nlohmann::json resolved;
  try {
    resolved = nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    throw ConfigError(file.string() + ": not valid JSON: " + e.what());
  }
  if (!resolved.is_object() || !resolved.contains("scenario") || !resolved.contains("track")) {
    throw ConfigError(file.string() + ": has no \"scenario\" and \"track\"");
  }
  const ConfigSource source{file.string(), {}};
  // JSON is YAML: the resolved values read back as a scenario file's
  Scenario scenario = ReadConfig<Scenario>(YAML::Load(resolved["scenario"].dump()), source);
  const auto spec = ReadConfig<world::TrackSpec>(YAML::Load(resolved["track"].dump()), source);
  std::optional<world::Track> track;
  try {
    track.emplace(spec);
  } catch (const std::invalid_argument& e) {
    throw ConfigError(file.string() + ": track: " + e.what());
  }
  return {std::move(resolved), std::move(scenario), std::move(*track)};
}

LoadedScenario LoadResolvedScenario(const std::filesystem::path& file) {
  ResolvedScenarioFile read = ReadResolvedScenarioFile(file);
  LoadedScenario loaded(file, std::move(read.scenario), std::move(read.track));
  const ConfigSource source{file.string(), {}};
  const YAML::Node root = YAML::Load(read.resolved["scenario"].dump());  // for error locations
  const ScenarioSite site{root, source};
  const nlohmann::json platforms = read.resolved.value("platforms", nlohmann::json::object());
  for (std::size_t i = 0; i < loaded.scenario.cars.size(); ++i) {
    loaded.cars.push_back(
        ResolveCar(loaded.scenario, i, loaded.track, file.parent_path(), site, &platforms));
  }
  loaded.warnings = StackMixWarnings(loaded.scenario);
  Resolve(&loaded);
  return loaded;
}

std::vector<std::string> StackMixWarnings(const Scenario& scenario) {
  if (scenario.traffic_lights.policy != world::ServerPolicy::kFifo) return {};
  std::string cars;
  for (std::size_t i = 0; i < scenario.cars.size(); ++i) {
    const auto& client = scenario.cars[i].intersection_client;
    if (client.blocking || !client.re_request) {
      cars += (cars.empty() ? "" : ",") + std::to_string(i);
    }
  }
  if (cars.empty()) return {};
  return {"cars[" + cars +
          "] run the lab's intersection client (intersection_client.blocking: true or "
          "re_request: false: it never renews a grant) against the fifo server, whose lease "
          "(traffic_lights.lease_s " +
          Num(ToSeconds(scenario.traffic_lights.lease)) +
          " s) then expires while the car crosses and lets the next car in: set "
          "traffic_lights.policy: original (the lab's vtl.py, as stack.preset: lab) or "
          "intersection_client.blocking: false and re_request: true (as stack.preset: safe)"};
}

}  // namespace autonomsim::sim
