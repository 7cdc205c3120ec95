#include "sim/v2i/mqtt_endpoint.h"

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <fstream>
#include <stdexcept>

#include "sim/mqtt/mqtt_process.h"
#include "world/validation.h"

namespace autonomsim::sim {
namespace {

using Clock = std::chrono::steady_clock;

// Re-sends back off up to this pause.
constexpr std::chrono::milliseconds kMaxRetryGap{1000};

std::string Ms(std::chrono::milliseconds d) { return std::to_string(d.count()) + " ms"; }

// The responses of one step, in order, once each matches the acknowledgement's copy; `what` names
// the step for the error.
std::vector<world::Response> CheckedResponses(const std::map<std::uint64_t, std::string>& responses,
                                              const SimAck& ack, const std::string& what) {
  std::vector<world::Response> out;
  std::uint64_t index = 0;
  for (const auto& [i, payload] : responses) {
    if (i != index || index >= ack.responses.size() || payload != ack.responses[index]) {
      throw MqttError("mqtt link: the /vtl/response messages of " + what +
                      " differ from tlserver's acknowledgement (another publisher on "
                      "/vtl/response?)");
    }
    const world::Decoded<world::Response> response = world::DecodeResponse(payload);
    if (!response) throw MqttError("mqtt link: tlserver sent " + response.error());
    out.push_back(response.value());
    ++index;
  }
  return out;
}

}  // namespace

std::string DefaultAcl() {
  return R"(# Access control for the /vtl/ traffic-light protocol (reference §7), for mosquitto's acl_file.
# Every client logs in with its own user (password_file); what a user may do is listed here, and
# anything not listed is refused. sim/v2i/mqtt_endpoint.cc holds a copy for the private brokers of
# simulation runs (a test keeps the two equal).

# The traffic-light server alone answers requests and publishes the state of the intersections.
user tlserver
topic read /vtl/request
topic read /vtl/request/+
topic read /vtl/free
topic read /vtl/free/+
topic read /vtl/sim/reset
topic read /vtl/sim/clock
topic write /vtl/response
topic write /vtl/status
topic write /vtl/sim/ack

# A simulation (autonomsim, v2i.link: mqtt) speaks for all its simulated cars and drives the
# server's clock in lock-step.
user autonomsim
topic write /vtl/request
topic write /vtl/free
topic write /vtl/sim/reset
topic write /vtl/sim/clock
topic read /vtl/response
topic read /vtl/status
topic read /vtl/sim/ack

# Read-only view of all /vtl/ traffic for operators: mosquitto_sub -u monitor -t '/vtl/#' -v
user monitor
topic read /vtl/#

# Cars log in as car0 .. car9 and may publish only requests and frees on their own topics,
# /vtl/request/<user> and /vtl/free/<user>; the server also refuses a payload that names
# another car there. The lab's unchanged cars publish on /vtl/request and /vtl/free, where the
# broker cannot tell whose payload it is: to admit them, add "topic write /vtl/request" and
# "topic write /vtl/free" under each car's user below, and know that any car can then ask or
# free in another car's name.
pattern write /vtl/request/%u
pattern write /vtl/free/%u

user car0
topic read /vtl/response
topic read /vtl/status
user car1
topic read /vtl/response
topic read /vtl/status
user car2
topic read /vtl/response
topic read /vtl/status
user car3
topic read /vtl/response
topic read /vtl/status
user car4
topic read /vtl/response
topic read /vtl/status
user car5
topic read /vtl/response
topic read /vtl/status
user car6
topic read /vtl/response
topic read /vtl/status
user car7
topic read /vtl/response
topic read /vtl/status
user car8
topic read /vtl/response
topic read /vtl/status
user car9
topic read /vtl/response
topic read /vtl/status
)";
}

