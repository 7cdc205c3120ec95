#include "sim/results/summary.h"

#include <box2d/b2_settings.h>
#include <fmt/format.h>

#include <cmath>
#include <concepts>
#include <fstream>
#include <limits>
#include <opencv2/core/version.hpp>
#include <type_traits>

#include "sim/core/config.h"
#include "sim/core/files.h"
#include "sim/platform/node_metrics.h"

#ifndef AUTONOMSIM_VERSION
#define AUTONOMSIM_VERSION "unknown"
#endif

namespace autonomsim::sim {
namespace {

using detail::IsMap;
using detail::IsOptional;
using detail::IsVector;

// ---- Writing ----

template <class T>
nlohmann::json ToJsonValue(const T& value);

class Writer {
 public:
  template <class T>
  void operator()(const char* key, const T& value, IfEmpty if_empty = IfEmpty::kNull) {
    if constexpr (IsOptional<T>::value) {
      if (!value && if_empty == IfEmpty::kLeftOut) return;
    }
    json_[key] = ToJsonValue(value);
  }
  nlohmann::json take() { return std::move(json_); }

 private:
  nlohmann::json json_ = nlohmann::json::object();
};

template <class T>
nlohmann::json ToJsonValue(const T& value) {
  if constexpr (IsOptional<T>::value) {
    return value ? ToJsonValue(*value) : nlohmann::json();
  } else if constexpr (IsVector<T>::value) {
    nlohmann::json array = nlohmann::json::array();
    for (const auto& item : value) array.push_back(ToJsonValue(item));
    return array;
  } else if constexpr (IsMap<T>::value) {
    nlohmann::json object = nlohmann::json::object();
    for (const auto& [key, item] : value) object[key] = ToJsonValue(item);
    return object;
  } else if constexpr (requires(Writer & w, T & t) { Describe(w, t); }) {
    Writer writer;
    Describe(writer, const_cast<T&>(value));  // Describe only reads through a Writer
    return writer.take();
  } else {
    return nlohmann::json(value);  // nlohmann writes a non-finite double as null
  }
}

// ---- Reading ----

[[noreturn]] void Fail(const std::string& path, const std::string& message) {
  throw ConfigError((path.empty() ? std::string("(top level)") : path) + ": " + message);
}

template <class T>
void Read(const nlohmann::json& json, T& out, const std::string& path);

class Reader {
 public:
  Reader(const nlohmann::json& json, std::string path) : json_(json), path_(std::move(path)) {}

  template <class T>
  void operator()(const char* key, T& value, IfEmpty = IfEmpty::kNull) {
    const std::string path = detail::JoinPath(path_, key);
    const auto it = json_.find(key);
    if (it != json_.end()) {
      Read(*it, value, path);
    } else if constexpr (IsOptional<T>::value) {
      value.reset();
    } else {
      Fail(path, "missing");
    }
  }

 private:
  const nlohmann::json& json_;
  std::string path_;
};

template <class T>
void Read(const nlohmann::json& json, T& out, const std::string& path) {
  if constexpr (IsOptional<T>::value) {
    if (json.is_null()) {
      out.reset();
    } else {
      typename T::value_type value{};
      Read(json, value, path);
      out = std::move(value);
    }
  } else if constexpr (IsVector<T>::value) {
    if (!json.is_array()) Fail(path, "expected a list, got " + json.dump());
    out.clear();
    for (std::size_t i = 0; i < json.size(); ++i) {
      typename T::value_type value{};
      Read(json[i], value, detail::JoinIndex(path, i));
      out.push_back(std::move(value));
    }
  } else if constexpr (IsMap<T>::value) {
    if (!json.is_object()) Fail(path, "expected an object, got " + json.dump());
    out.clear();
    for (const auto& [key, item] : json.items()) {
      typename T::mapped_type value{};
      Read(item, value, detail::JoinPath(path, key));
      out.emplace(key, std::move(value));
    }
  } else if constexpr (std::is_same_v<T, nlohmann::json>) {
    out = json;
  } else if constexpr (requires(Reader & r, T & t) { Describe(r, t); }) {
    if (!json.is_object()) Fail(path, "expected an object, got " + json.dump());
    Reader reader(json, path);
    Describe(reader, out);
  } else if constexpr (std::is_same_v<T, bool>) {
    if (!json.is_boolean()) Fail(path, "expected true or false, got " + json.dump());
    out = json.get<bool>();
  } else if constexpr (std::is_same_v<T, std::string>) {
    if (!json.is_string()) Fail(path, "expected a string, got " + json.dump());
    out = json.get<std::string>();
  } else if constexpr (std::floating_point<T>) {
    if (json.is_null()) {
      out = std::numeric_limits<T>::quiet_NaN();  // written from a NaN or an infinity
    } else {
      if (!json.is_number()) Fail(path, "expected a number, got " + json.dump());
      out = json.get<T>();
    }
  } else {
    static_assert(std::integral<T>, "summary.json holds bools, integers, doubles and strings");
    const bool fits = std::is_signed_v<T> ? json.is_number_integer() : json.is_number_unsigned();
    if (!fits) Fail(path, "expected a whole number, got " + json.dump());
    out = json.get<T>();
  }
}

}  // namespace

RunSummary Summarize(const LoadedScenario& loaded, const RunRecord& record,
                     const std::vector<ExpectationResult>& expectations, double wall_seconds) {
  RunSummary summary;
  summary.scenario = loaded.scenario.name;
  summary.scenario_file = loaded.file.string();
  summary.seed = loaded.scenario.seed;
  summary.scenario_sha256 = loaded.sha256;
  summary.result_sha256 = ResultSha256(record);
  summary.sim_seconds = ToSeconds(record.sim_duration);
  summary.wall_seconds = wall_seconds;
  if (wall_seconds > 0.0) summary.real_time_factor = summary.sim_seconds / wall_seconds;
  summary.kernel_events = record.kernel_events;
  summary.expectations = expectations;
  for (const ExpectationResult& r : expectations) summary.passed = summary.passed && r.passed;
  summary.cars = record.cars;
  summary.server = record.server;
  summary.v2i = record.v2i;
  summary.realtime = record.realtime;
  if (!record.boards.empty()) {
    summary.platform.emplace();
    for (const BoardReport& board : record.boards) {
      (*summary.platform)[board.board] = ReportJson(board.report);
    }
  }
  summary.preset_overrides = loaded.preset_overrides;
  summary.versions = {
      .autonomsim = AUTONOMSIM_VERSION,
      .box2d = fmt::format("{}.{}.{}", b2_version.major, b2_version.minor, b2_version.revision),
      .opencv = CV_VERSION,
      .compiler = __VERSION__};
  return summary;
}

nlohmann::json SummaryJson(const RunSummary& summary) { return ToJsonValue(summary); }

RunSummary ParseSummary(const nlohmann::json& json) {
  RunSummary summary;
  Read(json, summary, "");
  return summary;
}

RunSummary ReadSummaryFile(const std::filesystem::path& file) {
  RequireRegularFile(file);
  std::ifstream in(file);
  if (!in) throw ConfigError(file.string() + ": cannot read");
  try {
    return ParseSummary(nlohmann::json::parse(in));
  } catch (const nlohmann::json::exception& e) {
    throw ConfigError(file.string() + ": not valid JSON: " + e.what());
  } catch (const ConfigError& e) {
    throw ConfigError(file.string() + ": " + e.what());
  }
}

}  // namespace autonomsim::sim
