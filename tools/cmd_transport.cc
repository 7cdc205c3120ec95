// `autonomsim transport`: one publisher -> one subscriber over the modelled DDS transport alone
// (sim/platform/transport_run.h), what bench/dds_vs_cyclone.sh sets beside Cyclone DDS's ddsperf.
#include <fmt/format.h>

#include <cmath>
#include <nlohmann/json.hpp>

#include "sim/core/config.h"
#include "sim/platform/transport_run.h"
#include "sim/scenario/scenario.h"
#include "tools/cli_common.h"
#include "world/enum_names.h"
#include "world/time.h"

namespace autonomsim::cli {
namespace {

nlohmann::json ResultJson(const sim::TransportRunResult& r, std::int64_t bytes) {
  const sim::DdsLinkStats& s = r.stats;
  return {{"delivered_hz", r.delivered_hz},
          {"latency_p50_ms", r.latency_p50_ms},
          {"latency_p95_ms", r.latency_p95_ms},
          {"dropped_datagrams", s.datagrams_dropped},
          {"repairs", s.nacks},
          {"retransmitted_datagrams", s.datagrams_retransmitted},
          {"offered", r.offered},
          {"samples_written", s.samples_written},
          {"samples_delivered", s.samples_delivered},
          {"samples_lost", s.samples_lost},
          {"write_timeouts", s.write_timeouts},
          {"socket_buffer_bytes", r.params.SocketCapacityBytes()},
          {"datagrams_per_sample", r.params.DatagramsFor(bytes)}};
}

void PrintText(const sim::TransportRunResult& r, const sim::TransportRunOptions& o,
               const std::string& profile_name) {
  const sim::DdsLinkParams& p = r.params;
  const sim::DdsLinkStats& s = r.stats;
  fmt::print(
      "transport: {} B at {:g} Hz for {:g} s ({:g} s warm-up not measured), profile {}, "
      "{} cores, {} busy {}\n",
      o.bytes, o.rate_hz, ToSeconds(o.duration), ToSeconds(o.warmup), profile_name, r.cores,
      o.background_cores, o.background_cores == 1 ? "loop" : "loops");
  fmt::print(
      "  dds: {} {}, {} datagrams of up to {} fragments of {} B; socket buffer 2 x "
      "min({}, {}) = {} B, {} B per datagram of overhead\n",
      ToName(p.reliability), p.keep_all ? "keep_all" : fmt::format("keep_last {}", p.depth),
      p.DatagramsFor(o.bytes), p.FragmentsPerDatagram(), p.fragment_bytes, p.receive_buffer_bytes,
      p.host_rmem_max_bytes, p.SocketCapacityBytes(), p.socket_overhead_bytes);
  fmt::print(
      "  delivered {:.1f} Hz; latency p50 {:.1f} ms, p95 {:.1f} ms (write call to "
      "delivery); {} of {} ticks found the last write still running\n",
      r.delivered_hz, r.latency_p50_ms, r.latency_p95_ms,
      r.offered - s.samples_written - s.write_timeouts, r.offered);
  fmt::print(
      "  datagrams dropped {}, repairs (NACKs) {}, datagrams sent again {}; samples "
      "written {}, delivered {}, lost {}; writes that timed out {}\n",
      s.datagrams_dropped, s.nacks, s.datagrams_retransmitted, s.samples_written,
      s.samples_delivered, s.samples_lost, s.write_timeouts);
}

}  // namespace

Command AddTransportCommand(CLI::App& parent) {
  struct Options {
    std::int64_t bytes{0};
    double rate_hz{0.0};
    double seconds{10.0};
    double warmup_s{1.0};
    int depth{3};
    int background_cores{0};
    std::string profile{"scenarios/platforms/zcu104.yaml"};
    std::vector<std::string> overrides;
    bool json{false};
  };
  auto o = std::make_shared<Options>();
  CLI::App* cmd = parent.add_subcommand(
      "transport",
      "One publisher -> one subscriber over the modelled DDS transport alone (fragments, socket "
      "receive buffer, heartbeats and NACKs on the profile's cores): delivered rate, latency, "
      "datagrams dropped, repairs");
  cmd->add_option("--bytes", o->bytes, "Sample size in bytes")->type_name("N")->required();
  cmd->add_option("--rate-hz", o->rate_hz, "Samples offered per second")
      ->type_name("R")
      ->required();
  cmd->add_option("--seconds", o->seconds, "Simulated seconds")
      ->type_name("S")
      ->capture_default_str();
  cmd->add_option("--warmup", o->warmup_s, "Seconds at the start not measured")
      ->type_name("S")
      ->capture_default_str();
  cmd->add_option("--depth", o->depth, "The topic's keep-last history depth")
      ->type_name("N")
      ->capture_default_str();
  cmd->add_option("--background-load", o->background_cores,
                  "Busy loops beside the pair, each one core's worth of demand")
      ->type_name("CORES")
      ->capture_default_str();
  cmd->add_option("--profile", o->profile, kProfileHelp)->type_name("FILE")->capture_default_str();
  cmd->add_option("--set", o->overrides,
                  "Override a profile field, e.g. --set dds.receive_buffer_bytes=4194304 or "
                  "dds.fragment_bytes=65000, dds.reliability=best_effort, dds.history=keep_all "
                  "(repeatable)")
      ->type_name("KEY=VALUE");
  cmd->add_flag("--json", o->json,
                "Print the result as JSON: delivered_hz, latency_p50_ms, latency_p95_ms, "
                "dropped_datagrams, repairs, and more");
  return {cmd, [o] {
            if (!std::isfinite(o->seconds) || !std::isfinite(o->warmup_s) ||
                std::abs(o->seconds) > kMaxTimeSeconds || std::abs(o->warmup_s) > kMaxTimeSeconds) {
              fmt::print(stderr,
                         "error: --seconds and --warmup must be finite times, got {} and "
                         "{}\n",
                         o->seconds, o->warmup_s);
              return kExitUnusableInput;
            }
            sim::TransportRunOptions options{.bytes = o->bytes,
                                             .rate_hz = o->rate_hz,
                                             .duration = FromSeconds(o->seconds),
                                             .warmup = FromSeconds(o->warmup_s),
                                             .background_cores = o->background_cores,
                                             .depth = o->depth};
            sim::PlatformProfile profile;
            sim::TransportRunResult result;
            try {
              profile = sim::LoadPlatformProfile(sim::ResolveShippedFile(o->profile), o->overrides);
              result = sim::RunTransport(profile, options);
            } catch (const sim::ConfigError& e) {
              fmt::print(stderr, "error: {}\n", e.what());
              return kExitUnusableInput;
            }
            if (o->json) {
              fmt::print("{}\n", ResultJson(result, options.bytes).dump(2));
            } else {
              PrintText(result, options, profile.name);
            }
            return kExitOk;
          }};
}

}  // namespace autonomsim::cli
