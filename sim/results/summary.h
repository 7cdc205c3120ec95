// summary.json: what a run came to, in one file of its folder (ARCHITECTURE "Scenarios and
// outputs"), and the one definition of that file's format. The Describe functions below list every
// key once; the same lists write the file (SummaryJson) and read it back (ParseSummary), so the
// run folder that writes it and the sweep that tables and plots it cannot drift apart. Users'
// scripts read these keys: rename none.
//
// Describe is a free function here, not a member as for config structs (sim/core/config.h): most
// of these structs are the run record's (sim/scenario/run_record.h), which knows nothing of files.
// An optional is written as null when empty, unless its key is left out then (kLeftOut); a double
// that is not finite is written as null (JSON has no NaN) and read back as NaN. Reading is strict
// about the keys listed (each must be there, with its type; optionals may be missing) and ignores
// others, so a newer file still reads.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "sim/results/expectations.h"
#include "sim/scenario/run_record.h"
#include "sim/scenario/scenario.h"

namespace autonomsim::sim {

// What made the run.
struct SummaryVersions {
  std::string autonomsim;
  std::string box2d;
  std::string opencv;
  std::string compiler;
};

struct RunSummary {
  std::string scenario;  // the scenario's name
  std::string scenario_file;
  std::uint64_t seed{0};
  std::string scenario_sha256;  // of the resolved scenario (LoadedScenario::sha256)
  std::string result_sha256;    // ResultSha256 of the run's record
  double sim_seconds{0.0};
  double wall_seconds{0.0};                // host time the simulation took; 0: not measured
  std::optional<double> real_time_factor;  // sim_seconds / wall_seconds; empty when wall is 0
  std::uint64_t kernel_events{0};
  std::vector<ExpectationResult> expectations;
  bool passed{true};  // every expectation passed
  std::vector<CarMetrics> cars;
  RunRecord::ServerCounters server;
  RunRecord::LinkCounters v2i;
  // A real-time run's pacing and broker traffic (v2i.link: realtime); left out for other runs.
  std::optional<RealTimeMetrics> realtime;
  // Per board (the cars that have one): sim/platform's ReportJson as is, a format that module
  // defines. Left out when no car has a board.
  std::optional<std::map<std::string, nlohmann::json>> platform;
  SummaryVersions versions;
  // The keys the scenario sets itself against its stack.preset (LoadedScenario::preset_overrides);
  // written always ([] when none); missing in files written before it existed.
  std::optional<std::vector<PresetOverride>> preset_overrides;
};

// The summary of a finished run; `wall_seconds` is the host time its simulation took (0: not
// measured).
RunSummary Summarize(const LoadedScenario& scenario, const RunRecord& record,
                     const std::vector<ExpectationResult>& expectations, double wall_seconds);

nlohmann::json SummaryJson(const RunSummary& summary);
// ConfigError naming the key path (e.g. "cars[1].laps") of a missing key or a value of the wrong
// type.
RunSummary ParseSummary(const nlohmann::json& json);
// Reads a summary.json file; ConfigError naming the file when it cannot be read or parsed.
RunSummary ReadSummaryFile(const std::filesystem::path& file);

// ---- The format ----

// How an empty optional is written: as null, or by leaving its key out.
enum class IfEmpty { kNull, kLeftOut };

template <class V>
void Describe(V& v, ExpectationResult& e) {
  v("name", e.name);
  v("passed", e.passed);
  v("detail", e.detail);
  v("at_s", e.at_s, IfEmpty::kLeftOut);  // the first violation's instant, where there is one
  v("car", e.car, IfEmpty::kLeftOut);    // and its car
}

template <class V>
void Describe(V& v, PerceptionMetrics& p) {
  v("lane_frames", p.lane_frames);
  v("lane_valid_frames", p.lane_valid_frames);
  v("lane_error_samples", p.lane_error_samples);
  v("lane_error_max_m", p.lane_error_max_m);
  v("lane_error_rms_m", p.lane_error_rms_m);
  v("grid_frames", p.grid_frames);
  v("grid_obstacle_frames", p.grid_obstacle_frames);
}

template <class V>
void Describe(V& v, StackMetrics& s) {
  v("control_cycles", s.control_cycles);
  v("follow_path_cycles", s.follow_path_cycles);
  v("collision_cycles", s.collision_cycles);
  v("recoveries", s.recoveries);
  v("navigation_failed", s.navigation_failed);
  v("max_localization_error_m", s.max_localization_error_m);
  v("final_localization_error_m", s.final_localization_error_m);
}

template <class V>
void Describe(V& v, CarMetrics& c) {
  v("id", c.id);
  v("route", c.route);
  v("route_length_m", c.route_length_m);
  v("laps", c.laps);
  v("lap_times_s", c.lap_times_s);
  v("collisions", c.collisions);
  v("max_lateral_error_m", c.max_lateral_error_m);
  v("rms_lateral_error_m", c.rms_lateral_error_m);
  v("distance_m", c.distance_m);
  v("mean_speed_mps", c.mean_speed_mps);
  v("intersection_entries", c.intersection_entries);
  v("waits", c.waits);
  v("total_wait_s", c.total_wait_s);
  v("max_wait_s", c.max_wait_s);
  v("min_obstacle_gap_m", c.min_obstacle_gap_m);  // null when no obstacle came near
  v("perception", c.perception, IfEmpty::kLeftOut);
  v("stack", c.stack, IfEmpty::kLeftOut);
}

template <class V>
void Describe(V& v, RunRecord::ServerCounters& s) {
  v("requests", s.requests);
  v("grants", s.grants);
  v("denials", s.denials);
  v("frees", s.frees);
  v("lease_expiries", s.lease_expiries);
  v("malformed", s.malformed);
}

template <class V>
void Describe(V& v, RunRecord::LinkCounters& l) {
  v("sent", l.sent);
  v("delivered", l.delivered);
  v("lost", l.lost);
}

template <class V>
void Describe(V& v, RealTimeMetrics& r) {
  v("slice_s", r.slice_s);
  v("slices", r.slices);
  v("late_slices", r.late_slices);
  v("pacing_max_lag_s", r.pacing_max_lag_s);
  v("pacing_mean_lag_s", r.pacing_mean_lag_s);
  v("messages_sent", r.messages_sent);
  v("messages_received", r.messages_received);
}

template <class V>
void Describe(V& v, PresetOverride& o) {
  v("key", o.key);
  v("preset", o.preset);
  v("preset_value", o.preset_value);
  v("value", o.value);
}

template <class V>
void Describe(V& v, SummaryVersions& s) {
  v("autonomsim", s.autonomsim);
  v("box2d", s.box2d);
  v("opencv", s.opencv);
  v("compiler", s.compiler);
}

template <class V>
void Describe(V& v, RunSummary& s) {
  v("scenario", s.scenario);
  v("scenario_file", s.scenario_file);
  v("seed", s.seed);
  v("scenario_sha256", s.scenario_sha256);
  v("result_sha256", s.result_sha256);
  v("sim_seconds", s.sim_seconds);
  v("wall_seconds", s.wall_seconds);
  v("real_time_factor", s.real_time_factor);
  v("kernel_events", s.kernel_events);
  v("expectations", s.expectations);
  v("passed", s.passed);
  v("cars", s.cars);
  v("server", s.server);
  v("v2i", s.v2i);
  v("realtime", s.realtime, IfEmpty::kLeftOut);
  v("platform", s.platform, IfEmpty::kLeftOut);
  v("versions", s.versions);
  v("preset_overrides", s.preset_overrides);
}

}  // namespace autonomsim::sim
