#include "world/v2i_protocol.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <sstream>
#include <stdexcept>
#include <string>

namespace autonomsim::world {
namespace {

using ::testing::HasSubstr;

TEST(V2IProtocolTest, TopicsAreTheLabsOnes) {
  EXPECT_EQ(kVtlRequestTopic, "/vtl/request");
  EXPECT_EQ(kVtlResponseTopic, "/vtl/response");
  EXPECT_EQ(kVtlFreeTopic, "/vtl/free");
}

TEST(V2IProtocolTest, EncodesTheReferenceExamples) {
  EXPECT_EQ(Encode(Request{0, 1}), "01");  // reference §7: car 0 asks for intersection 1
  EXPECT_EQ(Encode(Response{3, true}), "31");
  EXPECT_EQ(Encode(Response{3, false}), "30");
  EXPECT_EQ(Encode(Free{7}), "7");
}

TEST(V2IProtocolTest, EveryValidMessageRoundTrips) {
  for (int car = 0; car <= kMaxV2IId; ++car) {
    for (int intersection = 0; intersection <= kMaxV2IId; ++intersection) {
      const Request request{car, intersection};
      const auto decoded = DecodeRequest(Encode(request));
      ASSERT_TRUE(decoded.ok()) << decoded.error();
      EXPECT_EQ(decoded.value(), request);
      EXPECT_TRUE(decoded.error().empty());
    }
    for (bool granted : {false, true}) {
      const Response response{car, granted};
      const auto decoded = DecodeResponse(Encode(response));
      ASSERT_TRUE(decoded.ok()) << decoded.error();
      EXPECT_EQ(decoded.value(), response);
    }
    const auto decoded = DecodeFree(Encode(Free{car}));
    ASSERT_TRUE(decoded.ok()) << decoded.error();
    EXPECT_EQ(decoded.value(), Free{car});
  }
}

TEST(V2IProtocolTest, MessagesCarryTopicAndPayload) {
  EXPECT_EQ(ToMessage(Request{0, 1}), (V2IMessage{"/vtl/request", "01"}));
  EXPECT_EQ(ToMessage(Response{2, true}), (V2IMessage{"/vtl/response", "21"}));
  EXPECT_EQ(ToMessage(Free{4}), (V2IMessage{"/vtl/free", "4"}));
  EXPECT_EQ(ToMessage(V2IPayload{Free{5}}), (V2IMessage{"/vtl/free", "5"}));

  for (const V2IPayload& payload :
       {V2IPayload{Request{9, 0}}, V2IPayload{Response{1, false}}, V2IPayload{Free{8}}}) {
    const auto decoded = Decode(ToMessage(payload));
    ASSERT_TRUE(decoded.ok()) << decoded.error();
    EXPECT_EQ(decoded.value(), payload);
  }
}

TEST(V2IProtocolTest, PrintsAsOnTheWire) {
  std::ostringstream os;
  os << Request{0, 1} << ", " << Response{2, false} << ", " << Free{3};
  EXPECT_EQ(os.str(), "/vtl/request \"01\", /vtl/response \"20\", /vtl/free \"3\"");
}

TEST(V2IProtocolTest, EncodingAnIdOutsideOneDigitThrows) {
  EXPECT_THROW(Encode(Request{10, 0}), std::invalid_argument);
  EXPECT_THROW(Encode(Request{0, -1}), std::invalid_argument);
  EXPECT_THROW(Encode(Response{-1, true}), std::invalid_argument);
  EXPECT_THROW(Encode(Free{12}), std::invalid_argument);
}

struct Malformed {
  std::string payload;
  std::string reason;  // a substring of the expected error
};

void ExpectRejected(const auto& decoded, const Malformed& m) {
  EXPECT_FALSE(decoded.ok()) << "accepted '" << m.payload << "'";
  EXPECT_FALSE(static_cast<bool>(decoded));
  EXPECT_THAT(decoded.error(), HasSubstr(m.reason)) << "payload '" << m.payload << "'";
  EXPECT_THROW(decoded.value(), std::logic_error);
}

TEST(V2IProtocolTest, MalformedRequestsAreRejectedWithAReason) {
  const std::vector<Malformed> cases = {
      {"", "empty"},
      {"0", "expected 2 byte(s)"},
      {"012", "expected 2 byte(s)"},   // extra byte
      {"01\n", "expected 2 byte(s)"},  // trailing newline
      {" 01", "expected 2 byte(s)"},   // leading whitespace
      {"0 ", "byte 1 is byte 0x20"},   // whitespace in place of a digit
      {"a1", "byte 0 is 'a'"},         // non-digit
      {"0x", "byte 1 is 'x'"},
      {"-1", "byte 0 is '-'"},
      {std::string("0\0", 2), "byte 1 is byte 0x00"},
      {"\xff"
       "1",
       "byte 0 is byte 0xff"},
  };
  for (const auto& m : cases) ExpectRejected(DecodeRequest(m.payload), m);
}

TEST(V2IProtocolTest, MalformedResponsesAreRejectedWithAReason) {
  const std::vector<Malformed> cases = {
      {"", "empty"},
      {"1", "expected 2 byte(s)"},
      {"110", "expected 2 byte(s)"},
      {"1\t", "byte 1 is byte 0x09"},
      {"x1", "byte 0 is 'x'"},
      {"12", "expected '0' (occupied) or '1' (granted)"},  // a digit, but not a verdict
      {"19", "expected '0' (occupied) or '1' (granted)"},
  };
  for (const auto& m : cases) ExpectRejected(DecodeResponse(m.payload), m);
}

TEST(V2IProtocolTest, MalformedFreesAreRejectedWithAReason) {
  const std::vector<Malformed> cases = {
      {"", "empty"},
      {"01", "expected 1 byte(s)"},  // a request payload on the free topic
      {"1 ", "expected 1 byte(s)"},
      {" ", "byte 0 is byte 0x20"},
      {"a", "byte 0 is 'a'"},
  };
  for (const auto& m : cases) ExpectRejected(DecodeFree(m.payload), m);
}

TEST(V2IProtocolTest, ErrorsNameTheTopicAndQuoteThePayloadSafely) {
  const auto decoded = DecodeRequest(std::string(40, '\x01'));
  ASSERT_FALSE(decoded.ok());
  EXPECT_THAT(decoded.error(), HasSubstr("/vtl/request"));
  EXPECT_THAT(decoded.error(), HasSubstr("\\x01\\x01"));
  EXPECT_THAT(decoded.error(), HasSubstr("\"..."));  // cut short, never the whole payload
  EXPECT_THAT(decoded.error(), HasSubstr("got 40"));
}

TEST(V2IProtocolTest, UnknownTopicIsRejected) {
  const auto decoded = Decode(V2IMessage{"/vtl/requests", "01"});
  ASSERT_FALSE(decoded.ok());
  EXPECT_THAT(decoded.error(), HasSubstr("unknown topic"));
  EXPECT_FALSE(Decode(V2IMessage{"", "0"}).ok());
  // A well-formed payload on the wrong topic fails that topic's check.
  EXPECT_FALSE(Decode(V2IMessage{"/vtl/free", "01"}).ok());
  EXPECT_THAT(Decode(V2IMessage{"/vtl/response", "0"}).error(), HasSubstr("/vtl/response"));
}

}  // namespace
}  // namespace autonomsim::world
