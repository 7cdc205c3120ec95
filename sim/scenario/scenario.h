// A scenario file, field for field (scenarios/*.yaml). Keys map 1:1 to these structs; the strict
// reader in sim/core/config.h turns every mistake into an error naming file, line and key.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
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
#include "sim/scenario/stack_presets.h"
#include "stack/intersection_client.h"
#include "vehicle/car.h"
#include "vehicle/physics_world.h"
#include "world/time.h"
#include "world/track.h"
#include "world/traffic_light_server.h"

namespace autonomsim::sim {

struct CarConfig {
  int id{0};  // 0..9: the /vtl/ protocol carries the car id as one digit (reference §7)
  std::optional<std::string> route;               // a route of the track, by name, or
  std::optional<std::vector<std::string>> lanes;  // the lane segments to drive, in order
  std::optional<std::string> start;  // a named start pose of the track (must lie on the route)
  std::optional<double> start_s_m;   // or the distance along the route to start at (default 0)
  std::optional<int> laps;           // on a loop: park after this many laps (default: drive on)
  // "oracle": ground-truth lane following (sim/car/oracle_driver.h); "stack": the AutonomROS stack
  // on the car's board (sim/car/stack_nodes.h; needs perception.enabled)
  std::string driver{"oracle"};
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
  bool drives_by_stack() const { return driver == "stack"; }

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
  std::string link{"embedded"};
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

// Arguments an expectation may take; which ones each kind accepts is checked in ExpectClause.
struct ExpectArgs {
  std::optional<int> car;           // the car it is about (default: every car)
  std::optional<int> laps;          // completes: laps to finish
  std::optional<double> within_s;   // completes: by this time (default: the scenario's duration)
  std::optional<double> max_m;      // max_lateral_error: the bound
  std::optional<double> min_m;      // min_obstacle_gap: the least free distance allowed
  std::optional<std::string> node;  // node_rate: the node, on the car's board
  std::optional<double> min_hz;     // node_rate: bounds on its jobs per second
  std::optional<double> max_hz;
  std::optional<double> min_percent;  // cpu_demand: bounds on the board's CPU demand
  std::optional<double> max_percent;  //   (% of one core, summed over its nodes)
  std::optional<double> max_s;        // no_gridlock: longest standstill; max_wait: longest wait;
                                      // recovers_within: the bound after a fault ends
  std::optional<int> intersection;    // max_wait, min_throughput: the one it is about (default all)
  std::optional<double> per_minute;   // min_throughput: least crossings per minute

  template <class V>
  void Describe(V& v) {
    v("car", car);
    v("laps", laps);
    v("within_s", within_s);
    v("max_m", max_m);
    v("min_m", min_m);
    v("node", node);
    v("min_hz", min_hz);
    v("max_hz", max_hz);
    v("min_percent", min_percent);
    v("max_percent", max_percent);
    v("max_s", max_s);
    v("intersection", intersection);
    v("per_minute", per_minute);
  }
  void Validate() const {}
};

// One `expect:` entry: exactly one of these keys, e.g. `- completes: {car: 0, laps: 3}`.
struct ExpectClause {
  std::optional<ExpectArgs> no_collision;
  std::optional<ExpectArgs> intersection_mutex;
  std::optional<ExpectArgs> no_entry_without_grant;
  std::optional<ExpectArgs> completes;
  std::optional<ExpectArgs> max_lateral_error;
  std::optional<ExpectArgs> min_obstacle_gap;
  std::optional<ExpectArgs> node_rate;   // {car, node, min_hz and/or max_hz}
  std::optional<ExpectArgs> cpu_demand;  // {car, min_percent and/or max_percent}
  // {car, max_s}: no car stands still longer than max_s (default 30 s) unless a red light holds it
  // (sim/results/expectations.h says exactly when)
  std::optional<ExpectArgs> no_gridlock;
  std::optional<ExpectArgs> max_wait;        // {car, intersection, max_s}: each wait at a stop zone
  std::optional<ExpectArgs> min_throughput;  // {intersection, per_minute}: crossings per minute
  // {car, max_s}: after each fault ends, every car moves again within max_s (expectations.h)
  std::optional<ExpectArgs> recovers_within;

