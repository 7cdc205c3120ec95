// The scenario reference page (docs/scenarios.md) is the text generated from the loader's
// Describe and the track file the loader reads, so it cannot drift from what the loader does.
#include "sim/scenario/reference.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cctype>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "sim/core/track_loader.h"
#include "sim/platform/platform_profile.h"
#include "sim/scenario/scenario.h"
#include "sim/scenario/tests/scenario_file.h"

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
  EXPECT_THAT(text, HasSubstr("| `cars[i].platform.cost_scale` | mapping by name to number |"));
  EXPECT_THAT(text, HasSubstr("### car_stall"));
  EXPECT_THAT(text, HasSubstr("| `car` | integer |  | `(required)` |"));
  EXPECT_THAT(text, HasSubstr("### recovers_within"));
}

// The cells of a table row, split at the pipes that are not escaped ("a \| b" is one cell).
std::vector<std::string> Cells(const std::string& row) {
  std::vector<std::string> cells;
  std::string cell;
  for (std::size_t i = 1; i < row.size(); ++i) {
    if (row[i] == '|' && row[i - 1] != '\\') {
      cells.push_back(cell);
      cell.clear();
    } else {
      cell += row[i];
    }
  }
  return cells;
}

// The rows (cells) of every key table (header "| key | type | unit | default | meaning |").
std::vector<std::vector<std::string>> KeyRows(const std::string& text) {
  std::vector<std::vector<std::string>> rows;
  std::istringstream lines(text);
  bool in_table = false;
  for (std::string line; std::getline(lines, line);) {
    if (line == "| key | type | unit | default | meaning |") {
      in_table = true;
    } else if (!line.starts_with("|")) {
      in_table = false;
    } else if (in_table && !line.starts_with("|---")) {
      rows.push_back(Cells(line));
    }
  }
  return rows;
}

// Issue 34: every key says what it means, from its `v(...)` in the loader's Describe.
TEST(ScenarioReferenceTest, EveryKeySaysWhatItMeans) {
  const std::vector<std::vector<std::string>> rows = KeyRows(ScenarioReferenceMarkdown());
  EXPECT_GT(rows.size(), 300u);  // the scenario's keys, the obstacle's, each kind's
  for (const std::vector<std::string>& cells : rows) {
    ASSERT_EQ(cells.size(), 5u) << ::testing::PrintToString(cells);
    EXPECT_NE(cells[4].find_first_not_of(' '), std::string::npos)
        << cells[0] << " says nothing: give its v(...) a meaning";
  }
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

// The text of the section under `heading` ("## Obstacles"), to the next heading of its level.
std::string Section(const std::string& text, const std::string& heading) {
  const std::size_t begin = text.find("\n" + heading + "\n");
  if (begin == std::string::npos) return "";
  const std::string level = heading.substr(0, heading.find(' ') + 1);
  const std::size_t end = text.find("\n" + level, begin + heading.size() + 1);
  return text.substr(begin, end == std::string::npos ? std::string::npos : end - begin);
}

// Issue 34: obstacle keys were in no section of their own.
TEST(ScenarioReferenceTest, ObstaclesHaveASectionWithEveryKey) {
  const std::string text = ScenarioReferenceMarkdown();
  EXPECT_THAT(text, HasSubstr("| `obstacles` | list (see below) |"));
  const std::string section = Section(text, "## Obstacles");
  ObstacleConfig obstacle;
  for (const std::string& key : detail::KeysOf(obstacle)) {
    EXPECT_THAT(section, HasSubstr("\n| `" + key + "` |")) << key;
  }
}

// Issue 34: the names a car's start, route and lanes take were in no document. Each start pose of
// the shipped track is listed with the routes it lies on, and it lies on exactly the routes the
// loader accepts it on.
TEST(ScenarioReferenceTest, EachStartPoseListsTheRoutesTheLoaderAcceptsItOn) {
  const std::string section = Section(ScenarioReferenceMarkdown(), "### Start poses");
  const world::TrackSpec track = LoadTrackSpec(ShippedScenarioFile("tracks/lab.yaml"));
  ASSERT_FALSE(track.start_poses.empty());
  for (const auto& [pose, spec] : track.start_poses) {
    std::smatch row;
    const std::regex row_of_pose("\\n\\| `" + pose + "` \\|[^\\n]*\\| ([^|\\n]*) \\|\\n");
    ASSERT_TRUE(std::regex_search(section, row, row_of_pose)) << pose << " is not listed";
    const std::string routes_listed = row[1];
    for (const auto& [route, lanes] : track.routes) {
      testing::ScenarioFile file(
          "reference_start_" + pose + "_" + route,
          "duration_s: 10\ncars:\n  - {id: 0, route: " + route + ", start: " + pose + "}\n");
      bool loads = true;
      try {
        LoadScenario(file.path());
      } catch (const ConfigError&) {
        loads = false;
      }
      EXPECT_EQ(routes_listed.find("`" + route + "`") != std::string::npos, loads)
          << "start " << pose << " on route " << route << ": listed " << routes_listed;
    }
  }
}

TEST(ScenarioReferenceTest, EveryRouteLaneAndIntersectionOfTheTrackIsListed) {
  const std::string text = ScenarioReferenceMarkdown();
  const world::TrackSpec track = LoadTrackSpec(ShippedScenarioFile("tracks/lab.yaml"));
  const std::string routes = Section(text, "### Routes");
  for (const auto& [route, lanes] : track.routes) {
    std::string listed;
    for (const std::string& lane : lanes) listed += (listed.empty() ? "`" : ", `") + lane + "`";
    EXPECT_THAT(routes, HasSubstr("\n| `" + route + "` | " + listed + " |")) << route;
  }
  const std::string lanes = Section(text, "### Lanes");
  for (const world::LaneSegmentSpec& lane : track.lanes) {
    EXPECT_THAT(lanes, HasSubstr("\n| `" + lane.name + "` |")) << lane.name;
  }
  const std::string intersections = Section(text, "### Intersections");
  for (const world::IntersectionSpec& intersection : track.intersections) {
    EXPECT_THAT(intersections, HasSubstr("\n| " + std::to_string(intersection.id) + " | " +
                                         intersection.name + " |"));
  }
}

// Issue 34: each kind said its keys but not what it does or checks.
TEST(ScenarioReferenceTest, EveryFaultAndExpectationKindSaysWhatItDoes) {
  const std::string text = ScenarioReferenceMarkdown();
  std::vector<std::string> kinds = NamesOf<FaultKind>();
  for (const std::string& name : NamesOf<ExpectKind>()) kinds.push_back(name);
  for (const std::string& kind : kinds) {
    const std::string section = Section(text, "### " + kind);
    ASSERT_FALSE(section.empty()) << kind;
    // the heading, a blank line, then a sentence before the keys
    std::istringstream lines(section.substr(1));
    std::string heading, blank, sentence;
    std::getline(lines, heading);
    std::getline(lines, blank);
    std::getline(lines, sentence);
    EXPECT_TRUE(blank.empty()) << kind;
    ASSERT_GT(sentence.size(), 20u) << kind;
    EXPECT_TRUE(std::isupper(static_cast<unsigned char>(sentence[0]))) << kind << ": " << sentence;
    EXPECT_FALSE(sentence.starts_with("|") || sentence.starts_with("No keys")) << kind;
  }
}

}  // namespace
}  // namespace autonomsim::sim
