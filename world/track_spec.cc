#include "world/track_spec.h"

#include <cmath>
#include <numbers>
#include <set>
#include <stdexcept>

#include "world/validation.h"

namespace autonomsim::world {
namespace {

void ValidatePoints(const PointList& points, const std::string& key) {
  Require(points.size() >= 2,
          key + " needs at least 2 points, got " + std::to_string(points.size()));
}

// Every point of the track lies on its floor, a square of side `size_m` centred on the origin:
// geometry off it (1e308, say) would reach Box2D and the path sampler as infinities.
void RequireOnFloor(double x_m, double y_m, double size_m, const std::string& what) {
  const double half = 0.5 * size_m;
  Require(std::abs(x_m) <= half && std::abs(y_m) <= half,
          what + " (" + Num(x_m) + ", " + Num(y_m) +
              ") m is off the floor (|x|, |y| <= " + Num(half) + " m: size_m " + Num(size_m) + ")");
}

}  // namespace

void TrackLineSpec::Validate() const {
  Require(!name.empty(), "line needs a name");
  Require(width_m > 0.0 && width_m < 1.0, "width_m must be in (0, 1) m, got " + Num(width_m));
  ValidatePoints(points_m, "points_m");
  Require(corner_radius_m >= 0.0, "corner_radius_m must be >= 0, got " + Num(corner_radius_m));
  Require(planner == "none" || planner == "line" || planner == "filled",
          "planner must be one of none, line, filled; got '" + planner + "'");
  Require(planner != "filled" || closed, "planner: filled needs closed: true");
  Require(planner_grey >= 0 && planner_grey <= 255,
          "planner_grey must be in [0, 255], got " + Num(planner_grey));
}

void LaneSegmentSpec::Validate() const {
  Require(!name.empty(), "lane needs a name");
  ValidatePoints(points_m, "points_m");
  Require(corner_radius_m > 0.0, "corner_radius_m must be > 0, got " + Num(corner_radius_m));
}

void IntersectionSpec::Validate() const {
  Require(id >= 0 && id <= 9,
          "id must be a single digit 0..9 (the /vtl/ protocol sends one "
          "character), got " +
              std::to_string(id));
  area.Validate();
  Require(!stop_zones.empty(), "stop_zones must not be empty");
  for (const Box& zone : stop_zones) zone.Validate();
}

Pose2 StartPoseSpec::ToPose() const { return Pose2{x_m, y_m, yaw_deg * std::numbers::pi / 180.0}; }

void TrackSpec::Validate() const {
  Require(size_m > 0.0, "size_m must be > 0, got " + Num(size_m));
  Require(!planner_map_size_m || *planner_map_size_m >= size_m,
          "planner_map_size_m must be >= size_m (" + Num(size_m) + " m), got " +
              (planner_map_size_m ? Num(*planner_map_size_m) : std::string()));
  for (const TrackLineSpec& line : lines) {
    for (std::size_t i = 0; i < line.points_m.size(); ++i) {
      RequireOnFloor(line.points_m[i][0], line.points_m[i][1], size_m,
                     "line '" + line.name + "' points_m[" + std::to_string(i) + "]");
    }
  }
  for (const LaneSegmentSpec& lane : lanes) {
    for (std::size_t i = 0; i < lane.points_m.size(); ++i) {
      RequireOnFloor(lane.points_m[i][0], lane.points_m[i][1], size_m,
                     "lane '" + lane.name + "' points_m[" + std::to_string(i) + "]");
    }
  }
  // (zone boxes may reach past the floor's edge, as the lab's do: they are look-ups, not bodies)
  for (const auto& [pose_name, pose] : start_poses) {
    RequireOnFloor(pose.x_m, pose.y_m, size_m, "start pose '" + pose_name + "'");
  }
  auto check_rgb = [](const Rgb& rgb, const std::string& key) {
    for (int c : rgb) Require(c >= 0 && c <= 255, key + " components must be in 0..255");
  };
  check_rgb(floor_rgb, "floor_rgb");
  for (const auto& [color, rgb] : colors_rgb) check_rgb(rgb, "colors_rgb." + color);
  std::set<std::string> line_names;
  for (const TrackLineSpec& line : lines) {
    Require(colors_rgb.count(line.color) == 1,
            "line '" + line.name + "' names unknown color '" + line.color + "'");
    Require(line_names.insert(line.name).second, "duplicate line name '" + line.name + "'");
  }
  std::set<std::string> lane_names;
  for (const LaneSegmentSpec& lane : lanes) {
    Require(lane_names.insert(lane.name).second, "duplicate lane name '" + lane.name + "'");
  }
  for (const auto& [route, segments] : routes) {
    Require(!segments.empty(), "route '" + route + "' is empty");
    for (const std::string& segment : segments) {
      Require(lane_names.count(segment) == 1,
              "route '" + route + "' names unknown lane '" + segment + "'");
    }
  }
  std::set<int> ids;
  for (const IntersectionSpec& intersection : intersections) {
    Require(ids.insert(intersection.id).second,
            "duplicate intersection id " + std::to_string(intersection.id));
  }
}

}  // namespace autonomsim::world