std::string NewEpoch() {
  static std::atomic<std::uint64_t> counter{0};
  const auto ticks = Clock::now().time_since_epoch().count();
  return "run" + std::to_string(::getpid()) + "-" + std::to_string(counter++) + "-" +
         std::to_string(ticks % 1000000000);
}

MqttTrafficLightEndpoint::MqttTrafficLightEndpoint(std::unique_ptr<MqttClient> client,
                                                   const world::TrafficLightServerParams& params,
                                                   std::vector<int> intersection_ids,
                                                   MqttEndpointOptions options)
    : client_(std::move(client)),
      options_(std::move(options)),
      params_(params),
      intersection_ids_(std::move(intersection_ids)) {
  if (!IsValidEpoch(options_.epoch)) {
    throw std::invalid_argument("MqttTrafficLightEndpoint: invalid epoch '" + options_.epoch + "'");
  }
  params.Validate();
  client_->Subscribe(std::string(world::kVtlResponseTopic), 1);
  client_->Subscribe(std::string(kSimAckTopic), 1);
  // tlserver announces itself there: the reset need not wait for a resend if it starts after us
  // (later status messages are ignored)
  client_->Subscribe(std::string(kVtlStatusTopic), 1);
  const auto give_up = Clock::now() + options_.timeout;
  while (!client_->WaitReady(std::min(give_up, Clock::now() + options_.first_retry))) {
    if (options_.check_alive) options_.check_alive();
    if (Clock::now() >= give_up) {
      throw MqttError("mqtt link: cannot connect to the broker " + options_.broker_address +
                      " within " + Ms(options_.timeout));
    }
  }
  Reset();
}

void MqttTrafficLightEndpoint::Reset() {
  const SimReset reset{options_.epoch, params_, intersection_ids_};
  Exchange(MqttMessage{.topic = std::string(kSimResetTopic), .payload = EncodeReset(reset)});
}

void MqttTrafficLightEndpoint::Restart() {
  before_restarts_ = counters();
  counters_ = {};
  options_.epoch = NewEpoch();
  seq_ = 0;
  Reset();
}

MqttMessage MqttTrafficLightEndpoint::Tagged(std::string_view topic, std::string payload,
                                             Time now) {
  ++seq_;
  MqttMessage message{.topic = std::string(topic), .payload = std::move(payload)};
  message.properties.emplace_back(std::string(kStepProperty),
                                  EncodeStepTag(StepTag{options_.epoch, seq_, now}));
  return message;
}

std::vector<world::Response> MqttTrafficLightEndpoint::OnRequest(Time now,
                                                                 const world::Request& request) {
  return Exchange(Tagged(world::kVtlRequestTopic, world::Encode(request), now));
}

std::vector<world::Response> MqttTrafficLightEndpoint::OnFree(Time now, const world::Free& free) {
  return Exchange(Tagged(world::kVtlFreeTopic, world::Encode(free), now));
}

std::vector<world::Response> MqttTrafficLightEndpoint::OnTick(Time now) {
  return Exchange(Step(kSimClockTopic, now));
}

std::vector<world::Response> MqttTrafficLightEndpoint::OnDisconnected(Time now) {
  return Exchange(Step(kSimDisconnectTopic, now));
}

std::vector<world::Response> MqttTrafficLightEndpoint::OnReconnected(Time now) {
  return Exchange(Step(kSimReconnectTopic, now));
}

MqttMessage MqttTrafficLightEndpoint::Step(std::string_view topic, Time now) {
  ++seq_;
  return MqttMessage{.topic = std::string(topic),
                     .payload = EncodeStepTag(StepTag{options_.epoch, seq_, now})};
}

std::optional<int> MqttTrafficLightEndpoint::Holder(int intersection) const {
  const auto it = holders_.find(intersection);
  return it == holders_.end() ? std::nullopt : it->second;
}

