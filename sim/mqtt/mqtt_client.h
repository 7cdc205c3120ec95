// A small MQTT client interface, and its implementation over libmosquitto. The rest of the code
// (the simulation's mqtt link, tlserver) talks to this interface only, so tests can put an
// in-memory broker behind it and nothing else includes <mosquitto.h>.
//
// The libmosquitto client speaks MQTT v5 (user properties carry the lock-step tags of
// sim/mqtt/mqtt_lockstep.h; clients of older versions, such as the lab's cars, interoperate through
// the broker), keeps its session across reconnects (clean start off, a session expiry interval) and
// reconnects by itself with a bounded back-off; QoS 1 messages published while the broker is away
// are kept and sent when it is back. Subscriptions are remembered and renewed on every connect, so
// a broker that lost its sessions (no persistence) still delivers afterwards.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace autonomsim::sim {

// The broker is unreachable, refused us, or a call was misused (bad topic, payload too large).
class MqttError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct MqttMessage {
  std::string topic;
  std::string payload;
  int qos{1};  // 1 for everything the /vtl/ protocol sends (reference §7)
  bool retain{false};
  // MQTT v5 user properties, in order (name, value).
  std::vector<std::pair<std::string, std::string>> properties;

  // The value of the first property named `name`, if any.
  std::optional<std::string> Property(const std::string& name) const;
  friend bool operator==(const MqttMessage&, const MqttMessage&) = default;
};

struct MqttOptions {
  std::string host{"127.0.0.1"};
  int port{1883};  // reference §7: the lab's broker listens on the MQTT default port
  // Must be unique per broker: the broker keeps one session per id, and a second connection with
  // the same id throws the first one off.
  std::string client_id;
  std::string username;  // empty: connect anonymously
  std::string password;
  // TLS: a CA file switches TLS on; a certificate and key authenticate us to the broker.
  std::string cafile;
  std::string certfile;
  std::string keyfile;
  std::chrono::seconds keepalive{10};  // the broker drops a silent client after 1.5x this
  // How long the broker keeps our session (subscriptions, queued QoS 1 messages) while we are
  // away, e.g. during its own restart.
  std::chrono::seconds session_expiry{std::chrono::hours(24)};
  // On destruction, tell the broker to drop our session at once (a run's session is of no use
  // after the run) instead of keeping it for session_expiry.
  bool end_session_on_close{false};
  // Reconnect back-off: first retry after the minimum, doubling up to the maximum.
  std::chrono::seconds reconnect_min{1};
  std::chrono::seconds reconnect_max{2};
  // Published by the broker when we vanish without disconnecting (MQTT "last will").
  std::optional<MqttMessage> will;
  // What happens on the connection (connected, lost, refused), for logs; called from the
  // client's network thread.
  std::function<void(const std::string&)> on_log;
};

class MqttClient {
 public:
  virtual ~MqttClient() = default;

  // Queues `message` for sending. A QoS 1 message published while disconnected is sent after the
  // reconnect. Throws MqttError for an invalid topic or an oversized payload.
  virtual void Publish(const MqttMessage& message) = 0;
  // Subscribes now (if connected) and again after every reconnect. Throws MqttError for an
  // invalid filter.
  virtual void Subscribe(const std::string& filter, int qos) = 0;
  // The next received message, or nullopt once `deadline` has passed or Interrupt() was called.
  virtual std::optional<MqttMessage> Receive(std::chrono::steady_clock::time_point deadline) = 0;
  // As Receive, and nullopt too as soon as the connection is lost or made meanwhile (tlserver:
  // its leases pause from the moment the broker is gone, not from its next timer).
  virtual std::optional<MqttMessage> ReceiveUntilConnectionChanges(
      std::chrono::steady_clock::time_point deadline) = 0;
  // Wakes a Receive blocked in another thread (it returns nullopt); thread-safe, also from a
  // signal-handling thread.
  virtual void Interrupt() = 0;
  // Blocks until connected with every subscription acknowledged, or until `deadline`; false on
  // timeout. Throws MqttError at once if the broker refused the connection (credentials, ACL).
  virtual bool WaitReady(std::chrono::steady_clock::time_point deadline) = 0;
  // Blocks until the broker has acknowledged every QoS 1 message published so far, or until
  // `deadline`; false on timeout.
  virtual bool Flush(std::chrono::steady_clock::time_point deadline) = 0;
  virtual bool connected() const = 0;
  // QoS 1 publications the broker answered with an error reason (MQTT v5 PUBACK), e.g. 135 "not
  // authorized" for a topic the ACL denies us. MQTT 3.1.1 brokers drop such messages silently.
  virtual std::uint64_t refused_publications() const = 0;
};

// Creates a libmosquitto client and starts connecting in the background (see WaitReady). Throws
// MqttError for unusable options (e.g. a TLS file that does not exist).
std::unique_ptr<MqttClient> MakeMosquittoClient(const MqttOptions& options);

// "HOST:PORT" → (host, port); throws std::invalid_argument naming what is wrong.
std::pair<std::string, int> ParseHostPort(const std::string& host_port);

}  // namespace autonomsim::sim
