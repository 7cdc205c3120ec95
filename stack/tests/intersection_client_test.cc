#include "stack/intersection_client.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "world/traffic_light_server.h"

namespace autonomsim::stack {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::IsEmpty;
using world::Box;
using world::Free;
using world::IntersectionSpec;
using world::Request;
using world::Response;
using world::Vec2;
using Phase = IntersectionClientState::Phase;

static_assert(std::is_copy_constructible_v<IntersectionClientState>);
static_assert(std::is_copy_assignable_v<IntersectionClientState>);

// The two intersections of scenarios/tracks/lab.yaml (reference §1), verbatim.
std::vector<IntersectionSpec> LabIntersections() {
  return {
      IntersectionSpec{0,
                       "right",
                       Box{1.3, 2.6, -0.6, 0.6},
                       {Box{2.0, 2.6, -1.4, -0.6},  // outer lane, northbound
                        Box{0.6, 1.3, -0.6, 0.0},   // middle road, eastbound
                        Box{1.3, 2.0, 0.6, 1.4}}},  // inner lane, southbound
      IntersectionSpec{1,
                       "left",
                       Box{-2.4, -1.1, -0.6, 0.6},
                       {Box{-1.75, -1.1, -1.35, -0.7},  // inner lane, northbound
                        Box{-1.1, -0.4, 0.0, 0.6},      // middle road, westbound
                        Box{-2.4, -1.75, 0.7, 1.4}}},   // outer lane, southbound
  };
}

constexpr int kCar = 0;

Time At(double s) { return FromSeconds(s); }

// One car's client, stepped by hand.
struct Client {
  IntersectionClientParams params;
  std::vector<IntersectionSpec> intersections = LabIntersections();
  IntersectionClientState state;
  int car = kCar;

  IntersectionClientOutput Step(double t_s, Vec2 p_map, std::vector<Response> responses = {}) {
    return StepIntersectionClient(params, car, intersections,
                                  IntersectionClientInput{At(t_s), p_map, std::move(responses)},
                                  &state);
  }
};

// Outer lane northbound through intersection 0 (x = 2.17).
Vec2 OuterNorth(double y_m) { return {2.17, y_m}; }

TEST(IntersectionClientParamsTest, DefaultsKeysAndValidation) {
  IntersectionClientParams params;
  EXPECT_EQ(params.tick_period, Milliseconds(100));
  EXPECT_EQ(params.retry_period, std::chrono::seconds(1));
  EXPECT_EQ(params.keepalive_period, std::chrono::seconds(1));
  EXPECT_NO_THROW(params.Validate());
  std::vector<std::string> keys;
  auto visit = [&](const std::string& key, auto&, auto&&...) { keys.push_back(key); };
  params.Describe(visit);
  EXPECT_THAT(keys, ElementsAre("tick_period_s", "retry_period_s", "keepalive_period_s",
                                "release_margin_m", "exit_margin_m", "re_request", "latch_wait",
                                "release_on_failure", "enter_only_if_clear", "blocking"));
  EXPECT_FALSE(params.blocking);

  params.retry_period = Duration::zero();
  try {
    params.Validate();
    FAIL() << "accepted retry_period_s = 0";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("retry_period_s"));
  }
  params = IntersectionClientParams{};
  params.release_margin_m = -0.1;
  EXPECT_THROW(params.Validate(), std::invalid_argument);
  params = IntersectionClientParams{};
  params.exit_margin_m = std::nan("");
  EXPECT_THROW(params.Validate(), std::invalid_argument);
}

TEST(IntersectionClientParamsTest, PeriodsMustBeShorterThanTheServerLease) {
  IntersectionClientParams params;
  EXPECT_NO_THROW(ValidateAgainstLease(params, world::TrafficLightServerParams{}.lease));
  params.keepalive_period = std::chrono::seconds(5);
  try {
    ValidateAgainstLease(params, std::chrono::seconds(5));
    FAIL() << "accepted keepalive_period_s = lease_s";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("keepalive_period_s"));
    EXPECT_THAT(e.what(), HasSubstr("lease_s"));
  }
  params = {};
  params.retry_period = std::chrono::seconds(6);
  EXPECT_THROW(ValidateAgainstLease(params, std::chrono::seconds(5)), std::invalid_argument);
  params.blocking = true;  // asks once: neither period is used
  EXPECT_NO_THROW(ValidateAgainstLease(params, std::chrono::seconds(5)));
}

TEST(IntersectionClientTest, RejectsACarIdThatIsNotOneDigit) {
  Client client;
  client.car = 10;
  EXPECT_THROW(client.Step(0.0, OuterNorth(-2.0)), std::invalid_argument);
}

