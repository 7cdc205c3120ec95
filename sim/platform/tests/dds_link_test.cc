// The DDS link (sim/platform/dds_link.h) against cases worked out by hand. The numbers are chosen
// to make the timeline easy to follow: one fragment per 1000-byte datagram, 1 ms of the writer's
// CPU to send a datagram, 2.5 ms of the receive thread's to take one (a heartbeat too), no copies,
// no wire time, two cores (the writer and the receive thread each have one), one datagram per CPU
// job. A 5000-byte sample is five datagrams; datagram i reaches the socket at i + 1 ms.
#include "sim/platform/dds_link.h"

#include <gtest/gtest.h>

#include <cmath>
#include <optional>
#include <vector>

#include "sim/core/kernel.h"
#include "sim/platform/platform.h"
#include "sim/platform/transport_run.h"

namespace autonomsim::sim {
namespace {

using std::chrono::microseconds;
using std::chrono::milliseconds;

DdsLinkParams HandParams(std::int64_t socket_capacity_bytes) {
  DdsLinkParams p;
  p.max_message_bytes = 1000;
  p.fragment_bytes = 1000;
  p.receive_buffer_bytes = socket_capacity_bytes / 2;  // the kernel doubles it
  p.host_rmem_max_bytes = socket_capacity_bytes / 2;
  p.socket_overhead_bytes = 0;
  p.control_bytes = 64;
  p.batch_datagrams = 1;
  p.latency = Duration{0};
  p.write = DdsSideCost{.per_datagram = milliseconds(1)};
  p.receive = DdsSideCost{.per_datagram = microseconds(2500)};
  p.whc_high_bytes = 100000;
  p.whc_low_bytes = 1000;
  p.max_blocking = std::nullopt;  // rmw_cyclonedds: infinite for reliable publishers
  return p;
}

struct Bench {
  explicit Bench(DdsLinkParams params)
      : cpu(kernel, 2, nullptr),
        socket(kernel, cpu, -1, params.SocketCapacityBytes()),
        link(kernel, cpu, params, -1, socket, [this](std::int64_t seq) {
          delivered.push_back({seq, kernel.Now()});
        }) {}

  // Writes `bytes` at `at`; the write call's return (time, accepted) lands in `returned`.
  void WriteAt(Time at, std::int64_t bytes) {
    kernel.ScheduleAt(at, [this, bytes] {
      link.Write(bytes, [this](bool accepted) { returned.push_back({kernel.Now(), accepted}); });
    });
  }

