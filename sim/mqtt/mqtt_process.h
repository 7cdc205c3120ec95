// Processes an mqtt run (or a test) starts: a private mosquitto broker on a free loopback port and
// the `tlserver` program. Each child gets SIGTERM when the thread that started it ends
// (PR_SET_PDEATHSIG), so a crashed run or test leaves no broker behind; start, use and stop them
// on one thread. Every wait is bounded.
#pragma once

#include <sys/types.h>

#include <chrono>
#include <filesystem>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

namespace autonomsim::sim {

// A private directory (mode 0700) under $TMPDIR or /tmp, removed with its contents at destruction.
class TempDir {
 public:
  explicit TempDir(const std::string& prefix);
  ~TempDir();
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

class ChildProcess {
 public:
  // Starts argv[0] (a path) with `argv`, stdin from /dev/null, stdout and stderr appended to
  // `log_file`. Throws std::runtime_error if it cannot be started.
  ChildProcess(std::vector<std::string> argv, std::filesystem::path log_file);
  // Stops it (Stop()) if it still runs.
  ~ChildProcess();
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  // False once it has exited (it is reaped then).
  bool Running();
  // SIGTERM, then SIGKILL if it has not exited after `grace`. Returns how it ended: the exit code,
  // or 128 + the signal that killed it.
  int Stop(std::chrono::milliseconds grace = std::chrono::seconds(5));
  // Waits up to `timeout` for it to exit by itself; its exit status as for Stop, or nullopt.
  std::optional<int> Wait(std::chrono::milliseconds timeout);
  void Signal(int signal_number);
  pid_t pid() const { return pid_; }
  const std::string& name() const { return argv_.front(); }
  // The last `bytes` of its log, for error messages.
  std::string LogTail(std::size_t bytes = 2000) const;

 private:
  std::vector<std::string> argv_;
  std::filesystem::path log_file_;
  pid_t pid_{-1};
  std::optional<int> status_;
};

// A program by name: `$PATH`, then /usr/sbin and /sbin (Debian installs mosquitto there). Throws
// std::runtime_error naming the package to install.
std::filesystem::path FindProgram(const std::string& name, const std::string& package);

// The tlserver program: $AUTONOMSIM_TLSERVER, or `tlserver` next to the running executable, or in
// $AUTONOMSIM_BIN_DIR. Throws std::runtime_error saying how to build it.
std::filesystem::path FindTlserver();

// Bytes from the system's random source as hex, for one-off passwords (not simulation
// randomness, which comes only from sim/core/random.h).
std::string RandomHex(std::size_t bytes);

struct BrokerUser {
  std::string name;
  std::string password;
};

struct LocalBrokerOptions {
  std::vector<BrokerUser> users;  // empty: anonymous clients may connect
  std::string acl;                // ACL file text (tools/mosquitto/acl); empty: no ACL
  bool persistence{true};         // keep sessions and queued messages across Restart()
  // When given: these settings instead of the generated ones (users, acl and persistence above
  // are then unused); the loopback listener and the process user are added.
  std::string config;
  // Settings of the listener itself (e.g. TLS: cafile, certfile, keyfile), after its line.
  std::string listener_config;
  std::chrono::milliseconds start_timeout{std::chrono::seconds(15)};
};

// mosquitto listening on 127.0.0.1 only, on a port that was free when it started, with its own
// config, password file, ACL, persistence and log in a private TempDir.
class LocalBroker {
 public:
  // Throws std::runtime_error (with the broker's log) if it does not come up within the timeout.
  explicit LocalBroker(LocalBrokerOptions options);
  ~LocalBroker();
  LocalBroker(const LocalBroker&) = delete;
  LocalBroker& operator=(const LocalBroker&) = delete;

  const std::string& host() const { return host_; }
  int port() const { return port_; }
  std::string address() const { return host_ + ":" + std::to_string(port_); }
  const std::filesystem::path& dir() const { return dir_.path(); }

  // SIGTERM (mosquitto saves its persistence file then), wait, and start again on the same port.
  void Stop();
  // SIGKILL, as a crash: mosquitto saves nothing, and what it queued is lost.
  void Kill();
  void Start();
  void Restart() {
    Stop();
    Start();
  }
  bool Running();
  std::string LogTail(std::size_t bytes = 3000) const;
  // A file holding `user`'s password alone (for `tlserver --password-file`).
  std::filesystem::path PasswordFile(const std::string& user) const;

 private:
  void GenerateConfig(std::ostringstream* out);
  // Starts mosquitto on port_ and waits until it listens; false if the port was taken.
  bool Launch();

  LocalBrokerOptions options_;
  TempDir dir_;
  std::string host_{"127.0.0.1"};
  int port_{0};
  std::optional<ChildProcess> process_;
};

}  // namespace autonomsim::sim
