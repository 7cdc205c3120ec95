// A large sample over DDS on one host, the way Cyclone DDS carries it (reference §10): the writer
// cuts the sample into fragments, packs them into datagrams and sends them at the pace its CPU
// allows; they land in the reader's UDP socket receive buffer, which the reader's receive thread
// drains at the pace its CPU allows; a datagram that finds the buffer full is dropped by the
// kernel. A reliable writer keeps the sample in its history cache (WHC) until the reader
// acknowledges it, announces what it has with heartbeats, and sends again what the reader's NACKs
// list; a write that finds the WHC above its high-water mark blocks until it drains to the
// low-water mark, or fails after the QoS's max blocking time. A best-effort sample with a dropped
// datagram is lost.
//
// The CPU work (sending, receiving) runs as jobs on the platform's Cpu, so the race between the
// writer and the receive thread is decided by the cores and the rest of their load. Everything
// happens on the kernel; nothing is random.
//
// What is modelled and what is not, with the sources of the rules, is docs/model.md#dds-transport.
#pragma once

#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <optional>
#include <set>
#include <utility>
#include <vector>

#include "sim/core/kernel.h"
#include "sim/platform/dds_stats.h"
#include "sim/platform/platform.h"
#include "sim/platform/platform_profile.h"

namespace autonomsim::sim {

// The numbers of one link: Cyclone DDS's settings, the host's socket accounting and the CPU costs
// (DdsLinkParamsFor builds them from a profile and a topic's QoS).
struct DdsLinkParams {
  std::int64_t max_message_bytes{14720};       // one datagram's payload at most (MaxMessageSize)
  std::int64_t fragment_bytes{1344};           // FragmentSize
  std::int64_t receive_buffer_bytes{1048576};  // SO_RCVBUF requested (SocketReceiveBufferSize)
  std::int64_t host_rmem_max_bytes{212992};    // the kernel's cap on it (net.core.rmem_max)
  std::int64_t socket_overhead_bytes{0};       // kernel bookkeeping charged per datagram (truesize)
  Duration heartbeat_interval{std::chrono::milliseconds(100)};  // HeartbeatInterval
  Duration nack_delay{std::chrono::milliseconds(100)};          // NackDelay
  std::int64_t whc_high_bytes{500000};                          // WhcHigh
  std::int64_t whc_low_bytes{1000};                             // WhcLow
  std::int64_t max_queued_rexmit_bytes{512000};                 // MaxQueuedRexmitBytes
  // fragments one NACKFRAG can list (Cyclone's NN_FRAGMENT_NUMBER_SET_MAX_BITS)
  std::int64_t nackfrag_max_fragments{256};
  // incomplete samples a best-effort reader keeps (Internal/DefragUnreliableMaxSamples)
  std::int64_t defrag_unreliable_max_samples{4};
  // reliability QoS max_blocking_time; none: infinite (rmw_cyclonedds' reliable publishers)
  std::optional<Duration> max_blocking;
  Reliability reliability{Reliability::kReliable};
  int depth{3};          // keep-last history of the writer
  bool keep_all{false};  // KEEP_ALL history: no depth, and the WHC marks throttle the writer
  Duration latency{0};   // loopback: a datagram or an ACKNACK from send to the socket
  std::int64_t control_bytes{64};  // a periodic heartbeat's datagram
  // Model resolution, not a Cyclone setting: datagrams sent or drained per CPU job.
  int batch_datagrams{8};
  DdsSideCost write;    // the writing thread: fixed and copies per sample, the rest per datagram
  DdsSideCost receive;  // the receive thread, per datagram (fixed: once per sample)
  double memcpy_bytes_per_s{1e9};
  Duration sched_slice{0};  // the receive thread's time slice on a busy CPU (CpuProfile)

