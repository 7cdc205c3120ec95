#include "stack/emergency_stop.h"

#include <gtest/gtest.h>

#include <limits>

namespace autonomsim::stack {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

TEST(EmergencyStopTest, StopsBelowTheStopDistanceAndReleasesOnlyAboveTheReleaseDistance) {
  const EmergencyStopParams params{
      .enabled = true, .stop_distance_m = 0.3, .release_distance_m = 0.45};
  EmergencyStopState state;
  EXPECT_EQ(StepEmergencyStop(params, 1.0, &state), std::nullopt);
  EXPECT_EQ(StepEmergencyStop(params, 0.31, &state), std::nullopt);
  EXPECT_EQ(StepEmergencyStop(params, 0.29, &state), std::optional<bool>(true));
  EXPECT_EQ(StepEmergencyStop(params, 0.28, &state), std::nullopt);  // already stopped
  EXPECT_EQ(StepEmergencyStop(params, 0.40, &state), std::nullopt);  // inside the hysteresis
  EXPECT_EQ(StepEmergencyStop(params, 0.45, &state), std::nullopt);
  EXPECT_EQ(StepEmergencyStop(params, 0.46, &state), std::optional<bool>(false));
  EXPECT_FALSE(state.stopped);
}

TEST(EmergencyStopTest, AnEchoInsideTheMinimumRangeStopsAndNothingInRangeReleases) {
  const EmergencyStopParams params{.enabled = true};
  EmergencyStopState state;
  EXPECT_EQ(StepEmergencyStop(params, -kInf, &state), std::optional<bool>(true));
  EXPECT_EQ(StepEmergencyStop(params, std::numeric_limits<double>::quiet_NaN(), &state),
            std::nullopt);
  EXPECT_TRUE(state.stopped);
  EXPECT_EQ(StepEmergencyStop(params, kInf, &state), std::optional<bool>(false));
}

TEST(EmergencyStopTest, ValidateRejectsAReleaseBelowTheStop) {
  EXPECT_THROW((EmergencyStopParams{.stop_distance_m = 0.5, .release_distance_m = 0.4}.Validate()),
               std::invalid_argument);
  EXPECT_THROW((EmergencyStopParams{.stop_distance_m = 0.0}.Validate()), std::invalid_argument);
  EXPECT_NO_THROW(EmergencyStopParams{}.Validate());
}

}  // namespace
}  // namespace autonomsim::stack
