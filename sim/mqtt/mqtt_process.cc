#include "sim/mqtt/mqtt_process.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <pwd.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <random>
#include <sstream>
#include <stdexcept>
#include <thread>

namespace autonomsim::sim {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

// How often a wait for a process or a port looks again.
constexpr std::chrono::milliseconds kPollPeriod{10};

std::string Errno(const std::string& what) { return what + ": " + std::strerror(errno); }

int StatusToCode(int status) {
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  if (WIFSIGNALED(status)) return 128 + WTERMSIG(status);
  return 255;
}

std::string ReadFile(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

void WriteFile(const fs::path& file, const std::string& text) {
  const int fd = ::open(file.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
  if (fd < 0) throw std::runtime_error(Errno("cannot write " + file.string()));
  std::size_t done = 0;
  while (done < text.size()) {
    const ssize_t n = ::write(fd, text.data() + done, text.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) {
      ::close(fd);
      throw std::runtime_error(Errno("cannot write " + file.string()));
    }
    done += static_cast<std::size_t>(n);
  }
  ::close(fd);
}

// A port on 127.0.0.1 that nobody listened on a moment ago (the kernel picks it).
int PickFreePort() {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) throw std::runtime_error(Errno("socket"));
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  addr.sin_port = 0;
  socklen_t len = sizeof addr;
  if (::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0 ||
      ::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len) != 0) {
    const std::string error = Errno("binding a free loopback port");
    ::close(fd);
    throw std::runtime_error(error);
  }
  ::close(fd);
  return ntohs(addr.sin_port);
}

bool CanConnect(int port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return false;
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  addr.sin_port = htons(static_cast<std::uint16_t>(port));
  const bool ok = ::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0;
  ::close(fd);
  return ok;
}

std::string CurrentUserName() {
  const passwd* pw = ::getpwuid(::geteuid());
  return pw != nullptr ? pw->pw_name : "root";
}

}  // namespace

TempDir::TempDir(const std::string& prefix) {
  const char* tmp = std::getenv("TMPDIR");
  const fs::path base = tmp != nullptr && *tmp != '\0' ? fs::path(tmp) : fs::path("/tmp");
  std::string pattern = (base / (prefix + "XXXXXX")).string();
  if (::mkdtemp(pattern.data()) == nullptr) {
    throw std::runtime_error(Errno("cannot create a temporary directory in " + base.string()));
  }
  path_ = pattern;
}

TempDir::~TempDir() {
  std::error_code ignored;
  fs::remove_all(path_, ignored);
}

ChildProcess::ChildProcess(std::vector<std::string> argv, fs::path log_file)
    : argv_(std::move(argv)), log_file_(std::move(log_file)) {
  if (argv_.empty()) throw std::invalid_argument("ChildProcess: empty argv");
  // Everything the child needs is prepared before fork: after it, only async-signal-safe calls.
  std::vector<char*> args;
  for (std::string& a : argv_) args.push_back(a.data());
  args.push_back(nullptr);
  const int log_fd = ::open(log_file_.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0600);
  if (log_fd < 0) throw std::runtime_error(Errno("cannot open " + log_file_.string()));
  const int null_fd = ::open("/dev/null", O_RDONLY | O_CLOEXEC);
  if (null_fd < 0) {
    ::close(log_fd);
    throw std::runtime_error(Errno("cannot open /dev/null"));
  }
  const pid_t parent = ::getpid();
  const pid_t pid = ::fork();
  if (pid == 0) {
    // If our parent (thread) dies, so do we: no orphaned brokers after a crashed test.
    ::prctl(PR_SET_PDEATHSIG, SIGTERM);
    if (::getppid() != parent) ::_exit(127);
    sigset_t none;
    sigemptyset(&none);
    ::sigprocmask(SIG_SETMASK, &none, nullptr);
    ::signal(SIGTERM, SIG_DFL);
    ::signal(SIGINT, SIG_DFL);
    ::signal(SIGPIPE, SIG_DFL);
    ::dup2(null_fd, 0);
    ::dup2(log_fd, 1);
    ::dup2(log_fd, 2);
    // Sockets of the parent (its MQTT connections) must not live on in the child.
    if (::syscall(SYS_close_range, 3U, ~0U, 0U) != 0) {
      for (int fd = 3; fd < 4096; ++fd) ::close(fd);
    }
    ::execv(args[0], args.data());
    constexpr char kMessage[] = "exec failed\n";
    [[maybe_unused]] const ssize_t n = ::write(2, kMessage, sizeof kMessage - 1);
    ::_exit(127);
  }
  const int fork_errno = errno;
  ::close(log_fd);
  ::close(null_fd);
  if (pid < 0) {
    errno = fork_errno;
    throw std::runtime_error(Errno("cannot start " + argv_.front()));
  }
  pid_ = pid;
}

