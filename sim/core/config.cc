#include "sim/core/config.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <fstream>
#include <limits>
#include <map>
#include <unordered_set>

#include "sim/core/files.h"

namespace autonomsim::sim {
// The unit a key's name gives (docs/scenarios.md's "unit" column), by the naming convention: the
// unit words at its end, e.g. `lease_s` s, `q_position_m2_per_s` m²/s, `gain_per_mps` 1/(m/s).
std::string UnitOfKey(std::string_view key) {
  static const std::map<std::string_view, std::string_view> kUnits = {
      {"s", "s"},       {"s2", "s²"},     {"s3", "s³"},     {"m", "m"},
      {"m2", "m²"},     {"mps", "m/s"},   {"mps2", "m/s²"}, {"rad", "rad"},
      {"rad2", "rad²"}, {"deg", "deg"},   {"hz", "Hz"},     {"px", "px"},
      {"kg", "kg"},     {"percent", "%"}, {"bytes", "B"},   {"ms", "ms"}};
  std::vector<std::string_view> words;
  for (std::size_t start = 0; start <= key.size();) {
    const std::size_t end = std::min(key.find('_', start), key.size());
    words.push_back(key.substr(start, end - start));
    start = end + 1;
  }
  // the unit word at the end, and before it "per" and a unit word (or "per" alone: 1/...) as
  // often as they come; two unit words side by side are a name and a unit (`start_s_m`: m)
  std::size_t first = words.size();
  if (first > 1 && kUnits.count(words[first - 1])) --first;
  while (first > 1 && words[first - 1] == "per") {
    --first;
    if (first > 1 && kUnits.count(words[first - 1])) --first;
  }
  std::string numerator, denominator;
  bool below = false;
  for (std::size_t i = first; i < words.size(); ++i) {
    if (words[i] == "per") {
      below = true;
      continue;
    }
    std::string& part = below ? denominator : numerator;
    part += (part.empty() ? "" : "·") + std::string(kUnits.at(words[i]));
  }
  if (denominator.empty()) return numerator;
  if (denominator.find('/') != std::string::npos) denominator = "(" + denominator + ")";
  return (numerator.empty() ? "1" : numerator) + "/" + denominator;
}

namespace detail {
namespace {

std::size_t EditDistance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t above = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = above;
    }
  }
  return row[b.size()];
}

bool IsOverridden(const std::string& path, const ConfigSource& source) {
  for (const std::string& overridden : source.overridden_paths) {
    if (path == overridden) return true;
    if (path.size() > overridden.size() && path.compare(0, overridden.size(), overridden) == 0 &&
        (path[overridden.size()] == '.' || path[overridden.size()] == '[')) {
      return true;
    }
  }
  return false;
}

}  // namespace

std::string LeadingWord(const std::string& message) {
  std::size_t n = 0;
  while (n < message.size() &&
         (std::isalnum(static_cast<unsigned char>(message[n])) != 0 || message[n] == '_')) {
    ++n;
  }
  return message.substr(0, n);
}

std::string JoinPath(const std::string& parent, const std::string& key) {
  return parent.empty() ? key : parent + "." + key;
}

std::string JoinIndex(const std::string& parent, std::size_t index) {
  return parent + "[" + std::to_string(index) + "]";
}

std::string Where(const YAML::Node& node, const std::string& path, const ConfigSource& source) {
  std::string key = path.empty() ? "(top level)" : path;
  if (IsOverridden(path, source)) return "--set " + key + ": ";
  const YAML::Mark mark = node.Mark();
  // a value below this one came from the command line: say so, the file alone would mislead
  for (const std::string& overridden : source.overridden_paths) {
    if (!path.empty() && IsOverridden(overridden, ConfigSource{"", {path}})) {
      // made by that --set (no line in the file): the --set is where it is
      if (mark.is_null()) return "--set " + overridden + ": " + key + ": ";
      key += " (with --set " + overridden + ")";
      break;
    }
  }
  std::string where = source.file;
  if (!mark.is_null()) {
    // fmt, not ":" + std::to_string(...): GCC 12 warns falsely (-Wrestrict) on that at -O2
    where += fmt::format(":{}:{}", mark.line + 1, mark.column + 1);
  }
  return where + ": " + key + ": ";
}

void Fail(const YAML::Node& node, const std::string& path, const ConfigSource& source,
          const std::string& message) {
  throw ConfigError(Where(node, path, source) + message);
}

std::string Describe(const YAML::Node& node) {
  switch (node.Type()) {
    case YAML::NodeType::Null:
      return "nothing";
    case YAML::NodeType::Scalar:
      return "'" + node.Scalar() + "'";
    case YAML::NodeType::Sequence:
      return "a list";
    case YAML::NodeType::Map:
      return "a mapping";
    default:
      return "an undefined value";
  }
}

