// A scenario file, field for field (scenarios/*.yaml). Keys map 1:1 to these structs; the strict
// reader in sim/core/config.h turns every mistake into an error naming file, line and key.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "sim/car/oracle_driver.h"
#include "sim/car/perception_config.h"
#include "sim/car/sensor_config.h"
#include "sim/car/stack_config.h"
#include "sim/core/config.h"
#include "sim/mqtt/mqtt_link_config.h"
#include "sim/platform/platform_profile.h"
#include "sim/scenario/expect_kinds.h"
#include "sim/scenario/fault_kinds.h"
#include "sim/scenario/stack_presets.h"
#include "stack/intersection_client.h"
#include "vehicle/car.h"
#include "vehicle/physics_world.h"
#include "world/time.h"
#include "world/track.h"
#include "world/traffic_light_server.h"

namespace autonomsim::sim {

// Who drives a car: "oracle", ground-truth lane following (sim/car/oracle_driver.h); "stack", the
// AutonomROS stack on the car's board (sim/car/stack_nodes.h; needs perception.enabled).
enum class Driver { kOracle, kStack };
// The car <-> traffic-light server link (V2IConfig::link).
enum class V2ILinkKind { kEmbedded, kMqtt, kRealtime };

}  // namespace autonomsim::sim

namespace autonomsim {
template <>
struct NameTable<sim::Driver> {
  static constexpr std::array<std::pair<sim::Driver, std::string_view>, 2> kEntries{
      {{sim::Driver::kOracle, "oracle"}, {sim::Driver::kStack, "stack"}}};
};
template <>
struct NameTable<sim::V2ILinkKind> {
  using K = sim::V2ILinkKind;
  static constexpr std::array<std::pair<K, std::string_view>, 3> kEntries{
      {{K::kEmbedded, "embedded"}, {K::kMqtt, "mqtt"}, {K::kRealtime, "realtime"}}};
};
}  // namespace autonomsim

namespace autonomsim::sim {

struct CarConfig {
  int id{0};  // 0..9: the /vtl/ protocol carries the car id as one digit (reference §7)
  std::optional<std::string> route;               // a route of the track, by name, or
  std::optional<std::vector<std::string>> lanes;  // the lane segments to drive, in order
  std::optional<std::string> start;  // a named start pose of the track (must lie on the route)
  std::optional<double> start_s_m;   // or the distance along the route to start at (default 0)
  std::optional<int> laps;           // on a loop: park after this many laps (default: drive on)
  Driver driver{Driver::kOracle};
  OracleDriverParams oracle;
  StackConfig stack;  // driver: stack
  stack::IntersectionClientParams intersection_client;
  vehicle::CarParams vehicle;
  SensorSuiteParams sensors;  // cameras, IMU, wheel encoder, ultrasonic (sim/car/sensor_config.h)
  // The perception nodes (point cloud, obstacle detection, lane detection), run on the car's
  // board on its camera frames when enabled (sim/car/perception_nodes.h).
  PerceptionConfig perception;
  // The car's compute board: profile, per-node mapping (sw/hw), per-topic transport
  // (sim/platform/platform_profile.h). Used when the car has nodes to run (perception).
  PlatformConfig platform;

  // Whether the car runs anything on a modeled board.
  bool has_board() const { return perception.enabled; }
  bool drives_by_stack() const { return driver == Driver::kStack; }

