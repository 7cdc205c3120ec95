// The track as data: what a track file (scenarios/tracks/*.yaml) says, field for field. Everything
// derived from it (sampled paths, road graph, floor raster, static map) lives in world/track.h.
//
// Config structs follow one convention across the project (CONTRIBUTING.md): in-class defaults,
// units in the key names, `Describe` lists the keys once for the one reader and the one writer,
// `Validate` throws std::invalid_argument naming the key and the bad value.
#pragma once

#include <array>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "world/geometry.h"

namespace autonomsim::world {

using PointList = std::vector<std::array<double, 2>>;  // [[x_m, y_m], ...] in the map frame
using Rgb = std::array<int, 3>;                        // 0..255 each

// A painted line: a polyline whose corners are rounded with one radius ("fillet polyline").
struct TrackLineSpec {
  std::string name;
  std::string color;  // a key of TrackSpec::colors_rgb
  double width_m{0.036};
  PointList points_m;
  bool closed{false};
  double corner_radius_m{0.0};
  // What the planner's static map makes of it (reference §1: the yellow lines and the islands are
  // obstacles there, the outer white boundary is missing): "none", "line" or "filled".
  // "line" draws the stroke only (a hollow outline if closed), "filled" also its inside.
  std::string planner{"none"};
  // The grey the planner's map draws it in: 0 black .. 255 white (world/occupancy_map.h turns
  // grey into map values as map_server does). Default black: an occupied line.
  int planner_grey{0};

  template <class V>
  void Describe(V& v) {
    v("name", name);
    v("color", color);
    v("width_m", width_m);
    v("points_m", points_m);
    v("closed", closed);
    v("corner_radius_m", corner_radius_m);
    v("planner", planner);
    v("planner_grey", planner_grey);
  }
  void Validate() const;
};

// A directed lane centre path between two road-graph nodes; right-hand traffic is encoded by the
// direction of travel along the points. Corners are rounded with corner_radius_m, which must be
// drivable (>= the car's minimum turning radius, 1/1.2 m).
struct LaneSegmentSpec {
  std::string name;
  PointList points_m;
  double corner_radius_m{0.9};

  template <class V>
  void Describe(V& v) {
    v("name", name);
    v("points_m", points_m);
    v("corner_radius_m", corner_radius_m);
  }
  void Validate() const;
};

// An intersection with its area and stop zones, in the real cars' map frame (reference §1). The
// id is the digit the /vtl/ protocol uses.
struct IntersectionSpec {
  int id{0};
  std::string name;
  Box area;
  std::vector<Box> stop_zones;

  template <class V>
  void Describe(V& v) {
    v("id", id);
    v("name", name);
    v("area", area);
    v("stop_zones", stop_zones);
  }
  void Validate() const;
};

struct StartPoseSpec {
  double x_m{0.0};
  double y_m{0.0};
  double yaw_deg{0.0};

  template <class V>
  void Describe(V& v) {
    v("x_m", x_m);
    v("y_m", y_m);
    v("yaw_deg", yaw_deg);
  }
  void Validate() const {}
  Pose2 ToPose() const;
};

struct TrackSpec {
  std::string name;
  std::string source;  // provenance of the geometry
  double size_m{5.0};  // the floor is a square of this side, centred on the origin
  // The planner's static map is a square of this side centred on the origin; absent: the floor's.
  // A map smaller than the floor would put reachable poses outside it ("start outside the map").
  std::optional<double> planner_map_size_m;
  Rgb floor_rgb{0, 0, 0};
  std::map<std::string, Rgb> colors_rgb;
  std::vector<TrackLineSpec> lines;
  std::vector<LaneSegmentSpec> lanes;
  std::map<std::string, std::vector<std::string>> routes;  // name -> lane segment names, in order
  std::vector<IntersectionSpec> intersections;
  std::map<std::string, StartPoseSpec> start_poses;

  template <class V>
  void Describe(V& v) {
    v("name", name);
    v("source", source);
    v("size_m", size_m);
    v("planner_map_size_m", planner_map_size_m);
    v("floor_rgb", floor_rgb);
    v("colors_rgb", colors_rgb);
    v("lines", lines);
    v("lanes", lanes);
    v("routes", routes);
    v("intersections", intersections);
    v("start_poses", start_poses);
  }
  // Cross-field checks: colours named by lines exist, names unique, routes name known lanes,
  // intersection ids unique and single digits.
  void Validate() const;
};

}  // namespace autonomsim::world