std::string ClosestName(const std::string& key, const std::vector<std::string>& candidates) {
  std::string closest;
  std::size_t best = std::numeric_limits<std::size_t>::max();
  for (const std::string& candidate : candidates) {
    const std::size_t d = EditDistance(key, candidate);
    if (d < best) {
      best = d;
      closest = candidate;
    }
  }
  return best <= std::max<std::size_t>(2, key.size() / 3) ? closest : std::string();
}

std::string LastKey(const std::string& path) {
  const std::size_t dot = path.rfind('.');
  return dot == std::string::npos ? path : path.substr(dot + 1);
}

void CheckKindKeys(const YAML::Node& node, const std::vector<std::string>& known,
                   const std::string& kind, const std::string& path, const ConfigSource& source) {
  for (const auto& item : node) {
    const std::string key = item.first.Scalar();
    if (std::find(known.begin(), known.end(), key) != known.end()) continue;
    const std::string closest = ClosestName(key, known);
    std::string list;
    for (const std::string& candidate : known) list += (list.empty() ? "" : ", ") + candidate;
    Fail(item.first, JoinPath(path, key), source,
         closest.empty() ? "'" + kind + "' takes no key '" + key +
                               "' (its keys: " + (list.empty() ? "none" : list) + ")"
                         : "unknown key '" + key + "' (did you mean '" + closest + "'?)");
  }
}

void CheckKeys(const YAML::Node& node, const std::vector<std::string>& known,
               const std::string& path, const ConfigSource& source) {
  for (const auto& item : node) {
    const std::string key = item.first.Scalar();
    if (std::find(known.begin(), known.end(), key) != known.end()) continue;
    std::string message = "unknown key '" + key + "'";
    const std::string closest = ClosestName(key, known);
    if (!closest.empty()) {
      message += " (did you mean '" + closest + "'?)";
    } else {
      std::string list;
      for (const std::string& candidate : known) list += (list.empty() ? "" : ", ") + candidate;
      message += " (known keys: " + list + ")";
    }
    Fail(item.first, JoinPath(path, key), source, message);
  }
}

void ReadScalar(const YAML::Node& node, bool& out, const std::string& path,
                const ConfigSource& source) {
  if (!node.IsScalar()) Fail(node, path, source, "expected true or false, got " + Describe(node));
  try {
    out = node.as<bool>();
  } catch (const YAML::Exception&) {
    Fail(node, path, source, "expected true or false, got " + Describe(node));
  }
}

void ReadScalar(const YAML::Node& node, int& out, const std::string& path,
                const ConfigSource& source) {
  if (!node.IsScalar()) Fail(node, path, source, "expected an integer, got " + Describe(node));
  try {
    out = node.as<int>();
  } catch (const YAML::Exception&) {
    Fail(node, path, source, "expected an integer, got " + Describe(node));
  }
}

void ReadScalar(const YAML::Node& node, std::uint64_t& out, const std::string& path,
                const ConfigSource& source) {
  const std::string& text = node.IsScalar() ? node.Scalar() : std::string();
  if (text.empty() || text.find_first_not_of("0123456789") != std::string::npos) {
    Fail(node, path, source, "expected a non-negative integer, got " + Describe(node));
  }
  try {
    out = node.as<std::uint64_t>();
  } catch (const YAML::Exception&) {
    Fail(node, path, source, "expected an integer below 2^64, got " + Describe(node));
  }
}

void ReadScalar(const YAML::Node& node, double& out, const std::string& path,
                const ConfigSource& source) {
  if (!node.IsScalar()) Fail(node, path, source, "expected a number, got " + Describe(node));
  try {
    out = node.as<double>();
  } catch (const YAML::Exception&) {
    Fail(node, path, source, "expected a number, got " + Describe(node));
  }
  if (!std::isfinite(out))
    Fail(node, path, source, "expected a finite number, got " + Describe(node));
  // A time (a key in seconds or milliseconds) within the int64-nanosecond range, so that nothing
  // fails mid-run converting it.
  const std::string unit = UnitOfKey(LastKey(path));
  const double scale = unit == "s" ? 1.0 : unit == "ms" ? 1e-3 : 0.0;
  if (scale != 0.0 && std::abs(out) * scale > kMaxTimeSeconds) {
    Fail(node, path, source,
         fmt::format("a time must be within ±{:g} s (int64 nanoseconds: about 292 years), got {}",
                     kMaxTimeSeconds, Describe(node)));
  }
}

