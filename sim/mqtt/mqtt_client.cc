#include "sim/mqtt/mqtt_client.h"

#include <mosquitto.h>
#include <mqtt_protocol.h>

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <cstdlib>
#include <deque>
#include <mutex>
#include <set>
#include <stdexcept>
#include <thread>

namespace autonomsim::sim {

std::optional<std::string> MqttMessage::Property(const std::string& name) const {
  for (const auto& [key, value] : properties) {
    if (key == name) return value;
  }
  return std::nullopt;
}

std::pair<std::string, int> ParseHostPort(const std::string& host_port) {
  const std::size_t colon = host_port.rfind(':');
  if (colon == std::string::npos || colon == 0 || colon + 1 == host_port.size()) {
    throw std::invalid_argument("expected HOST:PORT, got '" + host_port + "'");
  }
  std::string host = host_port.substr(0, colon);
  if (host.size() >= 2 && host.front() == '[' && host.back() == ']') {
    host = host.substr(1, host.size() - 2);  // [::1]:1883
  }
  const std::string port_text = host_port.substr(colon + 1);
  if (port_text.size() > 5 || !std::all_of(port_text.begin(), port_text.end(),
                                           [](char c) { return c >= '0' && c <= '9'; })) {
    throw std::invalid_argument("port of '" + host_port + "' must be a number 1..65535");
  }
  const int port = std::stoi(port_text);
  if (port < 1 || port > 65535) {
    throw std::invalid_argument("port of '" + host_port + "' must be a number 1..65535");
  }
  return {host, port};
}

namespace {

// libmosquitto wants one process-wide init (it sets up OpenSSL); cleanup runs at exit.
class MosquittoLibrary {
 public:
  static void Ensure() { static MosquittoLibrary instance; }

 private:
  MosquittoLibrary() { mosquitto_lib_init(); }
  ~MosquittoLibrary() { mosquitto_lib_cleanup(); }
};

std::string ErrorText(int rc) { return mosquitto_strerror(rc); }

// Message ids the broker still has to acknowledge. The acknowledgement can arrive (on the network
// thread) before the publishing thread has recorded the id it got back, so early ones are kept.
class MidTracker {
 public:
  void Sent(int mid) {
    if (!early_.erase(mid)) outstanding_.insert(mid);
  }
  void Acked(int mid) {
    if (!outstanding_.erase(mid)) early_.insert(mid);
  }
  void Clear() {
    outstanding_.clear();
    early_.clear();
  }
  bool empty() const { return outstanding_.empty(); }

 private:
  std::set<int> outstanding_;
  std::set<int> early_;
};

class MosquittoClient final : public MqttClient {
 public:
  explicit MosquittoClient(MqttOptions options);
  ~MosquittoClient() override;
  MosquittoClient(const MosquittoClient&) = delete;
  MosquittoClient& operator=(const MosquittoClient&) = delete;

  void Publish(const MqttMessage& message) override;
  void Subscribe(const std::string& filter, int qos) override;
  std::optional<MqttMessage> Receive(std::chrono::steady_clock::time_point deadline) override {
    return Take(deadline, false);
  }
  std::optional<MqttMessage> ReceiveUntilConnectionChanges(
      std::chrono::steady_clock::time_point deadline) override {
    return Take(deadline, true);
  }
  void Interrupt() override;
  bool WaitReady(std::chrono::steady_clock::time_point deadline) override;
  bool Flush(std::chrono::steady_clock::time_point deadline) override;
  bool connected() const override;
  std::uint64_t refused_publications() const override { return refused_publications_; }

 private:
  static void OnConnect(mosquitto* m, void* self, int rc, int flags, const mosquitto_property*);
  static void OnDisconnect(mosquitto* m, void* self, int rc, const mosquitto_property*);
  std::optional<MqttMessage> Take(std::chrono::steady_clock::time_point deadline,
                                  bool until_connection_changes);
  static void OnMessage(mosquitto* m, void* self, const mosquitto_message* msg,
                        const mosquitto_property* props);
  static void OnSubscribe(mosquitto* m, void* self, int mid, int count, const int* granted,
                          const mosquitto_property*);
  static void OnPublish(mosquitto* m, void* self, int mid, int reason, const mosquitto_property*);

