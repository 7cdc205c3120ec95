// Seconds at the edges (world/time.h): FromSeconds rounds to the nanosecond and refuses what int64
// nanoseconds cannot hold, writing the value as it was given.
#include "world/time.h"

#include <gtest/gtest.h>

#include <stdexcept>

namespace autonomsim {
namespace {

TEST(TimeTest, FromSecondsRoundsToTheNanosecond) {
  EXPECT_EQ(FromSeconds(0.25), std::chrono::milliseconds(250));
  EXPECT_EQ(FromSeconds(-2e-9), Duration{-2});
  EXPECT_DOUBLE_EQ(ToSeconds(FromSeconds(120.0)), 120.0);
}

// Issue 34: the message said "10000000000.000000 s".
TEST(TimeTest, OutOfRangeNamesTheValueAsWritten) {
  try {
    FromSeconds(1e10);
    FAIL() << "1e10 s was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(), "time value out of range: 1e+10 s");
  }
}

}  // namespace
}  // namespace autonomsim
