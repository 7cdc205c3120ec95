// The AutonomROS vehicle-to-infrastructure vocabulary (reference §7), exactly as the real cars and
// the lab's traffic-light server (vtl.py) speak it over MQTT:
//   /vtl/request   "<car_id><intersection_id>"  e.g. "01" = car 0 asks for intersection 1
//   /vtl/response  "<car_id>1" granted, "<car_id>0" occupied  (broadcast to every car)
//   /vtl/free      "<car_id>"  the car left its intersection (no intersection id)
// Ids are single ASCII digits 0..9. Decoding never throws: payloads come from a broker, so a
// malformed one yields an error naming what is wrong. Encoding our own messages with an id outside
// 0..9 is a programming error and throws std::invalid_argument.
#pragma once

#include <cstddef>
#include <iosfwd>
#include <string>
#include <string_view>
#include <utility>
#include <variant>

namespace autonomsim::world {

inline constexpr std::string_view kVtlRequestTopic = "/vtl/request";
inline constexpr std::string_view kVtlResponseTopic = "/vtl/response";
inline constexpr std::string_view kVtlFreeTopic = "/vtl/free";

inline constexpr int kMaxV2IId = 9;  // reference §7: ids are one ASCII digit

struct Request {
  int car{0};
  int intersection{0};
  friend bool operator==(const Request&, const Request&) = default;
};

struct Response {
  int car{0};
  bool granted{false};
  friend bool operator==(const Response&, const Response&) = default;
};

struct Free {
  int car{0};
  friend bool operator==(const Free&, const Free&) = default;
};

using V2IPayload = std::variant<Request, Response, Free>;

// What a broker carries: a topic and an opaque payload.
struct V2IMessage {
  std::string topic;
  std::string payload;
  friend bool operator==(const V2IMessage&, const V2IMessage&) = default;
};

// Either a decoded value or the reason it could not be decoded (C++20 has no std::expected).
template <class T>
class Decoded {
 public:
  static Decoded Ok(T value) { return Decoded(std::in_place_index<0>, std::move(value)); }
  static Decoded Error(std::string reason) {
    return Decoded(std::in_place_index<1>, std::move(reason));
  }

  bool ok() const { return v_.index() == 0; }
  explicit operator bool() const { return ok(); }
  // Throws std::logic_error when !ok(): asking for the value of a failed decode is a bug.
  const T& value() const;
  // Empty when ok().
  const std::string& error() const;

 private:
  template <std::size_t I, class A>
  Decoded(std::in_place_index_t<I> tag, A&& a) : v_(tag, std::forward<A>(a)) {}
  std::variant<T, std::string> v_;
};

std::string Encode(const Request& request);
std::string Encode(const Response& response);
std::string Encode(const Free& free);

Decoded<Request> DecodeRequest(std::string_view payload);
Decoded<Response> DecodeResponse(std::string_view payload);
Decoded<Free> DecodeFree(std::string_view payload);

V2IMessage ToMessage(const Request& request);
V2IMessage ToMessage(const Response& response);
V2IMessage ToMessage(const Free& free);
V2IMessage ToMessage(const V2IPayload& payload);

// Dispatches on the topic; an unknown topic is an error like a malformed payload.
Decoded<V2IPayload> Decode(const V2IMessage& message);

// For logs and test failures: the topic and the payload as on the wire, e.g. /vtl/request "01".
std::ostream& operator<<(std::ostream& os, const Request& request);
std::ostream& operator<<(std::ostream& os, const Response& response);
std::ostream& operator<<(std::ostream& os, const Free& free);

// Implementation of the template members.
namespace detail {
[[noreturn]] void ThrowDecodedValueOfError(const std::string& reason);
const std::string& EmptyString();
}  // namespace detail

template <class T>
const T& Decoded<T>::value() const {
  if (!ok()) detail::ThrowDecodedValueOfError(std::get<1>(v_));
  return std::get<0>(v_);
}

template <class T>
const std::string& Decoded<T>::error() const {
  return ok() ? detail::EmptyString() : std::get<1>(v_);
}

}  // namespace autonomsim::world
