#include "sim/scenario/run_record.h"

#include <fmt/format.h>

#include <array>
#include <charconv>
#include <cmath>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "sim/core/hash.h"

namespace autonomsim::sim {
namespace {

constexpr std::size_t kTrajectoryColumns = 11;

// `text` as a number of type T, all of it; throws std::invalid_argument naming `line` otherwise.
template <typename T>
T ParseField(std::string_view text, std::string_view line) {
  T value{};
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (error != std::errc() || end != text.data() + text.size()) {
    throw std::invalid_argument("not a trajectory.csv line: '" + std::string(line) + "'");
  }
  return value;
}

// The name of trajectory.csv's column i (from 0), as its header gives it.
std::string ColumnName(std::size_t i) {
  const std::string header = TrajectoryCsvHeader();
  std::size_t start = 0;
  for (std::size_t k = 0; k < i; ++k) start = header.find(',', start) + 1;
  return header.substr(start, header.find_first_of(",\n", start) - start);
}

}  // namespace

void ForEachEvent(const RunRecord& record, const std::function<void(const Event&)>& visit) {
  if (record.store) {
    record.store->ForEachEvent(visit);
    return;
  }
  for (const Event& e : record.events) visit(e);
}

void ForEachSample(const RunRecord& record,
                   const std::function<void(const TrajectorySample&)>& visit) {
  if (record.store) {
    record.store->ForEachSample(visit);
    return;
  }
  for (const TrajectorySample& s : record.trajectory) visit(s);
}

std::string TrajectoryCsvHeader() {
  return "t_s,car,x_m,y_m,yaw_rad,speed_mps,steering_rad,throttle,curvature_cmd_per_m,"
         "lateral_error_m,route_progress_m\n";
}

std::string TrajectoryCsvLine(const TrajectorySample& s) {
  return fmt::format("{},{},{},{},{},{},{},{},{},{},{}\n", ToSeconds(s.t), s.car, s.x_m, s.y_m,
                     s.yaw_rad, s.speed_mps, s.steering_rad, s.throttle, s.curvature_cmd_per_m,
                     s.lateral_error_m, s.route_progress_m);
}

TrajectorySample ParseTrajectoryCsvLine(std::string_view line) {
  if (!line.empty() && line.back() == '\n') line.remove_suffix(1);
  const auto malformed = [&] {
    return std::invalid_argument("not a trajectory.csv line: '" + std::string(line) + "'");
  };
  std::array<std::string_view, kTrajectoryColumns> fields;
  std::size_t count = 0;
  for (std::size_t start = 0;;) {
    if (count == kTrajectoryColumns) throw malformed();
    const std::size_t comma = line.find(',', start);
    fields[count++] = line.substr(start, comma == std::string_view::npos ? comma : comma - start);
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
  if (count != kTrajectoryColumns) throw malformed();
  auto number = [&](std::size_t i) {
    const double value = ParseField<double>(fields[i], line);
    if (!std::isfinite(value)) {  // from_chars takes "nan" and "inf"; a run writes neither
      throw std::invalid_argument(fmt::format("column {} ({}) is '{}': a run writes finite numbers",
                                              i + 1, ColumnName(i), fields[i]));
    }
    return value;
  };
  return TrajectorySample{.t = FromSeconds(number(0)),
                          .car = ParseField<int>(fields[1], line),
                          .x_m = number(2),
                          .y_m = number(3),
                          .yaw_rad = number(4),
                          .speed_mps = number(5),
                          .steering_rad = number(6),
                          .throttle = number(7),
                          .curvature_cmd_per_m = number(8),
                          .lateral_error_m = number(9),
                          .route_progress_m = number(10)};
}

std::string EventJsonLine(const Event& e) { return EventJson(e).dump() + "\n"; }

nlohmann::json EventJson(const Event& e) {
  nlohmann::json j = {{"t_s", ToSeconds(e.t)}, {"type", ToName(e.type)}};
  if (e.car >= 0) j["car"] = e.car;
  if (e.intersection >= 0) j["intersection"] = e.intersection;
  if (e.other_car >= 0) j["other_car"] = e.other_car;
  if (!e.obstacle.empty()) j["obstacle"] = e.obstacle;
  if (e.granted) j["granted"] = *e.granted;
  if (e.lap > 0) j["lap"] = e.lap;
  if (e.fault) j["fault"] = ToName(*e.fault);
  if (!e.detail.empty()) j["detail"] = e.detail;
  return j;
}

namespace {
template <NamedEnum E>
E ParseName(const std::string& name, const char* key) {
  if (const std::optional<E> value = FromName<E>(name)) return *value;
  throw std::invalid_argument(std::string("unknown ") + key + " '" + name +
                              "' (known: " + NameList<E>() + ")");
}
}  // namespace

Event ParseEventJsonLine(std::string_view line) {
  try {
    const nlohmann::json j = nlohmann::json::parse(line);
    Event e;
    e.t = FromSeconds(j.at("t_s").get<double>());
    e.type = ParseName<EventKind>(j.at("type").get<std::string>(), "type");
    e.car = j.value("car", -1);
    e.intersection = j.value("intersection", -1);
    e.other_car = j.value("other_car", -1);
    e.obstacle = j.value("obstacle", std::string());
    if (j.contains("granted")) e.granted = j.at("granted").get<bool>();
    e.lap = j.value("lap", 0);
    if (j.contains("fault"))
      e.fault = ParseName<FaultKind>(j.at("fault").get<std::string>(), "fault");
    e.detail = j.value("detail", std::string());
    return e;
  } catch (const std::exception& error) {
    throw std::invalid_argument("not an events.jsonl line (" + std::string(error.what()) + "): '" +
                                std::string(line) + "'");
  }
}

std::string TrajectoryCsv(const RunRecord& record) {
  std::string csv = TrajectoryCsvHeader();
  ForEachSample(record, [&](const TrajectorySample& s) { csv += TrajectoryCsvLine(s); });
  return csv;
}

std::string EventsJsonl(const RunRecord& record) {
  std::string lines;
  ForEachEvent(record, [&](const Event& e) { lines += EventJsonLine(e); });
  return lines;
}

std::string ResultSha256(const RunRecord& record) {
  Sha256 hash;
  if (record.store) {
    record.store->HashText(&hash);
  } else {
    hash.Update(TrajectoryCsv(record));
    hash.Update(EventsJsonl(record));
  }
  if (!record.boards.empty()) hash.Update(NodesCsv(record.boards));
  return hash.Hex();
}

}  // namespace autonomsim::sim