  struct Delivery {
    std::int64_t seq;
    Time at;
  };
  struct Return {
    Time at;
    bool accepted;
  };
  Kernel kernel;
  Cpu cpu;
  DdsSocket socket;
  DdsLink link;
  std::vector<Delivery> delivered;
  std::vector<Return> returned;
};

Time Ms(double ms) { return kZeroTime + microseconds(std::llround(ms * 1000.0)); }

TEST(DdsLinkParams, CycloneDefaultsCutA4_9MbCloudInto366DatagramsOf10Fragments) {
  const DdsLinkParams p;                    // Cyclone's defaults (reference §10)
  EXPECT_EQ(p.FragmentsPerDatagram(), 10);  // 14 720 / 1 344
  EXPECT_EQ(p.DatagramsFor(4915200), 366);  // 3 658 fragments
  // SO_RCVBUF 1 MiB capped by a stock 212 992 B rmem_max, doubled by the kernel
  EXPECT_EQ(p.SocketCapacityBytes(), 2 * 212992);
}

// Five datagrams into a buffer that holds them all: the receive thread drains one every 2.5 ms
// from 1 ms, so the sample is whole at 1 + 5 × 2.5 = 13.5 ms; the write returns when the last
// datagram is sent (5 ms); the heartbeat after it finds everything and is answered by an ACK.
TEST(DdsLink, ASampleThatFitsTheBufferArrivesWhenTheReceiveThreadHasDrainedIt) {
  Bench b(HandParams(10000));
  b.WriteAt(kZeroTime, 5000);
  b.kernel.RunUntil(Ms(500));
  ASSERT_EQ(b.delivered.size(), 1u);
  EXPECT_EQ(b.delivered[0].at, Ms(13.5));
  ASSERT_EQ(b.returned.size(), 1u);
  EXPECT_EQ(b.returned[0].at, Ms(5));
  EXPECT_TRUE(b.returned[0].accepted);
  const DdsLinkStats& s = b.link.stats();
  EXPECT_EQ(s.datagrams_dropped, 0);
  EXPECT_EQ(s.nacks, 0);
  EXPECT_EQ(s.samples_delivered, 1);
  EXPECT_EQ(b.link.whc_bytes(), 0);  // acknowledged
}

// A buffer of two datagrams: at 5 ms it holds datagrams 2 and 3 (1 is being received), so the
// last datagram, and the heartbeat it carries, are dropped. Datagrams 1-3 carry HEARTBEAT_FRAGs
// that show no gap. The periodic heartbeat (100 ms after the write: 105 ms; taken by the receive
// thread at 107.5 ms) shows the missing datagram, never asked for before, so the NACK leaves at
// once (Cyclone's sched_acknack_if_needed); the writer sends datagram 4 again (1 ms) and the
// receive thread takes it (2.5 ms): the sample is whole at 111 ms.
TEST(DdsLink, ASampleThatOverflowsTheBufferOnceIsRepairedOnTheHeartbeatAndNackTimers) {
  Bench b(HandParams(2000));
  b.WriteAt(kZeroTime, 5000);
  b.kernel.RunUntil(Ms(1000));
  ASSERT_EQ(b.delivered.size(), 1u);
  EXPECT_EQ(b.delivered[0].at, Ms(111));
  const DdsLinkStats& s = b.link.stats();
  EXPECT_EQ(s.datagrams_dropped, 1);  // datagram 4, with the heartbeat in it
  EXPECT_EQ(s.nacks, 1);
  EXPECT_EQ(s.datagrams_retransmitted, 1);
  EXPECT_EQ(s.samples_lost, 0);
  EXPECT_EQ(b.link.whc_bytes(), 0);
}

// One writer, two readers, each receive thread on a core of its own: the five datagrams are sent
// once and reach both sockets. Reader A's buffer holds them all (delivered at 13.5 ms, as above);
// reader B's holds two, loses the last datagram and is repaired alone, as above (111 ms): the
// periodic heartbeat goes to both, the retransmission only to B. The WHC keeps the sample until
// B, the last, acknowledges it.
TEST(DdsLink, TwoReadersGetOneSendAndEachRepairsOnItsOwn) {
  DdsLinkParams params = HandParams(10000);
  Kernel kernel;
  Cpu cpu(kernel, 3, nullptr);
  DdsSocket a(kernel, cpu, -1, 10000);
  DdsSocket b(kernel, cpu, -1, 2000);
  std::vector<Time> at_a;
  std::vector<Time> at_b;
  DdsLink link(kernel, cpu, params, -1, a, [&](std::int64_t) { at_a.push_back(kernel.Now()); });
  link.AddReader(b, [&](std::int64_t) { at_b.push_back(kernel.Now()); });
  link.Write(5000, {});
  kernel.RunUntil(Ms(50));
  EXPECT_EQ(link.whc_bytes(), 5000);  // A acknowledged, B did not
  kernel.RunUntil(Ms(1000));
  ASSERT_EQ(at_a.size(), 1u);
  ASSERT_EQ(at_b.size(), 1u);
  EXPECT_EQ(at_a[0], Ms(13.5));
  EXPECT_EQ(at_b[0], Ms(111));
  const DdsLinkStats& s = link.stats();
  EXPECT_EQ(s.datagrams_sent, 5 + 1);  // the sample once, one periodic heartbeat
  EXPECT_EQ(s.datagrams_dropped, 1);
  EXPECT_EQ(s.nacks, 1);
  EXPECT_EQ(s.datagrams_retransmitted, 1);
  EXPECT_EQ(s.samples_delivered, 2);
  EXPECT_EQ(link.whc_bytes(), 0);
  EXPECT_THROW(link.AddReader(b, {}), std::logic_error);  // readers come before the first write
}

// Best effort, the same overflow: the first sample is never whole; a one-datagram sample written
// at 50 ms arrives at 51 ms into an empty buffer and is delivered at 53.5 ms, and the first counts
// as lost. Nothing is repaired.
TEST(DdsLink, BestEffortLosesASampleWithADroppedDatagram) {
  DdsLinkParams p = HandParams(2000);
  p.reliability = Reliability::kBestEffort;
  Bench b(p);
  b.WriteAt(kZeroTime, 5000);
  b.WriteAt(Ms(50), 1000);
  b.kernel.RunUntil(Ms(1000));
  ASSERT_EQ(b.delivered.size(), 1u);
  EXPECT_EQ(b.delivered[0].seq, 1);
  EXPECT_EQ(b.delivered[0].at, Ms(53.5));
  const DdsLinkStats& s = b.link.stats();
  EXPECT_EQ(s.datagrams_dropped, 1);
  EXPECT_EQ(s.samples_lost, 1);
  EXPECT_EQ(s.nacks, 0);
  EXPECT_EQ(s.datagrams_retransmitted, 0);
}

// Best effort keeps at most four incomplete samples (Cyclone's DefragUnreliableMaxSamples): six
// samples that each lose their last datagram (written every 50 ms, the buffer as above) leave the
// reader holding the last four, and the first two counted lost when the fifth and sixth began.
TEST(DdsLink, BestEffortGivesUpTheOldestOfMoreThanFourIncompleteSamples) {
  DdsLinkParams p = HandParams(2000);
  p.reliability = Reliability::kBestEffort;
  Bench b(p);
  for (int i = 0; i < 6; ++i) b.WriteAt(Ms(50.0 * i), 5000);
  b.kernel.RunUntil(Ms(1000));
  EXPECT_EQ(b.link.stats().datagrams_dropped, 6);
  EXPECT_TRUE(b.delivered.empty());
  EXPECT_EQ(b.link.stats().samples_lost, 2);
}

// A KEEP_ALL writer with a high-water mark of 3000 bytes: after the first 5000-byte sample the
// WHC is above it, so the second write (at 6 ms) blocks until the first is acknowledged. The
// heartbeat rides in datagram 4, which the receive thread finishes at 13.5 ms: the ACK empties the
// WHC then, and the second write sends its five datagrams and returns at 18.5 ms.
TEST(DdsLink, TheHighWaterMarkBlocksTheWriterUntilTheReaderAcknowledges) {
  DdsLinkParams p = HandParams(10000);
  p.whc_high_bytes = 3000;
  p.keep_all = true;
  Bench b(p);
  b.WriteAt(kZeroTime, 5000);
  b.WriteAt(Ms(6), 5000);
  b.kernel.RunUntil(Ms(500));
  ASSERT_EQ(b.returned.size(), 2u);
  EXPECT_EQ(b.returned[0].at, Ms(5));
  EXPECT_EQ(b.returned[1].at, Ms(18.5));
  EXPECT_TRUE(b.returned[1].accepted);
  EXPECT_EQ(b.delivered.size(), 2u);
  EXPECT_EQ(b.link.stats().write_timeouts, 0);
}

// The same with a max blocking time of 5 ms: the second write gives up at 11 ms, unsent.
TEST(DdsLink, ABlockedWriteFailsAfterTheMaxBlockingTime) {
  DdsLinkParams p = HandParams(10000);
  p.whc_high_bytes = 3000;
  p.keep_all = true;
  p.max_blocking = milliseconds(5);
  Bench b(p);
  b.WriteAt(kZeroTime, 5000);
  b.WriteAt(Ms(6), 5000);
  b.kernel.RunUntil(Ms(500));
  ASSERT_EQ(b.returned.size(), 2u);
  EXPECT_EQ(b.returned[1].at, Ms(11));
  EXPECT_FALSE(b.returned[1].accepted);
  EXPECT_EQ(b.link.stats().write_timeouts, 1);
  EXPECT_EQ(b.link.stats().samples_written, 1);
  EXPECT_EQ(b.delivered.size(), 1u);
}

// Keep-last 1 on a reliable writer: a newer sample (written at 50 ms, before the periodic
// heartbeat would have the first repaired) pushes the unrepaired one out of the history, and the
// heartbeat in the new sample's datagram tells the reader to give up on it. A KEEP_LAST writer is
// never throttled (Cyclone sets its marks to INT32_MAX), whatever its WHC holds.
TEST(DdsLink, AKeepLastWriterIsNeverBlocked) {
  DdsLinkParams p = HandParams(10000);
  p.whc_high_bytes = 3000;  // below one sample
  Bench b(p);
  b.WriteAt(kZeroTime, 5000);
  b.WriteAt(Ms(6), 5000);
  b.kernel.RunUntil(Ms(500));
  ASSERT_EQ(b.returned.size(), 2u);
  EXPECT_EQ(b.returned[1].at, Ms(11));  // sent at once: 6 + 5 datagrams
  EXPECT_EQ(b.delivered.size(), 2u);
}

TEST(DdsLink, AReliableKeepLastWriterDropsWhatFallsOutOfItsHistory) {
  DdsLinkParams p = HandParams(2000);
  p.depth = 1;
  Bench b(p);
  b.WriteAt(kZeroTime, 5000);  // loses datagram 4 (as above)
  b.WriteAt(Ms(50), 1000);     // replaces it in the history before the repair (205 ms)
  b.kernel.RunUntil(Ms(1000));
  ASSERT_EQ(b.delivered.size(), 1u);
  EXPECT_EQ(b.delivered[0].seq, 1);
  EXPECT_EQ(b.link.stats().samples_lost, 1);
}

}  // namespace
}  // namespace autonomsim::sim