  template <class V>
  void Describe(V& v) {
    v("id", id, "the car's id, 0..9 (one digit in the /vtl/ protocol)");
    v("route", route, "the route it drives, by name ([routes](#routes)); or give `lanes`");
    v("lanes", lanes, "the lane segments it drives, in order ([lanes](#lanes)); or give `route`");
    v("start", start,
      "a named start pose on its route ([start poses](#start-poses)); or give `start_s_m`");
    v("start_s_m", start_s_m, "where it starts, as the distance along its route (default 0)");
    v("laps", laps, "on a loop: park after this many laps (default: drive on)");
    v("driver", driver,
      "who drives: `oracle`, ideal lane following on ground truth, or `stack`, the AutonomROS "
      "stack on its board");
    v("oracle", oracle, "the oracle driver's settings (`driver: oracle`)");
    v("stack", stack, "the AutonomROS stack's settings (`driver: stack`)");
    v("intersection_client", intersection_client,
      "the car's /vtl/ client: when it asks for, holds and frees an intersection");
    v("vehicle", vehicle, "the car's body, steering and motor");
    v("sensors", sensors, "the car's sensors: rates, topics, models");
    v("perception", perception, "the perception nodes on the car's board");
    v("platform", platform,
      "the car's compute board: where each node runs and how each topic is carried");
  }
  void Validate() const;
};

// A box on the floor, the one kind of obstacle (kMeaning says it for the scenario reference).
struct ObstacleConfig {
  static constexpr std::string_view kMeaning =
      "An obstacle is a box standing on the floor from `appear_s` until `disappear_s`: cars "
      "collide with it, their cameras and ultrasonic rangers see it";

  // Whether it stands on the floor at t.
  bool PresentAt(Time t) const {
    return FromSeconds(appear_s) <= t && !(disappear_s && FromSeconds(*disappear_s) <= t);
  }

  std::string name;
  double x_m{0.0};
  double y_m{0.0};
  double yaw_deg{0.0};
  double length_m{0.2};
  double width_m{0.2};
  double height_m{0.2};
  double appear_s{0.0};
  std::optional<double> disappear_s;

  template <class V>
  void Describe(V& v) {
    v("name", name, "names it in events and contacts; unique");
    v("x_m", x_m, "its centre on the floor, map frame (x east)");
    v("y_m", y_m, "its centre (y north)");
    v("yaw_deg", yaw_deg, "its heading, counter-clockwise from east");
    v("length_m", length_m, "its size along its heading");
    v("width_m", width_m, "its size across");
    v("height_m", height_m, "its height, for the cameras");
    v("appear_s", appear_s, "when it appears");
    v("disappear_s", disappear_s, "when it goes (default: it stays)");
  }
  void Validate() const;
};

// The car ↔ traffic-light-server link. "embedded": in-process, with a modeled WLAN delay and loss
// per message and direction.
struct V2IConfig {
  // "embedded": the server runs in process. "mqtt": the cars' messages go through a real
  // mosquitto broker to a `tlserver --sim-clock` process in lock-step (sim/v2i/mqtt_endpoint.h);
  // the run's result is the same. The modeled latency, jitter and loss apply to both.
  // "realtime": the run is paced to the wall clock and the cars speak the lab's plain protocol
  // through the broker mqtt.broker to a server outside the run (the lab's vtl.py, or `tlserver`
  // without --sim-clock), possibly beside real cars (sim/v2i/realtime_link.h); the network is
  // real, so the modeled latency, jitter and loss do not apply, and the result is not
  // reproducible bit for bit.
  V2ILinkKind link{V2ILinkKind::kEmbedded};
  Duration latency{std::chrono::milliseconds(20)};  // assumed: one-way WLAN + broker delay
  Duration jitter{std::chrono::milliseconds(5)};    // assumed: uniform extra delay in [0, jitter]
  double loss{0.0};                                 // probability that one message is lost
  MqttLinkConfig mqtt;                              // link: mqtt and realtime only

  template <class V>
  void Describe(V& v) {
    v("link", link,
      "how cars reach the traffic-light server: `embedded` (in process), `mqtt` (a real broker and "
      "`tlserver`, same result), `realtime` (a lab server over a real broker, wall-clock paced)");
    v("latency_s", latency, "one-way delay of each message (not with `realtime`)");
    v("jitter_s", jitter, "extra delay, uniform in [0, this]");
    v("loss", loss, "probability that one message is lost");
    v("mqtt", mqtt, "the broker, for `mqtt` and `realtime`");
  }
  void Validate() const;
};

struct OutputConfig {
  Duration trajectory_period{std::chrono::milliseconds(50)};  // one trajectory.csv row per car

