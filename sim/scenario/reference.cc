#include "sim/scenario/reference.h"

#include <fmt/format.h>

#include <map>
#include <string_view>
#include <type_traits>
#include <vector>

#include "sim/scenario/scenario.h"

namespace autonomsim::sim {
namespace {

struct Row {
  std::string key, type, unit, default_value;
};

class ReferenceWriter;
template <class T>
void Describe(ReferenceWriter& writer, const std::string& path, const T& value);

// Walks a struct's Describe and writes one row per scalar key, recursing into nested structs,
// lists and maps (their elements under `[i]` and `<name>`).
class ReferenceWriter {
 public:
  explicit ReferenceWriter(std::string prefix) : prefix_(std::move(prefix)) {}

  template <class T>
  void operator()(const char* key, const T& value) {
    Describe(*this, Join(key), value);
  }
  template <class T>
  void operator()(const char* key, const T& value, RequiredKey) {
    const std::size_t before = rows.size();
    (*this)(key, value);
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
  } else if constexpr (std::is_same_v<T, bool>) {
    return "bool";
  } else if constexpr (std::is_integral_v<T>) {
    return "integer";
  } else if constexpr (std::is_floating_point_v<T> || std::is_same_v<T, Duration>) {
    return "number";
  } else if constexpr (std::is_same_v<T, std::string>) {
    return "text";
  } else {
    return "?";
  }
}

std::string Last(const std::string& path) {
  const std::size_t dot = path.rfind('.');
  return dot == std::string::npos ? path : path.substr(dot + 1);
}

template <class T>
void Describe(ReferenceWriter& writer, const std::string& path, const T& value) {
  if constexpr (detail::IsOptional<T>::value) {
    const std::size_t before = writer.rows.size();
    Describe(writer, path, typename T::value_type{});
    for (std::size_t i = before; i < writer.rows.size(); ++i) {
      if (writer.rows[i].default_value != "(required)") writer.rows[i].default_value = "(none)";
    }
  } else if constexpr (detail::IsVector<T>::value) {
    using E = typename T::value_type;
    if constexpr (IsKindVariant<E>::value) {  // faults, expect: their own sections
      writer.rows.push_back({path, "list (see below)", "", "[]"});
    } else if constexpr (requires(E & e, ReferenceWriter & w) { e.Describe(w); }) {
      writer.rows.push_back({path, "list", "", fmt::format("{} entries", value.size())});
      Describe(writer, path + "[i]", E{});
    } else {
      writer.rows.push_back({path, "list of " + TypeName<E>(), UnitOfKey(Last(path)),
                             detail::ToJsonValue(value).dump()});
    }
  } else if constexpr (detail::IsArray<T>::value) {
    writer.rows.push_back(
        {path, TypeName<T>(), UnitOfKey(Last(path)), detail::ToJsonValue(value).dump()});
  } else if constexpr (detail::IsMap<T>::value) {
    writer.rows.push_back({path, "mapping by name", "", "{}"});
    Describe(writer, path + ".<name>", typename T::mapped_type{});
  } else if constexpr (requires(T & t, ReferenceWriter & w) { t.Describe(w); }) {
    const std::string outer = writer.prefix();
    writer.SetPrefix(path);
    const_cast<T&>(value).Describe(writer);  // reads only
    writer.SetPrefix(outer);
  } else {
    writer.rows.push_back(
        {path, TypeName<T>(), UnitOfKey(Last(path)), detail::ToJsonValue(value).dump()});
  }
}

std::string Table(const std::vector<Row>& rows) {
  std::string out = "| key | type | unit | default |\n|---|---|---|---|\n";
  for (const Row& row : rows) {
    out += fmt::format("| `{}` | {} | {} | {} |\n", row.key, row.type, row.unit,
                       row.default_value.empty() ? "" : "`" + row.default_value + "`");
  }
  return out;
}

// One section per kind of a variant: its keys.
template <class Variant, std::size_t... I>
std::string KindSections(std::index_sequence<I...>) {
  std::string out;
  (
      [&] {
        using Kind = std::variant_alternative_t<I, Variant>;
        ReferenceWriter writer("");
        Describe(writer, "", Kind{});
        out += fmt::format("### {}\n\n", ToName(Kind::kKind));
        out += writer.rows.empty() ? "No keys: `{}`.\n\n" : Table(writer.rows) + "\n";
      }(),
      ...);
  return out;
}

}  // namespace

std::string ScenarioReferenceMarkdown() {
  ReferenceWriter writer("");
  Describe(writer, "", Scenario{});
  std::string out =
      "# Scenario reference\n\n"
      "<!-- Generated from the loader's Describe (sim/scenario/reference.cc): do not edit; "
      "`build/bin/autonomsim reference --out docs/scenarios.md` writes it anew, and a test "
      "checks that it is current. -->\n\n"
      "Every key of a scenario file, as the loader reads it. A key left out takes its default; "
      "`(none)` marks an optional key that is absent unless given, `(required)` one that must "
      "be given. `[i]` stands for a list's entries and `<name>` for a mapping's names. Units "
      "follow the key's suffix (`_s` seconds, `_m` metres, `_mps` m/s, ...). A `stack.preset` "
      "fills in keys before the defaults (docs/lab-stack.md). How to write a scenario: "
      "[writing scenarios](writing-scenarios.md).\n\n"
      "## Keys\n\n" +
      Table(writer.rows) +
      "\n## Faults\n\n"
      "A `faults:` entry names one kind, e.g. `- car_stall: {car: 1, at_s: 20}`; what each does: "
      "[faults](faults.md).\n\n" +
      KindSections<FaultClause>(std::make_index_sequence<std::variant_size_v<FaultClause>>()) +
      "## Expectations\n\n"
      "An `expect:` entry names one kind, e.g. `- completes: {car: 0, laps: 3}`.\n\n" +
      KindSections<ExpectClause>(std::make_index_sequence<std::variant_size_v<ExpectClause>>());
  while (out.ends_with("\n\n")) out.pop_back();
  return out;
}

}  // namespace autonomsim::sim
