// The one reader (YAML) and the one writer (JSON) of every config struct. A struct opts in by
// listing its keys once in `template <class V> void Describe(V& v)` (CONTRIBUTING.md); reading is
// strict: an unknown key, a wrong type or a value its Validate() rejects is a ConfigError whose
// message names the file, line, column and key path, e.g.
//   scenarios/x.yaml:12:7: cars[0].oracle.speed_mps: expected a number, got 'fast'
#pragma once

#include <yaml-cpp/yaml.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>
#include <string_view>
#include <type_traits>
#include <variant>
#include <vector>

#include "world/enum_names.h"
#include "world/time.h"

namespace autonomsim::sim {

// Unusable user input (scenario, track, command line): the CLI maps it to exit code 2.
class ConfigError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Where values come from, for error messages: the file, and the key paths that --set replaced.
struct ConfigSource {
  std::string file;
  std::set<std::string> overridden_paths;
};

// Parses a YAML file. A ConfigError naming the file (and line where there is one) for a folder,
// an unreadable file, one over 16 MiB (a device such as /dev/zero), bytes that are not UTF-8, a
// syntax error, and a key repeated in a mapping.
YAML::Node LoadYamlFile(const std::filesystem::path& file);

// Keys of one mapping of which a file gives at most one (e.g. a car's `start` and `start_s_m`):
// an override that sets one removes the others from its mapping.
using AlternativeKeys = std::vector<std::vector<std::string>>;

// Applies `--set path=value`: the path is dot-separated keys with [i] for list elements (e.g.
// cars[0].oracle.speed_mps; anything else is refused, see ParseOverridePath); the value is parsed
// as YAML (so 0.3, true, [1, 2] and {a: 1} all work). Missing map keys are created (the strict
// reader then rejects those the schema does not know); list indices must exist. A null value
// (`null` or `~`) removes the key, or the list entry, so that its default applies (an optional
// key is then unset). Setting one of `alternatives` removes the others. Records the path in
// source.
void ApplyOverride(YAML::Node& root, const std::string& assignment, ConfigSource* source,
                   const AlternativeKeys& alternatives = {});
// Gives every place an alias (*name) refers to its own copy of the anchored value, so that an
// override or a preset of one place (cars[1].stack...) leaves the others (cars[0].stack, anchored
// `&stack`) as the file wrote them. yaml-cpp shares an anchored node among its aliases, and
// assigning into one changes all of them. Call it on a freshly loaded root, before overrides.
// A copy keeps the values but not their line numbers.
void BreakAliases(YAML::Node& root);
// The tokens of a --set key path: names, and list indices (as digits). ConfigError naming the key
// for anything but `name(.name|[N])*`.
std::vector<std::string> ParseOverridePath(const std::string& key);

// A key a struct must have: `v("car", car, kRequired);` in its Describe. The reader refuses a
// mapping without it ("car_stall needs car"); the writer and the reference treat it as any key.
struct RequiredKey {};
inline constexpr RequiredKey kRequired{};
// A key's meaning, in a line, is the last argument of its `v(...)`:
// `v("loss", loss, "probability that one message is lost");` The reference (docs/scenarios.md)
// prints it beside the key; the reader and the writer pass it by.

// A closed set of kinds read as a one-key mapping, the key naming the kind: a `std::variant` of
// structs each with `static constexpr E kKind` (E a NamedEnum, sim/core/../world/enum_names.h),
// e.g. `- car_stall: {car: 1, at_s: 20}`. NameTable<E> also gives `kClause`, the sentence that
// opens the error for a mapping that names no kind or several ("a faults entry names exactly one
// fault, e.g. ...").
template <class T>
struct IsKindVariant : std::false_type {};
template <class... Ts>
struct IsKindVariant<std::variant<Ts...>> : std::true_type {};

// The unit a key's name gives by the naming convention (docs/scenarios.md's "unit" column): the
// unit words at its end, e.g. `lease_s` "s", `q_position_m2_per_s` "m²/s", `gain_per_mps`
// "1/(m/s)"; "" for a key without one.
std::string UnitOfKey(std::string_view key);

namespace detail {

template <class T>
struct IsVector : std::false_type {};
template <class T, class A>
struct IsVector<std::vector<T, A>> : std::true_type {};
template <class T>
struct IsArray : std::false_type {};
template <class T, std::size_t N>
struct IsArray<std::array<T, N>> : std::true_type {};
template <class T>
struct IsMap : std::false_type {};
template <class T, class C, class A>
struct IsMap<std::map<std::string, T, C, A>> : std::true_type {};
template <class T>
struct IsOptional : std::false_type {};
template <class T>
struct IsOptional<std::optional<T>> : std::true_type {};

std::string JoinPath(const std::string& parent, const std::string& key);
std::string JoinIndex(const std::string& parent, std::size_t index);
// The last key of a path ("faults[0].car_stall" -> "car_stall").
std::string LastKey(const std::string& path);
// The candidate closest to `key` by edit distance if it is close enough to be a typo, else "".
std::string ClosestName(const std::string& key, const std::vector<std::string>& candidates);
// "file:line:col: path: " or "--set path: " when the value came from the command line.
std::string Where(const YAML::Node& node, const std::string& path, const ConfigSource& source);
[[noreturn]] void Fail(const YAML::Node& node, const std::string& path, const ConfigSource& source,
                       const std::string& message);
std::string Describe(const YAML::Node& node);  // a short rendering of a bad value for messages
// The identifier a message opens with ("loss must be ..." -> "loss"), or "" if none.
std::string LeadingWord(const std::string& message);
// Throws for keys of `node` not in `known`, suggesting the closest known key.
void CheckKeys(const YAML::Node& node, const std::vector<std::string>& known,
               const std::string& path, const ConfigSource& source);

void ReadScalar(const YAML::Node& node, bool& out, const std::string& path,
                const ConfigSource& source);
void ReadScalar(const YAML::Node& node, int& out, const std::string& path,
                const ConfigSource& source);
void ReadScalar(const YAML::Node& node, std::uint64_t& out, const std::string& path,
                const ConfigSource& source);
void ReadScalar(const YAML::Node& node, double& out, const std::string& path,
                const ConfigSource& source);
void ReadScalar(const YAML::Node& node, std::string& out, const std::string& path,
                const ConfigSource& source);
void ReadScalar(const YAML::Node& node, Duration& out, const std::string& path,
                const ConfigSource& source);

template <class T>
void Read(const YAML::Node& node, T& out, const std::string& path, const ConfigSource& source);

class YamlFieldReader {
 public:
  YamlFieldReader(const YAML::Node& node, const std::string& path, const ConfigSource& source)
      : node_(node), path_(path), source_(source) {}