void ReadScalar(const YAML::Node& node, std::string& out, const std::string& path,
                const ConfigSource& source) {
  if (!node.IsScalar()) Fail(node, path, source, "expected a string, got " + Describe(node));
  out = node.Scalar();
}

void ReadScalar(const YAML::Node& node, Duration& out, const std::string& path,
                const ConfigSource& source) {
  double seconds = 0.0;
  ReadScalar(node, seconds, path, source);
  try {
    out = FromSeconds(seconds);
  } catch (const std::invalid_argument& e) {
    Fail(node, path, source, e.what());
  }
}

}  // namespace detail

namespace {

// Config files are kilobytes. The cap stops a path to a device or a stream that never ends
// (`track: /dev/zero`) before it fills the memory.
constexpr std::size_t kMaxYamlFileBytes = std::size_t{16} << 20;

// The first byte of `text` that does not belong to well-formed UTF-8 (RFC 3629: no over-long
// forms, no surrogates, nothing above U+10FFFF), or npos.
std::size_t FirstInvalidUtf8(const std::string& text) {
  std::size_t i = 0;
  while (i < text.size()) {
    const auto byte = static_cast<unsigned char>(text[i]);
    if (byte < 0x80) {
      ++i;
      continue;
    }
    // the sequence's length, and the range its second byte must lie in
    std::size_t length = 0;
    unsigned char low = 0x80, high = 0xBF;
    if (byte >= 0xC2 && byte <= 0xDF) {
      length = 2;
    } else if (byte >= 0xE0 && byte <= 0xEF) {
      length = 3;
      if (byte == 0xE0) low = 0xA0;   // over-long
      if (byte == 0xED) high = 0x9F;  // surrogates
    } else if (byte >= 0xF0 && byte <= 0xF4) {
      length = 4;
      if (byte == 0xF0) low = 0x90;   // over-long
      if (byte == 0xF4) high = 0x8F;  // above U+10FFFF
    }
    if (length == 0 || i + length > text.size()) return i;
    const auto second = static_cast<unsigned char>(text[i + 1]);
    if (second < low || second > high) return i;
    for (std::size_t k = 2; k < length; ++k) {
      if ((static_cast<unsigned char>(text[i + k]) >> 6) != 0x02) return i;
    }
    i += length;
  }
  return std::string::npos;
}

// A ConfigError at `file`:line:column for the byte at `offset` of `text`.
ConfigError ErrorAtOffset(const std::filesystem::path& file, const std::string& text,
                          std::size_t offset, const std::string& message) {
  const std::size_t line =
      1 + static_cast<std::size_t>(std::count(text.begin(), text.begin() + offset, '\n'));
  const std::size_t line_start = text.rfind('\n', offset == 0 ? 0 : offset - 1);
  const std::size_t column = offset - (line_start == std::string::npos ? 0 : line_start + 1) + 1;
  return ConfigError(fmt::format("{}:{}:{}: {}", file.string(), line, column, message));
}

// How many nodes a file may expand to through its aliases (a few thousand in the shipped files):
// a chain of aliases each doubling the one before would otherwise take exponential time.
constexpr std::size_t kMaxYamlNodes = 1'000'000;

// `where` is the file, or "--set KEY (value)" for a value given on the command line.
ConfigError ErrorAtMark(const std::string& where, const YAML::Mark& mark,
                        const std::string& message) {
  return ConfigError(fmt::format("{}:{}:{}: {}", where, mark.line + 1, mark.column + 1, message));
}

// Checks the tree below `node` (`ancestors`: the nodes above it): every mapping has each key once
// and as a plain name (yaml-cpp keeps a repeated key's entries and reads the first, so
// `duration_s: 3` then `duration_s: 5` would run 3 s without a word); no alias contains itself
// (`a: &x [*x]` is a cycle every reader would follow forever); the tree stays below kMaxYamlNodes.
void CheckTree(const YAML::Node& node, const std::string& where, std::vector<YAML::Node>* ancestors,
               std::size_t* nodes) {
  if (++*nodes > kMaxYamlNodes) {
    throw ErrorAtMark(
        where, node.Mark(),
        fmt::format("the file expands to over {} values through its aliases", kMaxYamlNodes));
  }
  for (const YAML::Node& above : *ancestors) {
    if (node.is(above)) {
      throw ErrorAtMark(where, node.Mark(),
                        "an alias refers to a value that contains it (a cycle)");
    }
  }
  ancestors->push_back(node);
  if (node.IsMap()) {
    std::map<std::string, YAML::Mark> seen;
    for (const auto& entry : node) {
      if (!entry.first.IsScalar()) {
        throw ErrorAtMark(where, entry.first.Mark(),
                          "a key must be a plain name, got a " +
                              std::string(entry.first.IsMap() ? "mapping" : "list or null"));
      }
      const std::string key = entry.first.Scalar();
      const auto [first, inserted] = seen.emplace(key, entry.first.Mark());
      if (!inserted) {
        throw ErrorAtMark(
            where, entry.first.Mark(),
            fmt::format("{}: duplicate key (first at line {})", key, first->second.line + 1));
      }
      CheckTree(entry.second, where, ancestors, nodes);
    }
  } else if (node.IsSequence()) {
    for (const auto& child : node) CheckTree(child, where, ancestors, nodes);
  }
  ancestors->pop_back();
}

void CheckTree(const YAML::Node& root, const std::string& where) {
  std::vector<YAML::Node> ancestors;
  std::size_t nodes = 0;
  CheckTree(root, where, &ancestors, &nodes);
}

}  // namespace

