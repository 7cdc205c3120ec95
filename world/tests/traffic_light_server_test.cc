#include "world/traffic_light_server.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <stdexcept>
#include <string>
#include <vector>

namespace autonomsim::world {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::IsEmpty;
using Responses = std::vector<Response>;

constexpr int kI0 = 0;
constexpr int kI1 = 1;

Time At(double s) { return FromSeconds(s); }

TrafficLightServer MakeServer(const std::string& policy = "fifo", double lease_s = 5.0) {
  TrafficLightServerParams params;
  params.policy = FromName<ServerPolicy>(policy).value();
  params.lease = FromSeconds(lease_s);
  return TrafficLightServer(params, {kI0, kI1});
}

Response Granted(int car) { return Response{car, true}; }
Response Denied(int car) { return Response{car, false}; }

TEST(TrafficLightServerParamsTest, DefaultsAndKeys) {
  TrafficLightServerParams params;
  EXPECT_EQ(params.policy, ServerPolicy::kFifo);
  EXPECT_EQ(params.lease, std::chrono::seconds(5));
  EXPECT_NO_THROW(params.Validate());
  std::vector<std::string> keys;
  auto visit = [&](const std::string& key, auto&, auto&&...) { keys.push_back(key); };
  params.Describe(visit);
  EXPECT_THAT(keys, ElementsAre("policy", "lease_s"));
}

TEST(TrafficLightServerParamsTest, ValidateNamesTheKeyAndTheValue) {
  // a policy is one of two names (the config reader refuses any other, listing them)
  EXPECT_EQ(FromName<ServerPolicy>("original"), ServerPolicy::kOriginal);
  EXPECT_EQ(FromName<ServerPolicy>("lifo"), std::nullopt);
  EXPECT_EQ(NameList<ServerPolicy>(), "'fifo' or 'original'");
  TrafficLightServerParams params;
  params.lease = Duration::zero();
  try {
    params.Validate();
    FAIL() << "accepted a zero lease";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("lease_s"));
    EXPECT_THAT(e.what(), HasSubstr("got 0 s"));
  }
}

TEST(TrafficLightServerTest, ConstructorRejectsBadIntersectionIds) {
  EXPECT_THROW(TrafficLightServer({}, {}), std::invalid_argument);
  EXPECT_THROW(TrafficLightServer({}, {0, 10}), std::invalid_argument);
  EXPECT_THROW(TrafficLightServer({}, {-1}), std::invalid_argument);
  EXPECT_THROW(TrafficLightServer({}, {1, 1}), std::invalid_argument);
}

TEST(TrafficLightServerTest, GrantsAFreeIntersection) {
  auto server = MakeServer();
  EXPECT_THAT(server.OnRequest(At(0.0), {0, kI0}), ElementsAre(Granted(0)));
  EXPECT_EQ(server.Holder(kI0), 0);
  EXPECT_EQ(server.Holder(kI1), std::nullopt);
  EXPECT_EQ(server.counters().requests, 1u);
  EXPECT_EQ(server.counters().grants, 1u);
  EXPECT_EQ(server.counters().denials, 0u);
}

TEST(TrafficLightServerTest, HolderRequestRenewsAndIsGrantedAgain) {
  auto server = MakeServer();
  server.OnRequest(At(0.0), {0, kI0});
  EXPECT_THAT(server.OnRequest(At(1.0), {0, kI0}), ElementsAre(Granted(0)));
  EXPECT_EQ(server.Holder(kI0), 0);
  EXPECT_THAT(server.Queue(kI0), IsEmpty());
  EXPECT_EQ(server.counters().requests, 2u);
  EXPECT_EQ(server.counters().grants, 1u);  // a renewal is not a new grant
  EXPECT_EQ(server.NextDeadline(), At(6.0));
}

TEST(TrafficLightServerTest, SecondCarIsDeniedThenGrantedWhenTheHolderFrees) {
  auto server = MakeServer();
  server.OnRequest(At(0.0), {0, kI0});
  EXPECT_THAT(server.OnRequest(At(0.5), {1, kI0}), ElementsAre(Denied(1)));
  EXPECT_THAT(server.Queue(kI0), ElementsAre(1));
  EXPECT_THAT(server.OnFree(At(2.0), {0}), ElementsAre(Granted(1)));
  EXPECT_EQ(server.Holder(kI0), 1);
  EXPECT_THAT(server.Queue(kI0), IsEmpty());
  EXPECT_EQ(server.counters().grants, 2u);
  EXPECT_EQ(server.counters().denials, 1u);
  EXPECT_EQ(server.counters().frees, 1u);
}