  void Log(const std::string& line) const {
    if (options_.on_log) options_.on_log(line);
  }
  // Sends SUBSCRIBE for `filter`; the caller must not hold mu_ (libmosquitto takes its own locks).
  void SendSubscribe(const std::string& filter, int qos);
  // The network thread: libmosquitto's loop, and reconnecting with the bounded back-off, until
  // closing_. Ours rather than mosquitto_loop_start's: that thread can miss a disconnect that
  // arrives while it is reconnecting and then never exits, so mosquitto_loop_stop waits forever
  // (eclipse-mosquitto/mosquitto#2545, libmosquitto 2.0.11 in Debian 12).
  void RunNetwork();

  MqttOptions options_;
  mosquitto* mosq_{nullptr};
  std::thread network_;
  // Set once, by the destructor; the network thread sends what is queued (our DISCONNECT) and
  // stops.
  std::atomic<bool> closing_{false};
  std::mutex closing_mu_;
  std::condition_variable closing_cv_;       // wakes the back-off wait when closing_ is set
  std::chrono::seconds reconnect_delay_{0};  // network thread only

  mutable std::mutex mu_;
  std::condition_variable cv_;
  std::deque<MqttMessage> inbox_;
  bool interrupted_{false};
  bool connected_{false};
  std::string refusal_;  // why the broker refused the connection or a subscription
  std::vector<std::pair<std::string, int>> subscriptions_;
  MidTracker pending_subscriptions_;
  MidTracker pending_publications_;
  std::atomic<std::uint64_t> refused_publications_{0};
};

MosquittoClient::MosquittoClient(MqttOptions options) : options_(std::move(options)) {
  MosquittoLibrary::Ensure();
  if (options_.client_id.empty()) {
    throw MqttError("MQTT client id must not be empty (the broker keeps our session by it)");
  }
  // clean_session false: the broker keeps our subscriptions and queued messages while we are away.
  mosq_ = mosquitto_new(options_.client_id.c_str(), false, this);
  if (mosq_ == nullptr) throw MqttError("mosquitto_new failed for client " + options_.client_id);
  auto check = [this](int rc, const std::string& what) {
    if (rc != MOSQ_ERR_SUCCESS) {
      mosquitto_destroy(mosq_);
      mosq_ = nullptr;
      throw MqttError(what + ": " + ErrorText(rc));
    }
  };
  check(mosquitto_int_option(mosq_, MOSQ_OPT_PROTOCOL_VERSION, MQTT_PROTOCOL_V5),
        "MQTT v5 not available");
  // Each lock-step exchange is a few small packets: Nagle's algorithm would hold them back.
  check(mosquitto_int_option(mosq_, MOSQ_OPT_TCP_NODELAY, 1), "TCP_NODELAY");
  if (!options_.username.empty()) {
    check(
        mosquitto_username_pw_set(mosq_, options_.username.c_str(),
                                  options_.password.empty() ? nullptr : options_.password.c_str()),
        "MQTT credentials");
  }
  if (!options_.cafile.empty()) {
    check(mosquitto_tls_set(mosq_, options_.cafile.c_str(), nullptr,
                            options_.certfile.empty() ? nullptr : options_.certfile.c_str(),
                            options_.keyfile.empty() ? nullptr : options_.keyfile.c_str(), nullptr),
          "TLS files (cafile '" + options_.cafile + "', certfile '" + options_.certfile +
              "', keyfile '" + options_.keyfile + "')");
  } else if (!options_.certfile.empty() || !options_.keyfile.empty()) {
    check(MOSQ_ERR_INVAL, "a TLS certificate or key needs a CA file (cafile)");
  }
  if (options_.will) {
    check(mosquitto_will_set_v5(
              mosq_, options_.will->topic.c_str(), static_cast<int>(options_.will->payload.size()),
              options_.will->payload.data(), options_.will->qos, options_.will->retain, nullptr),
          "MQTT will on " + options_.will->topic);
  }
  // Our network thread calls into libmosquitto while others publish and subscribe.
  check(mosquitto_threaded_set(mosq_, true), "MQTT threading");
  mosquitto_connect_v5_callback_set(mosq_, &OnConnect);
  mosquitto_disconnect_v5_callback_set(mosq_, &OnDisconnect);
  mosquitto_message_v5_callback_set(mosq_, &OnMessage);
  mosquitto_subscribe_v5_callback_set(mosq_, &OnSubscribe);
  mosquitto_publish_v5_callback_set(mosq_, &OnPublish);

  // MQTT v5 ends a session when its connection closes unless an expiry interval is given.
  mosquitto_property* props = nullptr;
  mosquitto_property_add_int32(&props, MQTT_PROP_SESSION_EXPIRY_INTERVAL,
                               static_cast<std::uint32_t>(options_.session_expiry.count()));
  const int rc =
      mosquitto_connect_bind_v5(mosq_, options_.host.c_str(), options_.port,
                                static_cast<int>(options_.keepalive.count()), nullptr, props);
  mosquitto_property_free_all(&props);
  if (rc != MOSQ_ERR_SUCCESS) {
    // Not fatal: the network thread keeps retrying (a broker may start after us).
    Log("cannot reach broker " + options_.host + ":" + std::to_string(options_.port) + " yet (" +
        ErrorText(rc) + "), retrying");
  }
  network_ = std::thread([this] { RunNetwork(); });
}

void MosquittoClient::RunNetwork() {
  // select() wakes at once for anything queued (libmosquitto writes to its own socket pair); the
  // timeout only bounds how late a keep-alive or the closing check can be.
  constexpr int kLoopTimeoutMs = 100;
  constexpr auto kCloseGrace = std::chrono::seconds(1);  // to send our DISCONNECT when closing
  std::optional<std::chrono::steady_clock::time_point> close_by;
  reconnect_delay_ = options_.reconnect_min;
  while (true) {
    const int rc = mosquitto_loop(mosq_, kLoopTimeoutMs, 1);
    if (closing_) {
      if (!close_by) close_by = std::chrono::steady_clock::now() + kCloseGrace;
      if (rc != MOSQ_ERR_SUCCESS || std::chrono::steady_clock::now() > *close_by) return;
      continue;
    }
    if (rc == MOSQ_ERR_SUCCESS) continue;
    // Not connected (never, or lost): wait, then reconnect without blocking this thread in
    // connect(); the loop above completes the connection or reports it failed.
    {
      std::unique_lock lock(closing_mu_);
      if (closing_cv_.wait_for(lock, reconnect_delay_, [this] { return closing_.load(); })) {
        return;
      }
    }
    reconnect_delay_ = std::min(reconnect_delay_ * 2, options_.reconnect_max);
    const int reconnect = mosquitto_reconnect_async(mosq_);
    if (reconnect != MOSQ_ERR_SUCCESS) {
      Log("cannot reach broker " + options_.host + ":" + std::to_string(options_.port) + " (" +
          ErrorText(reconnect) + "), retrying");
    }
  }
}

MosquittoClient::~MosquittoClient() {
  if (mosq_ == nullptr) return;
  mosquitto_property* props = nullptr;
  if (options_.end_session_on_close) {
    mosquitto_property_add_int32(&props, MQTT_PROP_SESSION_EXPIRY_INTERVAL, 0);
  }
  {
    std::lock_guard lock(closing_mu_);
    closing_ = true;
  }
  closing_cv_.notify_all();
  mosquitto_disconnect_v5(mosq_, 0, props);  // queued; the network thread sends it
  mosquitto_property_free_all(&props);
  if (network_.joinable()) network_.join();
  mosquitto_destroy(mosq_);
}

void MosquittoClient::Publish(const MqttMessage& message) {
  mosquitto_property* props = nullptr;
  for (const auto& [name, value] : message.properties) {
    const int rc = mosquitto_property_add_string_pair(&props, MQTT_PROP_USER_PROPERTY, name.c_str(),
                                                      value.c_str());
    if (rc != MOSQ_ERR_SUCCESS) {
      mosquitto_property_free_all(&props);
      throw MqttError("user property '" + name + "': " + ErrorText(rc));
    }
  }
  int mid = 0;
  const int rc = mosquitto_publish_v5(mosq_, &mid, message.topic.c_str(),
                                      static_cast<int>(message.payload.size()),
                                      message.payload.data(), message.qos, message.retain, props);
  mosquitto_property_free_all(&props);
  // NO_CONN: a QoS 1 message stays queued and goes out after the reconnect.
  if (rc != MOSQ_ERR_SUCCESS && !(rc == MOSQ_ERR_NO_CONN && message.qos > 0)) {
    throw MqttError("publishing to '" + message.topic + "': " + ErrorText(rc));
  }
  if (rc == MOSQ_ERR_SUCCESS || message.qos > 0) {  // libmosquitto reports each one sent
    std::lock_guard lock(mu_);
    pending_publications_.Sent(mid);
  }
}

void MosquittoClient::Subscribe(const std::string& filter, int qos) {
  if (mosquitto_sub_topic_check(filter.c_str()) != MOSQ_ERR_SUCCESS) {
    throw MqttError("invalid subscription filter '" + filter + "'");
  }
  bool now = false;
  {
    std::lock_guard lock(mu_);
    subscriptions_.emplace_back(filter, qos);
    now = connected_;
  }
  // If we are not connected yet, OnConnect subscribes; if the connection comes up meanwhile, it
  // may subscribe twice, which MQTT treats as a harmless renewal.
  if (now) SendSubscribe(filter, qos);
}

void MosquittoClient::SendSubscribe(const std::string& filter, int qos) {
  int mid = 0;
  const int rc = mosquitto_subscribe_v5(mosq_, &mid, filter.c_str(), qos, 0, nullptr);
  if (rc == MOSQ_ERR_SUCCESS) {
    std::lock_guard lock(mu_);
    pending_subscriptions_.Sent(mid);
  }
  // Any failure here means the connection is going away; OnConnect subscribes again.
}

std::optional<MqttMessage> MosquittoClient::Take(std::chrono::steady_clock::time_point deadline,
                                                 bool until_connection_changes) {
  std::unique_lock lock(mu_);
  const bool was_connected = connected_;
  cv_.wait_until(lock, deadline, [&] {
    return !inbox_.empty() || interrupted_ ||
           (until_connection_changes && connected_ != was_connected);
  });
  if (interrupted_) {
    interrupted_ = false;
    return std::nullopt;
  }
  if (inbox_.empty()) return std::nullopt;
  MqttMessage message = std::move(inbox_.front());
  inbox_.pop_front();
  return message;
}

void MosquittoClient::Interrupt() {
  {
    std::lock_guard lock(mu_);
    interrupted_ = true;
  }
  cv_.notify_all();
}

bool MosquittoClient::WaitReady(std::chrono::steady_clock::time_point deadline) {
  std::unique_lock lock(mu_);
  const bool done = cv_.wait_until(lock, deadline, [this] {
    return !refusal_.empty() || (connected_ && pending_subscriptions_.empty());
  });
  if (!refusal_.empty()) throw MqttError(refusal_);
  return done;
}

bool MosquittoClient::Flush(std::chrono::steady_clock::time_point deadline) {
  std::unique_lock lock(mu_);
  return cv_.wait_until(lock, deadline, [this] { return pending_publications_.empty(); });
}

bool MosquittoClient::connected() const {
  std::lock_guard lock(mu_);
  return connected_;
}

void MosquittoClient::OnConnect(mosquitto*, void* obj, int rc, int, const mosquitto_property*) {
  auto* self = static_cast<MosquittoClient*>(obj);
  const std::string where = self->options_.host + ":" + std::to_string(self->options_.port);
  if (rc != 0) {
    {
      std::lock_guard lock(self->mu_);
      self->refusal_ = "broker " + where + " refused the connection of '" +
                       self->options_.client_id + "' (user '" + self->options_.username +
                       "'): " + mosquitto_reason_string(rc);
    }
    self->cv_.notify_all();
    self->Log(self->refusal_);
    return;
  }
  std::vector<std::pair<std::string, int>> subscriptions;
  {
    std::lock_guard lock(self->mu_);
    self->connected_ = true;
    self->pending_subscriptions_.Clear();
    subscriptions = self->subscriptions_;
  }
  self->reconnect_delay_ = self->options_.reconnect_min;  // OnConnect runs on the network thread
  self->Log("connected to " + where + " as '" + self->options_.client_id + "'");
  for (const auto& [filter, qos] : subscriptions) self->SendSubscribe(filter, qos);
  self->cv_.notify_all();
}

void MosquittoClient::OnDisconnect(mosquitto*, void* obj, int rc, const mosquitto_property*) {
  auto* self = static_cast<MosquittoClient*>(obj);
  {
    std::lock_guard lock(self->mu_);
    self->connected_ = false;
  }
  if (rc != 0) {
    self->Log("connection to " + self->options_.host + ":" + std::to_string(self->options_.port) +
              " lost (" + ErrorText(rc) + "), reconnecting");
  }
  self->cv_.notify_all();
}

void MosquittoClient::OnMessage(mosquitto*, void* obj, const mosquitto_message* msg,
                                const mosquitto_property* props) {
  auto* self = static_cast<MosquittoClient*>(obj);
  MqttMessage message;
  message.topic = msg->topic;
  if (msg->payloadlen > 0) {
    message.payload.assign(static_cast<const char*>(msg->payload),
                           static_cast<std::size_t>(msg->payloadlen));
  }
  message.qos = msg->qos;
  message.retain = msg->retain;
  for (const mosquitto_property* p = props; p != nullptr; p = mosquitto_property_next(p)) {
    if (mosquitto_property_identifier(p) != MQTT_PROP_USER_PROPERTY) continue;
    char* name = nullptr;
    char* value = nullptr;
    if (mosquitto_property_read_string_pair(p, MQTT_PROP_USER_PROPERTY, &name, &value, false)) {
      message.properties.emplace_back(name, value);
    }
    std::free(name);  // allocated by libmosquitto with malloc
    std::free(value);
  }
  {
    std::lock_guard lock(self->mu_);
    self->inbox_.push_back(std::move(message));
  }
  self->cv_.notify_all();
}

void MosquittoClient::OnSubscribe(mosquitto*, void* obj, int mid, int count, const int* granted,
                                  const mosquitto_property*) {
  auto* self = static_cast<MosquittoClient*>(obj);
  {
    std::lock_guard lock(self->mu_);
    self->pending_subscriptions_.Acked(mid);
    for (int i = 0; i < count; ++i) {
      if (granted[i] >= 0x80) {
        self->refusal_ = "broker " + self->options_.host + ":" +
                         std::to_string(self->options_.port) + " refused a subscription of '" +
                         self->options_.client_id + "' (user '" + self->options_.username +
                         "'): " + mosquitto_reason_string(granted[i]);
      }
    }
  }
  self->cv_.notify_all();
}

void MosquittoClient::OnPublish(mosquitto*, void* obj, int mid, int reason,
                                const mosquitto_property*) {
  auto* self = static_cast<MosquittoClient*>(obj);
  if (reason >= 0x80) {
    ++self->refused_publications_;
    self->Log(std::string("broker refused a publication: ") + mosquitto_reason_string(reason));
  }
  {
    std::lock_guard lock(self->mu_);
    self->pending_publications_.Acked(mid);
  }
  self->cv_.notify_all();
}

}  // namespace

std::unique_ptr<MqttClient> MakeMosquittoClient(const MqttOptions& options) {
  return std::make_unique<MosquittoClient>(options);
}

}  // namespace autonomsim::sim