std::vector<world::Response> MqttTrafficLightEndpoint::Exchange(const MqttMessage& message) {
  const auto start = Clock::now();
  const auto give_up = start + options_.timeout;
  std::chrono::milliseconds gap = options_.first_retry;
  auto resend_at = start + gap;
  std::map<std::uint64_t, std::string> responses;  // by index
  std::optional<SimAck> ack;
  const auto what = [&] {
    return "step " + std::to_string(seq_) + " (" + message.topic + " '" +
           message.payload.substr(0, 40) + "')";
  };
  client_->Publish(message);
  while (!ack || responses.size() < ack->responses.size()) {
    if (std::optional<MqttMessage> in = client_->Receive(std::min(resend_at, give_up))) {
      if (in->topic == world::kVtlResponseTopic) {
        const std::optional<std::string> property = in->Property(std::string(kResponseProperty));
        const auto tag = property ? DecodeResponseTag(*property)
                                  : world::Decoded<ResponseTag>::Error("untagged");
        if (tag && tag.value().epoch == options_.epoch && tag.value().seq == seq_) {
          responses.emplace(tag.value().index, in->payload);  // a duplicate changes nothing
        } else {
          ++stats_.ignored;
        }
      } else if (in->topic == kSimAckTopic) {
        world::Decoded<SimAck> decoded = DecodeAck(in->payload);
        if (decoded && decoded.value().epoch == options_.epoch && decoded.value().seq == seq_) {
          if (!decoded.value().error.empty()) {
            throw MqttError("mqtt link: tlserver refused " + what() + ": " + decoded.value().error);
          }
          ack = decoded.value();
        } else {
          ++stats_.ignored;
        }
      } else if (in->topic == kVtlStatusTopic && seq_ == 0 && !ack &&
                 in->payload.find("\"online\":true") != std::string::npos) {
        resend_at = Clock::now();  // a server (re)appeared: it may have missed the message
      } else {
        ++stats_.ignored;
      }
    }
    const auto now = Clock::now();
    if (ack && responses.size() >= ack->responses.size()) break;
    if (now >= give_up) {
      throw MqttError("mqtt link: no complete answer from tlserver to " + what() + " within " +
                      Ms(options_.timeout) + " (broker " + options_.broker_address +
                      (client_->connected() ? ", connected" : ", not connected") +
                      (ack ? ", acknowledged but " + std::to_string(responses.size()) + " of " +
                                 std::to_string(ack->responses.size()) + " responses received"
                           : ", not acknowledged") +
                      "); is a `tlserver --sim-clock` serving this broker?");
    }
    if (now >= resend_at) {
      if (options_.check_alive) options_.check_alive();
      client_->Publish(message);  // the server answers a repeated step from its cache
      ++stats_.resends;
      gap = std::min(2 * gap, kMaxRetryGap);
      resend_at = now + gap;
    }
  }
  const auto waited = Clock::now() - start;
  ++stats_.exchanges;
  stats_.wait_total += waited;
  stats_.wait_max = std::max<std::chrono::nanoseconds>(stats_.wait_max, waited);

  std::vector<world::Response> out = CheckedResponses(responses, *ack, what());
  deadline_ = ack->deadline;
  holders_.clear();
  for (const auto& [intersection, holder] : ack->holders) holders_[intersection] = holder;
  counters_ = ack->counters;
  records_.insert(records_.end(), ack->records.begin(), ack->records.end());
  return out;
}

std::vector<world::ServerRecord> MqttTrafficLightEndpoint::TakeRecords() {
  std::vector<world::ServerRecord> taken;
  taken.swap(records_);
  return taken;
}