TEST(IntersectionClientTest, FullCycleThroughTheRightIntersection) {
  Client client;
  // approach: the stop zone starts at y > -1.4 (strict), nothing is sent before
  for (int k = 0; k <= 6; ++k) {
    const auto out = client.Step(0.1 * k, OuterNorth(-2.0 + 0.1 * k));
    EXPECT_THAT(out.requests, IsEmpty()) << "k = " << k;
    EXPECT_TRUE(out.may_proceed);
    EXPECT_EQ(out.waiting_for, std::nullopt);
  }
  EXPECT_THAT(client.Step(0.65, OuterNorth(-1.4)).requests, IsEmpty());  // on the edge: outside

  // request on entering the stop zone, and wait
  auto out = client.Step(0.7, OuterNorth(-1.3));
  EXPECT_THAT(out.requests, ElementsAre(Request{kCar, 0}));
  EXPECT_FALSE(out.may_proceed);
  EXPECT_EQ(out.waiting_for, 0);
  EXPECT_EQ(client.state.phase, Phase::kWaiting);
  out = client.Step(0.8, OuterNorth(-1.3));
  EXPECT_THAT(out.requests, IsEmpty());  // no retry before retry_period
  EXPECT_FALSE(out.may_proceed);

  // granted: proceed
  out = client.Step(0.9, OuterNorth(-1.3), {Response{kCar, true}});
  EXPECT_TRUE(out.may_proceed);
  EXPECT_EQ(out.waiting_for, std::nullopt);
  EXPECT_EQ(client.state.phase, Phase::kHolding);

  // cross the area (y < 0.6), keepalive once a second after the last request (0.7 s)
  std::vector<double> keepalive_times;
  double t = 0.9;
  double y = -1.3;
  while (y < 0.55) {
    t += 0.1;
    y += 0.1;
    out = client.Step(t, OuterNorth(y));
    EXPECT_TRUE(out.may_proceed);
    EXPECT_THAT(out.frees, IsEmpty()) << "y = " << y;
    for (const Request& r : out.requests) {
      EXPECT_EQ(r, (Request{kCar, 0}));
      keepalive_times.push_back(t);
    }
  }
  ASSERT_EQ(keepalive_times.size(), 2u);
  EXPECT_NEAR(keepalive_times[0], 1.7, 1e-9);
  EXPECT_NEAR(keepalive_times[1], 2.7, 1e-9);

  // exit: the first step exit_margin_m (0.15 m) outside the area and every stop zone frees
  out = client.Step(t + 0.1, OuterNorth(0.7));
  EXPECT_THAT(out.frees, IsEmpty());
  EXPECT_EQ(client.state.phase, Phase::kHolding);
  out = client.Step(t + 0.2, OuterNorth(0.8));
  EXPECT_THAT(out.frees, ElementsAre(Free{kCar}));
  EXPECT_THAT(out.requests, IsEmpty());
  EXPECT_TRUE(out.may_proceed);
  EXPECT_EQ(client.state.phase, Phase::kIdle);
  out = client.Step(t + 0.3, OuterNorth(0.9));
  EXPECT_THAT(out.frees, IsEmpty());
  EXPECT_THAT(out.requests, IsEmpty());
}

TEST(IntersectionClientTest, TheEdgeBetweenStopZoneAndAreaCountsAsInside) {
  // Intersection 0's northbound stop zone ends at y = -0.6, where its area begins; strictly, a
  // point on that line is in neither box.
  Client holder;
  holder.Step(0.0, OuterNorth(-1.0));
  holder.Step(0.1, OuterNorth(-1.0), {Response{kCar, true}});
  EXPECT_THAT(holder.Step(0.2, OuterNorth(-0.6)).frees, IsEmpty());
  EXPECT_EQ(holder.state.phase, Phase::kHolding);

  Client waiter;
  waiter.Step(0.0, OuterNorth(-0.7));
  const auto out = waiter.Step(0.1, OuterNorth(-0.6));
  EXPECT_FALSE(out.may_proceed);
  EXPECT_EQ(out.waiting_for, 0);

  // but the edge does not start a request: entering is strict, as on the real cars
  Client idle;
  EXPECT_THAT(idle.Step(0.0, OuterNorth(-0.6)).requests, IsEmpty());
}

TEST(IntersectionClientTest, RetriesEveryRetryPeriodAfterADenial) {
  Client client;
  const Vec2 in_zone{0.9, -0.31};  // middle road, eastbound, stop zone of intersection 0
  EXPECT_THAT(client.Step(0.0, in_zone).requests, ElementsAre(Request{kCar, 0}));
  std::vector<double> request_times;
  for (int k = 1; k <= 35; ++k) {
    const double t = 0.1 * k;
    // the server answers every request "occupied" one tick later
    std::vector<Response> responses;
    if (!request_times.empty() && std::abs(request_times.back() - (t - 0.1)) < 1e-9) {
      responses.push_back(Response{kCar, false});
    }
    if (k == 1) responses.push_back(Response{kCar, false});
    const auto out = client.Step(t, in_zone, responses);
    EXPECT_FALSE(out.may_proceed) << "t = " << t;
    EXPECT_EQ(out.waiting_for, 0);
    for (const Request& r : out.requests) {
      EXPECT_EQ(r, (Request{kCar, 0}));
      request_times.push_back(t);
    }
  }
  ASSERT_EQ(request_times.size(), 3u);
  EXPECT_NEAR(request_times[0], 1.0, 1e-9);
  EXPECT_NEAR(request_times[1], 2.0, 1e-9);
  EXPECT_NEAR(request_times[2], 3.0, 1e-9);
  // the FIFO's later grant lets it go
  EXPECT_TRUE(client.Step(3.6, in_zone, {Response{kCar, true}}).may_proceed);
}

