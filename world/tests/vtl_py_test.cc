#include "world/vtl_py.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace autonomsim::world {
namespace {

using ::testing::HasSubstr;
using ::testing::Optional;

const std::vector<int> kLabSlots{0, 1};  // vtl.py:3-6

std::optional<std::string> OnRequest(const std::string& payload) {
  return VtlPyExitReason("/vtl/request", payload, kLabSlots);
}

// Each case was run through vtl.py's request_callback (vtl.py:25-36, lab commit 02c5ab4) under
// Python 3 without the broker.
TEST(VtlPyTest, ARequestItCannotParseOrIndexEndsTheScript) {
  EXPECT_THAT(OnRequest(""), Optional(HasSubstr("IndexError: string index")));
  EXPECT_THAT(OnRequest("0"), Optional(HasSubstr("IndexError: string index")));
  EXPECT_THAT(OnRequest("0x"), Optional(HasSubstr("ValueError: invalid literal for int() with "
                                                  "base 10: 'x' (vtl.py:28)")));
  EXPECT_THAT(OnRequest("0 "), Optional(HasSubstr("ValueError")));
  EXPECT_THAT(OnRequest(std::string("0\0", 2)), Optional(HasSubstr("'\\x00'")));
  EXPECT_THAT(OnRequest("02"), Optional(HasSubstr("IndexError: list index out of range, no slot "
                                                  "for intersection 2")));
  EXPECT_THAT(OnRequest("\xff\x01"), Optional(HasSubstr("UnicodeDecodeError")));
  EXPECT_THAT(OnRequest("0\xc3"), Optional(HasSubstr("UnicodeDecodeError")));          // cut short
  EXPECT_THAT(OnRequest("0\xed\xa0\x80"), Optional(HasSubstr("UnicodeDecodeError")));  // surrogate
  EXPECT_THAT(OnRequest("0\xc0\xb1"), Optional(HasSubstr("UnicodeDecodeError")));      // overlong
}

TEST(VtlPyTest, WhatItServesOrCannotBeJudgedIsNotClaimed) {
  // served by vtl.py: only request[0] and request[1] are read
  for (const char* served : {"00", "01", "91", "01x", "a1",
                             "\xc3\xa9"
                             "1"}) {
    EXPECT_EQ(OnRequest(served), std::nullopt) << served;
  }
  // int() takes the decimal digits of every script (int('\u0661') == 1: granted), so a second
  // character outside ASCII is not claimed; int('\u00e9') raises, but telling the two apart needs
  // Unicode's tables (tlserver rejects both as malformed)
  EXPECT_EQ(OnRequest("0\xd9\xa1"), std::nullopt);
  EXPECT_EQ(OnRequest("0\xc3\xa9"), std::nullopt);
  // a slot list beyond the lab's: the index is the intersection id
  EXPECT_EQ(VtlPyExitReason("/vtl/request", "02", {0, 1, 2}), std::nullopt);
}

TEST(VtlPyTest, AFreeEndsTheScriptOnlyWhenItIsNotUtf8) {
  // free_callback compares the payload with the slots (vtl.py:15-22): only decode() can raise
  EXPECT_THAT(VtlPyExitReason("/vtl/free", "\xff", kLabSlots),
              Optional(HasSubstr("UnicodeDecodeError: the payload is not UTF-8 (vtl.py:15)")));
  for (const char* ignored : {"", "0", "x", "00", "\xc3\xa9"}) {
    EXPECT_EQ(VtlPyExitReason("/vtl/free", ignored, kLabSlots), std::nullopt) << ignored;
  }
  // vtl.py subscribes to nothing else
  EXPECT_EQ(VtlPyExitReason("/vtl/response", "\xff", kLabSlots), std::nullopt);
}

}  // namespace
}  // namespace autonomsim::world
