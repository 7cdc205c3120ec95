#include "sim/platform/dds_link.h"

#include <algorithm>
#include <stdexcept>
#include <utility>

#include "sim/core/priorities.h"

namespace autonomsim::sim {
namespace {

double Seconds(Duration d) { return ToSeconds(d); }

}  // namespace

// ---- DdsLinkParams ----

std::int64_t DdsLinkParams::FragmentsPerDatagram() const {
  return std::max<std::int64_t>(1, max_message_bytes / fragment_bytes);
}

std::int64_t DdsLinkParams::SocketCapacityBytes() const {
  return 2 * std::min(receive_buffer_bytes, host_rmem_max_bytes);
}

std::int64_t DdsLinkParams::DatagramsFor(std::int64_t sample_bytes) const {
  return std::max<std::int64_t>(
      1, CeilDiv(CeilDiv(sample_bytes, fragment_bytes), FragmentsPerDatagram()));
}

std::int64_t DdsLinkParams::DatagramBytes(std::int64_t sample_bytes, std::int64_t index) const {
  const std::int64_t per = FragmentsPerDatagram() * fragment_bytes;
  return std::max<std::int64_t>(0, std::min(per, sample_bytes - index * per));
}

double DdsLinkParams::WriteUpFrontCoreSeconds(std::int64_t sample_bytes) const {
  return Seconds(write.fixed) + static_cast<double>(std::max(0, write.copies - 1)) *
                                    static_cast<double>(sample_bytes) / memcpy_bytes_per_s;
}

double DdsLinkParams::SendCoreSeconds(std::int64_t datagram_bytes) const {
  const double fragments = static_cast<double>(CeilDiv(datagram_bytes, fragment_bytes));
  const double copy =
      write.copies > 0 ? static_cast<double>(datagram_bytes) / memcpy_bytes_per_s : 0.0;
  return Seconds(write.per_datagram) + fragments * Seconds(write.per_fragment) + copy;
}

double DdsLinkParams::SampleCoreSeconds(const DdsSideCost& side, std::int64_t sample_bytes) const {
  // DdsCost's sum, with the datagrams as Cyclone packs the fragments
  return DdsSideCoreSeconds(side, memcpy_bytes_per_s, sample_bytes, DatagramsFor(sample_bytes),
                            CeilDiv(sample_bytes, fragment_bytes));
}

DdsLinkParams DdsLinkParamsFor(const PlatformProfile& profile, const TopicTransportConfig& topic,
                               int depth) {
  const DdsProfile& dds = profile.dds;
  DdsLinkParams p;
  p.max_message_bytes = topic.max_message_bytes.value_or(dds.max_message_bytes);
  p.fragment_bytes = topic.fragment_bytes.value_or(dds.fragment_bytes);
  p.receive_buffer_bytes = topic.receive_buffer_bytes.value_or(dds.receive_buffer_bytes);
  p.host_rmem_max_bytes = dds.host_rmem_max_bytes;
  p.socket_overhead_bytes = dds.socket_overhead_bytes;
  p.heartbeat_interval = dds.heartbeat_interval;
  p.nack_delay = dds.nack_delay;
  p.whc_high_bytes = dds.whc_high_bytes;
  p.whc_low_bytes = dds.whc_low_bytes;
  p.max_queued_rexmit_bytes = dds.max_queued_rexmit_bytes;
  p.max_blocking = dds.max_blocking;
  p.reliability = topic.reliability.value_or(dds.reliability);
  p.depth = depth;
  p.keep_all = topic.history.value_or(dds.history) == History::kKeepAll;
  p.latency = dds.latency;
  p.write = dds.write;
  p.receive = dds.receive;
  p.memcpy_bytes_per_s = profile.cpu.memcpy_bytes_per_s;
  p.sched_slice = profile.cpu.sched_slice;
  return p;
}

// ---- DdsSocket ----

DdsSocket::DdsSocket(Kernel& kernel, Cpu& cpu, int owner, std::int64_t capacity_bytes,
                     Duration sched_slice)
    : kernel_(kernel),
      cpu_(cpu),
      owner_(owner),
      capacity_(capacity_bytes),
      sched_slice_(sched_slice) {
  if (capacity_bytes <= 0) throw std::invalid_argument("DdsSocket: capacity must be > 0");
}

DdsSocket::~DdsSocket() { kernel_.Cancel(turn_); }

bool DdsSocket::Arrive(const Datagram& d) {
  if (used_ + d.charge > capacity_) return false;
  used_ += d.charge;
  buffer_.push_back(d);
  if (!draining_) {
    draining_ = true;  // woken: it runs at once, and its first slice begins
    slice_start_ = kernel_.Now();
    TakeBatch();
  }
  return true;
}

bool DdsSocket::Contended() const {
  return sched_slice_ > Duration{0} && cpu_.demand() >= static_cast<double>(cpu_.cores());
}

// Between two batches: asleep when the buffer is empty; on a contended CPU, off the core for the
// others' turns once it has had a slice.
void DdsSocket::Drain() {
  if (buffer_.empty()) {
    draining_ = false;
    return;
  }
  const Time now = kernel_.Now();
  if (Contended() && now - slice_start_ >= sched_slice_) {
    // its turn comes back after the others' (demand + itself) / cores - 1 slices
    const double turns = (cpu_.demand() + 1.0) / static_cast<double>(cpu_.cores()) - 1.0;
    const Duration off = FromSeconds(ToSeconds(sched_slice_) * std::max(0.0, turns));
    turn_ = kernel_.ScheduleIn(
        off,
        [this] {
          slice_start_ = kernel_.Now();
          TakeBatch();
        },
        kPriorityPlatform);
    return;
  }
  TakeBatch();
}

// The receive thread: takes up to a batch of datagrams out of the buffer (recvmsg frees their
// room at once), spends their CPU, then hands each to its link.
void DdsSocket::TakeBatch() {
  if (buffer_.empty()) {
    draining_ = false;
    return;
  }
  batch_.clear();
  double work = 0.0;
  while (!buffer_.empty() &&
         static_cast<int>(batch_.size()) < buffer_.front().link->params().batch_datagrams) {
    const Datagram& d = buffer_.front();
    // a batch is one sample's datagrams, or one control datagram
    if (!batch_.empty() &&
        (d.link != batch_.front().link || d.reader != batch_.front().reader ||
         d.seq != batch_.front().seq || d.index < 0 || batch_.front().index < 0)) {
      break;
    }
    const DdsLinkParams& p = d.link->params();
    used_ -= d.charge;
    work += Seconds(p.receive.per_datagram);
    if (d.index >= 0) {
      const double fragments = static_cast<double>(CeilDiv(d.bytes, p.fragment_bytes));
      work += fragments * Seconds(p.receive.per_fragment) + static_cast<double>(p.receive.copies) *
                                                                static_cast<double>(d.bytes) /
                                                                p.memcpy_bytes_per_s;
      if (d.index == 0) work += Seconds(p.receive.fixed);
    }
    batch_.push_back(d);
    buffer_.pop_front();
  }
  // a whole sample in one batch: its cost as DdsCost prices it
  const Datagram& first = batch_.front();
  const DdsLinkParams& fp = first.link->params();
  if (first.index == 0 && batch_.back().index + 1 == static_cast<int>(batch_.size()) &&
      static_cast<std::int64_t>(batch_.size()) == fp.DatagramsFor(first.sample_bytes)) {
    work = fp.SampleCoreSeconds(fp.receive, first.sample_bytes);
  }
  cpu_.Start(owner_, work, 1.0, [this, start = kernel_.Now(), work] {
    const std::vector<Datagram> done = std::move(batch_);
    batch_.clear();
    if (batch_done_) batch_done_(start, work);
    for (const Datagram& d : done) {
      if (d.index >= 0) d.link->OnData(d);
      if (d.heartbeat) {
        d.link->OnHeartbeat(d.reader, d.first_seq, d.last_seq);
      } else if (d.index >= 0 && d.link->params().reliability == Reliability::kReliable) {
        d.link->OnHeartbeatFrag(d.reader, d.seq);
      }
    }
    Drain();
  });
}

// ---- DdsLink: the writer ----

DdsLink::DdsLink(Kernel& kernel, Cpu& cpu, DdsLinkParams params, int writer_owner,
                 DdsSocket& socket, Delivered delivered)
    : kernel_(kernel), cpu_(cpu), params_(std::move(params)), writer_owner_(writer_owner) {
  if (params_.fragment_bytes <= 0 || params_.max_message_bytes <= 0 || params_.depth < 1 ||
      params_.batch_datagrams < 1 || params_.heartbeat_interval <= Duration{0}) {
    throw std::invalid_argument(
        "DdsLink: fragment and message sizes, depth, batch and heartbeat "
        "interval must be > 0");
  }
  AddReader(socket, std::move(delivered));
}

DdsLink::~DdsLink() {
  kernel_.Cancel(heartbeat_);
  for (Reader& r : readers_) kernel_.Cancel(r.nack);
  for (PendingWrite& w : writes_) kernel_.Cancel(w.timeout);
}

void DdsLink::AddReader(DdsSocket& socket, Delivered delivered) {
  if (next_seq_ > 0) throw std::logic_error("DdsLink::AddReader: after the first write");
  readers_.push_back(Reader{.socket = &socket, .delivered = std::move(delivered)});
}

std::int64_t DdsLink::Write(std::int64_t bytes, Written written) {
  if (bytes < 0) throw std::invalid_argument("DdsLink::Write: bytes must be >= 0");
  const std::int64_t seq = next_seq_++;
  writes_.push_back(PendingWrite{.seq = seq, .bytes = bytes, .written = std::move(written)});
  if (!writing_) NextWrite();
  return seq;
}

// Starts the oldest write: at once, or blocked while the WHC is above its high-water mark (then
// until it drains to the low-water mark, or max_blocking).
void DdsLink::NextWrite() {
  if (writes_.empty()) {
    writing_ = false;
    return;
  }
  writing_ = true;
  PendingWrite& w = writes_.front();
  // Only a reliable KEEP_ALL writer is throttled: Cyclone sets a KEEP_LAST writer's marks to
  // INT32_MAX. The check comes before the sample joins the WHC, so one sample above the mark
  // is accepted and the next write waits for it.
  const bool throttled = params_.reliability == Reliability::kReliable && params_.keep_all;
  if (throttled && whc_bytes_ > params_.whc_high_bytes) {
    if (!w.blocked) {
      w.blocked = true;
      if (!params_.max_blocking) return;  // blocks until the WHC drains, however long
      w.timeout = kernel_.ScheduleIn(
          *params_.max_blocking,
          [this] {
            PendingWrite failed = std::move(writes_.front());
            writes_.pop_front();
            ++stats_.write_timeouts;
            if (failed.written) failed.written(false);
            NextWrite();
          },
          kPriorityPlatform);
    }
    return;  // OnAckNack resumes it
  }
  PendingWrite started = std::move(writes_.front());
  writes_.pop_front();
  kernel_.Cancel(started.timeout);
  SendSample(std::move(started));
}

void DdsLink::SendSample(PendingWrite w) {
  ++stats_.samples_written;
  if (params_.reliability == Reliability::kReliable) {
    whc_.push_back(WhcSample{w.seq, w.bytes});
    whc_bytes_ += w.bytes;
    sample_bytes_[w.seq] = w.bytes;
    // keep-last: the oldest sample leaves the history, acknowledged or not
    while (!params_.keep_all && static_cast<int>(whc_.size()) > params_.depth) {
      whc_bytes_ -= whc_.front().bytes;
      sample_bytes_.erase(whc_.front().seq);
      whc_.pop_front();
    }
  }
  if (params_.DatagramsFor(w.bytes) <= params_.batch_datagrams) {
    // one CPU job for the whole write: the sample's cost as DdsCost prices it
    SendBatches(w.seq, w.bytes, 0, std::move(w.written),
                params_.SampleCoreSeconds(params_.write, w.bytes));
    return;
  }
  cpu_.Start(writer_owner_, params_.WriteUpFrontCoreSeconds(w.bytes), 1.0,
             [this, seq = w.seq, bytes = w.bytes, written = std::move(w.written)]() mutable {
               SendBatches(seq, bytes, 0, std::move(written));
             });
}

// Sends the sample's datagrams from `from` on, a batch per CPU job; each batch reaches the
// reader's socket `latency` after its job ends. After the last, a reliable writer piggybacks a
// heartbeat, and the write call returns.
void DdsLink::SendBatches(std::int64_t seq, std::int64_t bytes, std::int64_t from, Written written,
                          std::optional<double> whole_write_core_s) {
  const std::int64_t total = params_.DatagramsFor(bytes);
  const std::int64_t to = std::min(total, from + params_.batch_datagrams);
  double work = 0.0;
  for (std::int64_t i = from; i < to; ++i) {
    work += params_.SendCoreSeconds(params_.DatagramBytes(bytes, i));
  }
  if (whole_write_core_s) work = *whole_write_core_s;
  cpu_.Start(writer_owner_, work, 1.0,
             [this, seq, bytes, from, to, total, written = std::move(written)]() mutable {
               const bool reliable = params_.reliability == Reliability::kReliable;
               if (to == total) last_sent_seq_ = seq;
               for (std::int64_t i = from; i < to; ++i) {
                 Transmit(seq, static_cast<int>(i), bytes, reliable && i + 1 == total);
               }
               stats_.datagrams_sent += to - from;
               if (to < total) {
                 SendBatches(seq, bytes, to, std::move(written));
                 return;
               }
               if (reliable) ScheduleHeartbeat();
               if (written) written(true);
               NextWrite();
             });
}

void DdsLink::Transmit(std::int64_t seq, int index, std::int64_t sample_bytes, bool heartbeat,
                       int reader) {
  const std::int64_t bytes = params_.DatagramBytes(sample_bytes, index);
  const DdsSocket::Datagram d{.link = this,
                              .seq = seq,
                              .index = index,
                              .bytes = bytes,
                              .charge = bytes + params_.socket_overhead_bytes,
                              .sample_bytes = sample_bytes,
                              .heartbeat = heartbeat,
                              .first_seq = WhcFirstSeq(),
                              .last_seq = last_sent_seq_};
  Send(d, reader);
}

// Over loopback a datagram reaches the reader's socket within the sendmsg call (the kernel
// queues it there in the sender's context); the kernel drops it when it does not fit.
void DdsLink::Send(DdsSocket::Datagram d, int reader) {
  for (int r = 0; r < static_cast<int>(readers_.size()); ++r) {
    if (reader >= 0 && r != reader) continue;
    d.reader = r;
    if (!readers_[static_cast<std::size_t>(r)].socket->Arrive(d)) ++stats_.datagrams_dropped;
  }
}

std::int64_t DdsLink::WhcFirstSeq() const {
  return whc_.empty() ? last_sent_seq_ + 1 : whc_.front().seq;
}

// A periodic heartbeat: a small datagram of its own through the same socket (it can be dropped
// there too), announcing what the WHC holds.
void DdsLink::SendHeartbeat() {
  if (whc_.empty() || last_sent_seq_ < whc_.front().seq) return;
  const DdsSocket::Datagram d{.link = this,
                              .seq = last_sent_seq_,
                              .index = -1,
                              .bytes = params_.control_bytes,
                              .charge = params_.control_bytes + params_.socket_overhead_bytes,
                              .heartbeat = true,
                              .first_seq = whc_.front().seq,
                              .last_seq = last_sent_seq_};
  ++stats_.datagrams_sent;
  Send(d, -1);
}

// Periodic heartbeats while the WHC holds unacknowledged samples: a write arms one for
// HeartbeatInterval later unless one is due earlier (Cyclone's writer_hbcontrol_note_asyncwrite
// never postpones it), and each re-arms the next.
void DdsLink::ScheduleHeartbeat() {
  if (heartbeat_.valid() || whc_.empty()) return;
  heartbeat_ = kernel_.ScheduleIn(
      params_.heartbeat_interval,
      [this] {
        heartbeat_ = EventId{};
        SendHeartbeat();
        ScheduleHeartbeat();
      },
      kPriorityPlatform);
}

// A reader's ACKNACK: every sample below `base` is acknowledged; `missing` lists what to send it
// again. A sample leaves the WHC when every reader acknowledged it.
void DdsLink::OnAckNack(int reader, std::int64_t base, const std::vector<Missing>& missing) {
  Reader& from = readers_[static_cast<std::size_t>(reader)];
  from.acked = std::max(from.acked, base);
  std::int64_t all_acked = from.acked;
  for (const Reader& r : readers_) all_acked = std::min(all_acked, r.acked);
  while (!whc_.empty() && whc_.front().seq < all_acked) {
    whc_bytes_ -= whc_.front().bytes;
    sample_bytes_.erase(whc_.front().seq);
    whc_.pop_front();
  }
  if (whc_.empty() && kernel_.Cancel(heartbeat_)) heartbeat_ = EventId{};
  if (!missing.empty()) Retransmit(reader, missing);
  if (writing_ && !writes_.empty() && writes_.front().blocked &&
      whc_bytes_ <= params_.whc_low_bytes) {
    NextWrite();
  }
}

// Sends again what a NACK lists and the WHC still holds, up to max_queued_rexmit_bytes, as one
// CPU job of the writer's side (Cyclone's event thread, not the writing thread).
void DdsLink::Retransmit(int reader, const std::vector<Missing>& missing) {
  std::vector<std::pair<std::int64_t, int>> again;  // (seq, datagram)
  std::int64_t queued = 0;
  double work = 0.0;
  const auto add = [&](std::int64_t seq, std::int64_t bytes, std::int64_t index) {
    const std::int64_t b = params_.DatagramBytes(bytes, index);
    if (queued > 0 && queued + b > params_.max_queued_rexmit_bytes) return false;
    queued += b;
    work += params_.SendCoreSeconds(b);
    again.emplace_back(seq, static_cast<int>(index));
    return true;
  };
  for (const Missing& m : missing) {
    const auto it = sample_bytes_.find(m.seq);
    if (it == sample_bytes_.end()) continue;  // gone from the WHC: the heartbeat says so
    if (m.index >= 0) {
      if (!add(m.seq, it->second, m.index)) break;
      continue;
    }
    bool room = true;
    for (std::int64_t i = 0; room && i < params_.DatagramsFor(it->second); ++i) {
      room = add(m.seq, it->second, i);
    }
    if (!room) break;
  }
  if (again.empty()) return;
  cpu_.Start(writer_owner_, work, 1.0, [this, reader, again = std::move(again)] {
    for (std::size_t i = 0; i < again.size(); ++i) {
      const auto it = sample_bytes_.find(again[i].first);
      if (it == sample_bytes_.end()) continue;
      // the last datagram of the retransmission carries a HEARTBEAT
      Transmit(again[i].first, again[i].second, it->second, i + 1 == again.size(), reader);
      ++stats_.datagrams_retransmitted;
    }
  });
}

// ---- DdsLink: the reader ----

void DdsLink::OnData(const DdsSocket::Datagram& d) {
  Reader& r = readers_[static_cast<std::size_t>(d.reader)];
  if (d.seq < r.next_deliver) return;  // delivered or given up already
  RxSample& rx = r.rx[d.seq];
  if (rx.got.empty()) {
    rx.datagrams = params_.DatagramsFor(d.sample_bytes);
    rx.got.assign(static_cast<std::size_t>(rx.datagrams), false);
    rx.missing = rx.datagrams;
    // a best-effort reader's defragmenter holds a few samples; the oldest gives way
    while (params_.reliability == Reliability::kBestEffort &&
           static_cast<std::int64_t>(r.rx.size()) > params_.defrag_unreliable_max_samples) {
      GiveUpBefore(r, r.rx.begin()->first + 1);
    }
  }
  if (d.seq < r.next_deliver) return;
  rx.highest_index = std::max(rx.highest_index, d.index);
  const auto index = static_cast<std::size_t>(d.index);
  if (index >= rx.got.size() || rx.got[index]) return;
  rx.got[index] = true;
  --rx.missing;
  if (rx.missing > 0) return;
  if (params_.reliability == Reliability::kBestEffort) GiveUpBefore(r, d.seq);  // this one goes now
  DeliverInOrder(r);
}

void DdsLink::GiveUpBefore(Reader& r, std::int64_t seq) {
  if (seq <= r.next_deliver) return;
  r.rx.erase(r.rx.begin(), r.rx.lower_bound(seq));
  stats_.samples_lost += seq - r.next_deliver;
  r.next_deliver = seq;
}

void DdsLink::DeliverInOrder(Reader& r) {
  for (auto it = r.rx.find(r.next_deliver); it != r.rx.end() && it->second.missing == 0;
       it = r.rx.find(r.next_deliver)) {
    r.rx.erase(it);
    ++stats_.samples_delivered;
    // the subscriber's executor wakes up `latency` after the receive thread delivered the sample
    if (r.delivered) {
      kernel_.ScheduleIn(
          params_.latency,
          [this, reader = &r - readers_.data(), seq = r.next_deliver] {
            readers_[static_cast<std::size_t>(reader)].delivered(seq);
          },
          kPriorityPlatform);
    }
    ++r.next_deliver;
  }
}

// A HEARTBEAT (Cyclone's handle_Heartbeat and sched_acknack_if_needed): samples older than
// `first_seq` are gone from the writer, lost if the reader does not have them. With everything up
// to `last_seq` here, an ACK goes back. Otherwise a NACK: at once if it asks for something not
// asked for before, else NackDelay after the last NACK.
void DdsLink::OnHeartbeat(int reader, std::int64_t first_seq, std::int64_t last_seq) {
  Reader& r = readers_[static_cast<std::size_t>(reader)];
  r.rx.erase(r.rx.begin(), r.rx.lower_bound(first_seq));
  if (r.next_deliver < first_seq) {
    stats_.samples_lost += first_seq - r.next_deliver;
    r.next_deliver = first_seq;
    DeliverInOrder(r);
  }
  r.heard_last_seq = std::max(r.heard_last_seq, last_seq);
  const std::vector<Missing> missing = MissingNow(r);
  if (missing.empty()) {
    kernel_.ScheduleIn(
        params_.latency, [this, reader, base = r.next_deliver] { OnAckNack(reader, base, {}); },
        kPriorityPlatform);
    return;
  }
  const bool news = std::any_of(missing.begin(), missing.end(), [&r](const Missing& m) {
    return !r.nacked.contains({m.seq, m.index});
  });
  ScheduleNack(reader, news ? kernel_.Now() : r.last_nack + params_.nack_delay);
}

// A HEARTBEAT_FRAG (handle_HeartbeatFrag): a gap in the sample being sent is NACKed NackDelay
// later ("don't rush it"), unless a NACK is due before.
void DdsLink::OnHeartbeatFrag(int reader, std::int64_t seq) {
  const Reader& r = readers_[static_cast<std::size_t>(reader)];
  const auto it = r.rx.find(seq);
  if (it == r.rx.end()) return;
  const RxSample& rx = it->second;
  for (int i = 0; i < rx.highest_index; ++i) {
    if (!rx.got[static_cast<std::size_t>(i)]) {
      ScheduleNack(reader, kernel_.Now() + params_.nack_delay);
      return;
    }
  }
}

// A NACK at `at` (not before now), or earlier if one is due earlier already.
void DdsLink::ScheduleNack(int reader, Time at) {
  Reader& r = readers_[static_cast<std::size_t>(reader)];
  at = std::max(at, kernel_.Now());
  if (r.nack.valid()) {
    if (r.nack_at <= at) return;
    kernel_.Cancel(r.nack);
  }
  r.nack_at = at;
  r.nack = kernel_.ScheduleAt(
      at, [this, reader] { SendNack(reader); }, kPriorityPlatform);
}

void DdsLink::SendNack(int reader) {
  Reader& r = readers_[static_cast<std::size_t>(reader)];
  r.nack = EventId{};
  std::vector<Missing> missing = NackList(MissingNow(r));
  if (missing.empty()) return;
  for (const Missing& m : missing) r.nacked.insert({m.seq, m.index});
  r.last_nack = kernel_.Now();
  ++stats_.nacks;
  kernel_.ScheduleIn(
      params_.latency,
      [this, reader, base = r.next_deliver, missing = std::move(missing)] {
        OnAckNack(reader, base, missing);
      },
      kPriorityPlatform);
}

// What one ACKNACK asks for (Cyclone's add_AckNack_makebitmaps): every sample missing whole (its
// bitmap), and the missing fragments of the first sample it has part of, at most one NACKFRAG's
// worth. What it leaves out is asked for by the next one.
std::vector<DdsLink::Missing> DdsLink::NackList(const std::vector<Missing>& missing) const {
  std::vector<Missing> list;
  const std::int64_t frag_datagrams =
      std::max<std::int64_t>(1, params_.nackfrag_max_fragments / params_.FragmentsPerDatagram());
  std::optional<std::int64_t> partial;  // the first sample with missing datagrams
  std::int64_t listed = 0;
  for (const Missing& m : missing) {
    if (m.index < 0) {
      list.push_back(m);
      continue;
    }
    if (!partial) partial = m.seq;
    if (m.seq == *partial && listed < frag_datagrams) {
      list.push_back(m);
      ++listed;
    }
  }
  return list;
}

// What the reader knows it lacks: whole samples a heartbeat announced that it has nothing of, and
// the datagrams of the samples it has part of, up to the last one announced.
std::vector<DdsLink::Missing> DdsLink::MissingNow(const Reader& r) const {
  std::vector<Missing> missing;
  const std::int64_t last = std::max(r.heard_last_seq, r.rx.empty() ? -1 : r.rx.rbegin()->first);
  for (std::int64_t seq = r.next_deliver; seq <= last; ++seq) {
    const auto it = r.rx.find(seq);
    if (it == r.rx.end()) {
      if (seq <= r.heard_last_seq) missing.push_back({seq, -1});
      continue;
    }
    const RxSample& rx = it->second;
    const std::size_t known =
        seq <= r.heard_last_seq ? rx.got.size() : static_cast<std::size_t>(rx.highest_index);
    for (std::size_t i = 0; i < known; ++i) {
      if (!rx.got[i]) missing.push_back({seq, static_cast<int>(i)});
    }
  }
  return missing;
}

}  // namespace autonomsim::sim