TEST(TrafficLightServerTest, WaitingCarsAreGrantedInFifoOrder) {
  auto server = MakeServer();
  server.OnRequest(At(0.0), {0, kI0});
  EXPECT_THAT(server.OnRequest(At(0.1), {3, kI0}), ElementsAre(Denied(3)));
  EXPECT_THAT(server.OnRequest(At(0.2), {1, kI0}), ElementsAre(Denied(1)));
  EXPECT_THAT(server.OnRequest(At(0.3), {2, kI0}), ElementsAre(Denied(2)));
  // Retries keep their place; they do not move to the back.
  EXPECT_THAT(server.OnRequest(At(1.1), {3, kI0}), ElementsAre(Denied(3)));
  EXPECT_THAT(server.OnRequest(At(1.2), {1, kI0}), ElementsAre(Denied(1)));
  EXPECT_THAT(server.Queue(kI0), ElementsAre(3, 1, 2));

  EXPECT_THAT(server.OnFree(At(2.0), {0}), ElementsAre(Granted(3)));
  EXPECT_THAT(server.OnFree(At(2.5), {3}), ElementsAre(Granted(1)));
  EXPECT_THAT(server.OnFree(At(3.0), {1}), ElementsAre(Granted(2)));
  EXPECT_THAT(server.OnFree(At(3.5), {2}), IsEmpty());
  EXPECT_EQ(server.Holder(kI0), std::nullopt);
  EXPECT_EQ(server.counters().grants, 4u);
  EXPECT_EQ(server.counters().denials, 5u);
}

TEST(TrafficLightServerTest, FreeFromANonHolderChangesNothing) {
  auto server = MakeServer();
  server.OnRequest(At(0.0), {0, kI0});
  server.OnRequest(At(0.1), {1, kI0});
  EXPECT_THAT(server.OnFree(At(0.2), {2}), IsEmpty());  // car 2 holds nothing, waits for nothing
  EXPECT_EQ(server.Holder(kI0), 0);
  EXPECT_THAT(server.Queue(kI0), ElementsAre(1));
  EXPECT_EQ(server.counters().frees, 1u);
}

TEST(TrafficLightServerTest, FreeFromAQueuedCarWithdrawsItButKeepsTheHolder) {
  auto server = MakeServer();
  server.OnRequest(At(0.0), {0, kI0});
  server.OnRequest(At(0.1), {1, kI0});
  server.OnRequest(At(0.2), {2, kI0});
  EXPECT_THAT(server.OnFree(At(0.3), {1}), IsEmpty());  // car 1 gave up waiting
  EXPECT_EQ(server.Holder(kI0), 0);
  EXPECT_THAT(server.Queue(kI0), ElementsAre(2));
  EXPECT_THAT(server.OnFree(At(0.4), {0}), ElementsAre(Granted(2)));
}

TEST(TrafficLightServerTest, LeaseExpiryFreesASilentHolderAndGrantsTheNextExactlyOnTime) {
  auto server = MakeServer("fifo", 5.0);
  server.OnRequest(At(1.0), {0, kI0});
  server.OnRequest(At(2.0), {1, kI0});
  // Car 0 falls silent; car 1 keeps retrying, so it stays alive.
  server.OnRequest(At(3.0), {1, kI0});
  server.OnRequest(At(5.5), {1, kI0});
  ASSERT_EQ(server.NextDeadline(), At(6.0));  // 5 s after car 0 was last heard

  EXPECT_THAT(server.OnTick(At(6.0) - Duration{1}), IsEmpty());
  EXPECT_EQ(server.Holder(kI0), 0);
  EXPECT_THAT(server.OnTick(At(6.0)), ElementsAre(Granted(1)));
  EXPECT_EQ(server.Holder(kI0), 1);
  EXPECT_EQ(server.counters().lease_expiries, 1u);
  EXPECT_EQ(server.NextDeadline(), At(10.5));  // now car 1's lease
}