  template <class V>
  void Describe(V& v) {
    v("trajectory_period_s", trajectory_period, "one trajectory.csv row per car this often");
  }
  void Validate() const;
};

// The sizes a scenario may ask for (issue 33): each guards the memory or the disk against a typo
// (a track of size_m 1000 would need 40 GB), and a scenario that needs more raises it here. Checked
// at load, at the key that sets the size (docs/writing-scenarios.md, "Limits").
struct LimitsConfig {
  // Any one grid: the floor raster (size_m / 5 mm per side), a car's planner map
  // (planner_map_size_m / global_costmap.resolution_m), its local costmap and obstacle grid, a
  // camera's image. 2^24: the lab's planner map (10 m at 5.17 mm) is 3.7 M cells.
  std::uint64_t grid_cells{std::uint64_t{1} << 24};
  // trajectory.csv's rows: duration_s / output.trajectory_period_s × cars (about 180 bytes
  // each; 24 h of 10 cars at the default 50 ms is 17.3 M).
  std::uint64_t trajectory_rows{20'000'000};

  template <class V>
  void Describe(V& v) {
    v("grid_cells", grid_cells,
      "the most cells any one grid may have (floor raster, planner map, costmaps, camera images)");
    v("trajectory_rows", trajectory_rows, "the most rows trajectory.csv may have");
  }
  void Validate() const;  // both >= 1
};

struct Scenario {
  // The car with this id, or null.
  const CarConfig* FindCar(int id) const {
    for (const CarConfig& car : cars) {
      if (car.id == id) return &car;
    }
    return nullptr;
  }

  std::string name;
  std::string description;
  std::uint64_t seed{1};
  Duration duration{std::chrono::seconds(120)};
  std::string track{"tracks/lab.yaml"};  // relative to the scenario file's folder
  vehicle::PhysicsParams physics;
  world::TrafficLightServerParams traffic_lights;
  V2IConfig v2i;
  FleetStackConfig stack;  // `stack.preset` for every car and the server (stack_presets.h)
  std::vector<CarConfig> cars;
  std::vector<ObstacleConfig> obstacles;
  std::vector<ExpectClause> expect;
  std::vector<FaultClause> faults;  // in any order; sim/loop/faults.h
  OutputConfig output;
  vehicle::SceneAppearance appearance;  // how cars and obstacles look to the cameras
  // How the cameras' images are made: "raycast", the ray caster (vehicle/ray_caster.h), or "gl",
  // the rasteriser in an offscreen OpenGL ES context (vehicle/gl_camera.h), its cross-check.
  CameraBackend camera_backend{CameraBackend::kRayCast};
  LimitsConfig limits;

  template <class V>
  void Describe(V& v) {
    v("name", name, "the run's name (default: the file's)");
    v("description", description, "what the scenario is for");
    v("seed", seed, "the seed of every random draw");
    v("duration_s", duration, "how long the run lasts, simulated (at most a day)");
    v("track", track,
      "the track file, relative to the scenario (else the shipped one); its start poses and "
      "routes: [the lab track](#the-lab-track)");
    v("physics", physics, "the physics engine (Box2D): its step and solver");
    v("traffic_lights", traffic_lights, "the traffic-light server");
    v("v2i", v2i, "the cars' link to the server");
    v("stack", stack, "the fleet's stack preset");
    v("cars", cars, "the cars, at least one");
    v("obstacles", obstacles, "boxes on the floor ([obstacles](#obstacles))");
    v("expect", expect,
      "what must hold, judged on the finished run ([expectations](#expectations))");
    v("faults", faults, "what goes wrong on purpose, and when ([faults](#faults))");
    v("output", output, "what the run writes");
    v("appearance", appearance, "the colours the cameras see");
    v("camera_backend", camera_backend,
      "what renders the camera images: `raycast`, the ray caster, or `gl`, OpenGL ES (its "
      "cross-check)");
    v("limits", limits, "the sizes a scenario may ask for, against typos");
  }
  void Validate() const;
};

// One car of a loaded scenario: its config, resolved against the track.
struct LoadedCar {
  const CarConfig* config{nullptr};  // in LoadedScenario::scenario.cars
  world::Route route;
  double start_s_m{0.0};    // where on its route it starts
  world::Pose2 start_pose;  // its initial chassis pose
  // its board's profile (loaded from platform.profile, relative to the scenario's folder), for a
  // car that has a board (CarConfig::has_board)
  std::optional<PlatformProfile> profile;
};

// A scenario read, overridden, checked against its track, and ready to run: every error a user's
// input can cause is raised while loading, so a run never stops on a config error.
struct LoadedScenario {
  LoadedScenario(std::filesystem::path file_, Scenario scenario_, world::Track track_);
  // a copy's cars point into the copy's scenario
  LoadedScenario(const LoadedScenario& other);
  LoadedScenario& operator=(const LoadedScenario& other);
  LoadedScenario(LoadedScenario&&) = default;
  LoadedScenario& operator=(LoadedScenario&&) = default;

