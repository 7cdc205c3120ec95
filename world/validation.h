// The one helper every Validate() uses: a failed check is std::invalid_argument with a message that
// names the key and the bad value (the config reader adds file, line and key path).
#pragma once

#include <sstream>
#include <stdexcept>
#include <string>

namespace autonomsim {

inline void Require(bool ok, const std::string& message) {
  if (!ok) throw std::invalid_argument(message);
}

// A number as a person would write it in a message: 0.1, not 0.100000.
template <class T>
std::string Num(T value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

}  // namespace autonomsim
