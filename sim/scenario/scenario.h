// A scenario file, field for field (scenarios/*.yaml). Keys map 1:1 to these structs; the strict
// reader in sim/core/config.h turns every mistake into an error naming file, line and key.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <string>
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
    v("id", id);
    v("route", route);
    v("lanes", lanes);
    v("start", start);
    v("start_s_m", start_s_m);
    v("laps", laps);
    v("driver", driver);
    v("oracle", oracle);
    v("stack", stack);
    v("intersection_client", intersection_client);
    v("vehicle", vehicle);
    v("sensors", sensors);
    v("perception", perception);
    v("platform", platform);
  }
  void Validate() const;
};

// A box on the floor that cars can hit (and, later, see). It is present from appear_s until
// disappear_s (if given).
struct ObstacleConfig {
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
    v("name", name);
    v("x_m", x_m);
    v("y_m", y_m);
    v("yaw_deg", yaw_deg);
    v("length_m", length_m);
    v("width_m", width_m);
    v("height_m", height_m);
    v("appear_s", appear_s);
    v("disappear_s", disappear_s);
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
    v("link", link);
    v("latency_s", latency);
    v("jitter_s", jitter);
    v("loss", loss);
    v("mqtt", mqtt);
  }
  void Validate() const;
};

struct OutputConfig {
  Duration trajectory_period{std::chrono::milliseconds(50)};  // one trajectory.csv row per car

  template <class V>
  void Describe(V& v) {
    v("trajectory_period_s", trajectory_period);
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
    v("grid_cells", grid_cells);
    v("trajectory_rows", trajectory_rows);
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
    v("name", name);
    v("description", description);
    v("seed", seed);
    v("duration_s", duration);
    v("track", track);
    v("physics", physics);
    v("traffic_lights", traffic_lights);
    v("v2i", v2i);
    v("stack", stack);
    v("cars", cars);
    v("obstacles", obstacles);
    v("expect", expect);
    v("faults", faults);
    v("output", output);
    v("appearance", appearance);
    v("camera_backend", camera_backend);
    v("limits", limits);
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

// A file a command takes by name (`table1 --profile`, `transport --profile`): as given when it
// exists (or is absolute); else the checkout's own (scenarios/platforms/zcu104.yaml from any
// folder), or the shipped scenarios/ folder's (platforms/zcu104.yaml); else as given, for the
// loader to report missing.
std::filesystem::path ResolveShippedFile(const std::string& given);

}  // namespace autonomsim::sim
