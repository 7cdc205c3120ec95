// The scenario's `v2i.mqtt` section: how a run with `v2i.link: mqtt` reaches its traffic-light
// server. Kept apart from sim/v2i/mqtt_endpoint.h so that sim/scenario/scenario.h can hold it
// cheaply.
#pragma once

#include <chrono>
#include <string>

#include "world/time.h"

namespace autonomsim::sim {

struct MqttOptions;  // sim/mqtt/mqtt_client.h

struct MqttLinkConfig {
  // Empty: the run starts a private mosquitto on a free loopback port and a `tlserver
  // --sim-clock` on it, and stops both at its end. "HOST:PORT": a broker that is already running,
  // with a `tlserver --sim-clock` serving it (`autonomsim run --broker HOST:PORT`).
  std::string broker;
  // Our credentials on a given broker (tools/mosquitto/acl knows the user "autonomsim"); the
  // password file holds the password on its first line. A private broker makes its own password.
  std::string username{"autonomsim"};
  std::string password_file;
  // TLS to a given broker: the CA that signed its certificate, and our certificate and key if it
  // asks for one.
  std::string cafile;
  std::string certfile;
  std::string keyfile;
  // The longest the run waits, in wall-clock time, for the server to answer one message (or for
  // the broker and tlserver to come up) before it stops with an error. Assumed: covers a broker
  // restart (clients retry after 1-2 s) on a loaded machine.
  Duration timeout{std::chrono::seconds(20)};

  template <class V>
  void Describe(V& v) {
    v("broker", broker,
      "HOST:PORT of a running broker with its server; empty: the run starts its own mosquitto and "
      "`tlserver --sim-clock`");
    v("username", username, "our user on a given broker");
    v("password_file", password_file, "a file whose first line is the password on a given broker");
    v("cafile", cafile, "TLS to a given broker: the CA that signed its certificate");
    v("certfile", certfile, "TLS: our certificate, if the broker asks for one");
    v("keyfile", keyfile, "TLS: our certificate's key");
    v("timeout_s", timeout,
      "wall-clock seconds the run waits for the server to answer one message, or for broker and "
      "server to start, before it stops with an error");
  }
  // Throws std::invalid_argument naming the key and the bad value.
  void Validate() const;
};

// The client options for the given broker `config.broker` (not empty): its address, our user and
// password (read from password_file), TLS, and a session the broker drops when we disconnect (a
// run's session is of no use to anybody once it has ended). Throws MqttError when the password
// file cannot be read.
MqttOptions GivenBrokerOptions(const MqttLinkConfig& config, const std::string& client_id);

}  // namespace autonomsim::sim