YAML::Node LoadYamlFile(const std::filesystem::path& file) {
  RequireRegularFile(file);
  std::ifstream in(file, std::ios::binary);
  if (!in) throw ConfigError(file.string() + ": cannot open file");
  std::string text;
  std::array<char, 1 << 16> chunk;
  while (in.read(chunk.data(), chunk.size()) || in.gcount() > 0) {
    text.append(chunk.data(), static_cast<std::size_t>(in.gcount()));
    if (text.size() > kMaxYamlFileBytes) {
      throw ConfigError(fmt::format("{}: larger than {} MiB, not a config file", file.string(),
                                    kMaxYamlFileBytes >> 20));
    }
  }
  if (const std::size_t bad = FirstInvalidUtf8(text); bad != std::string::npos) {
    throw ErrorAtOffset(file, text, bad,
                        fmt::format("not UTF-8 text (byte 0x{:02X}); save the file as UTF-8",
                                    static_cast<unsigned char>(text[bad])));
  }
  try {
    YAML::Node root = YAML::Load(text);
    if (!root || root.IsNull()) throw ConfigError(file.string() + ": the file is empty");
    CheckTree(root, file.string());
    return root;
  } catch (const YAML::ParserException& e) {
    throw ConfigError(file.string() + ":" + std::to_string(e.mark.line + 1) + ":" +
                      std::to_string(e.mark.column + 1) + ": YAML syntax error: " + e.msg);
  }
}

std::vector<std::string> ParseOverridePath(const std::string& key) {
  // key := name ( "." name | "[" index "]" )*, name := [A-Za-z_][A-Za-z0-9_]*, index := [0-9]+
  const auto bad = [&](const std::string& why) {
    return ConfigError("--set " + key + ": " + why +
                       " (a key path is names joined by '.' and list indices in [], e.g. "
                       "cars[0].oracle.speed_mps)");
  };
  const auto is_name_char = [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '_';
  };
  std::vector<std::string> tokens;
  std::size_t i = 0;
  bool expect_name = true;  // at the start and after '.'
  while (i < key.size()) {
    if (expect_name) {
      const std::size_t start = i;
      while (i < key.size() && is_name_char(key[i])) ++i;
      if (i == start) throw bad("expected a name at position " + std::to_string(start + 1));
      if (std::isdigit(static_cast<unsigned char>(key[start])) != 0) {
        throw bad("'" + key.substr(start, i - start) + "' is not a name; index lists as [N]");
      }
      tokens.push_back(key.substr(start, i - start));
      expect_name = false;
    } else if (key[i] == '.') {
      ++i;
      expect_name = true;
    } else if (key[i] == '[') {
      const std::size_t close = key.find(']', i);
      if (close == std::string::npos) throw bad("'[' without ']'");
      const std::string index = key.substr(i + 1, close - i - 1);
      if (index.empty() || index.find_first_not_of("0123456789") != std::string::npos) {
        throw bad("list index '" + index + "' is not a whole number >= 0");
      }
      if (index.size() > 9) throw bad("list index " + index + " is out of range");
      tokens.push_back(index);
      i = close + 1;
    } else {
      throw bad(std::string("unexpected '") + key[i] + "' at position " + std::to_string(i + 1));
    }
  }
  if (tokens.empty()) throw bad("empty key");
  if (expect_name) throw bad("the path ends with '.'");
  return tokens;
}