  template <class V>
  void Describe(V& v) {
    v("no_collision", no_collision);
    v("intersection_mutex", intersection_mutex);
    v("no_entry_without_grant", no_entry_without_grant);
    v("completes", completes);
    v("max_lateral_error", max_lateral_error);
    v("min_obstacle_gap", min_obstacle_gap);
    v("node_rate", node_rate);
    v("cpu_demand", cpu_demand);
    v("no_gridlock", no_gridlock);
    v("max_wait", max_wait);
    v("min_throughput", min_throughput);
    v("recovers_within", recovers_within);
  }
  void Validate() const;
  std::string kind() const;
  const ExpectArgs& args() const;
};

// Arguments a fault may take; which ones each kind accepts is checked in FaultClause. Every fault
// starts at at_s; for_s is how long it lasts (absent: to the end of the run, except where
// FaultClause says otherwise). sim/loop/faults.h says what each kind does.
struct FaultArgs {
  double at_s{0.0};
  std::optional<double> for_s;
  std::optional<int> car;                // the car it strikes (v2i_*: default every car)
  std::optional<std::string> direction;  // v2i_partition: "up" (car → server), "down", "both"
  std::optional<double> loss;            // v2i_loss_burst: probability a message is lost
  std::optional<std::string> node;       // node_crash, node_hang: a node on the car's board
  std::optional<std::string> camera;     // camera_*: "color" (default) or "depth"
  std::optional<double> gyro_bias_rad_per_s;  // imu_bias_step: added to the gyro's z bias
  std::optional<double> dx_m;                 // localization_jump: the estimate's jump, map frame
  std::optional<double> dy_m;
  std::optional<double> dyaw_deg;

  template <class V>
  void Describe(V& v) {
    v("at_s", at_s);
    v("for_s", for_s);
    v("car", car);
    v("direction", direction);
    v("loss", loss);
    v("node", node);
    v("camera", camera);
    v("gyro_bias_rad_per_s", gyro_bias_rad_per_s);
    v("dx_m", dx_m);
    v("dy_m", dy_m);
    v("dyaw_deg", dyaw_deg);
  }
  void Validate() const {}
};

// One `faults:` entry: exactly one of these keys, e.g. `- car_stall: {car: 1, at_s: 20}`.
struct FaultClause {
  std::optional<FaultArgs> v2i_partition;
  std::optional<FaultArgs> v2i_loss_burst;
  std::optional<FaultArgs> server_restart;
  std::optional<FaultArgs> broker_outage;
  std::optional<FaultArgs> car_stall;
  std::optional<FaultArgs> node_crash;
  std::optional<FaultArgs> node_hang;
  std::optional<FaultArgs> camera_freeze;
  std::optional<FaultArgs> camera_blackout;
  std::optional<FaultArgs> imu_bias_step;
  std::optional<FaultArgs> localization_jump;

  template <class V>
  void Describe(V& v) {
    v("v2i_partition", v2i_partition);
    v("v2i_loss_burst", v2i_loss_burst);
    v("server_restart", server_restart);
    v("broker_outage", broker_outage);
    v("car_stall", car_stall);
    v("node_crash", node_crash);
    v("node_hang", node_hang);
    v("camera_freeze", camera_freeze);
    v("camera_blackout", camera_blackout);
    v("imu_bias_step", imu_bias_step);
    v("localization_jump", localization_jump);
  }
  void Validate() const;
  std::string kind() const;
  const FaultArgs& args() const;
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
  std::string camera_backend{"raycast"};

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
  }
  void Validate() const;
};

// A scenario read, overridden, checked against its track, and ready to run.
struct LoadedScenario {
  std::filesystem::path file;
  Scenario scenario;
  world::Track track;
  std::vector<world::Route> routes;       // one per car, in scenario order
  std::vector<double> start_s_m;          // per car: where on its route it starts
  std::vector<world::Pose2> start_poses;  // per car: its initial chassis pose
  // per car: its board's profile (loaded from platform.profile, relative to the scenario's
  // folder), for the cars that have a board (CarConfig::has_board)
  std::vector<std::optional<PlatformProfile>> profiles;
  std::string sha256;       // of the resolved scenario and track (canonical JSON)
  nlohmann::json resolved;  // {"scenario": ..., "track": ...} with every default
  // A ConfigError for `message` at a key of the scenario, located as the loader locates its own
  // ("file:line:col: key: " or "--set key: "), for errors found once the run is built.
  using KeyPath = std::vector<std::variant<std::string, std::size_t>>;
  std::function<ConfigError(const KeyPath& key, const std::string& message)> error_at;
};

// Reads `file`, applies `overrides` (key=value, see ApplyOverride) and then `seed` if given,
// loads the track, resolves each car's route and start. Throws ConfigError on unusable input.
LoadedScenario LoadScenario(const std::filesystem::path& file,
                            const std::vector<std::string>& overrides = {},
                            std::optional<std::uint64_t> seed = std::nullopt);

}  // namespace autonomsim::sim
