// Test helpers for everything that needs a real broker: a private mosquitto on a free loopback
// port (never a fixed port, never a non-loopback address) with the ACL of tools/mosquitto/acl and
// one user per role, tlserver processes, our own clients, and the mosquitto_pub / mosquitto_sub
// command-line clients. Every wait has a timeout; brokers and processes stop when their objects
// go, also when a test fails, and die with the test process (sim/mqtt/mqtt_process.h).
#pragma once

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "sim/mqtt/mqtt_client.h"
#include "sim/mqtt/mqtt_process.h"

namespace autonomsim::sim::testing {

using Clock = std::chrono::steady_clock;

// Generous on purpose: a loaded 2-core machine or a sanitizer build is slow, and a passing test
// never waits this long.
inline constexpr std::chrono::seconds kWait{20};

// The users of tools/mosquitto/acl, each with the password "pw-<user>".
inline std::vector<BrokerUser> AclUsers() {
  std::vector<BrokerUser> users;
  for (const char* name : {"tlserver", "autonomsim", "monitor", "car0", "car1", "car2"}) {
    users.push_back({name, std::string("pw-") + name});
  }
  return users;
}

inline std::string ReadText(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

// The ACL as shipped, read from the repository (tests run in its root).
inline std::string ShippedAcl() {
  const std::string acl = ReadText("tools/mosquitto/acl");
  if (acl.empty()) throw std::runtime_error("cannot read tools/mosquitto/acl from the working dir");
  return acl;
}

// A broker with the shipped ACL and AclUsers(), persistent sessions.
// A loopback port held bound but not listening for the object's life: connecting to it is refused
// at once, and no other test's broker can take it meanwhile (a stopped broker's port can be reused
// at once under ctest -j).
class RefusingPort {
 public:
  RefusingPort() : fd_(::socket(AF_INET, SOCK_STREAM, 0)) {
    if (fd_ < 0) throw std::runtime_error("RefusingPort: socket");
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t length = sizeof address;
    if (::bind(fd_, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0 ||
        ::getsockname(fd_, reinterpret_cast<sockaddr*>(&address), &length) != 0) {
      ::close(fd_);
      throw std::runtime_error("RefusingPort: bind");
    }
    port_ = ntohs(address.sin_port);
  }
  ~RefusingPort() { ::close(fd_); }
  RefusingPort(const RefusingPort&) = delete;
  RefusingPort& operator=(const RefusingPort&) = delete;
  std::string address() const { return "127.0.0.1:" + std::to_string(port_); }

 private:
  int fd_;
  int port_{0};
};

inline std::unique_ptr<LocalBroker> StartSecureBroker() {
  return std::make_unique<LocalBroker>(
      LocalBrokerOptions{.users = AclUsers(), .acl = ShippedAcl(), .persistence = true});
}

// tlserver on `broker` as user tlserver, with extra arguments; its log goes to the broker's dir.
inline std::unique_ptr<ChildProcess> StartTlserver(const LocalBroker& broker,
                                                   std::vector<std::string> extra,
                                                   const std::string& name = "tlserver") {
  std::vector<std::string> argv{FindTlserver().string(),
                                "--host",
                                broker.host(),
                                "--port",
                                std::to_string(broker.port()),
                                "--username",
                                "tlserver",
                                "--password-file",
                                broker.PasswordFile("tlserver").string(),
                                "--client-id",
                                name};
  argv.insert(argv.end(), extra.begin(), extra.end());
  return std::make_unique<ChildProcess>(argv, broker.dir() / (name + ".log"));
}

// Our client as `user`, connected and subscribed to `filters`.
inline std::unique_ptr<MqttClient> Connect(const LocalBroker& broker, const std::string& user,
                                           const std::string& client_id,
                                           const std::vector<std::string>& filters = {}) {
  MqttOptions options;
  options.host = broker.host();
  options.port = broker.port();
  options.client_id = client_id;
  options.username = user;
  options.password = "pw-" + user;
  std::unique_ptr<MqttClient> client = MakeMosquittoClient(options);
  for (const std::string& f : filters) client->Subscribe(f, 1);
  if (!client->WaitReady(Clock::now() + kWait)) {
    throw std::runtime_error("client " + client_id + " did not connect to " + broker.address());
  }
  return client;
}

// The next message on `topic` (others are skipped), or nullopt after `timeout`.
inline std::optional<MqttMessage> ReceiveOn(MqttClient& client, const std::string& topic,
                                            std::chrono::milliseconds timeout = kWait) {
  const auto give_up = Clock::now() + timeout;
  while (std::optional<MqttMessage> m = client.Receive(give_up)) {
    if (m->topic == topic) return m;
  }
  return std::nullopt;
}

// Waits until `done()` holds, polling; false after `timeout`.
inline bool WaitUntil(const std::function<bool()>& done,
                      std::chrono::milliseconds timeout = kWait) {
  const auto give_up = Clock::now() + timeout;
  while (!done()) {
    if (Clock::now() >= give_up) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return true;
}

struct ToolResult {
  int exit_code{-1};
  std::string output;  // stdout and stderr together
};

// Runs a mosquitto command-line client (mosquitto_pub, mosquitto_sub) against `broker` as `user`
// and waits for it (killed after `timeout`).
inline ToolResult RunTool(const LocalBroker& broker, const std::string& tool,
                          const std::string& user, std::vector<std::string> args,
                          std::chrono::milliseconds timeout = kWait) {
  static int counter = 0;
  const std::filesystem::path log =
      broker.dir() / (tool + "." + std::to_string(counter++) + ".log");
  std::vector<std::string> argv{FindProgram(tool, "mosquitto-clients").string(),
                                "-h",
                                broker.host(),
                                "-p",
                                std::to_string(broker.port()),
                                "-u",
                                user,
                                "-P",
                                "pw-" + user};
  argv.insert(argv.end(), args.begin(), args.end());
  ChildProcess process(argv, log);
  std::optional<int> code = process.Wait(timeout);
  if (!code) code = process.Stop(std::chrono::milliseconds(500));
  return {*code, ReadText(log)};
}

// mosquitto_pub of one message at QoS 1, as a car would send it.
inline ToolResult Pub(const LocalBroker& broker, const std::string& user, const std::string& topic,
                      const std::string& payload, std::vector<std::string> extra = {}) {
  std::vector<std::string> args{"-q", "1", "-t", topic, "-m", payload};
  args.insert(args.end(), extra.begin(), extra.end());
  return RunTool(broker, "mosquitto_pub", user, args);
}

// A mosquitto_sub running in the background, its output read while it runs.
class Sub {
 public:
  Sub(const LocalBroker& broker, const std::string& user, std::vector<std::string> topics,
      const std::string& name) {
    log_ = broker.dir() / (name + ".log");
    std::vector<std::string> argv{FindProgram("mosquitto_sub", "mosquitto-clients").string(),
                                  "-h",
                                  broker.host(),
                                  "-p",
                                  std::to_string(broker.port()),
                                  "-u",
                                  user,
                                  "-P",
                                  "pw-" + user,
                                  "-q",
                                  "1",
                                  "-v"};
    for (const std::string& t : topics) {
      argv.push_back("-t");
      argv.push_back(t);
    }
    process_ = std::make_unique<ChildProcess>(argv, log_);
  }
  std::string Output() const { return ReadText(log_); }
  // Waits until the output holds `text`.
  bool WaitFor(const std::string& text, std::chrono::milliseconds timeout = kWait) const {
    return WaitUntil([&] { return Output().find(text) != std::string::npos; }, timeout);
  }

 private:
  std::filesystem::path log_;
  std::unique_ptr<ChildProcess> process_;
};

}  // namespace autonomsim::sim::testing
