// The MCAP recording as a run observer (sim/results/mcap_recording.h): it changes nothing in the
// run, the same run gives the same file, and it records the topics asked for. What the file holds
// is checked by Foxglove's readers in tools/tests/mcap_run_check.mjs (ctest Mcap.run_and_export).
#include "sim/results/mcap_recording.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>

#include "sim/loop/simulation.h"
#include "sim/mqtt/mqtt_process.h"  // TempDir

namespace autonomsim::sim {

// gtest prints a channel by its topic and count
void PrintTo(const McapRecording::ChannelCount& c, std::ostream* out) {
  *out << c.topic << " (" << c.messages << ")";
}

namespace {

using ::testing::Contains;
using ::testing::Field;
using ::testing::Not;

std::string ReadBytes(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

struct Recorded {
  RunRecord record;
  std::vector<McapRecording::ChannelCount> channels;
  std::vector<std::string> unmatched;
  std::string bytes;
};

Recorded RunRecorded(const LoadedScenario& loaded, const std::filesystem::path& file,
                     McapRecordingOptions options) {
  Simulation simulation(loaded);
  McapRecording recording(loaded, file, std::move(options));
  simulation.AddObserver(&recording);
  simulation.Run();
  recording.Close({}, ResultSha256(simulation.record()));
  return {simulation.record(), recording.channels(), recording.unmatched_patterns(),
          ReadBytes(file)};
}

// Two cars on the stack with perception, 10 s: the first requests at the intersection by 8 s.
LoadedScenario Short() { return LoadScenario("scenarios/lab_two_cars.yaml", {"duration_s=10"}); }

TEST(SimulationMcap, RecordingChangesNothingInTheRun) {
  const LoadedScenario loaded = Short();
  const RunRecord plain = RunScenario(loaded);
  TempDir dir("mcap_test_");
  const Recorded recorded = RunRecorded(loaded, dir.path() / "all.mcap", {.topics = {"*"}});
  EXPECT_EQ(ResultSha256(recorded.record), ResultSha256(plain));
  EXPECT_EQ(recorded.record.kernel_events, plain.kernel_events);  // it schedules nothing
}

TEST(SimulationMcap, TheSameRunGivesTheSameFile) {
  const LoadedScenario loaded = Short();
  TempDir dir("mcap_test_");
  const Recorded a = RunRecorded(loaded, dir.path() / "a.mcap", {});
  const Recorded b = RunRecorded(loaded, dir.path() / "b.mcap", {});
  EXPECT_GT(a.bytes.size(), 1000u);
  EXPECT_EQ(a.bytes, b.bytes);
}

TEST(SimulationMcap, RecordsTheTopicsAskedForAndSaysWhichPatternsMatchedNothing) {
  const LoadedScenario loaded = Short();
  TempDir dir("mcap_test_");
  const auto topic = [](const std::string& name) {
    return Contains(Field(&McapRecording::ChannelCount::topic, name));
  };
  // the default: everything but the camera images
  const Recorded all = RunRecorded(loaded, dir.path() / "default.mcap", {});
  for (const char* name :
       {"/car0/tf", "/car0/tf_static", "/car1/ground_truth/pose", "/car0/camera_info",
        "/car0/depth/camera_info", "/car1/lane_detector/central_line/point_cloud",
        "/car0/local_costmap/costmap", "/car0/plan", "/car0/cmd_vel", "/car0/modelcar/drive_cmd",
        "/car0/intersection_check", "/car0/controller_selector", "/car0/cpu_load", "/track",
        "/rosout", "/vtl/request", "/vtl/response"}) {
    EXPECT_THAT(all.channels, topic(name));
  }
  EXPECT_THAT(all.channels, Not(topic("/car0/image")));
  EXPECT_THAT(all.channels, Not(topic("/car0/depth/image_raw")));
  EXPECT_TRUE(all.unmatched.empty());
  // globs on the full name
  const Recorded some =
      RunRecorded(loaded, dir.path() / "some.mcap", {.topics = {"/car1/*image*", "/nothing/*"}});
  ASSERT_EQ(some.channels.size(), 2u);
  EXPECT_THAT(some.channels, topic("/car1/image"));
  EXPECT_THAT(some.channels, topic("/car1/depth/image_raw"));
  EXPECT_EQ(some.unmatched, std::vector<std::string>{"/nothing/*"});
  // 10 s of 30 Hz frames: each one the cameras published
  for (const auto& c : some.channels) EXPECT_NEAR(static_cast<double>(c.messages), 300.0, 1.0);
}

}  // namespace
}  // namespace autonomsim::sim