ChildProcess::~ChildProcess() {
  if (pid_ > 0 && !status_) Stop();
}

bool ChildProcess::Running() {
  if (status_) return false;
  int status = 0;
  const pid_t r = ::waitpid(pid_, &status, WNOHANG);
  if (r == pid_) {
    status_ = StatusToCode(status);
    return false;
  }
  return r == 0;
}

std::optional<int> ChildProcess::Wait(std::chrono::milliseconds timeout) {
  const auto give_up = Clock::now() + timeout;
  while (Running()) {
    if (Clock::now() >= give_up) return std::nullopt;
    std::this_thread::sleep_for(kPollPeriod);
  }
  return status_;
}

void ChildProcess::Signal(int signal_number) {
  if (Running()) ::kill(pid_, signal_number);
}

int ChildProcess::Stop(std::chrono::milliseconds grace) {
  if (status_) return *status_;
  Signal(SIGTERM);
  if (const std::optional<int> code = Wait(grace)) return *code;
  Signal(SIGKILL);
  int status = 0;
  while (::waitpid(pid_, &status, 0) < 0 && errno == EINTR) {
  }
  status_ = StatusToCode(status);
  return *status_;
}

std::string ChildProcess::LogTail(std::size_t bytes) const {
  const std::string log = ReadFile(log_file_);
  return log.size() > bytes ? "..." + log.substr(log.size() - bytes) : log;
}

fs::path FindProgram(const std::string& name, const std::string& package) {
  std::vector<fs::path> dirs;
  if (const char* path = std::getenv("PATH")) {
    std::stringstream in(path);
    for (std::string dir; std::getline(in, dir, ':');) {
      if (!dir.empty()) dirs.emplace_back(dir);
    }
  }
  dirs.emplace_back("/usr/sbin");
  dirs.emplace_back("/sbin");
  for (const fs::path& dir : dirs) {
    const fs::path candidate = dir / name;
    if (::access(candidate.c_str(), X_OK) == 0) return candidate;
  }
  throw std::runtime_error("cannot find the program '" + name + "' (install the Debian package " +
                           package + ", e.g. with tools/install_deps.sh)");
}

fs::path FindTlserver() {
  if (const char* explicit_path = std::getenv("AUTONOMSIM_TLSERVER")) {
    if (::access(explicit_path, X_OK) == 0) return explicit_path;
    throw std::runtime_error(std::string("AUTONOMSIM_TLSERVER=") + explicit_path +
                             " is not an executable file");
  }
  std::vector<fs::path> dirs;
  std::error_code ec;
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) dirs.push_back(self.parent_path());
  if (const char* bin = std::getenv("AUTONOMSIM_BIN_DIR")) dirs.emplace_back(bin);
  for (const fs::path& dir : dirs) {
    const fs::path candidate = dir / "tlserver";
    if (::access(candidate.c_str(), X_OK) == 0) return candidate;
  }
  throw std::runtime_error(
      "cannot find the tlserver program next to " +
      (ec ? std::string("this program") : self.string()) +
      "; build it (cmake --build build --target tlserver) or name it in AUTONOMSIM_TLSERVER");
}

std::string RandomHex(std::size_t bytes) {
  std::random_device device;  // the system's random source; see the header
  static constexpr char kDigits[] = "0123456789abcdef";
  std::string out;
  for (std::size_t i = 0; i < bytes; ++i) {
    const unsigned value = device() & 0xffU;
    out += kDigits[value >> 4];
    out += kDigits[value & 0xfU];
  }
  return out;
}

LocalBroker::LocalBroker(LocalBrokerOptions options)
    : options_(std::move(options)), dir_("autonomsim-mosquitto-") {
  const fs::path dir = dir_.path();
  std::ostringstream conf;
  if (!options_.config.empty()) {
    conf << options_.config << "\nuser " << CurrentUserName() << "\n";
  } else {
    GenerateConfig(&conf);
  }
  WriteFile(dir / "mosquitto.conf.base", conf.str());
  // The kernel may hand the port we picked to someone else before mosquitto binds it.
  constexpr int kAttempts = 5;
  for (int attempt = 0; attempt < kAttempts; ++attempt) {
    port_ = PickFreePort();
    if (Launch()) return;
  }
  throw std::runtime_error("mosquitto could not bind a free loopback port in " +
                           std::to_string(kAttempts) + " attempts: " + LogTail());
}