TEST(IntersectionClientTest, HolderSendsKeepalivesWhileStoppedInTheZone) {
  Client client;
  const Vec2 in_zone = OuterNorth(-1.0);
  client.Step(0.0, in_zone);
  client.Step(0.1, in_zone, {Response{kCar, true}});
  std::vector<double> times;
  for (int k = 2; k <= 45; ++k) {
    const auto out = client.Step(0.1 * k, in_zone);
    EXPECT_TRUE(out.may_proceed);
    for (const Request& r : out.requests) {
      EXPECT_EQ(r, (Request{kCar, 0}));
      times.push_back(0.1 * k);
    }
  }
  ASSERT_EQ(times.size(), 4u);
  for (std::size_t n = 0; n < times.size(); ++n) EXPECT_NEAR(times[n], 1.0 + n, 1e-9);
}

TEST(IntersectionClientTest, WithoutReRequestADeniedCarAsksOnceAndAHolderNeverRenews) {
  Client client;  // asks as the lab's client does (reference §7): one request, then it waits
  client.params.re_request = false;
  const Vec2 in_zone{0.9, -0.31};
  EXPECT_THAT(client.Step(0.0, in_zone).requests, ElementsAre(Request{kCar, 0}));
  for (int k = 1; k <= 60; ++k) {
    const auto out = client.Step(
        0.1 * k, in_zone, k == 1 ? std::vector{Response{kCar, false}} : std::vector<Response>{});
    EXPECT_THAT(out.requests, IsEmpty()) << "k = " << k;
    EXPECT_FALSE(out.may_proceed);
  }
  EXPECT_TRUE(client.Step(6.1, in_zone, {Response{kCar, true}}).may_proceed);
  for (int k = 62; k <= 120; ++k) EXPECT_THAT(client.Step(0.1 * k, in_zone).requests, IsEmpty());
}

TEST(IntersectionClientTest, ALatchedWaitHoldsWhileTheEstimateJittersOutOfTheStopZone) {
  // Inner lane northbound into intersection 1: the stop zone ends at y = -0.7, the area begins
  // at y = -0.6. A car held 5 cm before the zone's end whose estimate jitters 7 cm forward is in
  // the gap: outside the zone, so the unlatched client lets it go.
  const Vec2 in_zone{-1.55, -0.75};
  const Vec2 jittered_out{-1.55, -0.68};
  for (const bool latch : {false, true}) {
    Client client;
    client.params.latch_wait = latch;
    client.Step(0.0, in_zone);
    EXPECT_FALSE(client.Step(0.1, in_zone, {Response{kCar, false}}).may_proceed);
    const auto out = client.Step(0.2, jittered_out);
    EXPECT_EQ(out.may_proceed, !latch) << "latch_wait " << latch;
    EXPECT_EQ(out.waiting_for, 1);
    // the grant ends the wait either way
    EXPECT_TRUE(client.Step(0.3, jittered_out, {Response{kCar, true}}).may_proceed);
  }
}

TEST(IntersectionClientTest, AFailedNavigationFreesTheGrantAndRetires) {
  for (const bool release : {false, true}) {
    Client client;
    client.params.release_on_failure = release;
    const Vec2 in_zone = OuterNorth(-1.0);
    client.Step(0.0, in_zone);
    client.Step(0.1, in_zone, {Response{kCar, true}});
    IntersectionClientInput failed{At(0.2), in_zone, {}};
    failed.navigation_failed = true;
    const auto out =
        StepIntersectionClient(client.params, kCar, client.intersections, failed, &client.state);
    if (release) {
      EXPECT_THAT(out.frees, ElementsAre(Free{kCar}));
      EXPECT_TRUE(client.state.retired);
      // retired: no keepalive, no request in any stop zone
      for (int k = 3; k <= 40; ++k) {
        EXPECT_THAT(client.Step(0.1 * k, in_zone).requests, IsEmpty());
      }
    } else {
      EXPECT_THAT(out.frees, IsEmpty());
      EXPECT_EQ(client.state.phase, Phase::kHolding);
    }
  }
}

