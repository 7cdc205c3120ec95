#include "world/vtl_py.h"

#include <algorithm>
#include <cstdio>

#include "world/v2i_protocol.h"

namespace autonomsim::world {
namespace {

bool IsContinuation(unsigned char c) { return (c & 0xC0) == 0x80; }

// The code points of `text` under Python's strict UTF-8 decoder (no overlong forms, no
// surrogates, nothing above U+10FFFF), or nullopt where bytes.decode("utf-8") raises.
std::optional<std::vector<char32_t>> DecodeUtf8Strictly(std::string_view text) {
  std::vector<char32_t> code_points;
  std::size_t k = 0;
  while (k < text.size()) {
    const auto lead = static_cast<unsigned char>(text[k]);
    int extra = 0;
    char32_t cp = lead;
    unsigned char low = 0x80;  // the second byte's range, which rules out overlong forms
    unsigned char high = 0xBF;
    if (lead < 0x80) {
      extra = 0;
    } else if (lead >= 0xC2 && lead <= 0xDF) {
      extra = 1;
      cp = lead & 0x1F;
    } else if (lead >= 0xE0 && lead <= 0xEF) {
      extra = 2;
      cp = lead & 0x0F;
      if (lead == 0xE0) low = 0xA0;
      if (lead == 0xED) high = 0x9F;  // U+D800..U+DFFF, the surrogates
    } else if (lead >= 0xF0 && lead <= 0xF4) {
      extra = 3;
      cp = lead & 0x07;
      if (lead == 0xF0) low = 0x90;
      if (lead == 0xF4) high = 0x8F;  // nothing above U+10FFFF
    } else {
      return std::nullopt;
    }
    if (k + static_cast<std::size_t>(extra) >= text.size()) return std::nullopt;  // cut short
    for (int i = 1; i <= extra; ++i) {
      const auto c = static_cast<unsigned char>(text[k + static_cast<std::size_t>(i)]);
      if (!IsContinuation(c) || (i == 1 && (c < low || c > high))) return std::nullopt;
      cp = (cp << 6) | (c & 0x3F);
    }
    code_points.push_back(cp);
    k += static_cast<std::size_t>(extra) + 1;
  }
  return code_points;
}

// The character as Python's repr would show it in a ValueError, for ASCII.
std::string ReprOfAscii(char32_t c) {
  if (c >= 0x20 && c < 0x7f && c != '\'' && c != '\\') return std::string(1, static_cast<char>(c));
  char hex[8];
  std::snprintf(hex, sizeof hex, "\\x%02x", static_cast<unsigned>(c));
  return hex;
}

std::optional<std::string> RequestExitReason(std::string_view payload,
                                             const std::vector<int>& slots) {
  // request = msg.payload.decode("utf-8"); intersections[int(request[1])] (vtl.py:27-28)
  const std::optional<std::vector<char32_t>> request = DecodeUtf8Strictly(payload);
  if (!request) return "UnicodeDecodeError: the payload is not UTF-8 (vtl.py:27)";
  if (request->size() < 2) return "IndexError: string index out of range (vtl.py:28)";
  const char32_t second = (*request)[1];
  if (second >= 0x80) return std::nullopt;  // perhaps a digit of another script (header)
  if (second < '0' || second > '9') {
    return "ValueError: invalid literal for int() with base 10: '" + ReprOfAscii(second) +
           "' (vtl.py:28)";
  }
  const int slot = static_cast<int>(second - '0');
  if (std::find(slots.begin(), slots.end(), slot) == slots.end()) {
    return "IndexError: list index out of range, no slot for intersection " + std::to_string(slot) +
           " (vtl.py:28)";
  }
  return std::nullopt;
}

}  // namespace

std::optional<std::string> VtlPyExitReason(std::string_view topic, std::string_view payload,
                                           const std::vector<int>& slots) {
  if (topic == kVtlRequestTopic) return RequestExitReason(payload, slots);
  if (topic == kVtlFreeTopic && !DecodeUtf8Strictly(payload)) {
    return "UnicodeDecodeError: the payload is not UTF-8 (vtl.py:15)";
  }
  return std::nullopt;
}

}  // namespace autonomsim::world