// Issue 33: a holder stalled inside its intersection whose renewals cannot reach the server while
// the broker is away must not lose its grant to the car queued behind it. No lease runs out while
// the server is disconnected; on reconnecting every holder and queued car has a full lease.
TEST(TrafficLightServerTest, NoLeaseRunsOutWhileTheBrokerIsAwayAndReconnectingRenewsThemAll) {
  auto server = MakeServer("fifo", 5.0);
  server.OnRequest(At(3.7), {1, kI0});  // car 1 holds
  server.OnRequest(At(6.2), {0, kI0});  // car 0 queued
  server.OnRequest(At(6.7), {1, kI0});  // car 1's last renewal before the outage
  EXPECT_THAT(server.OnDisconnected(At(6.9)), IsEmpty());
  EXPECT_FALSE(server.connected());
  EXPECT_EQ(server.NextDeadline(), std::nullopt);
  EXPECT_THAT(server.OnTick(At(11.7)), IsEmpty());  // car 1's lease would have ended here
  server.OnReconnected(At(11.9));
  EXPECT_TRUE(server.connected());
  EXPECT_EQ(server.Holder(kI0), 1);
  EXPECT_EQ(server.Queue(kI0), std::vector<int>{0});
  EXPECT_EQ(server.NextDeadline(), At(16.9));  // a full lease for both from the reconnect
  // car 0 asks first after the outage: still denied
  EXPECT_THAT(server.OnRequest(At(12.2), {0, kI0}), ElementsAre(Denied(0)));
  EXPECT_THAT(server.OnRequest(At(12.7), {1, kI0}), ElementsAre(Granted(1)));  // renewal
  EXPECT_EQ(server.counters().lease_expiries, 0u);
  EXPECT_THAT(server.OnRequest(At(15.0), {0, kI0}), ElementsAre(Denied(0)));  // car 0 asks on
  // a holder that stays silent after the reconnect loses its grant one lease later, as ever
  EXPECT_THAT(server.OnTick(At(17.7)), ElementsAre(Granted(0)));
  EXPECT_EQ(server.counters().lease_expiries, 1u);
}

TEST(TrafficLightServerTest, ExpiriesDueBeforeADisconnectStillApply) {
  auto server = MakeServer("fifo", 5.0);
  server.OnRequest(At(1.0), {0, kI0});
  server.OnRequest(At(2.0), {1, kI0});
  server.OnRequest(At(5.0), {1, kI0});
  // car 0's lease ended at 6 s; the broker goes at 7 s: car 1 is granted (the link loses it)
  EXPECT_THAT(server.OnDisconnected(At(7.0)), ElementsAre(Granted(1)));
  EXPECT_EQ(server.Holder(kI0), 1);
  EXPECT_THAT(server.OnDisconnected(At(8.0)), IsEmpty());  // already down: nothing changes
  server.OnReconnected(At(9.0));
  server.OnReconnected(At(9.5));  // already up: the leases stay from 9 s
  EXPECT_EQ(server.NextDeadline(), At(14.0));
}

TEST(TrafficLightServerOriginalTest, TheBrokerGoingAwayChangesNothing) {
  auto server = MakeServer("original");
  server.OnRequest(At(1.0), {0, kI0});
  EXPECT_THAT(server.OnDisconnected(At(2.0)), IsEmpty());
  server.OnReconnected(At(30.0));
  EXPECT_EQ(server.Holder(kI0), 0);
  EXPECT_EQ(server.NextDeadline(), std::nullopt);
}