namespace {

// `node`, or a copy of it if an earlier part of the walk reached the same node (an alias), with
// the same done for everything inside. A map's entry that changes is removed and added again (a
// node assigned in place would change every alias of it); a sequence with a changed element is
// built anew. Nodes are told apart by where they start in the file: every node of a freshly
// parsed file starts at its own position, and an alias is the anchored node itself (copies have
// no position and are never shared).
YAML::Node Unshared(YAML::Node node, std::unordered_set<int>* seen) {
  const int at = node.Mark().pos;
  const bool shared = at >= 0 && !seen->insert(at).second;
  YAML::Node result = shared ? YAML::Clone(node) : node;
  if (result.IsMap()) {
    std::vector<YAML::Node> keys;
    for (const auto& entry : result) keys.push_back(entry.first);
    for (const YAML::Node& key : keys) {
      YAML::Node child = result[key];
      YAML::Node fresh = Unshared(child, seen);
      if (!fresh.is(child)) {
        result.remove(key);
        result[key] = fresh;
      }
    }
  } else if (result.IsSequence()) {
    std::vector<YAML::Node> items;
    bool changed = false;
    for (std::size_t i = 0; i < result.size(); ++i) {
      YAML::Node child = result[i];
      items.push_back(Unshared(child, seen));
      changed = changed || !items.back().is(child);
    }
    if (changed) {
      YAML::Node rebuilt(YAML::NodeType::Sequence);
      for (const YAML::Node& item : items) rebuilt.push_back(item);
      return rebuilt;
    }
  }
  return result;
}

}  // namespace

void BreakAliases(YAML::Node& root) {
  std::unordered_set<int> seen;
  YAML::Node fresh = Unshared(root, &seen);
  if (!fresh.is(root)) root.reset(fresh);
}

namespace {

// The last step of an override into a mapping: a null removes the key (there may be nothing to
// remove), any other value replaces it and removes the key's alternatives.
void SetMapKey(YAML::Node& map, const std::string& key, const YAML::Node& value,
               const AlternativeKeys& alternatives) {
  if (value.IsNull()) {
    if (map.IsMap()) map.remove(key);
    return;
  }
  if (map.IsMap()) {
    for (const std::vector<std::string>& group : alternatives) {
      if (std::find(group.begin(), group.end(), key) == group.end()) continue;
      for (const std::string& other : group) {
        if (other != key) map.remove(other);
      }
    }
  }
  map[key] = value;
}

}  // namespace

void ApplyOverride(YAML::Node& root, const std::string& assignment, ConfigSource* source,
                   const AlternativeKeys& alternatives) {
  const std::size_t equals = assignment.find('=');
  if (equals == std::string::npos || equals == 0) {
    throw ConfigError("--set " + assignment + ": expected key=value, e.g. cars[0].laps=3");
  }
  const std::string key = assignment.substr(0, equals);
  const std::string text = assignment.substr(equals + 1);

  const std::vector<std::string> tokens = ParseOverridePath(key);
  if (FirstInvalidUtf8(assignment) != std::string::npos) {
    throw ConfigError("--set " + key + ": the value is not UTF-8 text");
  }

  YAML::Node value;
  try {
    value = YAML::Load(text);
  } catch (const YAML::ParserException& e) {
    throw ConfigError("--set " + key + ": cannot parse value '" + text + "': " + e.msg);
  }
  CheckTree(value, "--set " + key + " (value)");

  std::string canonical;
  YAML::Node node;
  node.reset(root);
  for (std::size_t i = 0; i < tokens.size(); ++i) {
    const std::string& t = tokens[i];
    const bool is_index = t.find_first_not_of("0123456789") == std::string::npos;
    const bool last = i + 1 == tokens.size();
    if (is_index) {
      if (!node.IsSequence()) {
        throw ConfigError("--set " + key + ": '" + (canonical.empty() ? "(top level)" : canonical) +
                          "' is not a list");
      }
      const std::size_t index = std::stoul(t);  // ParseOverridePath bounded it
      if (index >= node.size()) {
        throw ConfigError("--set " + key + ": index " + t + " is out of range ('" + canonical +
                          "' has " + std::to_string(node.size()) + " entries)");
      }
      canonical = detail::JoinIndex(canonical, index);
      if (last && value.IsNull()) {
        node.remove(index);
      } else if (last) {
        node[index] = value;
      } else {
        YAML::Node child = node[index];
        node.reset(child);
      }
    } else {
      if (node.IsDefined() && !node.IsMap() && !node.IsNull()) {
        throw ConfigError("--set " + key + ": '" + (canonical.empty() ? "(top level)" : canonical) +
                          "' is not a mapping");
      }
      canonical = detail::JoinPath(canonical, t);
      if (last) {
        SetMapKey(node, t, value, alternatives);
      } else {
        YAML::Node child = node[t];
        node.reset(child);
      }
    }
  }
  source->overridden_paths.insert(canonical);
}

}  // namespace autonomsim::sim
