// The simulation side of the mqtt link against an in-memory stand-in for broker + tlserver, with
// the faults a real broker can produce (lost, repeated and reordered messages, traffic of other
// runs) and the failures it must report (silence, refusal). No processes, no sockets.
#include "sim/v2i/mqtt_endpoint.h"

#include <gtest/gtest.h>

#include <deque>
#include <thread>

namespace autonomsim::sim {
namespace {

using Clock = std::chrono::steady_clock;

// Answers the endpoint as tlserver --sim-clock would, from a world::TrafficLightServer.
class FakeServerClient final : public MqttClient {
 public:
  struct Faults {
    int lose_first{0};          // this many published messages vanish
    bool repeat{false};         // every output is delivered twice
    bool ack_first{false};      // the ack overtakes the responses
    bool others{false};         // untagged responses and acks of another run arrive too
    bool silent{false};         // nothing is answered
    bool wrong_payload{false};  // /vtl/response differs from what the ack lists
    std::string error;          // every step is answered with this error
  };
  explicit FakeServerClient(Faults faults) : faults_(std::move(faults)) {}

  void Publish(const MqttMessage& m) override {
    ++published_;
    if (lost_ < faults_.lose_first) {
      ++lost_;
      return;
    }
    if (faults_.silent) return;
    std::vector<MqttMessage> out = Handle(m);
    if (faults_.ack_first && out.size() > 1) std::rotate(out.begin(), out.end() - 1, out.end());
    if (faults_.others) {
      inbox_.push_back({.topic = "/vtl/response", .payload = "91"});
      SimAck other;
      other.epoch = "another-run";
      other.seq = seq_;
      inbox_.push_back({.topic = std::string(kSimAckTopic), .payload = EncodeAck(other)});
    }
    for (const MqttMessage& o : out) {
      inbox_.push_back(o);
      if (faults_.repeat) inbox_.push_back(o);
    }
  }
  void Subscribe(const std::string&, int) override {}
  std::optional<MqttMessage> Receive(Clock::time_point deadline) override {
    if (inbox_.empty()) {
      std::this_thread::sleep_until(deadline);
      return std::nullopt;
    }
    MqttMessage m = inbox_.front();
    inbox_.pop_front();
    return m;
  }
  std::optional<MqttMessage> ReceiveUntilConnectionChanges(Clock::time_point deadline) override {
    return Receive(deadline);  // always connected
  }
  void Interrupt() override {}
  bool WaitReady(Clock::time_point) override { return true; }
  bool Flush(Clock::time_point) override { return true; }
  bool connected() const override { return true; }
  std::uint64_t refused_publications() const override { return 0; }
  int published() const { return published_; }

 private:
  std::vector<MqttMessage> Handle(const MqttMessage& m) {
    std::vector<world::Response> responses;
    StepTag tag;
    if (m.topic == kSimResetTopic) {
      const SimReset reset = DecodeReset(m.payload).value();
      server_.emplace(reset.params, reset.intersections);
      tag = {reset.epoch, 0, kZeroTime};
      intersections_ = reset.intersections;
    } else if (m.topic == kSimClockTopic) {
      tag = DecodeStepTag(m.payload).value();
      if (tag.seq == seq_) return cache_;
      responses = server_->OnTick(tag.now);
    } else {
      tag = DecodeStepTag(*m.Property(std::string(kStepProperty))).value();
      if (tag.seq == seq_) return cache_;
      if (m.topic == world::kVtlRequestTopic) {
        responses = server_->OnRequest(tag.now, world::DecodeRequest(m.payload).value());
      } else {
        responses = server_->OnFree(tag.now, world::DecodeFree(m.payload).value());
      }
    }
    seq_ = tag.seq;
    SimAck ack{.epoch = tag.epoch, .seq = tag.seq};
    std::vector<MqttMessage> out;
    if (!faults_.error.empty()) {
      ack.error = faults_.error;
      return {{.topic = std::string(kSimAckTopic), .payload = EncodeAck(ack)}};
    }
    for (std::size_t i = 0; i < responses.size(); ++i) {
      MqttMessage r{.topic = "/vtl/response", .payload = world::Encode(responses[i])};
      r.properties.emplace_back(std::string(kResponseProperty),
                                EncodeResponseTag({tag.epoch, tag.seq, i}));
      ack.responses.push_back(r.payload);
      if (faults_.wrong_payload) r.payload[1] = r.payload[1] == '1' ? '0' : '1';
      out.push_back(r);
    }
    ack.deadline = server_->NextDeadline();
    for (int id : intersections_) ack.holders.emplace_back(id, server_->Holder(id));
    ack.counters = server_->counters();
    out.push_back({.topic = std::string(kSimAckTopic), .payload = EncodeAck(ack)});
    cache_ = out;
    return out;
  }

