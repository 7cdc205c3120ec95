// autonomsim._core: the bindings of the Python module (docs/python.md) over sim/. What is here
// is the thinnest layer that keeps the C++ objects alive and moves their results into Python;
// names, defaults, docstrings and conveniences live in the pure Python layer (autonomsim/).
//
// The GIL is released while a simulation runs (run, Simulation.advance_to and finish), so that
// runs on several Python threads go on in parallel; every object here is used by one thread at a
// time (the Python layer's Simulation holds a lock). Results move as JSON text where they are
// nested (summary, events, board reports): the Python layer parses it, and the C++ writers that
// make it are the ones the run folder's files come from.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <yaml-cpp/yaml.h>

#include <chrono>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "sim/core/config.h"
#include "sim/core/files.h"
#include "sim/loop/simulation.h"
#include "sim/platform/node_metrics.h"
#include "sim/results/expectations.h"
#include "sim/results/outputs.h"
#include "sim/results/summary.h"
#include "sim/scenario/run_record.h"
#include "sim/scenario/scenario.h"
#include "sim/study/sweep.h"

namespace py = pybind11;

namespace autonomsim::python {
namespace {

using sim::LoadedScenario;
using Scenario = std::shared_ptr<const LoadedScenario>;

Scenario Load(const std::string& file, const std::vector<std::string>& overrides,
              std::optional<std::uint64_t> seed) {
  return std::make_shared<const LoadedScenario>(sim::LoadScenario(file, overrides, seed));
}

// A finished run: its record and verdicts, and the scenario it came from.
struct Finished {
  Scenario scenario;
  sim::RunRecord record;
  std::vector<sim::ExpectationResult> expectations;
  double wall_seconds{0.0};  // host time the simulation took (summary.json's wall_seconds)

  bool passed() const {
    for (const sim::ExpectationResult& e : expectations) {
      if (!e.passed) return false;
    }
    return true;
  }
  std::string SummaryJson() const {
    return sim::SummaryJson(sim::Summarize(*scenario, record, expectations, wall_seconds)).dump();
  }
  std::string EventsJson() const {
    nlohmann::json events = nlohmann::json::array();
    sim::ForEachEvent(record, [&](const sim::Event& e) { events.push_back(sim::EventJson(e)); });
    return events.dump();
  }
  std::string NodesCsv() const { return record.boards.empty() ? "" : sim::NodesCsv(record.boards); }
  // The columns of trajectory.csv, each as a numpy array (t_s and the doubles as float64, car as
  // int64): the same numbers the file writes, which prints each double in its shortest exact form.
  py::dict Trajectory() const;
  // The run's folder, as `autonomsim run --out` writes it.
  void Write(const std::string& out_dir, bool force) const {
    sim::WriteRunFolder(*scenario, record, expectations, wall_seconds, out_dir, force);
  }
};

py::dict Finished::Trajectory() const {
  std::vector<const sim::TrajectorySample*> samples;
  sim::ForEachSample(record, [&](const sim::TrajectorySample& s) { samples.push_back(&s); });
  const auto column = [&](auto field) {
    using T = decltype(field(*samples.front()));
    py::array_t<T> array(static_cast<py::ssize_t>(samples.size()));
    auto out = array.template mutable_unchecked<1>();
    for (std::size_t i = 0; i < samples.size(); ++i)
      out(static_cast<py::ssize_t>(i)) = field(*samples[i]);
    return array;
  };
  py::dict columns;
  if (samples.empty()) return columns;
  using S = sim::TrajectorySample;
  columns["t_s"] = column([](const S& s) { return ToSeconds(s.t); });
  columns["car"] = column([](const S& s) { return static_cast<std::int64_t>(s.car); });
  columns["x_m"] = column([](const S& s) { return s.x_m; });
  columns["y_m"] = column([](const S& s) { return s.y_m; });
  columns["yaw_rad"] = column([](const S& s) { return s.yaw_rad; });
  columns["speed_mps"] = column([](const S& s) { return s.speed_mps; });
  columns["steering_rad"] = column([](const S& s) { return s.steering_rad; });
  columns["throttle"] = column([](const S& s) { return s.throttle; });
  columns["curvature_cmd_per_m"] = column([](const S& s) { return s.curvature_cmd_per_m; });
  columns["lateral_error_m"] = column([](const S& s) { return s.lateral_error_m; });
  columns["route_progress_m"] = column([](const S& s) { return s.route_progress_m; });
  return columns;
}

double SecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// One run in steps. The simulation refers to its scenario, which it therefore keeps.
class Stepper {
 public:
  explicit Stepper(Scenario scenario)
      : scenario_(std::move(scenario)),
        simulation_(std::make_unique<sim::Simulation>(*scenario_)) {}

  double time_s() const { return ToSeconds(simulation_->now()); }
  double end_s() const { return ToSeconds(simulation_->end()); }
  bool finished() const { return simulation_->finished(); }

