// `autonomsim render SCENARIO --car ID --at T --out DIR`: what one car's cameras see at one
// instant, one folder per camera.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "sim/core/config.h"
#include "sim/core/files.h"
#include "sim/results/render.h"
#include "tools/cli_common.h"

namespace autonomsim::cli {
namespace {

namespace fs = std::filesystem;

struct RenderArgs {
  std::string scenario;
  int car{0};
  std::vector<double> at_s;
  std::string out;
  std::optional<std::uint64_t> seed;
  std::vector<std::string> overrides;
  std::optional<std::string> backend;
  bool labels{false};
  bool force{false};
};

int RenderCommand(const RenderArgs& a) {
  try {  // refused before anything runs
    sim::CheckOutputFolder(a.out, a.force, sim::OutputKind::kRender);
  } catch (const sim::ConfigError& e) {
    fmt::print(stderr, "error: {}\n", e.what());
    return kExitUnusableInput;
  }
  std::optional<sim::LoadedScenario> loaded;
  try {
    loaded.emplace(sim::LoadScenario(a.scenario, a.overrides, a.seed));
  } catch (const sim::ConfigError& e) {
    fmt::print(stderr, "error: {}\n", e.what());
    return kExitUnusableInput;
  }
  const sim::Scenario& scenario = loaded->scenario;
  const sim::CameraBackend camera_backend =
      a.backend ? sim::ParseCameraBackend(*a.backend) : scenario.camera_backend;
  const sim::CarConfig* car = scenario.FindCar(a.car);
  if (car == nullptr) {
    std::string ids;
    for (const sim::CarConfig& c : scenario.cars)
      ids += (ids.empty() ? "" : ", ") + std::to_string(c.id);
    fmt::print(stderr, "error: --car {}: {} has no such car (its cars: {})\n", a.car, a.scenario,
               ids);
    return kExitUnusableInput;
  }
  const double duration_s = ToSeconds(scenario.duration);
  std::vector<Time> instants;
  for (const double at_s : a.at_s) {
    if (!(std::isfinite(at_s) && at_s >= 0.0 && at_s <= duration_s)) {
      fmt::print(stderr, "error: --at {}: must be within the scenario's [0, {}] s\n", at_s,
                 duration_s);
      return kExitUnusableInput;
    }
    const Time t = FromSeconds(at_s);
    if (a.at_s.size() > 1 && t % std::chrono::milliseconds(1) != Time{0}) {
      fmt::print(stderr, "error: --at {}: several instants must each be whole milliseconds\n",
                 at_s);
      return kExitUnusableInput;
    }
    instants.push_back(t);
  }
  std::sort(instants.begin(), instants.end());
  instants.erase(std::unique(instants.begin(), instants.end()), instants.end());
  const auto start = std::chrono::steady_clock::now();
  const std::vector<sim::WorldSnapshot> snapshots = sim::SnapshotsAt(*loaded, instants);
  std::optional<sim::CarCameras> cameras;
  try {
    cameras.emplace(loaded->track, car->sensors, scenario.appearance, camera_backend);
  } catch (const vehicle::GlUnavailable& e) {
    fmt::print(stderr, "error: --backend gl: {}\n", e.what());
    return kExitUnusableInput;
  }
  const sim::RngStreams streams(scenario.seed);
  std::vector<sim::RenderedInstant> rendered;
  for (const sim::WorldSnapshot& snapshot : snapshots) {
    rendered.push_back({snapshot.t, cameras->Render(snapshot, a.car, streams, a.labels),
                        a.labels ? cameras->InstancesJson(snapshot, a.car) : nlohmann::json()});
  }
  sim::WriteRenderFolder(rendered, a.car, cameras->ClassNames(), a.out, a.force);
  if (rendered.size() == 1) {
    for (const sim::RenderedCamera& camera : rendered.front().cameras) {
      fmt::print("{}: {}\n", camera.name, (fs::path(a.out) / camera.name).string());
    }
  } else {
    fmt::print("{} instants: {}/t_*/\n", rendered.size(), a.out);
  }
  fmt::print("car {} at {} instant(s) of {} rendered ({}{}) in {:.2f} s wall\n", a.car,
             rendered.size(), scenario.name, ToName(camera_backend),
             a.labels ? ", with labels" : "", WallSecondsSince(start));
  return kExitOk;
}

}  // namespace

Command AddRenderCommand(CLI::App& parent) {
  auto o = std::make_shared<RenderArgs>();
  CLI::App* render = parent.add_subcommand(
      "render",
      "Run a scenario up to an instant and write what one car's cameras see then: "
      "DIR/<camera>/ with what that camera publishes: color_camera/color.png; "
      "depth_camera/depth.png (uint16 mm) and depth_preview.png (false colour, with a colour "
      "bar); camera_info.json for each. With several instants (--at 5 10 15), one run and a "
      "folder per instant, DIR/t_0005.000/<camera>/...: a camera dataset");
  render->add_option("SCENARIO", o->scenario, "Scenario file (YAML)")->required();
  render->add_option("--car", o->car, "The car's id")->required()->type_name("ID");
  render
      ->add_option("--at", o->at_s,
                   "The instant(s), seconds of simulated time (several: whole milliseconds)")
      ->required()
      ->expected(1, -1)
      ->delimiter(',')
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
  render->add_flag("--labels", o->labels,
                   "Also write ground-truth labels: <camera>/labels.png (each pixel's class: "
                   "floor, paint colour, car, obstacle), <camera>/instances.png (which object) "
                   "and labels.json, their legend");
  render->add_flag("--force", o->force,
                   "Replace --out even if this program did not write it (never a device)");
  AddSeedOption(render, &o->seed);
  AddSetOption(render, &o->overrides);
  return {render, [o] { return RenderCommand(*o); }};
}

}  // namespace autonomsim::cli
