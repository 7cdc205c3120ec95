// `autonomsim render SCENARIO --car ID --at T --out DIR`: what one car's cameras see at one
// instant, one folder per camera.
#include <fmt/format.h>

#include <cmath>
#include <stdexcept>

#include "sim/core/config.h"
#include "sim/core/files.h"
#include "sim/results/render.h"
#include "tools/cli_common.h"

namespace autonomsim::cli {
namespace {

namespace fs = std::filesystem;

int RenderCommand(const std::string& scenario_file, int car_id, double at_s, const std::string& out,
                  std::optional<std::uint64_t> seed, const std::vector<std::string>& overrides,
                  const std::optional<std::string>& backend, bool force) {
  try {  // refused before anything runs
    sim::CheckOutputFolder(out, force);
  } catch (const sim::ConfigError& e) {
    fmt::print(stderr, "error: {}\n", e.what());
    return kExitUnusableInput;
  }
  std::optional<sim::LoadedScenario> loaded;
  try {
    loaded.emplace(sim::LoadScenario(scenario_file, overrides, seed));
  } catch (const sim::ConfigError& e) {
    fmt::print(stderr, "error: {}\n", e.what());
    return kExitUnusableInput;
  }
  const sim::Scenario& scenario = loaded->scenario;
  const sim::CameraBackend camera_backend =
      sim::ParseCameraBackend(backend.value_or(scenario.camera_backend));
  if (scenario.FindCar(car_id) == nullptr) {
    std::string ids;
    for (const sim::CarConfig& c : scenario.cars)
      ids += (ids.empty() ? "" : ", ") + std::to_string(c.id);
    fmt::print(stderr, "error: --car {}: {} has no such car (its cars: {})\n", car_id,
               scenario_file, ids);
    return kExitUnusableInput;
  }
  const double duration_s = ToSeconds(scenario.duration);
  if (!(std::isfinite(at_s) && at_s >= 0.0 && at_s <= duration_s)) {
    fmt::print(stderr, "error: --at {}: must be within the scenario's [0, {}] s\n", at_s,
               duration_s);
    return kExitUnusableInput;
  }
  const Time at = FromSeconds(at_s);
  const auto start = std::chrono::steady_clock::now();
  const sim::WorldSnapshot snapshot = sim::SnapshotAt(*loaded, at);
  std::vector<sim::RenderedCamera> cameras;
  try {
    cameras = sim::RenderCameras(loaded->track, snapshot, car_id,
                                 scenario.FindCar(car_id)->sensors, scenario.appearance,
                                 sim::RngStreams(scenario.seed), camera_backend);
  } catch (const vehicle::GlUnavailable& e) {
    fmt::print(stderr, "error: --backend gl: no OpenGL ES context can be made here: {}\n",
               e.what());
    return kExitUnusableInput;
  }
  sim::WriteRenderFolder(cameras, at, car_id, out, force);
  for (const sim::RenderedCamera& camera : cameras) {
    fmt::print("{}: {}\n", camera.name, (fs::path(out) / camera.name).string());
  }
  fmt::print("car {} at {} s of {} rendered ({}) in {:.2f} s wall\n", car_id, at_s, scenario.name,
             camera_backend == sim::CameraBackend::kGl ? "gl" : "raycast",
             WallSecondsSince(start));
  return kExitOk;
}

}  // namespace

Command AddRenderCommand(CLI::App& parent) {
  struct Options {
    std::string scenario;
    int car{0};
    double at_s{0.0};
    std::string out;
    std::optional<std::uint64_t> seed;
    std::vector<std::string> overrides;
    std::optional<std::string> backend;
    bool force{false};
  };
  auto o = std::make_shared<Options>();
  CLI::App* render = parent.add_subcommand(
      "render",
      "Run a scenario up to an instant and write what one car's cameras see then: "
      "DIR/<camera>/ with what that camera publishes: color_camera/color.png; "
      "depth_camera/depth.png (uint16 mm) and depth_preview.png (false colour, with a colour "
      "bar); camera_info.json for each");
  render->add_option("SCENARIO", o->scenario, "Scenario file (YAML)")->required();
  render->add_option("--car", o->car, "The car's id")->required()->type_name("ID");
  render->add_option("--at", o->at_s, "The instant, seconds of simulated time")
      ->required()
      ->type_name("T");
  render
      ->add_option("--out", o->out,
                   "Output folder; replaced if an earlier run, render, check or sweep wrote it "
                   "(else refused: see --force)")
      ->required()
      ->type_name("DIR");
  render
      ->add_option("--backend", o->backend,
                   "How the images are made: raycast (the ray caster) or gl (rasterised with "
                   "OpenGL ES in an offscreen EGL context); default: the scenario's "
                   "camera_backend, raycast unless it says otherwise")
      ->check(CLI::IsMember({"raycast", "gl"}))
      ->type_name("raycast|gl");
  render->add_flag("--force", o->force,
                   "Replace --out even if this program did not write it (never a device)");
  AddSeedOption(render, &o->seed);
  AddSetOption(render, &o->overrides);
  return {render, [o] {
            return RenderCommand(o->scenario, o->car, o->at_s, o->out, o->seed, o->overrides,
                                 o->backend, o->force);
          }};
}

}  // namespace autonomsim::cli