  // Fragments one datagram carries, and the bytes the socket buffer holds: the kernel doubles
  // SO_RCVBUF for its bookkeeping (man 7 socket), which socket_overhead_bytes then charges.
  std::int64_t FragmentsPerDatagram() const;
  std::int64_t SocketCapacityBytes() const;
  std::int64_t DatagramsFor(std::int64_t sample_bytes) const;
  // The payload of a sample's datagram `index` (the last one carries the rest).
  std::int64_t DatagramBytes(std::int64_t sample_bytes, std::int64_t index) const;
  // The writer's CPU for a sample of several batches: serialization and the write path's fixed
  // cost before the first datagram; then one sendmsg each (the datagram's own cost, its
  // fragments' and the copy into the kernel, the write side's last copy).
  double WriteUpFrontCoreSeconds(std::int64_t sample_bytes) const;
  double SendCoreSeconds(std::int64_t datagram_bytes) const;
  // One side's CPU for a whole sample in one job (a sample that fits one batch, written or
  // received whole): the same sum as DdsCost's, so that a small sample costs what it always did.
  double SampleCoreSeconds(const DdsSideCost& side, std::int64_t sample_bytes) const;
};

// A profile's dds section with a topic's own settings (TopicTransportConfig: each unset one is the
// profile's) and its keep-last history depth.
DdsLinkParams DdsLinkParamsFor(const PlatformProfile& profile, const TopicTransportConfig& topic,
                               int depth);

class DdsLink;

// The reader's host side: one UDP socket's receive buffer and the receive thread that drains it
// (Cyclone: one per participant). Several links may land on one socket.
class DdsSocket {
 public:
  // `owner`: whose CPU the receive thread's work counts as (a metrics node index, or -1).
  // `sched_slice` (CpuProfile::sched_slice): while the other jobs want every core, the receive
  // thread runs in time slices: woken (it slept: the scheduler's credit) it runs at once, and
  // having run a slice it waits slice x ((demand + 1) / cores - 1) while the others run theirs
  // (its fair share, in turns).
  DdsSocket(Kernel& kernel, Cpu& cpu, int owner, std::int64_t capacity_bytes,
            Duration sched_slice = Duration{0});
  DdsSocket(const DdsSocket&) = delete;
  DdsSocket& operator=(const DdsSocket&) = delete;
  ~DdsSocket();

  std::int64_t used_bytes() const { return used_; }
  std::int64_t capacity_bytes() const { return capacity_; }
  // `done(start, core_s)` runs each time the receive thread has processed a batch: when the
  // batch began and the CPU it took (its owner's metrics).
  void OnBatchDone(std::function<void(Time, double)> done) { batch_done_ = std::move(done); }

 private:
  friend class DdsLink;
  struct Datagram {
    DdsLink* link;
    int reader{0};  // which of the link's readers it goes to
    std::int64_t seq;
    int index;  // the datagram's place in its sample; -1 for a periodic heartbeat
    std::int64_t bytes;
    std::int64_t charge;           // bytes + the link's socket overhead
    std::int64_t sample_bytes{0};  // data: its sample's size (DATA_FRAG carries it)
    // A HEARTBEAT rides in it (a periodic one, or piggybacked on the last datagram a
    // transmission sends): the WHC holds [first_seq, last_seq]. Other data datagrams of a
    // reliable writer carry a HEARTBEAT_FRAG.
    bool heartbeat{false};
    std::int64_t first_seq{0};
    std::int64_t last_seq{0};
  };
  // Whether it fits (and is queued); false when the kernel drops it.
  bool Arrive(const Datagram& d);
  void Drain();
  void TakeBatch();
  bool Contended() const;  // the other jobs want every core

  Kernel& kernel_;
  Cpu& cpu_;
  int owner_;
  std::int64_t capacity_;
  Duration sched_slice_;
  std::int64_t used_{0};
  Time slice_start_{0};  // when the thread's current turn on a core began
  std::deque<Datagram> buffer_;
  bool draining_{false};         // the receive thread is awake (running, or waiting for a core)
  EventId turn_;                 // the receive thread's next turn on a core, while it waits for one
  std::vector<Datagram> batch_;  // being processed by the receive thread
  std::function<void(Time, double)> batch_done_;
};

class DdsLink {
 public:
  using Written = std::function<void(bool accepted)>;
  using Delivered = std::function<void(std::int64_t seq)>;

  // A writer whose CPU work counts as `writer_owner`'s, and its first reader on `socket`:
  // `delivered` runs with each sample's sequence number when the reader has it whole, in order,
  // `latency` after its receive thread had it (the subscriber's executor waking up).
  DdsLink(Kernel& kernel, Cpu& cpu, DdsLinkParams params, int writer_owner, DdsSocket& socket,
          Delivered delivered);
  // Another reader of the same writer (before the first write). A sample's datagrams are sent
  // once and reach every reader's socket (as a multicast send, or several unicast sends paid
  // once: the lab's Cyclone network configuration is unknown, docs/model.md#dds-transport); each
  // reader repairs on its own, and the WHC keeps a sample until every reader acknowledged it.
  void AddReader(DdsSocket& socket, Delivered delivered);
  DdsLink(const DdsLink&) = delete;
  DdsLink& operator=(const DdsLink&) = delete;
  ~DdsLink();

