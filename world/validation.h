// The one helper every Validate() uses: a failed check is std::invalid_argument with a message that
// names the key and the bad value (the config reader adds file, line and key path).
#pragma once

#include <cmath>
#include <concepts>
#include <sstream>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>

namespace autonomsim {

inline void Require(bool ok, const std::string& message) {
  if (!ok) throw std::invalid_argument(message);
}

// The same, with a message that is built only when the check fails: for a message with numbers
// in it (Num, std::to_string) on a path that runs every step, where building the text of a check
// that passes would cost more than the step's own work.
template <class MakeMessage>
requires std::invocable<MakeMessage&>
void Require(bool ok, MakeMessage&& make_message) {
  if (!ok) throw std::invalid_argument(std::string(make_message()));
}

// A number as a person would write it in a message: 0.1, not 0.100000.
template <class T>
std::string Num(T value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

// A finite x > 0, else "<key> must be > 0, got <x>" (a Duration: pass ToSeconds(d) and its _s key).
inline void RequirePositive(double x, std::string_view key) {
  Require(std::isfinite(x) && x > 0.0,
          [&] { return std::string(key) + " must be > 0, got " + Num(x); });
}

}  // namespace autonomsim
