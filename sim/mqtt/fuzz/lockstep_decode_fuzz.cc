// libFuzzer target: the lock-step codec's decoders (sim/mqtt/mqtt_lockstep.h) on any bytes a broker
// may carry. A decoder must never throw, a failure must say why, and what decodes must survive
// encode → decode unchanged. tools/fuzz.sh runs it.
//
// Input: one selector byte, then the text. The selector (mod 4) picks the decoder: step tag,
// response tag, reset (JSON), ack (JSON): "0run 1 2" is the step tag "run 1 2".
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>

#include "sim/mqtt/mqtt_lockstep.h"

namespace autonomsim::sim {
namespace {

[[noreturn]] void Finding(const char* what, std::string_view text) {
  std::fprintf(stderr, "FINDING: %s\n  input '%.*s'\n", what, static_cast<int>(text.size()),
               text.data());
  std::abort();
}

template <class T>
bool Failed(const world::Decoded<T>& decoded, std::string_view text) {
  if (decoded.ok()) return false;
  if (decoded.error().empty()) Finding("a failed decode without a reason", text);
  return true;
}

// Encoding a decoded value and decoding that gives the same value (compared by its encoding for
// the JSON messages, which have no operator==).
template <class T, class Encode, class Decode, class Same>
void CheckRoundTrip(std::string_view text, Encode encode, Decode decode, Same same) {
  const world::Decoded<T> first = decode(text);
  if (Failed(first, text)) return;
  const std::string encoded = encode(first.value());
  const world::Decoded<T> second = decode(encoded);
  if (!second.ok()) Finding(("its encoding does not decode: " + second.error()).c_str(), text);
  if (!same(first.value(), second.value())) Finding("encode → decode changes the value", text);
}

}  // namespace
}  // namespace autonomsim::sim

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace autonomsim::sim;
  if (size == 0) return 0;
  const unsigned selector = data[0] % 4;
  const std::string_view text(reinterpret_cast<const char*>(data) + 1, size - 1);
  const auto equal = [](const auto& a, const auto& b) { return a == b; };
  switch (selector) {
    case 0:
      CheckRoundTrip<StepTag>(text, EncodeStepTag, DecodeStepTag, equal);
      break;
    case 1:
      CheckRoundTrip<ResponseTag>(text, EncodeResponseTag, DecodeResponseTag, equal);
      break;
    case 2:
      CheckRoundTrip<SimReset>(
          text, EncodeReset, DecodeReset,
          [](const SimReset& a, const SimReset& b) { return EncodeReset(a) == EncodeReset(b); });
      break;
    default:
      CheckRoundTrip<SimAck>(text, EncodeAck, DecodeAck, [](const SimAck& a, const SimAck& b) {
        return EncodeAck(a) == EncodeAck(b);
      });
      break;
  }
  return 0;
}