  // One write call of a `bytes` sample; returns its sequence number (0, 1, ...). `written`
  // runs when the call returns: true once its datagrams are sent, false when it blocked for
  // max_blocking (the sample is not sent). Writes run one after another, as on one thread.
  std::int64_t Write(std::int64_t bytes, Written written);

  const DdsLinkStats& stats() const { return stats_; }
  std::int64_t next_seq() const { return next_seq_; }  // what the next Write returns
  const DdsLinkParams& params() const { return params_; }
  std::int64_t whc_bytes() const { return whc_bytes_; }

 private:
  friend class DdsSocket;
  struct PendingWrite {
    std::int64_t seq;
    std::int64_t bytes;
    Written written;
    EventId timeout;
    bool blocked{false};
  };
  struct WhcSample {
    std::int64_t seq;
    std::int64_t bytes;
  };
  struct RxSample {
    std::int64_t datagrams{0};
    std::vector<bool> got;
    std::int64_t missing{0};
    int highest_index{-1};  // the last datagram announced so far (HEARTBEAT_FRAG)
  };
  struct Missing {
    std::int64_t seq;
    int index;  // -1: the whole sample (the reader has none of it)
  };

  // writer
  void NextWrite();
  void SendSample(PendingWrite w);
  // `whole_write_core_s`: a sample sent in one batch costs this, the write's whole CPU
  void SendBatches(std::int64_t seq, std::int64_t bytes, std::int64_t from, Written written,
                   std::optional<double> whole_write_core_s = std::nullopt);
  // One reader's side: its socket, what it has of each sample, and its repair state.
  struct Reader {
    DdsSocket* socket;
    Delivered delivered;
    std::map<std::int64_t, RxSample> rx;
    std::int64_t next_deliver{0};
    std::int64_t heard_last_seq{-1};                // the newest sample a heartbeat announced
    std::set<std::pair<std::int64_t, int>> nacked;  // (seq, datagram) asked for before
    Time last_nack{0};
    EventId nack;
    Time nack_at{0};        // when nack fires
    std::int64_t acked{0};  // every sample below it acknowledged
  };

  // writer; `reader` -1: to every reader
  void Transmit(std::int64_t seq, int index, std::int64_t sample_bytes, bool heartbeat,
                int reader = -1);
  void SendHeartbeat();
  void Send(DdsSocket::Datagram d, int reader);
  std::int64_t WhcFirstSeq() const;
  void ScheduleHeartbeat();
  void OnAckNack(int reader, std::int64_t base, const std::vector<Missing>& missing);
  void Retransmit(int reader, const std::vector<Missing>& missing);
  // reader
  void OnData(const DdsSocket::Datagram& d);
  void OnHeartbeat(int reader, std::int64_t first_seq, std::int64_t last_seq);
  void OnHeartbeatFrag(int reader, std::int64_t seq);
  void DeliverInOrder(Reader& r);
  // best effort: what is older and not delivered is lost
  void GiveUpBefore(Reader& r, std::int64_t seq);
  void SendNack(int reader);
  void ScheduleNack(int reader, Time at);
  std::vector<Missing> MissingNow(const Reader& r) const;
  std::vector<Missing> NackList(const std::vector<Missing>& missing) const;

  Kernel& kernel_;
  Cpu& cpu_;
  DdsLinkParams params_;
  int writer_owner_;
  DdsLinkStats stats_;
  // writer
  std::int64_t next_seq_{0};
  std::deque<PendingWrite> writes_;  // the front one is running or blocked
  bool writing_{false};
  std::deque<WhcSample> whc_;
  std::int64_t whc_bytes_{0};
  std::int64_t last_sent_seq_{-1};  // the newest sample whose datagrams are all sent
  std::map<std::int64_t, std::int64_t> sample_bytes_;  // of the samples the WHC holds
  EventId heartbeat_;
  std::vector<Reader> readers_;
};

}  // namespace autonomsim::sim
