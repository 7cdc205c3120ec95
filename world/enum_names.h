// A closed vocabulary is a type: an `enum class` with one table that maps its values to the names
// the files use (scenario YAML, events.jsonl, summary.json). Specialise NameTable<E> once, next to
// the enum, with every value in declaration order; then ToName, FromName and NameList serve every
// reader and writer, and a name appears nowhere else in the code. The config reader
// (sim/core/config.h) reads and writes any such enum as its name, and its error lists the names.
#pragma once

#include <array>
#include <cstddef>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace autonomsim {

// Specialise with `static constexpr std::array<std::pair<E, std::string_view>, N> kEntries{...}`.
template <class E>
struct NameTable;

template <class E>
concept NamedEnum = std::is_enum_v<E> && requires {
  NameTable<E>::kEntries;
};

template <NamedEnum E>
constexpr std::string_view ToName(E value) {
  for (const auto& [v, name] : NameTable<E>::kEntries) {
    if (v == value) return name;
  }
  throw std::logic_error("ToName: a value without a name in its NameTable");
}

template <NamedEnum E>
constexpr std::optional<E> FromName(std::string_view name) {
  for (const auto& [v, n] : NameTable<E>::kEntries) {
    if (n == name) return v;
  }
  return std::nullopt;
}

// "'a', 'b' or 'c'", for messages.
template <NamedEnum E>
std::string NameList() {
  std::string out;
  const auto& entries = NameTable<E>::kEntries;
  for (std::size_t i = 0; i < entries.size(); ++i) {
    if (i > 0) out += i + 1 == entries.size() ? " or " : ", ";
    out += "'" + std::string(entries[i].second) + "'";
  }
  return out;
}

// Every name, in the table's order (for "did you mean" and lists).
template <NamedEnum E>
std::vector<std::string> NamesOf() {
  std::vector<std::string> names;
  for (const auto& entry : NameTable<E>::kEntries) names.emplace_back(entry.second);
  return names;
}

}  // namespace autonomsim
