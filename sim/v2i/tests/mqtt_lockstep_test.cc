// The lock-step protocol's messages, the link's config and the private brokers' ACL: no broker.
#include "sim/mqtt/mqtt_lockstep.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>
#include <utility>
#include <vector>

#include "sim/mqtt/mqtt_client.h"
#include "sim/mqtt/mqtt_link_config.h"
#include "sim/mqtt/tests/mqtt_fixture.h"
#include "sim/v2i/mqtt_endpoint.h"

namespace autonomsim::sim {
namespace {

TEST(MqttLockstepTest, StepTagsRoundTripAndRejectWhatIsNotOne) {
  const StepTag tag{"run12-3-456", 42, Time{1'234'567'890'123}};
  EXPECT_EQ(EncodeStepTag(tag), "run12-3-456 42 1234567890123");
  ASSERT_TRUE(DecodeStepTag(EncodeStepTag(tag)));
  EXPECT_EQ(DecodeStepTag(EncodeStepTag(tag)).value(), tag);
  for (const char* bad : {"", "run 1", "run 1 2 3", "run x 5", "run 1 -5", "r@n 1 2", "run  1 2",
                          "run 1 2 ", "run 18446744073709551616 0"}) {
    EXPECT_FALSE(DecodeStepTag(bad)) << bad;
  }
  EXPECT_NE(DecodeStepTag("run 1").error().find("<epoch> <seq> <now_ns>"), std::string::npos);
}

TEST(MqttLockstepTest, ResponseTagsRoundTrip) {
  const ResponseTag tag{"e", 7, 2};
  EXPECT_EQ(DecodeResponseTag(EncodeResponseTag(tag)).value(), tag);
  EXPECT_FALSE(DecodeResponseTag("e 7"));
}

TEST(MqttLockstepTest, EpochsAreShortAndPlain) {
  EXPECT_TRUE(IsValidEpoch("run1-2_3.x"));
  EXPECT_FALSE(IsValidEpoch(""));
  EXPECT_FALSE(IsValidEpoch("a b"));
  EXPECT_FALSE(IsValidEpoch(std::string(65, 'a')));
  EXPECT_TRUE(IsValidEpoch(NewEpoch()));
  EXPECT_NE(NewEpoch(), NewEpoch());
}

TEST(MqttLockstepTest, ResetCarriesPolicyLeaseAndIntersectionsExactly) {
  SimReset reset{"run1", {}, {0, 1}};
  reset.params.policy = world::ServerPolicy::kOriginal;
  reset.params.lease = Duration{5'000'000'001};  // not a round number of seconds
  const world::Decoded<SimReset> back = DecodeReset(EncodeReset(reset));
  ASSERT_TRUE(back) << back.error();
  EXPECT_EQ(back.value().epoch, "run1");
  EXPECT_EQ(back.value().params.policy, world::ServerPolicy::kOriginal);
  EXPECT_EQ(back.value().params.lease, reset.params.lease);
  EXPECT_EQ(back.value().intersections, (std::vector<int>{0, 1}));
  EXPECT_FALSE(DecodeReset("{"));
  EXPECT_FALSE(DecodeReset(R"({"epoch":"a b","policy":"fifo","lease_ns":1,"intersections":[]})"));
}

TEST(MqttLockstepTest, AcksRoundTripWithNullsAndErrors) {
  SimAck ack;
  ack.epoch = "run1";
  ack.seq = 9;
  ack.responses = {"01", "10"};
  ack.deadline = Time{77};
  ack.holders = {{0, 0}, {1, std::nullopt}};
  ack.counters.requests = 3;
  ack.counters.queue_drops = 1;
  const world::Decoded<SimAck> back = DecodeAck(EncodeAck(ack));
  ASSERT_TRUE(back) << back.error();
  EXPECT_EQ(back.value().responses, ack.responses);
  EXPECT_EQ(back.value().deadline, ack.deadline);
  EXPECT_EQ(back.value().holders, ack.holders);
  EXPECT_EQ(back.value().counters.requests, 3u);
  EXPECT_EQ(back.value().counters.queue_drops, 1u);
  ack.deadline.reset();
  EXPECT_FALSE(DecodeAck(EncodeAck(ack)).value().deadline);

  SimAck error;
  error.epoch = "run1";
  error.seq = 3;
  error.error = "steps are missing";
  EXPECT_EQ(DecodeAck(EncodeAck(error)).value().error, "steps are missing");
  EXPECT_FALSE(DecodeAck("not json"));
  EXPECT_FALSE(DecodeAck(R"({"epoch":"a","seq":1})"));
}

// Issue 15 (fuzzing): a float or an out-of-range integer reached nlohmann's get<int>() and
// get<int64_t>(), a cast that is undefined behaviour out of range (UBSan: "1.18447e+20 is outside
// the range of representable values of type 'int'") and that silently truncated 2.5 to 2.
TEST(MqttLockstepTest, NumbersMustBeIntegersTheFieldHolds) {
  const std::string reset_ok = R"({"epoch":"e","policy":"fifo","lease_ns":5,"intersections":[0]})";
  ASSERT_TRUE(DecodeReset(reset_ok)) << DecodeReset(reset_ok).error();
  for (const auto& [from, to] : std::vector<std::pair<std::string, std::string>>{
           {"\"lease_ns\":5", "\"lease_ns\":1e30"},
           {"\"lease_ns\":5", "\"lease_ns\":2.5"},
           {"\"lease_ns\":5", "\"lease_ns\":9223372036854775808"},
           {"[0]", "[0,118446744073709551616]"},
           {"[0]", "[4294967296]"},
           {"[0]", "{\"a\":0}"}}) {
    std::string bad = reset_ok;
    bad.replace(bad.find(from), from.size(), to);
    const world::Decoded<SimReset> decoded = DecodeReset(bad);
    EXPECT_FALSE(decoded) << bad;
    EXPECT_THAT(decoded.error(), ::testing::HasSubstr("expected")) << bad;
  }

  SimAck ack;
  ack.epoch = "e";
  ack.seq = 1;
  ack.holders = {{0, 1}};
  const std::string ack_ok = EncodeAck(ack);
  ASSERT_TRUE(DecodeAck(ack_ok));
  for (const auto& [from, to] : std::vector<std::pair<std::string, std::string>>{
           {"\"seq\":1", "\"seq\":-1"},
           {"\"seq\":1", "\"seq\":1e300"},
           {"\"deadline_ns\":null", "\"deadline_ns\":-1e300"},
           {"[[0,1]]", "[[0,1e10]]"},
           {"[[0,1]]", "[[2147483648,1]]"},
           {"\"requests\":0", "\"requests\":-5"}}) {
    std::string bad = ack_ok;
    ASSERT_NE(bad.find(from), std::string::npos) << from << " in " << ack_ok;
    bad.replace(bad.find(from), from.size(), to);
    EXPECT_FALSE(DecodeAck(bad)) << bad;
  }
}

TEST(MqttLinkConfigTest, ValidatesBrokerCredentialsTlsAndTimeout) {
  MqttLinkConfig config;
  EXPECT_NO_THROW(config.Validate());
  config.broker = "localhost:1883";
  EXPECT_NO_THROW(config.Validate());
  for (const char* bad : {"localhost", ":1883", "host:", "host:0", "host:65536", "host:x1"}) {
    config.broker = bad;
    EXPECT_THROW(config.Validate(), std::invalid_argument) << bad;
  }
  config.broker = "";
  config.password_file = "/etc/x";
  EXPECT_THROW(config.Validate(), std::invalid_argument);  // a private broker makes its own
  config = {};
  config.broker = "h:1";
  config.certfile = "c";
  config.keyfile = "k";
  EXPECT_THROW(config.Validate(), std::invalid_argument);  // no cafile
  config.cafile = "ca";
  EXPECT_NO_THROW(config.Validate());
  config.timeout = kZeroTime;
  EXPECT_THROW(config.Validate(), std::invalid_argument);
}

TEST(MqttClientTest, ParsesHostAndPort) {
  EXPECT_EQ(ParseHostPort("127.0.0.1:1883"), (std::pair<std::string, int>{"127.0.0.1", 1883}));
  EXPECT_EQ(ParseHostPort("[::1]:8883"), (std::pair<std::string, int>{"::1", 8883}));
  EXPECT_THROW(ParseHostPort("1883"), std::invalid_argument);
}

TEST(MqttLockstepTest, PrivateBrokersUseTheShippedAcl) {
  EXPECT_EQ(DefaultAcl(), testing::ShippedAcl());
}

}  // namespace
}  // namespace autonomsim::sim
