// A run's trajectory and events streamed to its folder's trajectory.csv and events.jsonl as the
// run makes them, and read back from there: a run of any length keeps none of them in memory.
#pragma once

#include <filesystem>
#include <fstream>

#include "sim/scenario/run_record.h"

namespace autonomsim::sim {

// Read back a trajectory.csv (after its header) or an events.jsonl that a run wrote, calling
// `visit` for each sample or event in order. std::runtime_error naming the file when it cannot
// be read, and file:line for a line a run did not write.
void ReadTrajectoryCsv(const std::filesystem::path& file,
                       const std::function<void(const TrajectorySample&)>& visit);
void ReadEventsJsonl(const std::filesystem::path& file,
                     const std::function<void(const Event&)>& visit);

class RecordFiles : public RecordStore {
 public:
  // Creates (or truncates) `folder`/trajectory.csv and `folder`/events.jsonl.
  explicit RecordFiles(const std::filesystem::path& folder);

  // Throw std::runtime_error naming the file when it cannot be written (e.g. the disk is full).
  void Append(const TrajectorySample& sample) override;
  void Append(const Event& event) override;
  void Close() override;

  // After Close, while the files are where they were written.
  void ForEachSample(const std::function<void(const TrajectorySample&)>& visit) const override;
  void ForEachEvent(const std::function<void(const Event&)>& visit) const override;
  void HashText(Sha256* hash) const override;
  // `folder`/trace.json, created on the first call.
  std::ostream* OpenTrace() override;

  const std::filesystem::path& trajectory_file() const { return trajectory_file_; }
  const std::filesystem::path& events_file() const { return events_file_; }

 private:
  void RequireClosed() const;

  std::filesystem::path trajectory_file_;
  std::filesystem::path events_file_;
  std::filesystem::path trace_file_;
  std::ofstream trajectory_;
  std::ofstream events_;
  std::ofstream trace_;  // open once OpenTrace was called
  bool closed_{false};
};

}  // namespace autonomsim::sim
