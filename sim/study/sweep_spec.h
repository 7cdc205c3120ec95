// A sweep's grid (issue 8): --vary specs and study files parsed into a SweepSpec, the grid it
// expands to, and the --shard that selects part of it. Pure: nothing is run or written.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

namespace autonomsim::sim {

// One value of a varied key: the YAML text given to ApplyOverride, and how tables and plots name
// it (the text itself unless a study file gives labels).
struct VaryValue {
  std::string label;
  std::string yaml;
};

// One --vary: a --set path (sim/core/config.h ApplyOverride) and its values.
struct VaryAxis {
  std::string key;
  std::vector<VaryValue> values;
};

// Splits `text` at `separator` where it is not inside [], {} or quotes (so YAML flow values such
// as {target: sw} or [1, 2] stay whole); parts are trimmed of surrounding spaces.
std::vector<std::string> SplitTopLevel(const std::string& text, char separator);

// The whole text as a finite number, or nullopt (empty, trailing characters, inf, nan).
std::optional<double> ParseFiniteNumber(const std::string& text);

// "key=a,b,c" (each value YAML) or "key=start:stop:count" (count >= 2 evenly spaced numbers from
// start to stop inclusive, or count = 1: start). ConfigError naming the spec when malformed.
VaryAxis ParseVary(const std::string& spec);

// A key varied twice (two --vary of one key, or a study's vary and a --vary) would give two table
// columns of one name and the same run twice: ConfigError naming the key and saying to give its
// values in one --vary.
void CheckAxesDistinct(const std::vector<VaryAxis>& axes);

// The most values one range --vary (start:stop:count) may give.
inline constexpr int kMaxRangeCount = 1'000'000;
// The most runs (grid points × repeat) a sweep may have unless `sweep --max-runs` raises it: its
// table of points is built before the first run, and 10^5 runs of the default scenario are 1.5
// core-days.
inline constexpr std::uint64_t kDefaultMaxRuns = 100'000;

struct SweepSpec {
  std::filesystem::path scenario;
  std::vector<std::string> overrides;  // --set, applied to every run before the varied keys
  std::vector<VaryAxis> axes;
  int repeat{1};  // seeds per grid point: the scenario's seed, seed + 1, ..., seed + repeat - 1

  nlohmann::json ToJson() const;
  static SweepSpec FromJson(const nlohmann::json& json);
};

// The sweep's runs (the axes' sizes times repeat, without overflow). ConfigError, naming the
// grid, the seeds and how to raise the limit, when they are more than `max_runs`.
std::uint64_t CheckSweepSize(const SweepSpec& spec, std::uint64_t max_runs);

// A study file (scenarios/studies/*.yaml): `scenario` (relative to the study file's folder),
// optional `description`, `set` (list of key=value), `repeat`, and `vary` (none: one point,
// `repeat` seeds of it): a list of
// {key, values} (values a list of YAML values, or a mapping label: value) or {key, range:
// [start, stop, count]}, or a string "key=..." as on the command line. ConfigError on bad input.
SweepSpec LoadStudy(const std::filesystem::path& file);
// Whether `file` is a study file (a YAML mapping with a top-level `scenario` key) rather than a
// scenario. ConfigError if it is not a regular file (RequireRegularFile).
bool IsStudyFile(const std::filesystem::path& file);

// One run of the grid: its place in grid order (the axes in the order given, the last varying
// fastest, repeats innermost), the value chosen on each axis, and its repeat number.
struct SweepPoint {
  std::size_t index{0};
  std::vector<std::size_t> value_index;  // per axis
  int repeat{0};
};
std::vector<SweepPoint> ExpandGrid(const SweepSpec& spec);
// The --set list of one point (the spec's overrides, then one per axis).
std::vector<std::string> PointOverrides(const SweepSpec& spec, const SweepPoint& point);

// --shard k/n (1 <= k <= n): this process runs the points whose index % n == k - 1.
struct Shard {
  int k{1};
  int n{1};
};
Shard ParseShard(const std::string& text);  // "k/n"; ConfigError when malformed
bool InShard(std::size_t index, const Shard& shard);

}  // namespace autonomsim::sim
