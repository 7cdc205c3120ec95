#include "sim/mqtt/mqtt_link_config.h"

#include <stdexcept>
#include <string>

#include "sim/mqtt/mqtt_client.h"
#include "world/validation.h"

namespace autonomsim::sim {

void MqttLinkConfig::Validate() const {
  if (!broker.empty()) {
    try {
      ParseHostPort(broker);
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(std::string("broker: ") + e.what());
    }
  }
  Require(!broker.empty() ||
              (password_file.empty() && cafile.empty() && certfile.empty() && keyfile.empty()),
          "password_file, cafile, certfile and keyfile apply to a given broker only; the private "
          "broker of a run (broker: '') makes its own credentials");
  Require(!broker.empty() || username == "autonomsim",
          "username applies to a given broker only; a private broker knows the user 'autonomsim'");
  Require(!username.empty(), "username must not be empty");
  Require(certfile.empty() == keyfile.empty(), "certfile and keyfile go together");
  Require(certfile.empty() || !cafile.empty(), "certfile and keyfile need a cafile (TLS)");
  Require(timeout > kZeroTime, "timeout_s must be > 0 s, got " + Num(ToSeconds(timeout)) + " s");
}

}  // namespace autonomsim::sim