  template <class T>
  void operator()(const char* key, T& value, const char* /*meaning*/ = "") {
    known_.emplace_back(key);
    const YAML::Node child = node_[key];
    if (child) Read(child, value, JoinPath(path_, key), source_);
  }
  template <class T>
  void operator()(const char* key, T& value, RequiredKey, const char* /*meaning*/ = "") {
    if (!node_[key]) Fail(node_, path_, source_, LastKey(path_) + " needs " + key);
    (*this)(key, value);
  }
  const std::vector<std::string>& known() const { return known_; }

 private:
  const YAML::Node& node_;
  const std::string& path_;
  const ConfigSource& source_;
  std::vector<std::string> known_;
};

// The keys a struct's Describe lists.
class KeyLister {
 public:
  template <class T>
  void operator()(const char* key, T&, const char* /*meaning*/ = "") {
    keys.emplace_back(key);
  }
  template <class T>
  void operator()(const char* key, T& value, RequiredKey, const char* /*meaning*/ = "") {
    (*this)(key, value);
  }
  std::vector<std::string> keys;
};
template <class T>
std::vector<std::string> KeysOf(T& value) {
  KeyLister lister;
  value.Describe(lister);
  return lister.keys;
}
// Throws for a key of a kind's mapping that the kind does not take: "'server_restart' takes no
// key 'car' (its keys: at_s, for_s)", or the closest key for a typo.
void CheckKindKeys(const YAML::Node& node, const std::vector<std::string>& known,
                   const std::string& kind, const std::string& path, const ConfigSource& source);

template <NamedEnum E>
void ReadEnum(const YAML::Node& node, E& out, const std::string& path, const ConfigSource& source) {
  std::string name;
  ReadScalar(node, name, path, source);
  if (const std::optional<E> value = FromName<E>(name)) {
    out = *value;
    return;
  }
  const std::string closest = ClosestName(name, NamesOf<E>());
  Fail(node, path, source,
       LastKey(path) + " must be " + NameList<E>() + ", got '" + name + "'" +
           (closest.empty() ? "" : " (did you mean '" + closest + "'?)"));
}

template <class Variant, std::size_t I = 0>
bool ReadAlternative(const std::string& kind, const YAML::Node& node, Variant& out,
                     const std::string& path, const ConfigSource& source) {
  if constexpr (I == std::variant_size_v<Variant>) {
    return false;
  } else {
    using Alternative = std::variant_alternative_t<I, Variant>;
    if (ToName(Alternative::kKind) != kind) {
      return ReadAlternative<Variant, I + 1>(kind, node, out, path, source);
    }
    Alternative value{};
    if (node.IsMap()) CheckKindKeys(node, KeysOf(value), kind, JoinPath(path, kind), source);
    Read(node, value, JoinPath(path, kind), source);
    out = std::move(value);
    return true;
  }
}

template <class Variant>
void ReadKindVariant(const YAML::Node& node, Variant& out, const std::string& path,
                     const ConfigSource& source) {
  using Kind = std::remove_cv_t<decltype(std::variant_alternative_t<0, Variant>::kKind)>;
  if (!node.IsMap() || node.size() != 1) {
    std::string got = Describe(node);
    if (node.IsMap()) {
      got = std::to_string(node.size()) + " keys";
      for (const auto& item : node) got += " '" + item.first.as<std::string>("?") + "'";
    }
    Fail(node, path, source, std::string(NameTable<Kind>::kClause) + "; got " + got);
  }
  const auto item = node.begin();
  if (!item->first.IsScalar()) {
    Fail(item->first, path, source, "expected a name as key, got " + Describe(item->first));
  }
  const std::string kind = item->first.Scalar();
  if (ReadAlternative(kind, item->second, out, path, source)) return;
  CheckKeys(node, NamesOf<Kind>(), path, source);  // names the closest kind, or lists them all
}

template <class T>
void Read(const YAML::Node& node, T& out, const std::string& path, const ConfigSource& source) {
  if constexpr (NamedEnum<T>) {
    ReadEnum(node, out, path, source);
  } else if constexpr (IsKindVariant<T>::value) {
    ReadKindVariant(node, out, path, source);
  } else if constexpr (IsOptional<T>::value) {
    typename T::value_type value{};
    Read(node, value, path, source);
    out = std::move(value);
  } else if constexpr (IsVector<T>::value) {
    if (!node.IsSequence()) Fail(node, path, source, "expected a list, got " + Describe(node));
    out.clear();
    for (std::size_t i = 0; i < node.size(); ++i) {
      typename T::value_type value{};
      Read(node[i], value, JoinIndex(path, i), source);
      out.push_back(std::move(value));
    }
  } else if constexpr (IsArray<T>::value) {
    if (!node.IsSequence() || node.size() != out.size()) {
      Fail(node, path, source,
           "expected a list of " + std::to_string(out.size()) + " values, got " + Describe(node));
    }
    for (std::size_t i = 0; i < out.size(); ++i) Read(node[i], out[i], JoinIndex(path, i), source);
  } else if constexpr (IsMap<T>::value) {
    if (!node.IsMap()) Fail(node, path, source, "expected a mapping, got " + Describe(node));
    out.clear();
    for (const auto& item : node) {
      // a YAML key may be a list or a mapping (`[a, b]: 1`, `? {x: 1}`); ours are names
      if (!item.first.IsScalar()) {
        Fail(item.first, path, source, "expected a name as key, got " + Describe(item.first));
      }
      const std::string key = item.first.Scalar();
      typename T::mapped_type value{};
      Read(item.second, value, JoinPath(path, key), source);
      out.emplace(key, std::move(value));
    }
  } else if constexpr (requires(T & t, YamlFieldReader & r) { t.Describe(r); }) {
    if (node.IsNull()) {
      // `key:` or `key: ~` keeps every default, like `key: {}`.
    } else if (!node.IsMap()) {
      Fail(node, path, source, "expected a mapping, got " + Describe(node));
    } else {
      YamlFieldReader reader(node, path, source);
      out.Describe(reader);
      CheckKeys(node, reader.known(), path, source);
    }
    try {
      out.Validate();
    } catch (const std::invalid_argument& e) {
      // a message that opens with one of the mapping's keys ("loss must be in [0, 1)") is
      // reported at that key's own line
      const std::string key = LeadingWord(e.what());
      if (node.IsMap() && !key.empty() && node[key]) {
        Fail(node[key], JoinPath(path, key), source, e.what());
      }
      Fail(node, path, source, e.what());
    }
  } else {
    ReadScalar(node, out, path, source);
  }
}

template <class T>
nlohmann::json ToJsonValue(const T& value);

class JsonFieldWriter {
 public:
  template <class T>
  void operator()(const char* key, const T& value, const char* /*meaning*/ = "") {
    if constexpr (IsOptional<T>::value) {
      if (!value) return;
    }
    json_[key] = ToJsonValue(value);
  }
  template <class T>
  void operator()(const char* key, const T& value, RequiredKey, const char* /*meaning*/ = "") {
    (*this)(key, value);
  }
  nlohmann::json take() { return std::move(json_); }