// Issue 33: a grant reached a second car while the first stood inside, its renewals cut off (a
// partitioned uplink) or forgotten (a restarted server). With enter_only_if_clear a granted car
// that has not been inside waits in its stop zone while it sees another car in the area, and goes
// once the area is clear; inside, what it sees no longer holds it. The lab's client
// (intersection_checker.cpp:84-104) goes on its grant whatever is in the area.
TEST(IntersectionClientTest, AGrantedCarWaitsWhileItSeesAnotherCarInTheArea) {
  for (const bool guard : {false, true}) {
    Client client;
    client.params.enter_only_if_clear = guard;
    const Vec2 in_zone = OuterNorth(-1.0);
    client.Step(0.0, in_zone);
    const auto step = [&](double t_s, Vec2 p, std::vector<int> occupied,
                          std::vector<Response> responses = {}) {
      IntersectionClientInput input{At(t_s), p, std::move(responses)};
      input.occupied_areas = std::move(occupied);
      return StepIntersectionClient(client.params, kCar, client.intersections, input,
                                    &client.state);
    };
    auto out = step(0.1, in_zone, {0}, {Response{kCar, true}});
    EXPECT_EQ(client.state.phase, Phase::kHolding);
    EXPECT_EQ(out.may_proceed, !guard);
    if (guard) {
      EXPECT_EQ(out.waiting_for, 0);
    }
    // another intersection's area occupied: no matter
    EXPECT_TRUE(step(0.2, in_zone, {1}).may_proceed);
    // held while the area stays occupied, renewing its lease all along
    int keepalives = 0;
    for (int k = 3; k <= 30; ++k) {
      out = step(0.1 * k, in_zone, {0});
      EXPECT_EQ(out.may_proceed, !guard) << k;
      keepalives += static_cast<int>(out.requests.size());
    }
    EXPECT_GE(keepalives, 2);
    EXPECT_TRUE(step(3.1, in_zone, {}).may_proceed);  // clear: go
    // inside the area, another car seen in it does not stop the car
    EXPECT_TRUE(step(3.2, OuterNorth(0.0), {0}).may_proceed);
  }
}

TEST(IntersectionClientTest, ACarThatFailedInsideTheAreaKeepsItsGrantAlive) {
  Client client;
  client.params.release_on_failure = true;
  client.Step(0.0, OuterNorth(-1.0));
  client.Step(0.1, OuterNorth(-1.0), {Response{kCar, true}});
  const Vec2 in_area = OuterNorth(0.0);
  client.Step(0.2, in_area);
  int keepalives = 0;
  for (int k = 3; k <= 40; ++k) {
    IntersectionClientInput failed{At(0.1 * k), in_area, {}};
    failed.navigation_failed = true;
    const auto out =
        StepIntersectionClient(client.params, kCar, client.intersections, failed, &client.state);
    EXPECT_THAT(out.frees, IsEmpty());
    keepalives += static_cast<int>(out.requests.size());
  }
  EXPECT_EQ(keepalives, 4);  // at 1, 2, 3 and 4 s: the lease never frees it under a dead car
  EXPECT_EQ(client.state.phase, Phase::kHolding);
  EXPECT_FALSE(client.state.retired);
}

TEST(IntersectionClientTest, IgnoresOtherCarsResponses) {
  Client client;
  const Vec2 in_zone = OuterNorth(-1.0);
  client.Step(0.0, in_zone);
  auto out = client.Step(0.1, in_zone, {Response{1, true}, Response{2, true}});
  EXPECT_FALSE(out.may_proceed);
  EXPECT_EQ(client.state.phase, Phase::kWaiting);
  out = client.Step(0.2, in_zone, {Response{kCar, true}});
  EXPECT_TRUE(out.may_proceed);
  out = client.Step(0.3, in_zone, {Response{1, false}});
  EXPECT_TRUE(out.may_proceed);
  EXPECT_EQ(client.state.phase, Phase::kHolding);
  // a stale grant for another car never triggers a free either
  Client idle;
  EXPECT_THAT(idle.Step(0.0, OuterNorth(-2.0), {Response{3, true}}).frees, IsEmpty());
}

TEST(IntersectionClientTest, ACarPassingOutsideTheStopZonesNeverRequests) {
  Client client;
  std::vector<Vec2> path;
  for (int k = 0; k <= 48; ++k) path.push_back({-2.4 + 0.1 * k, -2.17});  // outer lane, south
  for (int k = 0; k <= 25; ++k) path.push_back({2.5 - 0.1 * k, 0.31});    // leaving 0 westbound
  for (int k = 0; k <= 17; ++k) path.push_back({2.17, 0.7 + 0.1 * k});    // leaving 0 northbound
  for (int k = 0; k <= 17; ++k) path.push_back({-2.17, -0.7 - 0.1 * k});  // leaving 1 southbound
  double t = 0.0;
  for (const Vec2& p : path) {
    const auto out = client.Step(t, p);
    EXPECT_THAT(out.requests, IsEmpty()) << p.transpose();
    EXPECT_THAT(out.frees, IsEmpty()) << p.transpose();
    EXPECT_TRUE(out.may_proceed);
    t += 0.1;
  }
}

