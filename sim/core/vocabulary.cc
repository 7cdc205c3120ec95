#include "sim/core/vocabulary.h"

#include <stdexcept>

namespace autonomsim::sim {

using RecordKind = world::ServerRecord::Kind;

EventKind EventKindOf(RecordKind kind) {
  switch (kind) {
    case RecordKind::kRequest:
      return EventKind::kRequest;
    case RecordKind::kFree:
      return EventKind::kFree;
    case RecordKind::kGrant:
      return EventKind::kGrant;
    case RecordKind::kDenied:
      return EventKind::kDenied;
    case RecordKind::kLeaseExpired:
      return EventKind::kLeaseExpired;
    case RecordKind::kQueueDrop:
      return EventKind::kQueueDrop;
  }
  throw std::logic_error("EventKindOf: a server record kind without its event");
}

}  // namespace autonomsim::sim
