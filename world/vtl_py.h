// The lab's traffic-light server as a script (code/vtl_ws/vtl.py, lab commit 02c5ab4) on a raw
// payload: which messages make it exit. Its callbacks decode and index the payload unchecked, and
// an exception raised in a paho callback ends loop_forever and the script (reference §7: "A
// malformed request raises in the callback and the server exits").
//
// What raises (vtl.py:15 and :27-28; the rest of a payload is never looked at):
//   /vtl/request  a payload that is not UTF-8 (UnicodeDecodeError); fewer than two characters
//                 (IndexError); a second character that int() rejects (ValueError); a second
//                 character naming no slot (IndexError: vtl.py has slots 0 and 1 only);
//   /vtl/free     a payload that is not UTF-8 (UnicodeDecodeError); nothing else: a free is
//                 compared with the slots, never parsed.
// Claimed only where certain: a second character outside ASCII may be a decimal digit of another
// script, which int() takes (int('١') == 1), so it is not claimed here (tlserver rejects it as
// malformed, as any payload that is not the protocol).
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace autonomsim::world {

// The exception vtl.py would die of on `payload` received on `topic` (kVtlRequestTopic or
// kVtlFreeTopic; any other topic: nullopt, vtl.py does not subscribe to it), e.g.
// "ValueError: int('x') (vtl.py:28)"; nullopt where vtl.py carries on. `slots`: the intersection
// ids it has a slot for (the lab's vtl.py: 0 and 1).
std::optional<std::string> VtlPyExitReason(std::string_view topic, std::string_view payload,
                                           const std::vector<int>& slots);

}  // namespace autonomsim::world
