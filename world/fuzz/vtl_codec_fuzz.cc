// libFuzzer target: the /vtl/ codec (world/v2i_protocol.h) on any broker message. Decoding must
// never throw, a failure must say why, and a payload that decodes must be the canonical encoding
// of its value (encoding it again gives the same bytes). tools/fuzz.sh runs it.
//
// Input: one selector byte, then the payload. The selector (mod 4) picks the topic: /vtl/request,
// /vtl/response, /vtl/free, or (3) the bytes up to the first space, the payload being the rest:
// "001" is a request "01", "3/vtl/free 4" the message /vtl/free "4".
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <string>
#include <string_view>
#include <variant>

#include "world/v2i_protocol.h"

namespace autonomsim::world {
namespace {

[[noreturn]] void Finding(const char* what, const V2IMessage& message) {
  std::fprintf(stderr, "FINDING: %s\n  topic '%s', payload '%s'\n", what, message.topic.c_str(),
               message.payload.c_str());
  std::abort();
}

V2IMessage MessageOf(std::string_view input) {
  const unsigned selector = static_cast<unsigned char>(input[0]) % 4;
  const std::string_view rest = input.substr(1);
  switch (selector) {
    case 0:
      return {std::string(kVtlRequestTopic), std::string(rest)};
    case 1:
      return {std::string(kVtlResponseTopic), std::string(rest)};
    case 2:
      return {std::string(kVtlFreeTopic), std::string(rest)};
    default: {
      const std::size_t space = rest.find(' ');
      if (space == std::string_view::npos) return {std::string(rest), ""};
      return {std::string(rest.substr(0, space)), std::string(rest.substr(space + 1))};
    }
  }
}

// The topic's own decoder agrees with Decode().
bool TopicDecoderAccepts(const V2IMessage& message) {
  if (message.topic == kVtlRequestTopic) return DecodeRequest(message.payload).ok();
  if (message.topic == kVtlResponseTopic) return DecodeResponse(message.payload).ok();
  if (message.topic == kVtlFreeTopic) return DecodeFree(message.payload).ok();
  return false;
}

}  // namespace
}  // namespace autonomsim::world

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace autonomsim::world;
  if (size == 0) return 0;
  const V2IMessage message = MessageOf({reinterpret_cast<const char*>(data), size});

  const Decoded<V2IPayload> decoded = Decode(message);
  if (decoded.ok() != TopicDecoderAccepts(message)) {
    Finding("Decode and the topic's decoder disagree", message);
  }
  if (!decoded.ok()) {
    if (decoded.error().empty()) Finding("a failed decode without a reason", message);
    return 0;
  }
  if (ToMessage(decoded.value()) != message) {
    Finding("a decoded message does not encode back to its bytes", message);
  }
  std::ostringstream log;
  std::visit([&log](const auto& value) { log << value; }, decoded.value());
  return 0;
}
