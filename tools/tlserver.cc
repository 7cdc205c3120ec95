// `tlserver`: the traffic-light server of the AutonomROS lab as a program. It speaks the lab's
// /vtl/ topics and payloads (reference §7) through an MQTT broker, so it can stand in for the
// lab's vtl.py; with --sim-clock it serves a simulation in lock-step instead
// (sim/mqtt/mqtt_lockstep.h). The message handling is tools/tlserver_service.h; this file is the
// process around it: options, connection, timer, signals, logs.
//
// Exit codes: 0 after SIGINT/SIGTERM, 2 for unusable options or credentials the broker refused,
// 1 for anything else, among it (--policy original) a message the lab's vtl.py would have died on:
// vtl.py's uncaught exception ends Python with status 1 too.
#include <pthread.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <atomic>
#include <csignal>
#include <fstream>
#include <thread>

#include "sim/mqtt/mqtt_client.h"
#include "tools/tlserver_service.h"

namespace autonomsim::tlserver {
namespace {

using Clock = std::chrono::steady_clock;

constexpr int kExitOk = 0;
constexpr int kExitFailure = 1;
constexpr int kExitUnusable = 2;
// On shutdown, how long we wait for the broker to take our last status.
constexpr std::chrono::seconds kFlushTimeout{2};
// Without a lease to watch, wake up this often anyway (to notice a lost broker in the log).
constexpr std::chrono::seconds kIdleWake{60};
// While the broker is away: how often we look whether it is back (leases are paused meanwhile).
constexpr std::chrono::seconds kConnectionPoll{1};

struct Options {
  std::string host{"localhost"};
  int port{1883};  // reference §7
  std::string client_id{"tlserver"};
  std::string username;
  std::string password;
  std::string password_file;
  std::string cafile, certfile, keyfile;
  // the server's own defaults (world/traffic_light_server.h) and the lab's two intersections
  std::string policy{ToName(world::TrafficLightServerParams{}.policy)};
  double lease_s{ToSeconds(world::TrafficLightServerParams{}.lease)};
  std::vector<int> intersections{ServiceOptions{}.intersections};
  bool sim_clock{false};
  std::string log_level{"info"};
};

std::string ReadPassword(const std::string& file) {
  std::ifstream in(file);
  if (!in) throw std::invalid_argument("cannot read --password-file " + file);
  std::string line;
  std::getline(in, line);
  while (!line.empty() && (line.back() == '\r' || line.back() == '\n')) line.pop_back();
  return line;
}

// std::invalid_argument for an unreadable password file.
sim::MqttOptions ToMqttOptions(const Options& o) {
  sim::MqttOptions mqtt;
  mqtt.host = o.host;
  mqtt.port = o.port;
  mqtt.client_id = o.client_id;
  mqtt.username = o.username;
  mqtt.password = o.password_file.empty() ? o.password : ReadPassword(o.password_file);
  mqtt.cafile = o.cafile;
  mqtt.certfile = o.certfile;
  mqtt.keyfile = o.keyfile;
  return mqtt;
}

ServiceOptions ToServiceOptions(const Options& o) {
  ServiceOptions service_options;
  service_options.params.policy = *FromName<world::ServerPolicy>(o.policy);  // CLI checked it
  service_options.params.lease = FromSeconds(o.lease_s);
  service_options.intersections = o.intersections;
  service_options.sim_clock = o.sim_clock;
  return service_options;
}

// SIGINT and SIGTERM are taken by a thread of our own (sigwait), never by a handler: the mask is
// set before any thread starts, so every thread inherits it.
sigset_t BlockStopSignals() {
  sigset_t stop_signals;
  sigemptyset(&stop_signals);
  sigaddset(&stop_signals, SIGINT);
  sigaddset(&stop_signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr);
  return stop_signals;
}

// The thread that waits for a stop signal, then says so and interrupts the client's wait; ended
// however Serve is left.
class StopSignalThread {
 public:
  StopSignalThread(sigset_t stop_signals, sim::MqttClient* client)
      : thread_([this, stop_signals, client] {
          int signal_number = 0;
          sigwait(&stop_signals, &signal_number);
          spdlog::info("{} received, shutting down", strsignal(signal_number));
          stop_ = true;
          client->Interrupt();
        }) {}
  StopSignalThread(const StopSignalThread&) = delete;
  StopSignalThread& operator=(const StopSignalThread&) = delete;
  ~StopSignalThread() {
    if (!stop_) kill(getpid(), SIGTERM);
    thread_.join();
  }
  bool stopped() const { return stop_; }

