// A run recorded as an MCAP file while it goes (`autonomsim run --mcap FILE`, `export --mcap`),
// in MCAP's ros2 profile: ros2msg schemas, CDR messages, every car's topics under /carN/ with the
// lab's names, stamped in simulated time. docs/mcap.md lists the channels and what each holds.
//
// It is a RunObserver (sim/loop/run_observer.h): it taps the boards' topics as their nodes publish
// (a frozen camera's frame is recorded as the stack got it), the V2I messages as they are sent,
// the trajectory samples and the events, and changes nothing in the run. Images are rendered
// from the published frame only when their topic is recorded. Memory does not grow with the run's
// length: messages go to the file chunk by chunk (sim/mcap/mcap_writer.h).
#pragma once

#include <cstdint>
#include <deque>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "sim/loop/run_observer.h"
#include "sim/mcap/cdr.h"
#include "sim/mcap/mcap_writer.h"
#include "sim/mcap/ros2_messages.h"
#include "sim/results/expectations.h"
#include "sim/scenario/scenario.h"

namespace autonomsim::sim {

struct McapRecordingOptions {
  // fnmatch(3) globs on the full topic name ('*' matches '/' too); empty: every topic but the
  // camera images (DefaultMcapTopics).
  std::vector<std::string> topics;
  // The camera images as sensor_msgs/CompressedImage (PNG, lossless) instead of sensor_msgs/Image.
  bool png_images{false};
  mcap::WriterOptions writer;
};

// Bytes that open every MCAP file this program writes (the Header's profile and library, after
// the magic): what tells a file it may replace (sim::CheckOutputFile's signature).
std::string McapFileSignature();

// Whether `topic` is recorded by default: every topic but the camera images.
bool DefaultMcapTopic(const std::string& topic, mcap::ros2::Type type);

class McapRecording final : public RunObserver {
 public:
  // Creates or truncates `file` (the caller has checked that it may) and writes the track
  // (/track, at time 0). std::runtime_error if the file cannot be written.
  McapRecording(const LoadedScenario& loaded, const std::filesystem::path& file,
                McapRecordingOptions options);
  ~McapRecording() override;
  McapRecording(const McapRecording&) = delete;
  McapRecording& operator=(const McapRecording&) = delete;

  void OnBoard(int car_id, Board& board, const SensorSuite& sensors) override;
  void OnV2iPublished(Time t, std::optional<int> car_id, const world::V2IMessage& message) override;
  void OnSample(const TrajectorySample& sample) override;
  void OnEvent(const Event& event) override;

  // After the run: each failed expectation on /rosout (at its instant, else at the end, level
  // ERROR), the run's metadata (scenario, seed, hashes) and the file's summary; closes the file.
  void Close(const std::vector<ExpectationResult>& expectations, const std::string& result_sha256);

  struct ChannelCount {
    std::string topic;
    std::string schema;
    std::uint64_t messages{0};
    std::uint64_t bytes{0};  // the messages' CDR, uncompressed
  };
  // The channels written so far, in the order they were opened.
  std::vector<ChannelCount> channels() const;
  mcap::Writer::Counts counts() const { return writer_.counts(); }
  // The patterns of options.topics that no topic of the run matched.
  std::vector<std::string> unmatched_patterns() const;

 private:
  struct Slot;     // one topic: its type, whether it is recorded, its channel once opened
  struct CarTaps;  // per car: its slots and what its messages need (frames, last load)
  Slot& SlotFor(const std::string& topic, mcap::ros2::Type type,
                std::map<std::string, std::string> metadata = {});
  bool Wanted(Slot& slot);
  // Encodes with `encode(CdrWriter&)` and writes the message at `t` if the slot's topic is
  // recorded (nothing is encoded otherwise). Defined in the .cc, which alone calls it.
  template <class Encode>
  void Write(Slot& slot, Time t, const Encode& encode);
  void OpenChannel(Slot& slot);
  void TapStack(CarTaps& car, NodeGraph& graph);
  void TapCommands(CarTaps& car, NodeGraph& graph);
  void TapCameras(CarTaps& car, NodeGraph& graph, const SensorSuite& sensors);
  void WriteStatics(const CarTaps& car, const SensorSuite& sensors);
  void WriteTrack();

  const LoadedScenario& loaded_;
  McapRecordingOptions options_;
  mcap::Writer writer_;
  mcap::CdrWriter cdr_;
  std::deque<Slot> slots_;  // stable addresses: the taps hold pointers
  std::map<std::string, Slot*> slot_of_topic_;
  Slot* rosout_{nullptr};      // the events' and failed expectations' topic
  std::vector<Slot*> opened_;  // the slots with a channel, in the order they were opened
  std::map<mcap::ros2::Type, std::uint16_t> schema_ids_;
  std::vector<std::unique_ptr<CarTaps>> cars_;
  std::map<int, CarTaps*> car_of_id_;
  std::vector<bool> pattern_matched_;
  bool closed_{false};
};

}  // namespace autonomsim::sim
