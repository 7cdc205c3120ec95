#include "sim/scenario/run_record.h"

#include <fmt/format.h>

#include <nlohmann/json.hpp>

#include "sim/core/hash.h"

namespace autonomsim::sim {

std::string TrajectoryCsv(const RunRecord& record) {
  std::string csv =
      "t_s,car,x_m,y_m,yaw_rad,speed_mps,steering_rad,throttle,curvature_cmd_per_m,"
      "lateral_error_m,route_progress_m\n";
  for (const TrajectorySample& s : record.trajectory) {
    csv += fmt::format("{},{},{},{},{},{},{},{},{},{},{}\n", ToSeconds(s.t), s.car, s.x_m, s.y_m,
                       s.yaw_rad, s.speed_mps, s.steering_rad, s.throttle, s.curvature_cmd_per_m,
                       s.lateral_error_m, s.route_progress_m);
  }
  return csv;
}

std::string EventsJsonl(const RunRecord& record) {
  std::string lines;
  for (const Event& e : record.events) {
    nlohmann::json j = {{"t_s", ToSeconds(e.t)}, {"type", e.type}};
    if (e.car >= 0) j["car"] = e.car;
    if (e.intersection >= 0) j["intersection"] = e.intersection;
    if (e.other_car >= 0) j["other_car"] = e.other_car;
    if (!e.obstacle.empty()) j["obstacle"] = e.obstacle;
    if (e.granted) j["granted"] = *e.granted;
    if (e.lap > 0) j["lap"] = e.lap;
    if (!e.detail.empty()) j["detail"] = e.detail;
    lines += j.dump() + "\n";
  }
  return lines;
}

std::string ResultSha256(const RunRecord& record) {
  Sha256 hash;
  hash.Update(TrajectoryCsv(record));
  hash.Update(EventsJsonl(record));
  if (!record.boards.empty()) hash.Update(NodesCsv(record.boards));
  return hash.Hex();
}

}  // namespace autonomsim::sim
