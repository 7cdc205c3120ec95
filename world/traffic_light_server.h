// The traffic-light server's logic (reference §7: vtl.py), as a pure object: messages and the
// current time go in, the /vtl/response broadcasts to send come out, in order. No clock, no I/O;
// the `tlserver` process and the simulator's embedded V2I link both drive this one class.
//
// Policy "fifo" (ours), per intersection:
//   - mutual exclusion: at most one holder;
//   - a request from the holder renews it and is answered "<car>1" again;
//   - a request when the intersection is free (hence nobody queued) is granted;
//   - otherwise the car joins the queue once (a repeated request keeps its place) and is answered
//     "<car>0"; when the holder frees or its lease expires, the queue head is granted by a later
//     broadcast "<car>1";
//   - liveness is per car and intersection: only a request for an intersection renews the car's
//     grant of it (or its place in its queue). A car silent about an intersection from its last
//     request for it + lease on (inclusive) loses it (lease_expiries) or leaves its queue; the next
//     live car in the queue is granted. A car that keeps talking about another intersection (it
//     moved on, or it holds one and waits for another) therefore never keeps a stale grant: within
//     one lease of its last request for an intersection, that intersection is served again;
//   - Free("<car>") releases every intersection that car holds and withdraws it from every queue
//     (the protocol's free names no intersection; it never touches another car's grant);
//   - a request for an unknown intersection is counted and answered "<car>0".
// Policy "original" (the lab's vtl.py, code/vtl_ws/vtl.py at lab commit 02c5ab4): grant if the
// slot is empty or held by the same car, deny otherwise (vtl.py:28-36); no queue, no lease. A
// denied car is never granted unless it asks again. Free releases only the first slot the car
// holds, the lowest intersection id (vtl.py:15-22: `if` slot 0 `elif` slot 1), so a car holding
// two intersections keeps the other until it frees again. vtl.py raises, and exits, on a request
// for an intersection it has no slot for (IndexError, vtl.py:28); here such a request is counted
// and denied under both policies: the embedded link never sends one (cars ask only for their
// track's intersections, which the server serves), and tlserver stops before it gets here
// (world/vtl_py.h).
//
// Expiries are applied lazily too: every On*(now) first applies what expired at `now`, so the
// outcome depends only on the timestamps of the calls, not on whether OnTick ran in between.
// `now` must not decrease from one call to the next (std::invalid_argument otherwise).
// Output order is deterministic: responses to expiries and frees come in ascending intersection
// id, then the answer to the request itself.
#pragma once

#include <array>
#include <cstdint>
#include <deque>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "world/enum_names.h"
#include "world/time.h"
#include "world/v2i_protocol.h"

namespace autonomsim::world {

// "fifo": ours (above); "original": the lab's vtl.py behaviour (reference §7).
enum class ServerPolicy { kFifo, kOriginal };

}  // namespace autonomsim::world

namespace autonomsim {
template <>
struct NameTable<world::ServerPolicy> {
  static constexpr std::array<std::pair<world::ServerPolicy, std::string_view>, 2> kEntries{
      {{world::ServerPolicy::kFifo, "fifo"}, {world::ServerPolicy::kOriginal, "original"}}};
};
}  // namespace autonomsim

namespace autonomsim::world {

struct TrafficLightServerParams {
  ServerPolicy policy{ServerPolicy::kFifo};
  // Assumed: the reference has no timeout at all (§7). A holder silent this long loses its grant;
  // it must exceed the cars' keepalive and retry periods (stack/intersection_client.h, 1 s) with
  // room for a few lost messages.
  Duration lease{std::chrono::seconds(5)};

