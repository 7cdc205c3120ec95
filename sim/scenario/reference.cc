#include "sim/scenario/reference.h"

#include <fmt/format.h>

#include <map>
#include <string_view>
#include <type_traits>
#include <vector>

#include "sim/core/track_loader.h"
#include "sim/scenario/scenario.h"

namespace autonomsim::sim {
namespace {

struct Row {
  std::string key, type, unit, default_value, meaning;
};

class ReferenceWriter;
template <class T>
void Describe(ReferenceWriter& writer, const std::string& path, const T& value,
              const std::string& meaning);
template <class T>
void DescribeFields(ReferenceWriter& writer, const std::string& path, const T& value);

// Walks a struct's Describe and writes one row per key with its meaning (the last argument of
// the key's `v(...)`), recursing into nested structs, lists and maps (their elements under `[i]`
// and `<name>`).
class ReferenceWriter {
 public:
  explicit ReferenceWriter(std::string prefix) : prefix_(std::move(prefix)) {}

  template <class T>
  void operator()(const char* key, const T& value, const char* meaning = "") {
    Describe(*this, Join(key), value, meaning);
  }
  template <class T>
  void operator()(const char* key, const T& value, RequiredKey, const char* meaning = "") {
    const std::size_t before = rows.size();
    (*this)(key, value, meaning);
    for (std::size_t i = before; i < rows.size(); ++i) rows[i].default_value = "(required)";
  }

  std::string Join(const char* key) const { return prefix_.empty() ? key : prefix_ + "." + key; }
  void SetPrefix(std::string prefix) { prefix_ = std::move(prefix); }
  const std::string& prefix() const { return prefix_; }

  std::vector<Row> rows;