namespace {

// A run's own broker and tlserver around the endpoint; destroyed in reverse order.
class PrivateMqttEndpoint final : public TrafficLightEndpoint {
 public:
  PrivateMqttEndpoint(const MqttLinkConfig& config, const world::TrafficLightServerParams& params,
                      std::vector<int> intersection_ids) {
    const std::string epoch = NewEpoch();
    broker_ = std::make_unique<LocalBroker>(
        LocalBrokerOptions{.users = {{"tlserver", RandomHex(16)}, {config.username, RandomHex(16)}},
                           .acl = DefaultAcl(),
                           .persistence = true});
    const std::filesystem::path log = broker_->dir() / "tlserver.log";
    tlserver_ = std::make_unique<ChildProcess>(
        std::vector<std::string>{FindTlserver().string(), "--host", broker_->host(), "--port",
                                 std::to_string(broker_->port()), "--username", "tlserver",
                                 "--password-file", broker_->PasswordFile("tlserver").string(),
                                 "--client-id", "tlserver-" + epoch, "--sim-clock"},
        log);
    MqttOptions options;
    options.host = broker_->host();
    options.port = broker_->port();
    options.client_id = "autonomsim-" + epoch;
    options.username = config.username;
    options.end_session_on_close = true;
    std::ifstream(broker_->PasswordFile(config.username)) >> options.password;
    MqttEndpointOptions endpoint_options{
        .epoch = epoch,
        .timeout = std::chrono::duration_cast<std::chrono::milliseconds>(config.timeout),
        .check_alive =
            [this] {
              if (!tlserver_->Running()) {
                throw MqttError("mqtt link: tlserver exited: " + tlserver_->LogTail());
              }
              if (!broker_->Running()) {
                throw MqttError("mqtt link: the private mosquitto exited: " + broker_->LogTail());
              }
            },
        .broker_address = broker_->address()};
    endpoint_ = std::make_unique<MqttTrafficLightEndpoint>(
        MakeMosquittoClient(options), params, std::move(intersection_ids), endpoint_options);
  }
  ~PrivateMqttEndpoint() override {
    endpoint_.reset();
    if (tlserver_) tlserver_->Stop();
  }

  std::vector<world::Response> OnRequest(Time now, const world::Request& request) override {
    return endpoint_->OnRequest(now, request);
  }
  std::vector<world::Response> OnFree(Time now, const world::Free& free) override {
    return endpoint_->OnFree(now, free);
  }
  std::vector<world::Response> OnTick(Time now) override { return endpoint_->OnTick(now); }
  std::vector<world::Response> OnDisconnected(Time now) override {
    return endpoint_->OnDisconnected(now);
  }
  std::vector<world::Response> OnReconnected(Time now) override {
    return endpoint_->OnReconnected(now);
  }
  void Restart() override { endpoint_->Restart(); }
  std::optional<Time> NextDeadline() const override { return endpoint_->NextDeadline(); }
  std::optional<int> Holder(int intersection) const override {
    return endpoint_->Holder(intersection);
  }
  world::TrafficLightServer::Counters counters() const override { return endpoint_->counters(); }
  std::vector<world::ServerRecord> TakeRecords() override { return endpoint_->TakeRecords(); }

 private:
  std::unique_ptr<LocalBroker> broker_;
  std::unique_ptr<ChildProcess> tlserver_;
  std::unique_ptr<MqttTrafficLightEndpoint> endpoint_;
};

}  // namespace

std::unique_ptr<TrafficLightEndpoint> MakeMqttEndpoint(
    const MqttLinkConfig& config, const world::TrafficLightServerParams& params,
    std::vector<int> intersection_ids) {
  config.Validate();
  if (config.broker.empty()) {
    return std::make_unique<PrivateMqttEndpoint>(config, params, std::move(intersection_ids));
  }
  const std::string epoch = NewEpoch();
  const MqttOptions options = GivenBrokerOptions(config, "autonomsim-" + epoch);
  return std::make_unique<MqttTrafficLightEndpoint>(
      MakeMosquittoClient(options), params, std::move(intersection_ids),
      MqttEndpointOptions{
          .epoch = epoch,
          .timeout = std::chrono::duration_cast<std::chrono::milliseconds>(config.timeout),
          .broker_address = config.broker});
}

}  // namespace autonomsim::sim