TEST(IntersectionClientTest, AGrantLostToTheLeaseStopsACarStillInTheZone) {
  Client client;
  const Vec2 in_zone = OuterNorth(-1.0);
  client.Step(0.0, in_zone);
  EXPECT_TRUE(client.Step(0.1, in_zone, {Response{kCar, true}}).may_proceed);
  // its keepalive was answered "occupied": someone else holds it now
  auto out = client.Step(1.1, in_zone, {Response{kCar, false}});
  EXPECT_FALSE(out.may_proceed);
  EXPECT_EQ(out.waiting_for, 0);
  EXPECT_THAT(client.Step(1.2, in_zone, {Response{kCar, true}}).waiting_for, std::nullopt);
}

TEST(IntersectionClientTest, GivingUpAWaitFreesAndALateGrantIsFreedAgain) {
  Client client;
  client.Step(0.0, OuterNorth(-1.0));
  // pushed back out of the stop zone while waiting (say, a relocalisation jump), farther than
  // release_margin_m
  auto out = client.Step(0.1, OuterNorth(-1.8));
  EXPECT_THAT(out.frees, ElementsAre(Free{kCar}));  // also withdraws it from the server's queue
  EXPECT_TRUE(out.may_proceed);
  EXPECT_EQ(out.waiting_for, std::nullopt);
  // the grant was already on its way: release it at once
  out = client.Step(0.2, OuterNorth(-1.8), {Response{kCar, true}});
  EXPECT_THAT(out.frees, ElementsAre(Free{kCar}));
  EXPECT_THAT(out.requests, IsEmpty());
  EXPECT_EQ(client.state.phase, Phase::kIdle);
}

TEST(IntersectionClientTest, AGrantArrivingAsTheCarLeavesIsReleasedInTheSameStep) {
  Client client;
  client.Step(0.0, OuterNorth(-1.0));
  const auto out = client.Step(0.1, OuterNorth(-1.8), {Response{kCar, true}});
  EXPECT_THAT(out.frees, ElementsAre(Free{kCar}));
  EXPECT_EQ(client.state.phase, Phase::kIdle);
}

// Reference §1: at the left intersection the inner lane's stop zone ends at y = -0.7 and the area
// begins at y = -0.6. Crossing that gap is not leaving the intersection.
TEST(IntersectionClientTest, TheGapBetweenStopZoneAndAreaDoesNotReleaseTheGrant) {
  Client client;
  const auto inner_north = [](double y_m) { return Vec2{-1.55, y_m}; };
  EXPECT_THAT(client.Step(0.0, inner_north(-1.0)).requests, ElementsAre(Request{kCar, 1}));
  client.Step(0.1, inner_north(-0.9), {Response{kCar, true}});
  auto out = client.Step(0.2, inner_north(-0.65));  // in the gap
  EXPECT_THAT(out.frees, IsEmpty());
  EXPECT_EQ(client.state.phase, Phase::kHolding);
  out = client.Step(0.3, inner_north(0.0));  // in the area
  EXPECT_THAT(out.frees, IsEmpty());
  // once it has crossed, leaving the boxes by exit_margin_m (0.15 m) frees
  out = client.Step(0.4, inner_north(0.7));
  EXPECT_THAT(out.frees, IsEmpty());
  out = client.Step(0.5, inner_north(0.8));
  EXPECT_THAT(out.frees, ElementsAre(Free{kCar}));
  EXPECT_EQ(client.state.phase, Phase::kIdle);
}

// Seeds 46 and 53 of the default scenario: the car stopped just inside the area's edge, its
// estimate stepped back into the gap below it, the client freed, the next car was granted and
// drove in while this one was still there. The estimate's noise is not leaving.
TEST(IntersectionClientTest, AnEstimateJitteringBackAcrossTheAreaEdgeKeepsTheGrant) {
  Client client;
  const auto inner_north = [](double y_m) { return Vec2{-1.55, y_m}; };
  client.Step(0.0, inner_north(-1.0));
  client.Step(0.1, inner_north(-0.9), {Response{kCar, true}});
  client.Step(0.2, inner_north(-0.58));             // crossed: in the area
  auto out = client.Step(0.3, inner_north(-0.66));  // estimate back in the gap
  EXPECT_THAT(out.frees, IsEmpty());
  EXPECT_EQ(client.state.phase, Phase::kHolding);
  out = client.Step(0.4, inner_north(-0.59));
  EXPECT_THAT(out.frees, IsEmpty());
  EXPECT_EQ(client.state.phase, Phase::kHolding);
}

TEST(IntersectionClientTest, ACarThatOvershotIntoTheAreaKeepsGoingAndKeepsAsking) {
  Client client;
  client.Step(0.0, OuterNorth(-0.7));
  auto out = client.Step(0.1, OuterNorth(-0.5));  // past the stop line, in the area
  EXPECT_TRUE(out.may_proceed);
  EXPECT_EQ(out.waiting_for, 0);
  out = client.Step(1.0, OuterNorth(0.0));
  EXPECT_THAT(out.requests, ElementsAre(Request{kCar, 0}));
  out = client.Step(1.1, OuterNorth(0.2), {Response{kCar, true}});
  EXPECT_EQ(client.state.phase, Phase::kHolding);
  EXPECT_THAT(client.Step(1.2, OuterNorth(0.8)).frees, ElementsAre(Free{kCar}));
}