 private:
  nlohmann::json json_ = nlohmann::json::object();
};

template <class T>
nlohmann::json ToJsonValue(const T& value) {
  if constexpr (NamedEnum<T>) {
    return std::string(ToName(value));
  } else if constexpr (IsKindVariant<T>::value) {
    return std::visit(
        [](const auto& alternative) {
          return nlohmann::json{{std::string(ToName(alternative.kKind)), ToJsonValue(alternative)}};
        },
        value);
  } else if constexpr (IsOptional<T>::value) {
    return value ? ToJsonValue(*value) : nlohmann::json();
  } else if constexpr (IsVector<T>::value || IsArray<T>::value) {
    nlohmann::json array = nlohmann::json::array();
    for (const auto& item : value) array.push_back(ToJsonValue(item));
    return array;
  } else if constexpr (IsMap<T>::value) {
    nlohmann::json object = nlohmann::json::object();
    for (const auto& [key, item] : value) object[key] = ToJsonValue(item);
    return object;
  } else if constexpr (requires(T & t, JsonFieldWriter & w) { t.Describe(w); }) {
    JsonFieldWriter writer;
    const_cast<T&>(value).Describe(writer);  // Describe only reads through a writer
    return writer.take();
  } else if constexpr (std::is_same_v<T, Duration>) {
    return ToSeconds(value);
  } else {
    return value;
  }
}

}  // namespace detail

// Reads a whole config struct from a YAML node (strict; see the top of this file).
template <class T>
T ReadConfig(const YAML::Node& node, const ConfigSource& source, const std::string& path = "") {
  T value{};
  detail::Read(node, value, path, source);
  return value;
}

// The same struct as JSON, every key present (defaults included): the canonical, resolved form.
template <class T>
nlohmann::json ToJson(const T& value) {
  return detail::ToJsonValue(value);
}

}  // namespace autonomsim::sim