 private:
  std::atomic<bool> stop_{false};  // before thread_: set up before the thread starts
  std::thread thread_;
};

void LogStart(const Options& o) {
  std::string ids;
  for (int id : o.intersections) ids += (ids.empty() ? "" : ",") + std::to_string(id);
  spdlog::info(
      "tlserver: broker {}:{} as '{}'{}, policy {}, lease {} s, intersections {}, {} clock", o.host,
      o.port, o.client_id, o.username.empty() ? "" : " (user " + o.username + ")", o.policy,
      o.lease_s, ids, o.sim_clock ? "simulation" : "wall");
}

// Messages and lease timers until a stop signal; the service's time is the wall time since start.
void ServeUntilStopped(Service& service, sim::MqttClient& client, const StopSignalThread& signals,
                       Clock::time_point start) {
  auto wall_now = [&] { return std::chrono::duration_cast<Duration>(Clock::now() - start); };
  while (!signals.stopped() && !service.exit_reason()) {
    // the connection first: a lease must not run out for want of a broker (Service::OnConnection)
    for (const sim::MqttMessage& m : service.OnConnection(client.connected(), wall_now())) {
      client.Publish(m);
    }
    const std::optional<Time> next = service.NextTimer();
    const Clock::time_point wake =
        next ? start + *next
             : Clock::now() + (service.server().connected() ? kIdleWake : kConnectionPoll);
    std::vector<sim::MqttMessage> out;
    if (std::optional<sim::MqttMessage> in = client.ReceiveUntilConnectionChanges(wake)) {
      out = service.OnMessage(*in, wall_now());
    } else if (next && Clock::now() >= wake) {
      // the broker may have gone while we waited: then the lease does not run out
      out = service.OnConnection(client.connected(), wall_now());
      for (sim::MqttMessage& m : service.OnTimer(wall_now())) out.push_back(std::move(m));
    }
    for (const sim::MqttMessage& m : out) client.Publish(m);
  }
}

// The final status (the broker's confirmation awaited a while), then the counters in the log.
void SignOff(const Service& service, sim::MqttClient& client) {
  client.Publish(service.Status(false));
  if (!client.Flush(Clock::now() + kFlushTimeout)) {
    spdlog::warn("the broker did not confirm the final status within {} s", kFlushTimeout.count());
  }
  const ServiceCounters& c = service.counters();
  const world::TrafficLightServer::Counters s = service.server().counters();
  spdlog::info(
      "tlserver stopped: {} requests, {} grants, {} denials, {} frees, {} lease expiries, {} "
      "malformed, {} refused, {} duplicates",
      s.requests, s.grants, s.denials, s.frees, s.lease_expiries, c.malformed, c.refused,
      c.duplicates);
}

int Serve(const Options& o) {
  // options → service and client; mistakes here are unusable input
  sim::MqttOptions mqtt;
  std::optional<Service> service;
  try {
    const ServiceOptions service_options = ToServiceOptions(o);
    mqtt = ToMqttOptions(o);
    service.emplace(service_options);
  } catch (const std::invalid_argument& e) {
    spdlog::critical("{}", e.what());
    return kExitUnusable;
  }
  mqtt.will = service->Status(false);
  mqtt.on_log = [](const std::string& line) { spdlog::info("mqtt: {}", line); };

  const sigset_t stop_signals = BlockStopSignals();
  std::unique_ptr<sim::MqttClient> client;
  try {
    client = sim::MakeMosquittoClient(mqtt);
  } catch (const sim::MqttError& e) {
    spdlog::critical("{}", e.what());
    return kExitUnusable;
  }
  const StopSignalThread signals(stop_signals, client.get());

  LogStart(o);
  for (const std::string& filter : Service::Subscriptions()) client->Subscribe(filter, 1);
  try {
    while (!signals.stopped() && !client->WaitReady(Clock::now() + std::chrono::seconds(5))) {
      spdlog::warn("waiting for the broker at {}:{}", o.host, o.port);
    }
  } catch (const sim::MqttError& e) {
    spdlog::critical("{}", e.what());
    return kExitUnusable;
  }

  const Clock::time_point start = Clock::now();
  client->Publish(service->Status(true));
  try {
    ServeUntilStopped(*service, *client, signals, start);
  } catch (const std::exception& e) {
    spdlog::critical("stopping: {}", e.what());
    return kExitFailure;
  }
  SignOff(*service, *client);
  if (service->exit_reason()) {
    spdlog::critical("{}", *service->exit_reason());  // the last line, as vtl.py's traceback
    return kExitFailure;
  }
  return kExitOk;
}

}  // namespace
}  // namespace autonomsim::tlserver