TEST(TrafficLightServerTest, TheRecordsAddUpToTheCountersAndNameTheIntersection) {
  using K = ServerRecord::Kind;
  auto server = MakeServer("fifo", 5.0);
  server.OnRequest(At(1.0), {0, kI1});  // granted
  server.OnRequest(At(1.5), {0, kI1});  // a renewal: a request, not a grant
  server.OnRequest(At(2.0), {1, kI1});  // denied, queued
  server.OnRequest(At(2.5), {2, kI0});  // granted
  server.OnFree(At(3.0), {0});          // releases 1, grants it to car 1
  server.OnFree(At(3.5), {3});          // releases nothing
  server.OnTick(At(8.0));               // car 1 silent since 2.0: its lease expired at 7.0
  EXPECT_THAT(
      server.TakeRecords(),
      ElementsAre(ServerRecord{K::kRequest, 0, kI1}, ServerRecord{K::kGrant, 0, kI1},
                  ServerRecord{K::kRequest, 0, kI1}, ServerRecord{K::kRequest, 1, kI1},
                  ServerRecord{K::kDenied, 1, kI1}, ServerRecord{K::kRequest, 2, kI0},
                  ServerRecord{K::kGrant, 2, kI0}, ServerRecord{K::kFree, 0, kI1},
                  ServerRecord{K::kGrant, 1, kI1}, ServerRecord{K::kFree, 3, -1},
                  ServerRecord{K::kLeaseExpired, 2, kI0}, ServerRecord{K::kLeaseExpired, 1, kI1}));
  EXPECT_THAT(server.TakeRecords(), IsEmpty());  // taken
  const auto c = server.counters();
  EXPECT_EQ(c.requests, 4u);
  EXPECT_EQ(c.grants, 3u);
  EXPECT_EQ(c.denials, 1u);
  EXPECT_EQ(c.frees, 2u);
  EXPECT_EQ(c.lease_expiries, 2u);
}

TEST(TrafficLightServerTest, ExpiryIsAppliedByAnyCallEvenWithoutATick) {
  auto server = MakeServer("fifo", 5.0);
  server.OnRequest(At(0.0), {0, kI0});
  server.OnRequest(At(0.0), {1, kI0});
  server.OnRequest(At(4.0), {1, kI0});
  // Car 2's request at 7 s first sees car 0 expire (5 s) and car 1 take over, then queues.
  EXPECT_THAT(server.OnRequest(At(7.0), {2, kI0}), ElementsAre(Granted(1), Denied(2)));
  EXPECT_EQ(server.Holder(kI0), 1);
  EXPECT_THAT(server.Queue(kI0), ElementsAre(2));
}

TEST(TrafficLightServerTest, SilentQueuedCarIsDroppedAndNeverGranted) {
  auto server = MakeServer("fifo", 5.0);
  server.OnRequest(At(0.0), {0, kI0});
  server.OnRequest(At(0.5), {1, kI0});  // then silent
  server.OnRequest(At(0.7), {2, kI0});
  for (double t = 1.0; t <= 5.0; t += 1.0) {  // keepalives from the holder, retries from car 2
    server.OnRequest(At(t), {0, kI0});
    server.OnRequest(At(t + 0.2), {2, kI0});
  }
  EXPECT_THAT(server.Queue(kI0), ElementsAre(1, 2));
  EXPECT_EQ(server.NextDeadline(), At(5.5));  // car 1's silence
  EXPECT_THAT(server.OnTick(At(5.5)), IsEmpty());
  EXPECT_THAT(server.Queue(kI0), ElementsAre(2));
  EXPECT_EQ(server.counters().queue_drops, 1u);
  EXPECT_THAT(server.OnFree(At(6.0), {0}), ElementsAre(Granted(2)));
}

TEST(TrafficLightServerTest, ALateTickNeverGrantsACarThatIsItselfDead) {
  auto server = MakeServer("fifo", 5.0);
  server.OnRequest(At(0.0), {0, kI0});
  server.OnRequest(At(0.5), {1, kI0});
  server.OnRequest(At(1.0), {2, kI0});
  // Nobody calls until 5.9 s: car 0 (dead at 5 s) and car 1 (5.5 s) are gone, car 2 is next.
  EXPECT_THAT(server.OnTick(At(5.9)), ElementsAre(Granted(2)));
  EXPECT_EQ(server.counters().lease_expiries, 1u);
  EXPECT_EQ(server.counters().queue_drops, 1u);
}

TEST(TrafficLightServerTest, RenewalsPostponeExpiry) {
  auto server = MakeServer("fifo", 5.0);
  server.OnRequest(At(0.0), {0, kI0});
  server.OnRequest(At(0.1), {1, kI0});
  for (double t = 1.0; t < 20.0; t += 1.0) {
    server.OnRequest(At(t), {0, kI0});
    server.OnRequest(At(t + 0.1), {1, kI0});
    EXPECT_THAT(server.OnTick(At(t + 0.5)), IsEmpty());
    EXPECT_EQ(server.Holder(kI0), 0);
    EXPECT_EQ(server.NextDeadline(), At(t + 5.0));
  }
  EXPECT_EQ(server.counters().lease_expiries, 0u);
  // A free from the holder counts as hearing from it too, and releases at once.
  EXPECT_THAT(server.OnFree(At(20.0), {0}), ElementsAre(Granted(1)));
}

