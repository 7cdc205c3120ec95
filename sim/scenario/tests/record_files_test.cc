#include "sim/scenario/record_files.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "sim/core/hash.h"
#include "sim/mqtt/mqtt_process.h"  // TempDir

namespace autonomsim::sim {
namespace {

using std::chrono::milliseconds;
using ::testing::HasSubstr;

std::string Read(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// A record kept in memory with values that stress the text round trip: shortest-form doubles,
// negative and tiny numbers, every optional event field, and text that JSON must escape.
RunRecord HandMadeRecord() {
  RunRecord r;
  r.trajectory = {{.t = milliseconds(0),
                   .car = 0,
                   .x_m = 0.1,
                   .y_m = -2.2750000000000004,
                   .yaw_rad = 3.14159,
                   .speed_mps = 1e-300,
                   .steering_rad = -0.0,
                   .throttle = 0.25},
                  {.t = std::chrono::nanoseconds(86'399'999'999'999),
                   .car = 9,
                   .x_m = -1.0 / 3.0,
                   .y_m = 2.5,
                   .lateral_error_m = 0.172,
                   .route_progress_m = 12345.678}};
  r.events = {{.t = milliseconds(1500), .type = EventKind::kRequest, .car = 1, .intersection = 0},
              {.t = milliseconds(1750),
               .type = EventKind::kEnter,
               .car = 1,
               .intersection = 0,
               .granted = false},
              {.t = milliseconds(2000),
               .type = EventKind::kCollision,
               .car = 1,
               .other_car = 2,
               .obstacle = "box \"a\"",
               .lap = 3,
               .detail = "ü\n\t"}};
  return r;
}

TEST(RecordFiles, WhatIsAppendedReadsBackEqualWithTheSameTextAndHash) {
  const TempDir dir("record_files_test");
  const RunRecord memory = HandMadeRecord();
  auto files = std::make_shared<RecordFiles>(dir.path());
  for (const TrajectorySample& s : memory.trajectory) files->Append(s);
  for (const Event& e : memory.events) files->Append(e);
  files->Close();
  RunRecord streamed;
  streamed.store = files;

  EXPECT_EQ(Read(dir.path() / "trajectory.csv"), TrajectoryCsv(memory));
  EXPECT_EQ(Read(dir.path() / "events.jsonl"), EventsJsonl(memory));
  EXPECT_EQ(TrajectoryCsv(streamed), TrajectoryCsv(memory));  // read back through the store
  EXPECT_EQ(EventsJsonl(streamed), EventsJsonl(memory));
  EXPECT_EQ(ResultSha256(streamed), ResultSha256(memory));

  std::vector<TrajectorySample> samples;
  ForEachSample(streamed, [&](const TrajectorySample& s) { samples.push_back(s); });
  ASSERT_EQ(samples.size(), 2u);
  EXPECT_EQ(samples[1].t, memory.trajectory[1].t);  // the nanosecond survives the seconds column
  EXPECT_EQ(samples[0].y_m, memory.trajectory[0].y_m);
  EXPECT_EQ(samples[0].speed_mps, memory.trajectory[0].speed_mps);
  EXPECT_EQ(samples[1].x_m, memory.trajectory[1].x_m);
  std::vector<Event> events;
  ForEachEvent(streamed, [&](const Event& e) { events.push_back(e); });
  ASSERT_EQ(events.size(), 3u);
  EXPECT_EQ(events[1].granted, std::optional<bool>(false));
  EXPECT_EQ(events[2].obstacle, "box \"a\"");
  EXPECT_EQ(events[2].detail, "ü\n\t");
  EXPECT_EQ(events[2].other_car, 2);
  EXPECT_EQ(events[2].lap, 3);
  EXPECT_EQ(events[0].granted, std::nullopt);
}

TEST(RecordFiles, ReadingBeforeCloseIsAnError) {
  const TempDir dir("record_files_test");
  RecordFiles files(dir.path());
  files.Append(Event{.type = EventKind::kLap, .car = 0});
  EXPECT_THROW(files.ForEachEvent([](const Event&) {}), std::logic_error);
}

TEST(RecordFiles, AnUnwritableFolderIsAnErrorNamingTheFile) {
  try {
    RecordFiles files("/nonexistent/autonomsim");
    FAIL() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), HasSubstr("/nonexistent/autonomsim/trajectory.csv"));
  }
}

TEST(RecordText, LinesNotWrittenByTheRecordAreErrors) {
  EXPECT_THROW(ParseTrajectoryCsvLine("1,2,3"), std::invalid_argument);
  EXPECT_THROW(ParseTrajectoryCsvLine("0,0,0,0,0,0,0,0,0,0,0,0"), std::invalid_argument);
  EXPECT_THROW(ParseTrajectoryCsvLine("0,x,0,0,0,0,0,0,0,0,0"), std::invalid_argument);
  EXPECT_NO_THROW(ParseTrajectoryCsvLine("0,1,0,0,0,0,0,0,0,0,0"));
  EXPECT_THROW(ParseEventJsonLine("{\"type\": \"lap\"}"), std::invalid_argument);  // no t_s
  EXPECT_THROW(ParseEventJsonLine("not json"), std::invalid_argument);
}

}  // namespace
}  // namespace autonomsim::sim