  std::filesystem::path file;
  Scenario scenario;
  world::Track track;
  std::vector<LoadedCar> cars;  // in scenario order
  std::string sha256;           // of the resolved scenario and track (canonical JSON)
  nlohmann::json resolved;      // {"scenario": ..., "track": ...} with every default

  // The names of a car's board (its nodes and topics, which platform settings and node faults
  // name) are checked when the board is built, before the run's first instant: this locates such
  // an error at its key, e.g. ErrorAt("cars[0].platform.mapping.lane_planer", "no node ...").
  ConfigError ErrorAt(const std::string& key_path, const std::string& message) const;
  using KeyPath = std::vector<std::variant<std::string, std::size_t>>;
  std::map<std::string, std::string> key_locations;  // key path -> "file:line:col: key path: "
  // The keys the scenario sets itself against its stack.preset (ApplyStackPresets).
  std::vector<PresetOverride> preset_overrides;
  // Settings that do not go together (StackMixWarnings), for run and check to print.
  std::vector<std::string> warnings;
};

// Warnings about a scenario whose cars and server come from different stacks in a way that breaks
// the crossing: a lab intersection client (blocking, or re_request false: it never renews its
// grant) against the fifo server, whose lease then expires while the car crosses (the lab's client
// belongs with vtl.py, policy original). Empty when the settings go together.
std::vector<std::string> StackMixWarnings(const Scenario& scenario);

// Reads `file`, applies `overrides` (key=value, see ApplyOverride) and then `seed` if given,
// loads the track, resolves each car's route and start. Throws ConfigError on unusable input.
LoadedScenario LoadScenario(const std::filesystem::path& file,
                            const std::vector<std::string>& overrides = {},
                            std::optional<std::uint64_t> seed = std::nullopt);

// A finished run's scenario.resolved.json read as it is: the JSON, its scenario and its track.
// ConfigError for a file that cannot be read, is not JSON or lacks either.
struct ResolvedScenarioFile {
  nlohmann::json resolved;
  Scenario scenario;
  world::Track track;
};
ResolvedScenarioFile ReadResolvedScenarioFile(const std::filesystem::path& file);

// A finished run's scenario.resolved.json read back (its scenario, track and boards' profiles,
// every default as resolved), ready to run again: the run it describes, without the files it was
// made from. Its sha256 equals that run's scenario_sha256. Throws ConfigError on an unusable file.
LoadedScenario LoadResolvedScenario(const std::filesystem::path& file);

// How a named start pose sits against a route: the distance along the route nearest to it, how far
// it lies off the route there and how far its heading is off the route's. A car may start at the
// pose only on a route it lies on (`on`).
struct StartPlacement {
  double s_m{0.0};
  double distance_m{0.0};
  double heading_error_rad{0.0};
  // within 0.1 m of the route, heading within 30° of its direction
  bool on() const;
};
StartPlacement PlaceStart(const world::Pose2& pose, const world::Route& route);

// A file of the shipped scenarios/ folder (fixed at build time), e.g. "tracks/lab.yaml": where a
// scenario that names it finds it when its own folder has no such file.
std::filesystem::path ShippedScenarioFile(const std::string& name);

// A file a command takes by name (`table1 --profile`, `transport --profile`): as given when it
// exists (or is absolute); else the checkout's own (scenarios/platforms/zcu104.yaml from any
// folder), or the shipped scenarios/ folder's (platforms/zcu104.yaml); else as given, for the
// loader to report missing.
std::filesystem::path ResolveShippedFile(const std::string& given);

}  // namespace autonomsim::sim