TEST(TrafficLightServerTest, OnlyRequestsForAnIntersectionRenewItsGrant) {
  auto server = MakeServer("fifo", 5.0);
  server.OnRequest(At(0.0), {0, kI0});
  server.OnRequest(At(4.0), {0, kI1});  // about the other intersection: renews that one only
  EXPECT_EQ(server.NextDeadline(), At(5.0));
  EXPECT_THAT(server.OnTick(At(5.0)), IsEmpty());
  EXPECT_EQ(server.Holder(kI0), std::nullopt);
  EXPECT_EQ(server.Holder(kI1), 0);
  EXPECT_EQ(server.counters().lease_expiries, 1u);
  EXPECT_EQ(server.NextDeadline(), At(9.0));
}

// Issue 15's repro (after a broker crash lost both frees): each car holds one intersection and
// keeps asking for the other's. Under per-car liveness both were told "occupied" for as long as
// they talked; now each grant ends one lease after its holder's last request for it.
TEST(TrafficLightServerTest, TwoCarsEachHoldingWhatTheOtherWantsAreServedWithinOneLease) {
  auto server = MakeServer("fifo", 3.0);
  EXPECT_THAT(server.OnRequest(At(0.0), {1, kI0}), ElementsAre(Granted(1)));
  EXPECT_THAT(server.OnRequest(At(0.0), {2, kI1}), ElementsAre(Granted(2)));
  std::vector<Response> grants;
  for (double t = 1.0; t <= 10.0; t += 1.0) {
    for (const Response& r : server.OnRequest(At(t), {1, kI1})) {
      if (r.granted) grants.push_back(r);
    }
    for (const Response& r : server.OnRequest(At(t), {2, kI0})) {
      if (r.granted) grants.push_back(r);
    }
    if (t >= 3.0) {  // one lease after the holders' last requests for what they hold
      EXPECT_EQ(server.Holder(kI0), 2) << "at " << t << " s";
      EXPECT_EQ(server.Holder(kI1), 1) << "at " << t << " s";
    }
  }
  EXPECT_EQ(server.counters().lease_expiries, 2u);
  EXPECT_THAT(grants, ::testing::IsSupersetOf({Granted(1), Granted(2)}));
}

TEST(TrafficLightServerTest, UnknownIntersectionIsCountedAndDenied) {
  auto server = MakeServer();
  EXPECT_THAT(server.OnRequest(At(0.0), {4, 7}), ElementsAre(Denied(4)));
  EXPECT_EQ(server.counters().unknown_intersection, 1u);
  EXPECT_EQ(server.counters().denials, 1u);
  EXPECT_EQ(server.Holder(7), std::nullopt);
  EXPECT_THAT(server.Queue(7), IsEmpty());
  EXPECT_EQ(server.NextDeadline(), std::nullopt);
}

TEST(TrafficLightServerTest, IntersectionsAreIndependent) {
  auto server = MakeServer();
  EXPECT_THAT(server.OnRequest(At(0.0), {0, kI0}), ElementsAre(Granted(0)));
  EXPECT_THAT(server.OnRequest(At(0.1), {1, kI1}), ElementsAre(Granted(1)));
  EXPECT_THAT(server.OnRequest(At(0.2), {2, kI1}), ElementsAre(Denied(2)));
  EXPECT_THAT(server.OnFree(At(0.3), {0}), IsEmpty());  // car 0 releases 0 only
  EXPECT_EQ(server.Holder(kI0), std::nullopt);
  EXPECT_EQ(server.Holder(kI1), 1);
  EXPECT_THAT(server.Queue(kI1), ElementsAre(2));
}