TEST(IntersectionClientTest, LeavingStraightIntoAnotherStopZoneFreesThenRequests) {
  Client client;
  // a track where intersection 5's stop zone begins where intersection 4's area ends
  client.intersections = {
      IntersectionSpec{4, "a", Box{0.0, 1.0, 0.0, 1.0}, {Box{-1.0, 0.0, 0.0, 1.0}}},
      IntersectionSpec{5, "b", Box{2.0, 3.0, 0.0, 1.0}, {Box{1.0, 2.0, 0.0, 1.0}}},
  };
  EXPECT_THAT(client.Step(0.0, {-0.5, 0.5}).requests, ElementsAre(Request{kCar, 4}));
  client.Step(0.1, {-0.5, 0.5}, {Response{kCar, true}});
  client.Step(0.2, {0.5, 0.5});
  const auto out = client.Step(0.3, {1.5, 0.5});
  EXPECT_THAT(out.frees, ElementsAre(Free{kCar}));
  EXPECT_THAT(out.requests, ElementsAre(Request{kCar, 5}));
  EXPECT_FALSE(out.may_proceed);
  EXPECT_EQ(out.waiting_for, 5);
}

// ---- the lab's blocking client (blocking: true): intersection_checker.cpp, lab commit 02c5ab4
// ----

// The lab's client. Our options are left at their defaults: blocking overrides them.
Client Blocking() {
  Client client;
  client.params.blocking = true;
  return client;
}

// Inner lane northbound into intersection 1 (x = -1.42): stop zone y in (-1.35, -0.7), then a
// 0.1 m gap outside every box, then the area from y = -0.6 (reference §1).
Vec2 InnerNorthLeft(double y_m) { return {-1.42, y_m}; }

TEST(BlockingIntersectionClientTest, IgnoresDenialsAndHoldsTheCarUntilItsGrant) {
  // :84-104: the wait consumes messages until "<car>1"; "<car>0" is logged (:96-99) and other
  // cars' grants are dropped (:101-103). Nothing is asked again (no re_request, though it is on).
  Client client = Blocking();
  const Vec2 in_zone = OuterNorth(-1.0);
  auto out = client.Step(0.0, in_zone);
  EXPECT_THAT(out.requests, ElementsAre(Request{kCar, 0}));
  EXPECT_FALSE(out.may_proceed);  // bt_call(0) (:73) went out before the wait
  EXPECT_FALSE(out.stuck);
  for (int k = 1; k <= 100; ++k) {
    std::vector<Response> heard;
    if (k % 10 == 1) heard = {Response{kCar, false}, Response{1, true}};
    out = client.Step(0.1 * k, in_zone, heard);
    EXPECT_TRUE(out.stuck) << "k = " << k;
    EXPECT_FALSE(out.may_proceed);
    EXPECT_EQ(out.waiting_for, 0);
    EXPECT_THAT(out.requests, IsEmpty()) << "k = " << k;
  }
  out = client.Step(10.1, in_zone, {Response{kCar, false}, Response{kCar, true}});
  EXPECT_FALSE(out.stuck);
  EXPECT_TRUE(out.may_proceed);  // bt_call(1) (:92)
  EXPECT_EQ(out.waiting_for, std::nullopt);
  EXPECT_EQ(client.state.phase, Phase::kHolding);  // switch_controller (:93)
  EXPECT_EQ(client.state.queued_grants, 0);
}

TEST(BlockingIntersectionClientTest, SendsNoFreeAndNoRequestWhileBlocked) {
  // :84-104 never return without a grant: no zone is checked, whatever the estimate does, and a
  // failed navigation changes nothing (release_on_failure does not apply)
  Client client = Blocking();
  client.params.release_on_failure = true;
  client.Step(0.0, OuterNorth(-1.0));
  const std::vector<Vec2> wanderings = {OuterNorth(-3.0),      // outside every box
                                        OuterNorth(0.0),       // in the area
                                        InnerNorthLeft(-1.0),  // another intersection's zone
                                        OuterNorth(-1.0)};
  double t = 0.0;
  for (const Vec2& p : wanderings) {
    t += 0.1;
    const auto out = StepIntersectionClient(
        client.params, kCar, client.intersections,
        IntersectionClientInput{At(t), p, {Response{kCar, false}}, true}, &client.state);
    EXPECT_TRUE(out.stuck) << p.transpose();
    EXPECT_FALSE(out.may_proceed);
    EXPECT_THAT(out.requests, IsEmpty()) << p.transpose();
    EXPECT_THAT(out.frees, IsEmpty()) << p.transpose();
  }
  EXPECT_EQ(client.state.phase, Phase::kWaiting);
  EXPECT_EQ(client.state.intersection, 0);
}

