// The one helper every Validate() uses: a failed check is std::invalid_argument with a message that
// names the key and the bad value (the config reader adds file, line and key path).
#pragma once

#include <concepts>
#include <sstream>
#include <stdexcept>
#include <string>
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

}  // namespace autonomsim