  void AdvanceTo(double t_s) {
    const Time t = FromSeconds(t_s);
    Timed([&] { simulation_->AdvanceTo(t); });
  }
  std::shared_ptr<Finished> Finish() {
    Timed([&] { simulation_->Finish(); });
    auto done = std::make_shared<Finished>();
    done->scenario = scenario_;
    done->record = simulation_->record();
    done->expectations = sim::EvaluateExpectations(scenario_->scenario, done->record);
    done->wall_seconds = wall_seconds_;
    return done;
  }
  // A fault as a `faults:` entry, in YAML or JSON ({car_stall: {car: 0, for_s: 2}}), at now.
  void Inject(const std::string& fault_text);
  py::list Cars() const;
  py::list Server() const;
  py::list Boards() const;
  // events.jsonl's events of time >= t_s so far, as a JSON array.
  std::string EventsSince(double t_s) const;

 private:
  template <class F>
  void Timed(F&& step) {
    const auto start = std::chrono::steady_clock::now();
    {
      py::gil_scoped_release unlocked;
      step();
    }
    wall_seconds_ += SecondsSince(start);
  }

  Scenario scenario_;
  std::unique_ptr<sim::Simulation> simulation_;
  double wall_seconds_{0.0};
};

void Stepper::Inject(const std::string& fault_text) {
  YAML::Node node;
  try {
    node = YAML::Load(fault_text);
  } catch (const YAML::Exception& e) {
    throw sim::ConfigError("inject: " + std::string(e.what()));
  }
  sim::FaultClause fault;
  try {
    fault = sim::ReadConfig<sim::FaultClause>(node, sim::ConfigSource{.file = "inject"});
  } catch (const sim::ConfigError& e) {
    // "inject:LINE:COL: kind.key: message": the line and column are the JSON text's, which the
    // caller never saw; the key path alone locates it
    const std::string message = e.what();
    const std::size_t key = message.find(": ");
    throw sim::ConfigError(key == std::string::npos ? message : message.substr(key + 2));
  }
  try {
    std::visit([](const auto& f) { f.Validate(); }, fault);
  } catch (const std::invalid_argument& e) {
    throw sim::ConfigError(std::string(ToName(sim::KindOf(fault))) + ": " + e.what());
  }
  simulation_->Inject(std::move(fault));
}

py::dict PoseDict(const world::Pose2& pose) {
  py::dict d;
  d["x_m"] = pose.x_m;
  d["y_m"] = pose.y_m;
  d["yaw_rad"] = pose.yaw_rad;
  return d;
}

py::list Stepper::Cars() const {
  py::list cars;
  for (const sim::Simulation::CarState& c : simulation_->Cars()) {
    py::dict car;
    car["id"] = c.id;
    car["pose"] = PoseDict(c.pose);
    car["speed_mps"] = c.speed_mps;
    car["steering_rad"] = c.steering_rad;
    car["lateral_error_m"] = c.lateral_error_m;
    car["route_progress_m"] = c.route_progress_m;
    car["laps"] = c.laps;
    car["estimate"] = c.estimate ? py::object(PoseDict(*c.estimate)) : py::none();
    car["behavior_mode"] = c.behavior_mode ? py::object(py::str(*c.behavior_mode)) : py::none();
    cars.append(car);
  }
  return cars;
}

py::list Stepper::Server() const {
  py::list areas;
  for (const sim::Simulation::IntersectionState& s : simulation_->Server()) {
    py::dict area;
    area["intersection"] = s.id;
    area["holder"] = s.holder >= 0 ? py::object(py::int_(s.holder)) : py::none();
    area["queue"] = s.queue;
    areas.append(area);
  }
  return areas;
}

py::list Stepper::Boards() const {
  py::list boards;
  for (const sim::Simulation::BoardState& b : simulation_->Boards()) {
    py::dict board;
    board["car"] = b.car;
    board["name"] = b.name;
    board["busy_cores"] = b.busy_cores;
    board["report_json"] = b.report.dump();
    boards.append(board);
  }
  return boards;
}

std::string Stepper::EventsSince(double t_s) const {
  const Time from = FromSeconds(t_s);
  nlohmann::json events = nlohmann::json::array();
  sim::ForEachEvent(simulation_->record(), [&](const sim::Event& e) {
    if (e.t >= from) events.push_back(sim::EventJson(e));
  });
  return events.dump();
}

std::shared_ptr<Finished> Run(const Scenario& scenario) {
  Stepper stepper(scenario);
  return stepper.Finish();
}

// `autonomsim sweep`: a study file or a scenario, with --set, --vary and --repeat, into `out`
// (resumed: complete runs are not redone). Returns what it did; the table is out/results.csv.
py::dict Sweep(const std::string& file, const std::vector<std::string>& overrides,
               const std::vector<std::string>& vary, std::optional<int> repeat, int jobs,
               const std::string& out, bool force, bool plots) {
  sim::SweepSpec spec;
  if (sim::IsStudyFile(file)) {
    spec = sim::LoadStudy(file);
  } else {
    spec.scenario = file;
  }
  spec.overrides.insert(spec.overrides.end(), overrides.begin(), overrides.end());
  for (const std::string& v : vary) spec.axes.push_back(sim::ParseVary(v));
  sim::CheckAxesDistinct(spec.axes);
  if (repeat) spec.repeat = *repeat;
  sim::SweepOptions options;
  sim::CheckSweepSize(spec, options.max_runs);  // before the folder is made
  options.jobs = jobs;
  options.plots = plots;
  options.out_dir = sim::PrepareOutputFolder(out, force);
  options.wall_clock = [] {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(
        std::chrono::steady_clock::now().time_since_epoch());
  };
  sim::SweepSummary summary;
  {
    py::gil_scoped_release unlocked;
    summary = sim::RunSweep(spec, options);
  }
  py::dict done;
  done["table"] = summary.table.string();
  done["grid_points"] = summary.grid_points;
  done["ran"] = summary.ran;
  done["already_done"] = summary.already_done;
  done["failures"] = summary.failures;
  done["failed_expectations"] = summary.failed_expectations;
  return done;
}

void BindScenario(py::module_& m) {
  py::class_<LoadedScenario, std::shared_ptr<LoadedScenario>>(m, "Scenario")
      .def_property_readonly("name", [](const LoadedScenario& s) { return s.scenario.name; })
      .def_property_readonly("file", [](const LoadedScenario& s) { return s.file.string(); })
      .def_property_readonly("seed", [](const LoadedScenario& s) { return s.scenario.seed; })
      .def_property_readonly("duration_s",
                             [](const LoadedScenario& s) { return ToSeconds(s.scenario.duration); })
      .def_property_readonly("sha256", [](const LoadedScenario& s) { return s.sha256; })
      .def_property_readonly("warnings", [](const LoadedScenario& s) { return s.warnings; })
      .def_property_readonly("resolved_json",
                             [](const LoadedScenario& s) { return s.resolved.dump(); });
  m.def(
      "load",
      [](const std::string& file, const std::vector<std::string>& overrides,
         std::optional<std::uint64_t> seed) -> std::shared_ptr<LoadedScenario> {
        Scenario loaded = Load(file, overrides, seed);
        return std::const_pointer_cast<LoadedScenario>(loaded);
      },
      py::arg("file"), py::arg("overrides"), py::arg("seed"));
}

void BindResults(py::module_& m) {
  py::class_<Finished, std::shared_ptr<Finished>>(m, "Finished")
      .def_property_readonly("passed", &Finished::passed)
      .def_property_readonly("result_sha256",
                             [](const Finished& f) { return sim::ResultSha256(f.record); })
      .def_property_readonly("wall_seconds", [](const Finished& f) { return f.wall_seconds; })
      .def("summary_json", &Finished::SummaryJson)
      .def("events_json", &Finished::EventsJson)
      .def("nodes_csv", &Finished::NodesCsv)
      .def("trajectory", &Finished::Trajectory)
      .def("write", &Finished::Write, py::arg("out"), py::arg("force"));
  m.def("sweep", &Sweep, py::arg("file"), py::arg("overrides"), py::arg("vary"), py::arg("repeat"),
        py::arg("jobs"), py::arg("out"), py::arg("force"), py::arg("plots"));
  m.def(
      "run", [](const std::shared_ptr<LoadedScenario>& scenario) { return Run(scenario); },
      py::arg("scenario"));
}

void BindStepper(py::module_& m) {
  py::class_<Stepper>(m, "Stepper")
      .def(py::init([](const std::shared_ptr<LoadedScenario>& s) {
             return std::make_unique<Stepper>(s);
           }),
           py::arg("scenario"))
      .def_property_readonly("time_s", &Stepper::time_s)
      .def_property_readonly("end_s", &Stepper::end_s)
      .def_property_readonly("finished", &Stepper::finished)
      .def("advance_to", &Stepper::AdvanceTo, py::arg("t_s"))
      .def("finish", &Stepper::Finish)
      .def("inject", &Stepper::Inject, py::arg("fault_text"))
      .def("cars", &Stepper::Cars)
      .def("server", &Stepper::Server)
      .def("boards", &Stepper::Boards)
      .def("events_since_json", &Stepper::EventsSince, py::arg("t_s"));
}

}  // namespace
}  // namespace autonomsim::python

PYBIND11_MODULE(_core, m) {
  using namespace autonomsim::python;
  m.doc() = "autonomsim's bindings over its C++ simulator; use the package `autonomsim` instead.";
  m.attr("__version__") = AUTONOMSIM_VERSION;
  // bad scenario input, with the CLI's message "file:line:col: key.path: message"; the Python
  // layer reads file, line and key out of it
  py::register_exception<autonomsim::sim::ConfigError>(m, "ScenarioError", PyExc_ValueError);
  py::register_exception<autonomsim::sim::OutputError>(m, "OutputError", PyExc_OSError);
  BindScenario(m);
  BindResults(m);
  BindStepper(m);
}