TEST(BlockingIntersectionClientTest, AStaleQueuedGrantReleasesTheCarAtItsNextStopLine) {
  // A response that arrives while the client is not waiting stays in the MQTT client's queue;
  // the next wait consumes it first (:85), so a grant that answered nothing now releases the car
  // before the server has answered its new request.
  Client client = Blocking();
  client.Step(0.0, OuterNorth(-1.0));
  client.Step(0.1, OuterNorth(-1.0), {Response{kCar, true}});
  // a second "<car>1" (a repeated request's answer) arrives while it holds: queued, not acted on
  auto out = client.Step(0.2, OuterNorth(0.0), {Response{kCar, true}, Response{kCar, false}});
  EXPECT_TRUE(out.may_proceed);
  EXPECT_EQ(client.state.queued_grants, 1);
  out = client.Step(0.3, OuterNorth(1.6));  // out of every box: frees intersection 0
  EXPECT_THAT(out.frees, ElementsAre(Free{kCar}));
  // at the next stop line the wait takes the stale grant at once
  out = client.Step(10.0, InnerNorthLeft(-1.0));
  EXPECT_THAT(out.requests, ElementsAre(Request{kCar, 1}));
  EXPECT_TRUE(out.may_proceed);
  EXPECT_FALSE(out.stuck);
  EXPECT_EQ(client.state.phase, Phase::kHolding);
  EXPECT_EQ(client.state.queued_grants, 0);
  // the server's real answer (occupied) comes too late to stop it, and is ignored
  EXPECT_TRUE(client.Step(10.1, InnerNorthLeft(-0.9), {Response{kCar, false}}).may_proceed);
}

TEST(BlockingIntersectionClientTest, FreesOnTheFirstTickOutsideEveryBoxAfterAGrant) {
  // check_position (:120-223): nothing happens in an area or a stop zone; the else branch
  // (:207-215) frees when switch_controller is set. The 0.1 m gap between intersection 1's inner
  // stop zone and its area is outside every box: the lab's client frees there, before the car
  // has entered the area. Strict tests: the edge y = -0.6 is outside as well.
  Client client = Blocking();
  client.Step(0.0, InnerNorthLeft(-1.0));
  auto out = client.Step(0.1, InnerNorthLeft(-1.0), {Response{kCar, true}});
  EXPECT_THAT(out.frees, IsEmpty());
  EXPECT_THAT(client.Step(0.2, InnerNorthLeft(-0.75)).frees, IsEmpty());  // in the stop zone
  out = client.Step(0.3, InnerNorthLeft(-0.65));                          // in the gap
  EXPECT_THAT(out.frees, ElementsAre(Free{kCar}));
  EXPECT_THAT(out.requests, IsEmpty());
  EXPECT_EQ(client.state.phase, Phase::kIdle);  // new_intersection again (:114)
  // crossing the area and leaving: nothing more (switch_controller was reset, :213)
  for (const double y : {-0.5, 0.0, 0.5, 0.65}) {
    out = client.Step(0.4, InnerNorthLeft(y));
    EXPECT_THAT(out.frees, IsEmpty()) << y;
    EXPECT_THAT(out.requests, IsEmpty()) << y;
    EXPECT_TRUE(out.may_proceed);
  }
  // and at intersection 0, the shared edge of stop zone and area frees too
  Client edge = Blocking();
  edge.Step(0.0, OuterNorth(-1.0));
  edge.Step(0.1, OuterNorth(-1.0), {Response{kCar, true}});
  EXPECT_THAT(edge.Step(0.2, OuterNorth(-0.6)).frees, ElementsAre(Free{kCar}));
}

TEST(BlockingIntersectionClientTest, AsksForNoSecondIntersectionUntilItHasFreed) {
  // new_intersection is reset when the request goes out (:148) and set again only by vtl_free
  // (:114): a car that reaches another stop zone without a tick outside every box asks nothing
  Client client = Blocking();
  client.Step(0.0, OuterNorth(-1.0));
  client.Step(0.1, OuterNorth(-1.0), {Response{kCar, true}});
  auto out = client.Step(0.2, InnerNorthLeft(-1.0));  // a jump of the estimate
  EXPECT_THAT(out.requests, IsEmpty());
  EXPECT_THAT(out.frees, IsEmpty());
  EXPECT_TRUE(out.may_proceed);
  out = client.Step(0.3, InnerNorthLeft(-2.0));  // outside: frees (what it holds: intersection 0)
  EXPECT_THAT(out.frees, ElementsAre(Free{kCar}));
  out = client.Step(0.4, InnerNorthLeft(-1.0));
  EXPECT_THAT(out.requests, ElementsAre(Request{kCar, 1}));
  EXPECT_FALSE(out.may_proceed);
}

