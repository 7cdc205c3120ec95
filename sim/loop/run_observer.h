// What a recorder watches while a run goes (sim/results/mcap_recording.h records it as MCAP). An
// observer only looks: it costs nothing on the boards, draws no random number and schedules no
// event, so a run with observers has the result of the run without (its result_sha256).
#pragma once

#include <optional>

#include "sim/car/sensors.h"
#include "sim/core/kernel.h"
#include "sim/platform/node_graph.h"
#include "sim/scenario/run_record.h"
#include "world/v2i_protocol.h"

namespace autonomsim::sim {

class RunObserver {
 public:
  virtual ~RunObserver() = default;
  // Once, when the observer is added: each car that has a board, with its board (whose graph's
  // topics it may tap: NodeGraph::Tap) and its sensors.
  virtual void OnBoard(int /*car_id*/, Board& /*board*/, const SensorSuite& /*sensors*/) {}
  // Every V2I message as its sender publishes it: a car's request or free (`car_id` the car's),
  // the server's response (`car_id` empty), whether or not it then arrives.
  virtual void OnV2iPublished(Time /*t*/, std::optional<int> /*car_id*/,
                              const world::V2IMessage& /*message*/) {}
  // Every trajectory sample (ground truth, trajectory.csv's rows) and event (events.jsonl's).
  virtual void OnSample(const TrajectorySample& /*sample*/) {}
  virtual void OnEvent(const Event& /*event*/) {}
};

}  // namespace autonomsim::sim
