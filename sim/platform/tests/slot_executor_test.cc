// The slots shared as the ReconROS executor shares them (sim/platform/slot_executor.h): timelines
// computed by hand for small arrival sequences.
#include "sim/platform/slot_executor.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "sim/platform/platform.h"
#include "sim/platform/tests/free_transport_profile.h"

namespace autonomsim::sim {
namespace {

using std::chrono::milliseconds;

// 4 cores (the delegates and the reconfigurations' CPU work never wait), memcpy 1 GB/s, the
// configuration port 400 MB/s: a 2 MB bitstream is copied in 2 ms and transferred in 5 ms.
PlatformProfile ExecutorProfile(int slots, Duration poll = Duration{0}) {
  PlatformProfile p = testing::FreeTransportProfile(4);
  p.cpu.memcpy_bytes_per_s = 1e9;
  p.fpga.slots = slots;
  p.fpga.slot_policy = SlotPolicy::kExecutor;
  p.fpga.config_port_bytes_per_s = 4e8;
  p.fpga.agent_poll_period = poll;
  return p;
}
constexpr std::int64_t kBitstream = 2'000'000;  // 2 ms copy + 5 ms transfer = 7 ms

struct ExecutorRig {
  explicit ExecutorRig(PlatformProfile profile) : platform(kernel, std::move(profile), &metrics) {
    executor().OnReconfigured(
        [this](const SlotExecutor::Reconfiguration& r) { reconfigurations.push_back(r); });
  }
  SlotExecutor& executor() { return *platform.slot_executor(); }
  // `node`'s callback of 10 ms of fabric ready at `at`; its end time goes to ends[node].
  void Callback(const std::string& node, Time at) {
    kernel.ScheduleAt(at, [this, node] {
      executor().Submit(node, -1, kBitstream, milliseconds(10), 0.001, [this, node] {
        ends.push_back({node, kernel.Now()});
      });
    });
  }
  Kernel kernel;
  RunMetrics metrics;
  Platform platform;
  std::vector<std::pair<std::string, Time>> ends;
  std::vector<SlotExecutor::Reconfiguration> reconfigurations;
};

TEST(SlotExecutor, OneSlotTwoNodesReconfiguresAtEachChangeOfNode) {
  ExecutorRig rig(ExecutorProfile(1));
  rig.executor().Preload(0, "a");
  rig.Callback("a", milliseconds(0));   // slot 0 holds a: runs 0-10
  rig.Callback("b", milliseconds(2));   // waits for the slot; at 10: 7 ms to load b, runs 17-27
  rig.Callback("a", milliseconds(30));  // idle slot, holds b: load a 30-37, runs 37-47
  rig.Callback("a", milliseconds(50));  // still holds a: runs 50-60
  rig.kernel.RunUntil(milliseconds(100));
  EXPECT_EQ(rig.ends, (std::vector<std::pair<std::string, Time>>{{"a", milliseconds(10)},
                                                                 {"b", milliseconds(27)},
                                                                 {"a", milliseconds(47)},
                                                                 {"a", milliseconds(60)}}));
  ASSERT_EQ(rig.reconfigurations.size(), 2u);
  // the transfer after the 2 ms copy: 12-17 and 32-37
  EXPECT_EQ(rig.reconfigurations[0].begin, milliseconds(10));
  EXPECT_EQ(rig.reconfigurations[0].transfer_begin, milliseconds(12));
  EXPECT_EQ(rig.reconfigurations[0].end, milliseconds(17));
  EXPECT_EQ(rig.reconfigurations[0].node, "b");
  EXPECT_EQ(rig.reconfigurations[0].replaced, "a");
  EXPECT_EQ(rig.reconfigurations[1].end, milliseconds(37));
  const auto& stats = rig.executor().stats(0);
  EXPECT_EQ(stats.callbacks, 4u);
  EXPECT_EQ(stats.reconfigurations, 2u);
  EXPECT_NEAR(stats.reconfiguring_s, 0.014, 1e-12);
  // the trace: each reconfiguration on the slot's track and its transfer on the port's
  const std::string trace = TraceJson({BoardMetrics{"car0", &rig.metrics}});
  EXPECT_NE(trace.find("\"configuration port\""), std::string::npos);
  EXPECT_NE(trace.find("\"slot 0 <- b\""), std::string::npos);
  EXPECT_NE(trace.find("\"reconfigure b\""), std::string::npos);
  EXPECT_EQ(rig.executor().waited(), 1u);              // b
  EXPECT_NEAR(rig.executor().wait_s(), 0.008, 1e-12);  // from 2 to 10 ms
}

TEST(SlotExecutor, ReconfigurationsGoOneAtATimeThroughThePort) {
  // Two empty slots, a and b ready at 0: both slots reconfigure, the port serves a's 0-7 (copy
  // 0-2, transfer 2-7), then b's 7-14; a runs 7-17, b 14-24.
  ExecutorRig rig(ExecutorProfile(2));
  rig.Callback("a", milliseconds(0));
  rig.Callback("b", milliseconds(0));
  rig.kernel.RunUntil(milliseconds(100));
  EXPECT_EQ(rig.ends, (std::vector<std::pair<std::string, Time>>{{"a", milliseconds(17)},
                                                                 {"b", milliseconds(24)}}));
  ASSERT_EQ(rig.reconfigurations.size(), 2u);
  EXPECT_EQ(rig.reconfigurations[0].slot, 0);
  EXPECT_EQ(rig.reconfigurations[1].slot, 1);
  EXPECT_EQ(rig.reconfigurations[1].begin, milliseconds(7));  // its copy 7-9, transfer 9-14
  EXPECT_EQ(rig.reconfigurations[1].transfer_begin, milliseconds(9));
}

TEST(SlotExecutor, AnIdleSlotHoldingTheBitstreamIsTakenElseTheOneIdleLongest) {
  ExecutorRig rig(ExecutorProfile(3));
  rig.executor().Preload(0, "a");
  rig.executor().Preload(1, "b");
  rig.executor().Preload(2, "c");
  rig.Callback("c", milliseconds(0));  // slot 2, no reconfiguration
  rig.Callback("b", milliseconds(1));  // slot 1
  // d at 30: every slot idle, slot 0 idle longest (since 0): it loads d
  rig.Callback("d", milliseconds(30));
  rig.kernel.RunUntil(milliseconds(100));
  ASSERT_EQ(rig.reconfigurations.size(), 1u);
  EXPECT_EQ(rig.reconfigurations[0].slot, 0);
  EXPECT_EQ(rig.reconfigurations[0].replaced, "a");
  EXPECT_EQ(rig.executor().stats(2).callbacks, 1u);
  EXPECT_EQ(rig.executor().stats(1).callbacks, 1u);
}

TEST(SlotExecutor, WithPollingAnIdleAgentTakesACallbackAtItsNextPoll) {
  // 1 ms polls from the moment the slot went idle (hw_executor.c:31): idle since 10 ms, a
  // callback ready at 12.5 ms is taken at 13 ms.
  ExecutorRig rig(ExecutorProfile(1, milliseconds(1)));
  rig.executor().Preload(0, "a");
  rig.Callback("a", milliseconds(0));                                    // taken at 0, ends at 10
  rig.Callback("a", milliseconds(12) + std::chrono::microseconds(500));  // taken at 13
  rig.kernel.RunUntil(milliseconds(100));
  ASSERT_EQ(rig.ends.size(), 2u);
  EXPECT_EQ(rig.ends[1].second, milliseconds(23));
}

TEST(SlotExecutor, PreloadingChecksTheSlot) {
  ExecutorRig rig(ExecutorProfile(2));
  EXPECT_THROW(rig.executor().Preload(2, "a"), std::invalid_argument);
  rig.executor().Preload(1, "a");
  EXPECT_THROW(rig.executor().Preload(1, "b"), std::invalid_argument);
}

}  // namespace
}  // namespace autonomsim::sim