TEST(BlockingIntersectionClientTest, AGrantTakenOutsideEveryBoxFreesInTheTickTheTimerOwes) {
  // The wait returns on the grant; rclcpp then runs the missed timer tick once, on the position
  // then: an estimate that wandered out of every box while blocked frees at once (:207-215).
  Client client = Blocking();
  client.Step(0.0, OuterNorth(-1.0));
  client.Step(0.1, OuterNorth(-3.0));
  const auto out = client.Step(0.2, OuterNorth(-3.0), {Response{kCar, true}});
  EXPECT_FALSE(out.stuck);
  EXPECT_THAT(out.frees, ElementsAre(Free{kCar}));
  EXPECT_TRUE(out.may_proceed);
  EXPECT_EQ(client.state.phase, Phase::kIdle);
}

// ---- client and server together, by message passing (no simulator) ----

// A car moving at 1 m/s along a straight line, stopping when the client says so.
struct Car {
  int id;
  Vec2 start;
  Vec2 direction;  // unit
  int steps_to_end;
  int moved{0};
  Client client;
  std::vector<Response> inbox;

  Vec2 p() const { return start + direction * (0.1 * moved); }
  bool done() const { return moved >= steps_to_end; }
};

struct RunResult {
  bool both_done{false};
  int max_inside_area{0};
  int max_holding{0};
  double end_s{0.0};
  world::TrafficLightServer::Counters counters;
};

// Every 100 ms: each car's client steps on the responses broadcast since its last step (one tick
// of latency), the car moves if it may, and the server takes its messages (frees first). A message
// whose running number is in `lost` never arrives.
RunResult RunTwoCars(const std::vector<int>& lost) {
  world::TrafficLightServer server({}, {0, 1});
  const auto intersections = LabIntersections();
  std::array<Car, 2> cars = {
      Car{0, OuterNorth(-2.0), {0.0, 1.0}, 40, 0, {}, {}},  // outer lane northbound
      Car{1, {0.05, -0.31}, {1.0, 0.0}, 30, 0, {}, {}},     // middle road eastbound
  };
  for (Car& car : cars) car.client.car = car.id;
  int message_number = 0;
  auto delivered = [&] {
    return std::find(lost.begin(), lost.end(), message_number++) == lost.end();
  };
  RunResult result;
  for (int k = 0; k < 600; ++k) {
    const double t = 0.1 * k;
    std::vector<Response> broadcast = server.OnTick(At(t));
    for (Car& car : cars) {
      const auto out = car.client.Step(t, car.p(), std::exchange(car.inbox, {}));
      if (out.may_proceed && !car.done()) ++car.moved;
      for (const Free& f : out.frees) {
        if (delivered()) {
          for (const Response& r : server.OnFree(At(t), f)) broadcast.push_back(r);
        }
      }
      for (const Request& r : out.requests) {
        if (delivered()) {
          for (const Response& resp : server.OnRequest(At(t), r)) broadcast.push_back(resp);
        }
      }
    }
    for (const Response& r : broadcast) {
      if (!delivered()) continue;
      for (Car& car : cars) car.inbox.push_back(r);  // a broadcast reaches every car
    }
    int inside = 0;
    int holding = 0;
    for (const Car& car : cars) {
      inside += intersections[0].area.Contains(car.p()) ? 1 : 0;
      holding += car.client.state.phase == Phase::kHolding ? 1 : 0;
    }
    result.max_inside_area = std::max(result.max_inside_area, inside);
    result.max_holding = std::max(result.max_holding, holding);
    if (cars[0].done() && cars[1].done()) {
      result.both_done = true;
      result.end_s = t;
      break;
    }
  }
  result.counters = server.counters();
  return result;
}

TEST(IntersectionClientServerTest, TwoCarsContendingForOneIntersectionBothGetThroughOneAtATime) {
  const RunResult result = RunTwoCars({});
  EXPECT_TRUE(result.both_done);
  EXPECT_EQ(result.max_inside_area, 1);
  EXPECT_EQ(result.max_holding, 1);
  EXPECT_EQ(result.counters.grants, 2u);
  EXPECT_GE(result.counters.denials, 1u);  // they did contend
  EXPECT_EQ(result.counters.lease_expiries, 0u);
}

TEST(IntersectionClientServerTest, LostMessagesDelayButNeverBreakMutualExclusion) {
  // Lose some of everything: requests, grants, denials, keepalives and frees.
  std::vector<int> lost;
  for (int n = 1; n < 400; n += 3) lost.push_back(n);
  const RunResult result = RunTwoCars(lost);
  EXPECT_TRUE(result.both_done);
  EXPECT_EQ(result.max_inside_area, 1);
  EXPECT_EQ(result.max_holding, 1);
  // This pattern happens to lose every message from car 1 for 5 s while the server holds the
  // intersection for it, so the lease has to free it.
  EXPECT_GE(result.counters.lease_expiries, 1u);
  EXPECT_GT(result.end_s, RunTwoCars({}).end_s);
}

}  // namespace
}  // namespace autonomsim::stack
