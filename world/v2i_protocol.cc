#include "world/v2i_protocol.h"

#include <cstdio>
#include <ostream>
#include <stdexcept>

namespace autonomsim::world {
namespace detail {

void ThrowDecodedValueOfError(const std::string& reason) {
  throw std::logic_error("value() of a failed decode: " + reason);
}

const std::string& EmptyString() {
  static const std::string kEmpty;
  return kEmpty;
}

}  // namespace detail

namespace {

// A broker payload can be anything; show at most this many bytes of it in an error.
constexpr std::size_t kMaxQuotedBytes = 16;

// The payload as a C-style quoted string, non-printable bytes as \xNN, cut after kMaxQuotedBytes.
std::string Quote(std::string_view payload) {
  std::string out = "\"";
  for (std::size_t k = 0; k < payload.size() && k < kMaxQuotedBytes; ++k) {
    const auto c = static_cast<unsigned char>(payload[k]);
    if (c >= 0x20 && c < 0x7f && c != '"' && c != '\\') {
      out += static_cast<char>(c);
    } else {
      char hex[8];
      std::snprintf(hex, sizeof hex, "\\x%02x", c);
      out += hex;
    }
  }
  out += "\"";
  if (payload.size() > kMaxQuotedBytes) out += "...";
  return out;
}

std::string DescribeByte(char ch) {
  const auto c = static_cast<unsigned char>(ch);
  char buf[32];
  if (c >= 0x21 && c < 0x7f) {
    std::snprintf(buf, sizeof buf, "'%c'", c);
  } else {
    std::snprintf(buf, sizeof buf, "byte 0x%02x", c);
  }
  return buf;
}

bool IsDigit(char c) { return c >= '0' && c <= '9'; }

// Checks the length and that every byte is a digit; returns the error, or "" when well formed.
std::string CheckDigits(std::string_view topic, std::string_view payload, std::size_t length,
                        std::string_view layout) {
  const std::string what = std::string(topic) + " payload " + Quote(payload) + ": ";
  if (payload.empty()) return what + "empty, expected " + std::string(layout);
  if (payload.size() != length) {
    return what + "expected " + std::to_string(length) + " byte(s) " + std::string(layout) +
           ", got " + std::to_string(payload.size());
  }
  for (std::size_t k = 0; k < payload.size(); ++k) {
    if (!IsDigit(payload[k])) {
      return what + "byte " + std::to_string(k) + " is " + DescribeByte(payload[k]) +
             ", expected an ASCII digit 0-9";
    }
  }
  return "";
}

char IdChar(int id, const char* field) {
  if (id < 0 || id > kMaxV2IId) {
    throw std::invalid_argument(std::string(field) +
                                " must be a single digit 0..9 (reference §7), got " +
                                std::to_string(id));
  }
  return static_cast<char>('0' + id);
}

}  // namespace

std::string Encode(const Request& request) {
  return {IdChar(request.car, "car"), IdChar(request.intersection, "intersection")};
}

std::string Encode(const Response& response) {
  return {IdChar(response.car, "car"), response.granted ? '1' : '0'};
}

std::string Encode(const Free& free) { return {IdChar(free.car, "car")}; }

Decoded<Request> DecodeRequest(std::string_view payload) {
  std::string error = CheckDigits(kVtlRequestTopic, payload, 2, "'<car><intersection>'");
  if (!error.empty()) return Decoded<Request>::Error(std::move(error));
  return Decoded<Request>::Ok(Request{payload[0] - '0', payload[1] - '0'});
}

Decoded<Response> DecodeResponse(std::string_view payload) {
  std::string error = CheckDigits(kVtlResponseTopic, payload, 2, "'<car><0|1>'");
  if (!error.empty()) return Decoded<Response>::Error(std::move(error));
  if (payload[1] != '0' && payload[1] != '1') {
    return Decoded<Response>::Error(std::string(kVtlResponseTopic) + " payload " + Quote(payload) +
                                    ": byte 1 is " + DescribeByte(payload[1]) +
                                    ", expected '0' (occupied) or '1' (granted)");
  }
  return Decoded<Response>::Ok(Response{payload[0] - '0', payload[1] == '1'});
}

Decoded<Free> DecodeFree(std::string_view payload) {
  std::string error = CheckDigits(kVtlFreeTopic, payload, 1, "'<car>'");
  if (!error.empty()) return Decoded<Free>::Error(std::move(error));
  return Decoded<Free>::Ok(Free{payload[0] - '0'});
}

V2IMessage ToMessage(const Request& request) {
  return {std::string(kVtlRequestTopic), Encode(request)};
}

V2IMessage ToMessage(const Response& response) {
  return {std::string(kVtlResponseTopic), Encode(response)};
}

V2IMessage ToMessage(const Free& free) { return {std::string(kVtlFreeTopic), Encode(free)}; }

V2IMessage ToMessage(const V2IPayload& payload) {
  return std::visit([](const auto& m) { return ToMessage(m); }, payload);
}

Decoded<V2IPayload> Decode(const V2IMessage& message) {
  auto lift = [](const auto& decoded) {
    if (!decoded.ok()) return Decoded<V2IPayload>::Error(decoded.error());
    return Decoded<V2IPayload>::Ok(V2IPayload{decoded.value()});
  };
  if (message.topic == kVtlRequestTopic) return lift(DecodeRequest(message.payload));
  if (message.topic == kVtlResponseTopic) return lift(DecodeResponse(message.payload));
  if (message.topic == kVtlFreeTopic) return lift(DecodeFree(message.payload));
  return Decoded<V2IPayload>::Error(
      "unknown topic " + Quote(message.topic) + ", expected " + std::string(kVtlRequestTopic) +
      ", " + std::string(kVtlResponseTopic) + " or " + std::string(kVtlFreeTopic));
}

std::ostream& operator<<(std::ostream& os, const Request& request) {
  return os << kVtlRequestTopic << " \"" << Encode(request) << '"';
}

std::ostream& operator<<(std::ostream& os, const Response& response) {
  return os << kVtlResponseTopic << " \"" << Encode(response) << '"';
}

std::ostream& operator<<(std::ostream& os, const Free& free) {
  return os << kVtlFreeTopic << " \"" << Encode(free) << '"';
}

}  // namespace autonomsim::world