namespace autonomsim::sim {
namespace {

// Woken by a datagram, the receive thread runs at once even on a busy CPU (a thread that slept
// has the scheduler's credit). One core, which the writer alone keeps busy while it sends, and a
// buffer of three datagrams: from 1 ms the two share the core. The receive thread takes datagram
// 0 over 1-6 ms and 1 over 6-10 ms (half the core until the writer ends at 9 ms), then 2, 3, 4 at
// 2.5 ms each: whole at 17.5 ms. Its 6 ms slice never runs out while the writer still wants the
// core, so slices change nothing here.
TEST(DdsLink, AReceiveThreadWokenOnABusyCpuRunsAtOnce) {
  for (const int slice_ms : {0, 6}) {
    Kernel kernel;
    Cpu cpu(kernel, 1, nullptr);
    DdsLinkParams p = HandParams(3000);
    DdsSocket socket(kernel, cpu, -1, p.SocketCapacityBytes(), milliseconds(slice_ms));
    Time delivered{0};
    DdsLink link(kernel, cpu, p, -1, socket, [&](std::int64_t) { delivered = kernel.Now(); });
    link.Write(5000, {});
    kernel.RunUntil(kZeroTime + milliseconds(1000));
    EXPECT_EQ(link.stats().datagrams_dropped, 0) << slice_ms << " ms";
    EXPECT_EQ(delivered, Ms(17.5)) << slice_ms << " ms";
  }
}

// Two busy loops and the writer want both cores: after each 2 ms slice the receive thread is off
// the core for (3 + 1) / 2 - 1 = 1 slice. A 40-datagram sample into a buffer that holds it all
// loses nothing, but arrives later than when the thread shares the cores as a fluid.
TEST(DdsLink, OnAContendedCpuTheReceiveThreadDrainsInTurns) {
  Duration arrival[2];
  for (const int slice_ms : {0, 2}) {
    Kernel kernel;
    Cpu cpu(kernel, 2, nullptr);
    cpu.Start(-1, 100.0, 1.0, {});
    cpu.Start(-1, 100.0, 1.0, {});
    DdsLinkParams p = HandParams(100000);
    DdsSocket socket(kernel, cpu, -1, p.SocketCapacityBytes(), milliseconds(slice_ms));
    Time delivered{0};
    DdsLink link(kernel, cpu, p, -1, socket, [&](std::int64_t) { delivered = kernel.Now(); });
    link.Write(40000, {});
    kernel.RunUntil(kZeroTime + milliseconds(2000));
    arrival[slice_ms == 0 ? 0 : 1] = delivered - kZeroTime;
  }
  EXPECT_GT(arrival[1], arrival[0]);
}

}  // namespace
}  // namespace autonomsim::sim

