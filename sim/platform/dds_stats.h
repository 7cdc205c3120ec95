// What a DDS link counted over a run (sim/platform/dds_link.h), on its own so that the metrics'
// reports carry it without the link's machinery.
#pragma once

#include <cstdint>

namespace autonomsim::sim {

struct DdsLinkStats {
  std::int64_t samples_written{0};    // accepted by a write
  std::int64_t write_timeouts{0};     // writes that blocked for max_blocking and failed
  std::int64_t samples_delivered{0};  // complete, handed to the reader in order
  std::int64_t samples_lost{0};       // never delivered: best effort, or gone from the WHC
  std::int64_t datagrams_sent{0};     // first transmissions (data, and periodic heartbeats)
  std::int64_t datagrams_retransmitted{0};
  std::int64_t datagrams_dropped{0};  // found the socket buffer full
  std::int64_t nacks{0};              // repair rounds: NACKs the reader sent
};

inline DdsLinkStats& operator+=(DdsLinkStats& a, const DdsLinkStats& b) {
  a.samples_written += b.samples_written;
  a.write_timeouts += b.write_timeouts;
  a.samples_delivered += b.samples_delivered;
  a.samples_lost += b.samples_lost;
  a.datagrams_sent += b.datagrams_sent;
  a.datagrams_retransmitted += b.datagrams_retransmitted;
  a.datagrams_dropped += b.datagrams_dropped;
  a.nacks += b.nacks;
  return a;
}

}  // namespace autonomsim::sim