int main(int argc, char** argv) {
  using autonomsim::tlserver::Options;
  Options o;
  CLI::App app{
      "tlserver: the AutonomROS traffic-light server over MQTT (/vtl/request, /vtl/response, "
      "/vtl/free; retained state on /vtl/status)"};
  app.add_option("--host", o.host, "Broker host")->capture_default_str();
  app.add_option("--port", o.port, "Broker port")
      ->capture_default_str()
      ->check(CLI::Range(1, 65535));
  app.add_option("--client-id", o.client_id, "MQTT client id (the broker keeps our session by it)")
      ->capture_default_str();
  app.add_option("--username", o.username, "MQTT user (see tools/mosquitto/acl)");
  auto* password = app.add_option("--password", o.password,
                                  "MQTT password (visible to other users in ps; prefer "
                                  "--password-file)");
  app.add_option("--password-file", o.password_file, "File whose first line is the password")
      ->excludes(password)
      ->check(CLI::ExistingFile);
  app.add_option("--cafile", o.cafile, "TLS: CA certificate that signed the broker's")
      ->check(CLI::ExistingFile);
  app.add_option("--certfile", o.certfile, "TLS: our certificate")->check(CLI::ExistingFile);
  app.add_option("--keyfile", o.keyfile, "TLS: our private key")->check(CLI::ExistingFile);
  app.add_option("--policy", o.policy,
                 "fifo: queue, later grant, lease, correct release (ours); original: the lab's "
                 "vtl.py")
      ->capture_default_str()
      ->check(CLI::IsMember({"fifo", "original"}));
  app.add_option("--lease-s", o.lease_s,
                 "A holder that sends no request for its intersection this long loses it (fifo)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--intersections", o.intersections, "Intersection ids served, e.g. 0,1")
      ->delimiter(',')
      ->capture_default_str();
  app.add_flag("--sim-clock", o.sim_clock,
               "Take the time from a simulation (autonomsim, v2i.link: mqtt) instead of the wall "
               "clock");
  app.add_option("--log-level", o.log_level, "trace, debug, info, warn, error")
      ->capture_default_str()
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error"}));
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  }
  if (!o.certfile.empty() != !o.keyfile.empty() || (!o.certfile.empty() && o.cafile.empty())) {
    fmt::print(stderr, "tlserver: --certfile and --keyfile go together, and need --cafile\n");
    return 2;
  }
  auto logger = spdlog::stderr_color_mt("tlserver");
  spdlog::set_default_logger(logger);
  spdlog::set_pattern("%Y-%m-%d %H:%M:%S.%e %^%-5l%$ %v");
  spdlog::set_level(spdlog::level::from_str(o.log_level));
  spdlog::flush_on(spdlog::level::trace);
  return autonomsim::tlserver::Serve(o);
}