void LocalBroker::GenerateConfig(std::ostringstream* out) {
  const fs::path dir = dir_.path();
  std::ostringstream& conf = *out;
  conf << "# a private broker started by autonomsim; it listens on loopback only\n"
       << "per_listener_settings false\n"
       << "allow_anonymous " << (options_.users.empty() ? "true" : "false") << "\n";
  if (!options_.users.empty()) {
    std::string passwords;
    for (const BrokerUser& u : options_.users) {
      passwords += u.name + ":" + u.password + "\n";
      WriteFile(dir / ("password." + u.name), u.password + "\n");
    }
    WriteFile(dir / "passwords", passwords);
    // Hashes the plain-text file in place, so no password appears on a command line.
    ChildProcess hash(
        {FindProgram("mosquitto_passwd", "mosquitto").string(), "-U", (dir / "passwords").string()},
        dir / "mosquitto_passwd.log");
    const std::optional<int> code = hash.Wait(options_.start_timeout);
    if (code != 0) {
      throw std::runtime_error("mosquitto_passwd -U failed: " + hash.LogTail());
    }
    conf << "password_file " << (dir / "passwords").string() << "\n";
  }
  if (!options_.acl.empty()) {
    WriteFile(dir / "acl", options_.acl);
    conf << "acl_file " << (dir / "acl").string() << "\n";
  }
  if (options_.persistence) {
    conf << "persistence true\n"
         << "persistence_location " << dir.string() << "/\n";
  }
  conf << "set_tcp_nodelay true\n"
       << "log_dest stderr\n"
       << "log_type error\nlog_type warning\nlog_type notice\nlog_type information\n"
       << "connection_messages true\n"
       // When started as root, mosquitto would switch to the user "mosquitto", who cannot read
       // this private directory; stay the user we are.
       << "user " << CurrentUserName() << "\n";
}

LocalBroker::~LocalBroker() { Stop(); }

bool LocalBroker::Launch() {
  const fs::path dir = dir_.path();
  WriteFile(dir / "mosquitto.conf", ReadFile(dir / "mosquitto.conf.base") + "listener " +
                                        std::to_string(port_) + " " + host_ + "\n" +
                                        options_.listener_config + "\n");
  const fs::path log = dir / "mosquitto.log";
  const std::size_t log_start = fs::exists(log) ? fs::file_size(log) : 0;
  process_.emplace(std::vector<std::string>{FindProgram("mosquitto", "mosquitto").string(), "-c",
                                            (dir / "mosquitto.conf").string()},
                   log);
  const auto give_up = Clock::now() + options_.start_timeout;
  for (;;) {
    const std::string output = ReadFile(log).substr(log_start);
    const bool alive = process_->Running();
    if (alive && output.find(" running") != std::string::npos && CanConnect(port_)) return true;
    if (!alive) {
      if (output.find("Address already in use") != std::string::npos) {
        process_.reset();
        return false;
      }
      throw std::runtime_error("mosquitto exited while starting: " + LogTail());
    }
    if (Clock::now() >= give_up) {
      process_->Stop();
      throw std::runtime_error("mosquitto did not come up on " + address() + " within " +
                               std::to_string(options_.start_timeout.count()) +
                               " ms: " + LogTail());
    }
    std::this_thread::sleep_for(kPollPeriod);
  }
}

void LocalBroker::Stop() {
  if (process_) process_->Stop();
  process_.reset();
}

void LocalBroker::Kill() {
  if (process_) {
    process_->Signal(SIGKILL);
    process_->Stop();  // reaps it
  }
  process_.reset();
}

void LocalBroker::Start() {
  if (process_ && process_->Running()) return;
  if (!Launch())
    throw std::runtime_error("port " + std::to_string(port_) + " was taken: " + LogTail());
}

bool LocalBroker::Running() { return process_ && process_->Running(); }

std::string LocalBroker::LogTail(std::size_t bytes) const {
  const std::string log = ReadFile(dir_.path() / "mosquitto.log");
  return log.size() > bytes ? "..." + log.substr(log.size() - bytes) : log;
}

fs::path LocalBroker::PasswordFile(const std::string& user) const {
  const fs::path file = dir_.path() / ("password." + user);
  if (!fs::exists(file)) throw std::invalid_argument("no broker user '" + user + "'");
  return file;
}

}  // namespace autonomsim::sim
