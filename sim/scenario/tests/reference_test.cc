// The scenario reference page (docs/scenarios.md) is the text generated from the loader's
// Describe, so it cannot drift from what the loader reads.
#include "sim/scenario/reference.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "sim/platform/platform_profile.h"
#include "sim/scenario/scenario.h"

namespace autonomsim::sim {
namespace {

using ::testing::HasSubstr;

TEST(ScenarioReferenceTest, TheDocsPageIsTheGeneratedText) {
  std::ifstream in("docs/scenarios.md", std::ios::binary);
  ASSERT_TRUE(in) << "docs/scenarios.md: cannot open (tests run from the checkout's root)";
  std::stringstream page;
  page << in.rdbuf();
  EXPECT_EQ(page.str(), ScenarioReferenceMarkdown() + "\n")
      << "docs/scenarios.md is out of date: build/bin/autonomsim reference --out "
         "docs/scenarios.md";
}

TEST(ScenarioReferenceTest, NamesEveryKeyWithItsTypeUnitAndDefault) {
  const std::string text = ScenarioReferenceMarkdown();
  EXPECT_THAT(text, HasSubstr("| `duration_s` | number | s | `120.0` |"));
  EXPECT_THAT(text,
              HasSubstr("| `v2i.link` | embedded \\| mqtt \\| realtime |  | `\"embedded\"` |"));
  EXPECT_THAT(text, HasSubstr("| `cars[i].driver` | oracle \\| stack |  | `\"oracle\"` |"));
  EXPECT_THAT(text, HasSubstr("| `cars[i].start` | text |  | `(none)` |"));
  EXPECT_THAT(text, HasSubstr("### car_stall"));
  EXPECT_THAT(text, HasSubstr("| `car` | integer |  | `(required)` |"));
  EXPECT_THAT(text, HasSubstr("### recovers_within"));
}

// The type cell of a key that takes one of a closed set of names: "a \\| b".
std::string Listed(const std::vector<std::string>& names) {
  std::string out;
  for (const std::string& name : names) out += (out.empty() ? "" : " \\| ") + name;
  return out;
}

// Issue 34: a key that takes a name from a closed set lists the names, from the set's one table
// (the preset, the lane thresholds and the cost distribution were text, their names nowhere).
TEST(ScenarioReferenceTest, AKeyOfAClosedSetListsItsNames) {
  const std::string text = ScenarioReferenceMarkdown();
  EXPECT_THAT(text, HasSubstr("| `stack.preset` | " + Listed(NamesOf<StackPreset>()) + " |"));
  EXPECT_THAT(text, HasSubstr("| `cars[i].stack.preset` | " + Listed(NamesOf<StackPreset>())));
  EXPECT_THAT(text, HasSubstr("| `cars[i].perception.lane_detection.thresholds` | " +
                              Listed(NamesOf<stack::LaneThresholdSet>()) + " |"));
  EXPECT_THAT(text, HasSubstr("| `cars[i].platform.cost_override.<name>.distribution` | " +
                              Listed(NamesOf<CostDistribution>()) + " |"));
  EXPECT_THAT(text, HasSubstr("| `v2i.link` | " + Listed(NamesOf<V2ILinkKind>()) + " |"));
}

}  // namespace
}  // namespace autonomsim::sim