  template <class V>
  void Describe(V& v) {
    v("policy", policy,
      "the server: `fifo`, ours (a queue per intersection, leases), or `original`, the lab's "
      "vtl.py (first come, no queue, no lease)");
    v("lease_s", lease,
      "`fifo` only: a holder silent this long loses its grant (longer than the cars' retry and "
      "keepalive periods)");
  }
  void Validate() const;
};

// What the server did, one entry per counted action, in order: the run's `request`, `free`,
// `grant`, `denied`, `lease_expired` and `queue_drop` events (sim/scenario/run_record.h), so the
// events add up to the counters. A renewal (a holder's request answered "<car>1" again) is a
// request, not a grant. A free names the intersection it released (-1: none; the lowest when it
// released several, the others in `also_released`).
struct ServerRecord {
  enum class Kind { kRequest, kFree, kGrant, kDenied, kLeaseExpired, kQueueDrop };
  Kind kind{Kind::kRequest};
  int car{-1};
  int intersection{-1};
  std::vector<int> also_released;  // kFree only
  friend bool operator==(const ServerRecord&, const ServerRecord&) = default;
};

class TrafficLightServer {
 public:
  struct Counters {
    std::uint64_t requests{0};        // request messages received (known and unknown intersections)
    std::uint64_t grants{0};          // a car became holder (renewal answers are not counted)
    std::uint64_t denials{0};         // "<car>0" responses sent
    std::uint64_t frees{0};           // free messages received (whether or not they released any)
    std::uint64_t lease_expiries{0};  // holders that lost an intersection by lease expiry
    std::uint64_t unknown_intersection{0};  // requests naming an intersection we do not serve
    std::uint64_t queue_drops{0};           // queued cars dropped for silence
  };

  // Throws std::invalid_argument for invalid params, an empty id list, an id outside 0..9 or a
  // repeated id.
  TrafficLightServer(TrafficLightServerParams params, std::vector<int> intersection_ids);

  // Car and intersection ids outside 0..9 throw std::invalid_argument (decoded messages cannot
  // carry them).
  std::vector<Response> OnRequest(Time now, const Request& request);
  std::vector<Response> OnFree(Time now, const Free& free);
  // Lease expiries due at `now`, and the grants that follow them.
  std::vector<Response> OnTick(Time now);
  // The server's connection to its clients (the broker) went down at `now`, or came back. While
  // it is down no lease runs out (nobody can renew, so silence says nothing about a car inside
  // an intersection); on reconnecting every holder and queued car has a full lease from `now`,
  // time to renew over the link that is back. Expiries due before the disconnect still apply
  // (their grants are in the returned responses, which a down link loses: the granted car learns
  // of it when it asks again). Policy "original" has no lease: nothing changes. Repeating the
  // current state (down when down) changes nothing.
  std::vector<Response> OnDisconnected(Time now);
  void OnReconnected(Time now);
  bool connected() const { return connected_; }

  // The earliest time at which the state changes by itself (a holder's lease expires or a queued
  // car is dropped), so a simulator can schedule OnTick exactly; nullopt when nothing is pending
  // (always for "original"; while disconnected).
  std::optional<Time> NextDeadline() const;

  // Unknown intersections: nullopt / empty.
  std::optional<int> Holder(int intersection) const;
  std::vector<int> Queue(int intersection) const;
  Counters counters() const { return counters_; }
  // The records since the last call, oldest first (see ServerRecord).
  std::vector<ServerRecord> TakeRecords();
  const TrafficLightServerParams& params() const { return params_; }

 private:
  struct Slot {
    int id{-1};  // the intersection's
    std::optional<int> holder;
    std::deque<int> queue;  // waiting cars, head first; never holds the holder or a duplicate
    // per car (holder and queued): its last request for this intersection
    std::map<int, Time> last_request;
  };

  void AdvanceTo(Time now);
  bool IsDead(const Slot& slot, int car, Time now) const;
  void Expire(Time now, std::vector<Response>* out);
  void GrantHeadIfFree(Slot* slot, std::vector<Response>* out);

  TrafficLightServerParams params_;
  bool fifo_{true};
  std::map<int, Slot> slots_;  // ordered by id: iteration order is output order
  std::optional<Time> last_now_;
  bool connected_{true};
  Counters counters_;
  std::vector<ServerRecord> records_;
};

}  // namespace autonomsim::world