 private:
  std::string prefix_;
};

template <class T>
concept HasKeys = requires(T& t, ReferenceWriter& w) {
  t.Describe(w);
};

// A list whose entries have a section of their own below the keys: faults and expectations (one
// kind per entry) and obstacles (a struct that says what it is, kMeaning).
template <class E>
constexpr bool kHasOwnSection = IsKindVariant<E>::value || requires {
  E::kMeaning;
};

template <class T>
std::string TypeName() {
  if constexpr (detail::IsArray<T>::value) {
    return fmt::format("list of {} {}", std::tuple_size_v<T>, TypeName<typename T::value_type>());
  } else if constexpr (detail::IsVector<T>::value) {
    return "list of " + TypeName<typename T::value_type>();
  } else if constexpr (NamedEnum<T>) {
    std::string names;
    for (const auto& [v, name] : NameTable<T>::kEntries) {
      names += (names.empty() ? "" : " \\| ") + std::string(name);
    }
    return names;
  } else if constexpr (requires { T::kTypeName; }) {
    return T::kTypeName;
  } else if constexpr (std::is_same_v<T, bool>) {
    return "bool";
  } else if constexpr (std::is_integral_v<T>) {
    return "integer";
  } else if constexpr (std::is_floating_point_v<T> || std::is_same_v<T, Duration>) {
    return "number";
  } else if constexpr (std::is_same_v<T, std::string>) {
    return "text";
  } else if constexpr (HasKeys<T>) {
    return "mapping";
  } else {
    return "?";
  }
}

std::string Last(const std::string& path) {
  const std::size_t dot = path.rfind('.');
  return dot == std::string::npos ? path : path.substr(dot + 1);
}

// The rows of a struct's keys under `path` (no row for the struct itself: a list's entry or a
// mapping's value is not a key).
template <class T>
void DescribeFields(ReferenceWriter& writer, const std::string& path, const T& value) {
  const std::string outer = writer.prefix();
  writer.SetPrefix(path);
  const_cast<T&>(value).Describe(writer);  // reads only
  writer.SetPrefix(outer);
}

template <class T>
void Describe(ReferenceWriter& writer, const std::string& path, const T& value,
              const std::string& meaning) {
  if constexpr (detail::IsOptional<T>::value) {
    const std::size_t before = writer.rows.size();
    Describe(writer, path, typename T::value_type{}, meaning);
    for (std::size_t i = before; i < writer.rows.size(); ++i) {
      if (writer.rows[i].default_value != "(required)") writer.rows[i].default_value = "(none)";
    }
  } else if constexpr (detail::IsVector<T>::value) {
    using E = typename T::value_type;
    if constexpr (kHasOwnSection<E>) {
      writer.rows.push_back({path, "list (see below)", "", "[]", meaning});
    } else if constexpr (HasKeys<E>) {
      writer.rows.push_back({path, "list", "", fmt::format("{} entries", value.size()), meaning});
      DescribeFields(writer, path + "[i]", E{});
    } else {
      writer.rows.push_back({path, "list of " + TypeName<E>(), UnitOfKey(Last(path)),
                             detail::ToJsonValue(value).dump(), meaning});
    }
  } else if constexpr (detail::IsArray<T>::value) {
    writer.rows.push_back(
        {path, TypeName<T>(), UnitOfKey(Last(path)), detail::ToJsonValue(value).dump(), meaning});
  } else if constexpr (detail::IsMap<T>::value) {
    using E = typename T::mapped_type;
    if constexpr (HasKeys<E>) {
      writer.rows.push_back({path, "mapping by name", "", "{}", meaning});
      DescribeFields(writer, path + ".<name>", E{});
    } else {
      writer.rows.push_back({path, "mapping by name to " + TypeName<E>(), "", "{}", meaning});
    }
  } else if constexpr (HasKeys<T>) {
    writer.rows.push_back({path, "mapping", "", "", meaning});
    DescribeFields(writer, path, value);
  } else {
    writer.rows.push_back(
        {path, TypeName<T>(), UnitOfKey(Last(path)), detail::ToJsonValue(value).dump(), meaning});
  }
}

// A meaning as a table cell: a `|` in it would end the cell.
std::string Cell(const std::string& text) {
  std::string out;
  for (char c : text) out += c == '|' ? std::string("\\|") : std::string(1, c);
  return out;
}

std::string Table(const std::vector<Row>& rows) {
  std::string out = "| key | type | unit | default | meaning |\n|---|---|---|---|---|\n";
  for (const Row& row : rows) {
    out += fmt::format("| `{}` | {} | {} | {} | {} |\n", row.key, row.type, row.unit,
                       row.default_value.empty() ? "" : "`" + row.default_value + "`",
                       Cell(row.meaning));
  }
  return out;
}

// The rows of a struct's keys, as the keys of a section of their own (`name`, not `x[i].name`).
template <class T>
std::vector<Row> RowsOf(const T& value) {
  ReferenceWriter writer("");
  DescribeFields(writer, "", value);
  return writer.rows;
}

// One section per kind of a variant: what it does or checks (the kind's kMeaning), its keys.
template <class Variant, std::size_t... I>
std::string KindSections(std::index_sequence<I...>) {
  std::string out;
  (
      [&] {
        using Kind = std::variant_alternative_t<I, Variant>;
        const std::vector<Row> rows = RowsOf(Kind{});
        out += fmt::format("### {}\n\n{}.\n\n", ToName(Kind::kKind), Kind::kMeaning);
        out += rows.empty() ? "No keys: `{}`.\n\n" : Table(rows) + "\n";
      }(),
      ...);
  return out;
}

template <class Variant>
std::string KindSections() {
  return KindSections<Variant>(std::make_index_sequence<std::variant_size_v<Variant>>());
}

// `a`, `b`: names as code, comma-separated.
std::string CodeList(const std::vector<std::string>& names) {
  std::string out;
  for (const std::string& name : names) out += (out.empty() ? "`" : ", `") + name + "`";
  return out;
}

// The names a car's `start`, `route` and `lanes` and an expectation's `intersection` take on the
// default track, from the track file as the loader reads it; a start pose lies on the routes the
// loader accepts it on (PlaceStart).
std::string TrackSections(const std::string& track_name, const world::Track& track) {
  const world::TrackSpec& spec = track.spec();
  std::string out = fmt::format(
      "## The lab track\n\n"
      "The names the default `track`, `{}`, defines, as the loader reads it: a car's `start`, "
      "`route` and `lanes`, an expectation's `intersection`. Another track file defines its "
      "own.\n\n"
      "### Start poses\n\n"
      "A car may start at a pose only on a route it lies on (within 0.1 m, heading within "
      "30°); elsewhere give `start_s_m`.\n\n"
      "| name | x_m | y_m | yaw_deg | on the routes |\n|---|---|---|---|---|\n",
      track_name);
  for (const auto& [name, pose] : spec.start_poses) {
    std::vector<std::string> routes;
    for (const auto& [route_name, lanes] : spec.routes) {
      if (PlaceStart(pose.ToPose(), track.RouteByName(route_name)).on()) {
        routes.push_back(route_name);
      }
    }
    out += fmt::format("| `{}` | {} | {} | {} | {} |\n", name, pose.x_m, pose.y_m, pose.yaw_deg,
                       routes.empty() ? "(none)" : CodeList(routes));
  }
  out +=
      "\n### Routes\n\n"
      "A route is lane segments driven in order; a loop leads back into its first.\n\n"
      "| name | lanes | length (m) | loop |\n|---|---|---|---|\n";
  for (const auto& [name, lanes] : spec.routes) {
    const world::Route route = track.RouteByName(name);
    out += fmt::format("| `{}` | {} | {:.2f} | {} |\n", name, CodeList(lanes),
                       route.path.length_m(), route.cyclic ? "yes" : "no");
  }
  out +=
      "\n### Lanes\n\n"
      "The lane segments a car's `lanes` may list, each followed by one that it leads into.\n\n"
      "| name | length (m) | leads into |\n|---|---|---|\n";
  const world::RoadGraph& graph = track.road_graph();
  for (int segment = 0; segment < static_cast<int>(graph.segment_count()); ++segment) {
    std::vector<std::string> next;
    for (int successor : graph.Successors(segment)) next.push_back(graph.name(successor));
    out += fmt::format("| `{}` | {:.2f} | {} |\n", graph.name(segment),
                       graph.path(segment).length_m(), CodeList(next));
  }
  out +=
      "\n### Intersections\n\n"
      "Each with its id, the digit of the /vtl/ protocol.\n\n"
      "| id | name |\n|---|---|\n";
  for (const world::IntersectionSpec& intersection : spec.intersections) {
    out += fmt::format("| {} | {} |\n", intersection.id, intersection.name);
  }
  return out + "\n";
}

}  // namespace

std::string ScenarioReferenceMarkdown() {
  ReferenceWriter writer("");
  DescribeFields(writer, "", Scenario{});
  const std::string track_name = Scenario{}.track;
  const world::Track track = LoadTrack(ShippedScenarioFile(track_name));
  std::string out =
      "# Scenario reference\n\n"
      "<!-- Generated from the loader's Describe (sim/scenario/reference.cc): do not edit; "
      "`build/bin/autonomsim reference --out docs/scenarios.md` writes it anew, and a test "
      "checks that it is current. -->\n\n"
      "Every key of a scenario file, as the loader reads it, with what it means. A key left out "
      "takes its default; `(none)` marks an optional key that is absent unless given, "
      "`(required)` one that must be given. A key whose type lists names (`a \\| b`) takes one "
      "of them. `[i]` stands for a list's entries and `<name>` for a mapping's names. Units "
      "follow the key's suffix (`_s` seconds, `_m` metres, `_mps` m/s, ...). A `stack.preset` "
      "fills in keys before the defaults ([the lab's stack](lab-stack.md)). Below the keys: "
      "[obstacles](#obstacles), the names [the lab track](#the-lab-track) defines, "
      "[faults](#faults) and [expectations](#expectations). How to write a scenario: "
      "[writing scenarios](writing-scenarios.md).\n\n"
      "## Keys\n\n" +
      Table(writer.rows) +
      fmt::format(
          "\n## Obstacles\n\n{}. An `obstacles:` entry, e.g. "
          "`- {{name: box, x_m: -0.3, y_m: -1.55, appear_s: 5, disappear_s: 25}}`:\n\n",
          ObstacleConfig::kMeaning) +
      Table(RowsOf(ObstacleConfig{})) + "\n" + TrackSections(track_name, track) +
      "## Faults\n\n"
      "A `faults:` entry names one kind, e.g. `- car_stall: {car: 1, at_s: 20}`; each strikes at "
      "`at_s`. More on each, and what a fault leaves in the results: [faults](faults.md).\n\n" +
      KindSections<FaultClause>() +
      "## Expectations\n\n"
      "An `expect:` entry names one kind, e.g. `- completes: {car: 0, laps: 3}`; each is judged "
      "on the finished run, and `check` turns them into its exit code.\n\n" +
      KindSections<ExpectClause>();
  while (out.ends_with("\n\n")) out.pop_back();
  return out;
}

}  // namespace autonomsim::sim