namespace autonomsim::sim {
namespace {

// The x86 profile (this machine's measured datagram costs, Cyclone's defaults): a 4.9 MB cloud at
// 30 Hz crosses whole while the two cores are free; with a busy loop on each core the receive
// thread drains in turns, the writer's bursts overflow the 2 MiB buffer, and the repairs cost the
// rate (ddsperf here: 30 Hz quiet, 2-9 Hz busy; docs/model.md#dds-against-cyclone-dds).
TEST(TransportRun, ABusyMachineLosesDatagramsAndRateWhereAQuietOneDeliversAll) {
  const PlatformProfile profile = LoadPlatformProfile(
      "scenarios/platforms/x86_loopback.yaml", {"dds.history=keep_all", "dds.max_blocking_s=10"});
  TransportRunOptions options;
  options.bytes = 4915200;
  options.duration = std::chrono::seconds(6);
  const TransportRunResult quiet = RunTransport(profile, options);
  EXPECT_DOUBLE_EQ(quiet.delivered_hz, 30.0);
  EXPECT_EQ(quiet.stats.datagrams_dropped, 0);
  options.background_cores = 2;
  const TransportRunResult busy = RunTransport(profile, options);
  EXPECT_GT(busy.stats.datagrams_dropped, 0);
  EXPECT_GT(busy.stats.nacks, 0);
  EXPECT_LT(busy.delivered_hz, 15.0);
  EXPECT_GT(busy.delivered_hz, 1.0);
}

}  // namespace
}  // namespace autonomsim::sim