  Faults faults_;
  int lost_{0};
  int published_{0};
  std::deque<MqttMessage> inbox_;
  std::optional<world::TrafficLightServer> server_;
  std::vector<int> intersections_;
  std::uint64_t seq_{~std::uint64_t{0}};
  std::vector<MqttMessage> cache_;
};

world::TrafficLightServerParams Params() {
  world::TrafficLightServerParams params;
  params.lease = std::chrono::seconds(2);
  return params;
}

MqttEndpointOptions Options(std::chrono::milliseconds timeout = std::chrono::seconds(5)) {
  return {.epoch = "test-run",
          .timeout = timeout,
          .first_retry = std::chrono::milliseconds(5),
          .broker_address = "fake"};
}

std::unique_ptr<MqttTrafficLightEndpoint> Endpoint(FakeServerClient::Faults faults,
                                                   FakeServerClient** raw = nullptr,
                                                   MqttEndpointOptions options = Options()) {
  auto client = std::make_unique<FakeServerClient>(std::move(faults));
  if (raw != nullptr) *raw = client.get();
  return std::make_unique<MqttTrafficLightEndpoint>(std::move(client), Params(),
                                                    std::vector<int>{0, 1}, options);
}

// One call sequence: queue, later grant, free, lease expiry, unknown intersection.
std::string Drive(TrafficLightEndpoint& e) {
  std::string log;
  auto note = [&](const char* what, const std::vector<world::Response>& responses) {
    log += what;
    for (const world::Response& r : responses) log += " " + world::Encode(r);
    const std::optional<Time> d = e.NextDeadline();
    log += " | deadline " + (d ? std::to_string(d->count()) : "-");
    for (int i : {0, 1}) {
      const std::optional<int> h = e.Holder(i);
      log += " h" + std::to_string(i) + "=" + (h ? std::to_string(*h) : "-");
    }
    log += "\n";
  };
  const auto s = [](double seconds) { return FromSeconds(seconds); };
  note("req 00", e.OnRequest(s(0.1), {0, 0}));
  note("req 10", e.OnRequest(s(0.2), {1, 0}));
  note("req 21", e.OnRequest(s(0.3), {2, 1}));
  note("req 05", e.OnRequest(s(0.4), {0, 5}));
  note("free 0", e.OnFree(s(1.0), {0}));
  note("req 00", e.OnRequest(s(1.1), {0, 0}));
  note("tick", e.OnTick(s(2.2)));  // car 1 silent since 0.2 s: its lease is over, car 0 next
  if (const std::optional<Time> d = e.NextDeadline()) note("tick", e.OnTick(*d));
  const world::TrafficLightServer::Counters c = e.counters();
  log += "counters " + std::to_string(c.requests) + " " + std::to_string(c.grants) + " " +
         std::to_string(c.denials) + " " + std::to_string(c.frees) + " " +
         std::to_string(c.lease_expiries) + " " + std::to_string(c.unknown_intersection) + "\n";
  return log;
}

TEST(MqttEndpointTest, AnswersAsTheEmbeddedServerDoes) {
  EmbeddedTrafficLightEndpoint embedded(Params(), {0, 1});
  const std::string expected = Drive(embedded);
  EXPECT_NE(expected.find("free 0 11"), std::string::npos) << expected;  // queued car granted
  EXPECT_EQ(Drive(*Endpoint({})), expected);
}

TEST(MqttEndpointTest, SurvivesLostRepeatedReorderedAndForeignMessages) {
  EmbeddedTrafficLightEndpoint embedded(Params(), {0, 1});
  const std::string expected = Drive(embedded);
  FakeServerClient* client = nullptr;
  auto endpoint =
      Endpoint({.lose_first = 3, .repeat = true, .ack_first = true, .others = true}, &client);
  EXPECT_EQ(Drive(*endpoint), expected);
  // the lost reset was sent again until answered (a slow machine may resend more: harmless)
  EXPECT_GE(endpoint->stats().resends, 3u);
  EXPECT_GT(endpoint->stats().ignored, 0u);
  EXPECT_EQ(endpoint->stats().exchanges, 9u);  // the reset and eight steps
}

TEST(MqttEndpointTest, ASilentServerIsAnErrorAfterTheTimeoutNotAHang) {
  const auto start = Clock::now();
  try {
    Endpoint({.silent = true}, nullptr, Options(std::chrono::milliseconds(300)));
    FAIL() << "no error";
  } catch (const MqttError& e) {
    EXPECT_NE(std::string(e.what()).find("no complete answer from tlserver"), std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("not acknowledged"), std::string::npos) << e.what();
  }
  EXPECT_LT(Clock::now() - start, std::chrono::seconds(10));
}

TEST(MqttEndpointTest, TheServersRefusalIsReported) {
  try {
    Endpoint({.error = "steps are missing"});
    FAIL() << "no error";
  } catch (const MqttError& e) {
    EXPECT_NE(std::string(e.what()).find("tlserver refused step 0"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("steps are missing"), std::string::npos);
  }
}

TEST(MqttEndpointTest, ResponsesThatDifferFromTheAckAreAnError) {
  auto endpoint = Endpoint({.wrong_payload = true});
  EXPECT_THROW(endpoint->OnRequest(FromSeconds(1), {0, 0}), MqttError);
}

TEST(MqttEndpointTest, ADeadDependencyStopsTheWait) {
  MqttEndpointOptions options = Options();
  options.check_alive = [] { throw MqttError("tlserver exited"); };
  EXPECT_THROW(Endpoint({.silent = true}, nullptr, options), MqttError);
}

}  // namespace
}  // namespace autonomsim::sim
