#include "sim/mqtt/mqtt_link_config.h"

#include <fstream>
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

MqttOptions GivenBrokerOptions(const MqttLinkConfig& config, const std::string& client_id) {
  if (config.broker.empty()) throw std::logic_error("GivenBrokerOptions: no broker given");
  const auto [host, port] = ParseHostPort(config.broker);
  MqttOptions options;
  options.host = host;
  options.port = port;
  options.client_id = client_id;
  options.username = config.username;
  if (!config.password_file.empty()) {
    std::ifstream in(config.password_file);
    if (!in) throw MqttError("cannot read v2i.mqtt.password_file " + config.password_file);
    std::getline(in, options.password);
  }
  options.cafile = config.cafile;
  options.certfile = config.certfile;
  options.keyfile = config.keyfile;
  options.session_expiry = std::chrono::minutes(5);
  options.end_session_on_close = true;
  return options;
}

}  // namespace autonomsim::sim