TEST(TrafficLightServerTest, ACarMayHoldSeveralAndFreeReleasesThemAllInIdOrder) {
  auto server = MakeServer();
  server.OnRequest(At(0.0), {5, kI1});
  server.OnRequest(At(0.1), {5, kI0});
  server.OnRequest(At(0.2), {6, kI1});
  server.OnRequest(At(0.3), {7, kI0});
  EXPECT_THAT(server.OnFree(At(1.0), {5}), ElementsAre(Granted(7), Granted(6)));
  EXPECT_EQ(server.Holder(kI0), 7);
  EXPECT_EQ(server.Holder(kI1), 6);
}

TEST(TrafficLightServerTest, TimeMustNotGoBackwards) {
  auto server = MakeServer();
  server.OnRequest(At(2.0), {0, kI0});
  EXPECT_NO_THROW(server.OnTick(At(2.0)));
  EXPECT_THROW(server.OnTick(At(1.0)), std::invalid_argument);
  EXPECT_THROW(server.OnRequest(At(2.0), {10, kI0}), std::invalid_argument);
}

TEST(TrafficLightServerOriginalTest, DeniedCarIsNeverGrantedLaterAndNothingExpires) {
  auto server = MakeServer("original", 5.0);
  EXPECT_THAT(server.OnRequest(At(0.0), {0, kI0}), ElementsAre(Granted(0)));
  EXPECT_THAT(server.OnRequest(At(0.1), {0, kI0}), ElementsAre(Granted(0)));  // same car
  EXPECT_THAT(server.OnRequest(At(0.2), {1, kI0}), ElementsAre(Denied(1)));
  EXPECT_THAT(server.Queue(kI0), IsEmpty());
  EXPECT_EQ(server.NextDeadline(), std::nullopt);
  // Car 0 dies silently: it keeps the slot for ever.
  EXPECT_THAT(server.OnTick(At(1000.0)), IsEmpty());
  EXPECT_EQ(server.Holder(kI0), 0);
  EXPECT_EQ(server.counters().lease_expiries, 0u);
  // Once it frees, nobody is told: car 1 only gets the slot by asking again.
  EXPECT_THAT(server.OnFree(At(1001.0), {0}), IsEmpty());
  EXPECT_EQ(server.Holder(kI0), std::nullopt);
  EXPECT_THAT(server.OnRequest(At(1002.0), {1, kI0}), ElementsAre(Granted(1)));
}

TEST(TrafficLightServerOriginalTest, FreeReleasesOnlyTheCarsSlots) {
  auto server = MakeServer("original");
  server.OnRequest(At(0.0), {0, kI0});
  server.OnRequest(At(0.0), {1, kI1});
  EXPECT_THAT(server.OnFree(At(1.0), {1}), IsEmpty());
  EXPECT_EQ(server.Holder(kI0), 0);
  EXPECT_EQ(server.Holder(kI1), std::nullopt);
}

TEST(TrafficLightServerOriginalTest, AFreeReleasesOnlyTheFirstSlotTheCarHolds) {
  // vtl.py:15-22 (lab commit 02c5ab4): `if` slot 0 `elif` slot 1, so one free clears one slot,
  // slot 0 first, whichever the car asked for first.
  auto server = MakeServer("original");
  server.OnRequest(At(0.0), {5, kI1});
  server.OnRequest(At(0.1), {5, kI0});
  EXPECT_THAT(server.OnFree(At(1.0), {5}), IsEmpty());
  EXPECT_EQ(server.Holder(kI0), std::nullopt);
  EXPECT_EQ(server.Holder(kI1), 5);  // still held: car 6 is denied
  EXPECT_THAT(server.OnRequest(At(1.1), {6, kI1}), ElementsAre(Denied(6)));
  EXPECT_EQ(server.TakeRecords().at(4),
            (ServerRecord{ServerRecord::Kind::kFree, 5, kI0, {}}));  // one slot, no others
  // a second free clears the other slot; a third finds nothing (vtl.py:21-22 prints an error)
  server.OnFree(At(2.0), {5});
  EXPECT_EQ(server.Holder(kI1), std::nullopt);
  server.OnFree(At(3.0), {5});
  EXPECT_EQ(server.counters().frees, 3u);
  EXPECT_THAT(server.OnRequest(At(3.1), {6, kI1}), ElementsAre(Granted(6)));
}

}  // namespace
}  // namespace autonomsim::world
