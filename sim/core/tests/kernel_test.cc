// Over 600 lines: one file keeps the kernel's whole contract beside its randomized reference model.
#include "sim/core/kernel.h"

#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <random>
#include <stdexcept>
#include <string>
#include <tuple>
#include <vector>

namespace autonomsim::sim {
namespace {

using std::chrono::microseconds;
using std::chrono::milliseconds;
using std::chrono::nanoseconds;

constexpr Time kMaxTime{std::numeric_limits<std::int64_t>::max()};

// Appends its label to a shared log when run.
struct Recorder {
  std::vector<int> log;
  Callback Note(int label) {
    return [this, label] { log.push_back(label); };
  }
};

TEST(KernelTest, StartsEmptyAtTimeZero) {
  Kernel k;
  EXPECT_EQ(k.Now(), kZeroTime);
  EXPECT_EQ(k.pending(), 0u);
  EXPECT_EQ(k.executed(), 0u);
  EXPECT_FALSE(k.Step());
  EXPECT_EQ(k.Now(), kZeroTime);
}

TEST(KernelTest, RunsEventsInTimeOrder) {
  Kernel k;
  Recorder r;
  k.ScheduleAt(milliseconds{30}, r.Note(3));
  k.ScheduleAt(milliseconds{10}, r.Note(1));
  k.ScheduleAt(milliseconds{20}, r.Note(2));
  std::vector<Time> times;
  while (k.Step()) times.push_back(k.Now());
  EXPECT_EQ(r.log, (std::vector<int>{1, 2, 3}));
  EXPECT_EQ(times, (std::vector<Time>{milliseconds{10}, milliseconds{20}, milliseconds{30}}));
}

TEST(KernelTest, EqualTimesRunByPriorityThenInsertionOrder) {
  Kernel k;
  Recorder r;
  const Time t = milliseconds{5};
  k.ScheduleAt(t, r.Note(1), 0);
  k.ScheduleAt(t, r.Note(2), 1);
  k.ScheduleAt(t, r.Note(3), -1);
  k.ScheduleAt(t, r.Note(4), 0);
  k.ScheduleAt(t, r.Note(5), kMinPriority);
  k.ScheduleAt(t, r.Note(6), kMaxPriority);
  k.ScheduleAt(t, r.Note(7), -1);
  k.ScheduleAt(t - nanoseconds{1}, r.Note(8), kMaxPriority);  // earlier time beats any priority
  k.RunUntil(t);
  EXPECT_EQ(r.log, (std::vector<int>{8, 5, 3, 7, 1, 4, 2, 6}));
}

TEST(KernelTest, ManyTiesKeepInsertionOrder) {
  Kernel k;
  Recorder r;
  for (int i = 0; i < 5000; ++i) k.ScheduleAt(milliseconds{1}, r.Note(i));
  k.RunUntil(milliseconds{1});
  ASSERT_EQ(r.log.size(), 5000u);
  for (int i = 0; i < 5000; ++i) ASSERT_EQ(r.log[i], i);
}

TEST(KernelTest, SchedulingInThePastThrowsNamingBothTimes) {
  Kernel k;
  k.RunUntil(milliseconds{10});
  try {
    k.ScheduleAt(milliseconds{3}, [] {});
    FAIL() << "no exception";
  } catch (const std::logic_error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("3000000 ns"), std::string::npos) << what;
    EXPECT_NE(what.find("10000000 ns"), std::string::npos) << what;
  }
  EXPECT_THROW(k.ScheduleIn(nanoseconds{-1}, [] {}), std::logic_error);
  EXPECT_THROW(k.SchedulePeriodic(milliseconds{9}, milliseconds{1}, [] {}), std::logic_error);
  EXPECT_THROW(k.RunUntil(milliseconds{9}), std::logic_error);
  EXPECT_EQ(k.pending(), 0u);
  EXPECT_EQ(k.Now(), milliseconds{10});
}

TEST(KernelTest, InvalidArgumentsThrowAndLeaveKernelUnchanged) {
  Kernel k;
  k.ScheduleAt(milliseconds{1}, [] {});
  EXPECT_THROW(k.SchedulePeriodic(kZeroTime, kZeroTime, [] {}), std::logic_error);
  EXPECT_THROW(k.SchedulePeriodic(kZeroTime, nanoseconds{-5}, [] {}), std::logic_error);
  EXPECT_THROW(k.ScheduleAt(
                   kZeroTime, [] {}, kMaxPriority + 1),
               std::logic_error);
  EXPECT_THROW(k.ScheduleAt(
                   kZeroTime, [] {}, kMinPriority - 1),
               std::logic_error);
  EXPECT_THROW(k.ScheduleAt(kZeroTime, Callback{}), std::logic_error);
  k.RunUntil(nanoseconds{10});
  EXPECT_THROW(k.ScheduleIn(kMaxTime - nanoseconds{5}, [] {}), std::logic_error);
  EXPECT_EQ(k.pending(), 1u);
  EXPECT_TRUE(k.Step());
  EXPECT_FALSE(k.Step());
}

TEST(KernelTest, ScheduleInIsRelativeToNow) {
  Kernel k;
  Time fired{-1};
  k.ScheduleAt(milliseconds{7}, [&] { k.ScheduleIn(microseconds{250}, [&] { fired = k.Now(); }); });
  k.RunUntil(milliseconds{100});
  EXPECT_EQ(fired, milliseconds{7} + microseconds{250});
}

TEST(KernelTest, CancelBeforeRunPreventsIt) {
  Kernel k;
  Recorder r;
  const EventId a = k.ScheduleAt(milliseconds{1}, r.Note(1));
  const EventId b = k.ScheduleAt(milliseconds{2}, r.Note(2));
  k.ScheduleAt(milliseconds{3}, r.Note(3));
  EXPECT_TRUE(a.valid());
  EXPECT_NE(a, b);
  EXPECT_EQ(k.pending(), 3u);
  EXPECT_TRUE(k.Cancel(b));
  EXPECT_EQ(k.pending(), 2u);
  EXPECT_FALSE(k.Cancel(b));  // already cancelled
  k.RunUntil(milliseconds{10});
  EXPECT_EQ(r.log, (std::vector<int>{1, 3}));
  EXPECT_EQ(k.executed(), 2u);
}

TEST(KernelTest, CancellingStaleOrInvalidIdsIsHarmless) {
  Kernel k;
  Recorder r;
  const EventId fired = k.ScheduleAt(milliseconds{1}, r.Note(1));
  k.RunUntil(milliseconds{1});
  // The fired event's slot is reused by the next event; the old id must not reach it.
  const EventId reused = k.ScheduleAt(milliseconds{2}, r.Note(2));
  EXPECT_EQ(reused.slot, fired.slot);
  EXPECT_FALSE(k.Cancel(fired));
  EXPECT_FALSE(k.Cancel(EventId{}));
  EXPECT_FALSE(EventId{}.valid());
  EXPECT_FALSE(k.Cancel(EventId{12345, 1}));
  EXPECT_FALSE(k.Cancel(EventId{reused.slot, reused.generation + 1}));
  // A forged id that matches a free slot's current generation must not "cancel" it.
  const EventId other = k.ScheduleAt(milliseconds{3}, r.Note(3));
  ASSERT_TRUE(k.Cancel(other));
  EXPECT_FALSE(k.Cancel(EventId{other.slot, other.generation + 1}));
  EXPECT_EQ(k.pending(), 1u);
  k.RunUntil(milliseconds{5});
  EXPECT_EQ(r.log, (std::vector<int>{1, 2}));
  EXPECT_EQ(k.pending(), 0u);
}

TEST(KernelTest, CancelFromInsideItsOwnCallbackReturnsFalse) {
  Kernel k;
  EventId self;
  bool result = true;
  self = k.ScheduleAt(milliseconds{1}, [&] { result = k.Cancel(self); });
  k.RunUntil(milliseconds{1});
  EXPECT_FALSE(result);
  EXPECT_EQ(k.executed(), 1u);
}

TEST(KernelTest, CallbacksMayScheduleAtNowAndCancelOthers) {
  Kernel k;
  Recorder r;
  EventId victim;
  k.ScheduleAt(milliseconds{1}, [&] {
    r.log.push_back(1);
    EXPECT_TRUE(k.Cancel(victim));
    k.ScheduleAt(k.Now(), r.Note(2));    // runs after this one, same time
    k.ScheduleIn(kZeroTime, r.Note(3));  // and after that one
  });
  victim = k.ScheduleAt(milliseconds{1}, r.Note(99));
  k.ScheduleAt(milliseconds{1}, r.Note(4));  // inserted before 2 and 3
  k.RunUntil(milliseconds{1});
  EXPECT_EQ(r.log, (std::vector<int>{1, 4, 2, 3}));
  EXPECT_EQ(k.Now(), milliseconds{1});
}

TEST(KernelTest, PeriodicTimerKeepsExactPhaseAndPeriod) {
  Kernel k;
  const Time first = microseconds{3'333};
  const Duration period = nanoseconds{33'333'333};  // 30 Hz: not a whole number of microseconds
  std::vector<Time> fires;
  const EventId id = k.SchedulePeriodic(first, period, [&] { fires.push_back(k.Now()); });
  k.RunUntil(first + 100'000 * period);
  ASSERT_EQ(fires.size(), 100'001u);
  for (std::size_t i = 0; i < fires.size(); ++i)
    ASSERT_EQ(fires[i], first + static_cast<std::int64_t>(i) * period) << i;
  EXPECT_EQ(k.pending(), 1u);  // still armed
  EXPECT_TRUE(k.Cancel(id));
  EXPECT_EQ(k.pending(), 0u);
  EXPECT_FALSE(k.Step());
  EXPECT_FALSE(k.Cancel(id));
}

TEST(KernelTest, PeriodicTimerCancelledFromInsideItsCallbackStops) {
  Kernel k;
  int fires = 0;
  EventId id;
  id = k.SchedulePeriodic(milliseconds{10}, milliseconds{10}, [&] {
    if (++fires == 3) {
      EXPECT_TRUE(k.Cancel(id));
      EXPECT_FALSE(k.Cancel(id));
    }
  });
  k.RunUntil(milliseconds{1000});
  EXPECT_EQ(fires, 3);
  EXPECT_EQ(k.pending(), 0u);
  EXPECT_EQ(k.executed(), 3u);
}

TEST(KernelTest, PeriodicTimerCancelledInsideItsCallbackMayHaveItsSlotReused) {
  Kernel k;
  Recorder r;
  EventId id;
  int fires = 0;
  id = k.SchedulePeriodic(milliseconds{1}, milliseconds{1}, [&] {
    ++fires;
    k.Cancel(id);
    k.ScheduleIn(milliseconds{5}, r.Note(7));  // takes the slot the timer just gave up
  });
  k.RunUntil(milliseconds{20});
  EXPECT_EQ(fires, 1);
  EXPECT_EQ(r.log, (std::vector<int>{7}));
  EXPECT_EQ(k.pending(), 0u);
}

TEST(KernelTest, PeriodicTimerCancelledByAnotherEvent) {
  Kernel k;
  int fires = 0;
  const EventId id = k.SchedulePeriodic(kZeroTime, milliseconds{2}, [&] { ++fires; });
  k.ScheduleAt(milliseconds{7}, [&] { EXPECT_TRUE(k.Cancel(id)); });
  k.RunUntil(milliseconds{100});
  EXPECT_EQ(fires, 4);  // 0, 2, 4, 6 ms
}

TEST(KernelTest, PeriodicReArmCountsAsInsertedBeforeWhatItsCallbackSchedules) {
  Kernel k;
  Recorder r;
  int fires = 0;
  const EventId id = k.SchedulePeriodic(milliseconds{1}, milliseconds{1}, [&] {
    r.log.push_back(100 + fires);
    if (fires++ == 0) k.ScheduleAt(milliseconds{2}, r.Note(1));  // same key as the re-arm
  });
  k.ScheduleAt(milliseconds{2}, r.Note(0));  // scheduled before the timer first re-armed
  k.RunUntil(milliseconds{2});
  EXPECT_EQ(r.log, (std::vector<int>{100, 0, 101, 1}));
  k.Cancel(id);
}

TEST(KernelTest, PeriodicTimerEndsAtTheLastRepresentableTime) {
  Kernel k;
  int fires = 0;
  k.SchedulePeriodic(kMaxTime - nanoseconds{15}, nanoseconds{10}, [&] { ++fires; });
  k.RunUntil(kMaxTime);
  EXPECT_EQ(fires, 2);
  EXPECT_EQ(k.pending(), 0u);
}

TEST(KernelTest, RunUntilRunsEventsAtExactlyEndAndSetsNow) {
  Kernel k;
  Recorder r;
  k.ScheduleAt(milliseconds{5}, r.Note(1));
  k.ScheduleAt(milliseconds{10}, [&] {
    r.log.push_back(2);
    k.ScheduleIn(kZeroTime, r.Note(3));  // also at exactly end
  });
  k.ScheduleAt(milliseconds{10} + nanoseconds{1}, r.Note(4));
  k.RunUntil(milliseconds{10});
  EXPECT_EQ(r.log, (std::vector<int>{1, 2, 3}));
  EXPECT_EQ(k.Now(), milliseconds{10});
  EXPECT_EQ(k.pending(), 1u);
  k.RunUntil(milliseconds{50});
  EXPECT_EQ(r.log, (std::vector<int>{1, 2, 3, 4}));
  EXPECT_EQ(k.Now(), milliseconds{50});  // advances past the last event
  k.RunUntil(milliseconds{50});          // end == Now() is allowed
  EXPECT_EQ(k.Now(), milliseconds{50});
}

TEST(KernelTest, StopMakesRunUntilReturnAfterTheCurrentEvent) {
  Kernel k;
  Recorder r;
  k.ScheduleAt(milliseconds{1}, r.Note(1));
  k.ScheduleAt(milliseconds{2}, [&] {
    r.log.push_back(2);
    k.Stop();
  });
  k.ScheduleAt(milliseconds{2}, r.Note(3));
  k.ScheduleAt(milliseconds{4}, r.Note(4));
  k.RunUntil(milliseconds{10});
  EXPECT_EQ(r.log, (std::vector<int>{1, 2}));
  EXPECT_EQ(k.Now(), milliseconds{2});
  EXPECT_EQ(k.pending(), 2u);
  k.RunUntil(milliseconds{10});  // a new RunUntil starts un-stopped
  EXPECT_EQ(r.log, (std::vector<int>{1, 2, 3, 4}));
  EXPECT_EQ(k.Now(), milliseconds{10});
}

TEST(KernelTest, StopOutsideRunUntilHasNoEffect) {
  Kernel k;
  Recorder r;
  k.ScheduleAt(milliseconds{1}, [&] {
    r.log.push_back(1);
    k.Stop();
  });
  k.ScheduleAt(milliseconds{2}, r.Note(2));
  k.ScheduleAt(milliseconds{3}, r.Note(3));
  k.Stop();
  EXPECT_TRUE(k.Step());  // the callback's Stop() is not left armed for the next RunUntil
  k.RunUntil(milliseconds{4});
  EXPECT_EQ(r.log, (std::vector<int>{1, 2, 3}));
  EXPECT_EQ(k.Now(), milliseconds{4});
}

TEST(KernelTest, TwoKernelsAreIndependent) {
  Kernel a;
  Kernel b;
  Recorder ra;
  Recorder rb;
  a.ScheduleAt(milliseconds{1}, ra.Note(1));
  b.ScheduleAt(milliseconds{5}, rb.Note(5));
  const EventId a2 = a.ScheduleAt(milliseconds{2}, ra.Note(2));
  EXPECT_EQ(a.pending(), 2u);
  EXPECT_EQ(b.pending(), 1u);
  a.RunUntil(milliseconds{1});
  EXPECT_EQ(b.Now(), kZeroTime);
  EXPECT_EQ(b.executed(), 0u);
  EXPECT_FALSE(b.Cancel(a2));  // b has no slot 1 in use
  b.RunUntil(milliseconds{10});
  a.RunUntil(milliseconds{10});
  EXPECT_EQ(ra.log, (std::vector<int>{1, 2}));
  EXPECT_EQ(rb.log, (std::vector<int>{5}));
}

TEST(KernelTest, ExceptionFromCallbackPropagatesAndKernelKeepsWorking) {
  Kernel k;
  Recorder r;
  k.ScheduleAt(milliseconds{1}, r.Note(1));
  k.ScheduleAt(milliseconds{2}, [&] {
    k.ScheduleIn(milliseconds{1}, r.Note(3));
    throw std::runtime_error("boom");
  });
  k.ScheduleAt(milliseconds{4}, r.Note(4));
  EXPECT_THROW(k.RunUntil(milliseconds{10}), std::runtime_error);
  EXPECT_EQ(k.Now(), milliseconds{2});
  EXPECT_EQ(k.executed(), 2u);
  EXPECT_EQ(k.pending(), 2u);
  k.ScheduleAt(milliseconds{2}, r.Note(2));
  k.RunUntil(milliseconds{10});
  EXPECT_EQ(r.log, (std::vector<int>{1, 2, 3, 4}));
  EXPECT_EQ(k.pending(), 0u);
}

TEST(KernelTest, PeriodicTimerThatThrowsStaysArmed) {
  Kernel k;
  int fires = 0;
  const EventId id = k.SchedulePeriodic(milliseconds{1}, milliseconds{1}, [&] {
    if (++fires == 2) throw std::runtime_error("second fire");
  });
  EXPECT_THROW(k.RunUntil(milliseconds{5}), std::runtime_error);
  EXPECT_EQ(k.Now(), milliseconds{2});
  EXPECT_EQ(k.pending(), 1u);
  k.RunUntil(milliseconds{5});
  EXPECT_EQ(fires, 5);
  EXPECT_TRUE(k.Cancel(id));
}

TEST(KernelTest, StepAndRunUntilFromInsideACallbackThrow) {
  Kernel k;
  bool step_threw = false;
  bool run_threw = false;
  k.ScheduleAt(milliseconds{1}, [&] {
    try {
      k.Step();
    } catch (const std::logic_error&) {
      step_threw = true;
    }
    try {
      k.RunUntil(milliseconds{5});
    } catch (const std::logic_error&) {
      run_threw = true;
    }
  });
  k.ScheduleAt(milliseconds{2}, [] {});
  EXPECT_TRUE(k.Step());
  EXPECT_TRUE(step_threw);
  EXPECT_TRUE(run_threw);
  EXPECT_EQ(k.pending(), 1u);
  EXPECT_TRUE(k.Step());
}

TEST(KernelTest, PendingAndExecutedCount) {
  Kernel k;
  std::vector<EventId> ids;
  for (int i = 0; i < 10; ++i) ids.push_back(k.ScheduleAt(milliseconds{i}, [] {}));
  const EventId timer = k.SchedulePeriodic(kZeroTime, milliseconds{3}, [] {});
  EXPECT_EQ(k.pending(), 11u);
  k.Cancel(ids[4]);
  k.Cancel(ids[7]);
  EXPECT_EQ(k.pending(), 9u);
  k.RunUntil(milliseconds{5});  // events 0,1,2,3,5 and the timer at 0 and 3
  EXPECT_EQ(k.executed(), 7u);
  EXPECT_EQ(k.pending(), 4u);  // events 6, 8, 9 and the timer
  k.Cancel(timer);
  while (k.Step()) {
  }
  EXPECT_EQ(k.executed(), 10u);
  EXPECT_EQ(k.pending(), 0u);
}

TEST(KernelTest, CallbacksAreDestroyedWhenRunOrCancelled) {
  Kernel k;
  auto token = std::make_shared<int>(0);
  k.ScheduleAt(milliseconds{1}, [token] {});
  const EventId cancelled = k.ScheduleAt(milliseconds{2}, [token] {});
  const EventId timer = k.SchedulePeriodic(milliseconds{1}, milliseconds{1}, [token] {});
  EXPECT_EQ(token.use_count(), 4);
  k.Cancel(cancelled);
  EXPECT_EQ(token.use_count(), 3);
  k.RunUntil(milliseconds{3});
  EXPECT_EQ(token.use_count(), 2);  // the timer still holds its callback
  k.Cancel(timer);
  EXPECT_EQ(token.use_count(), 1);
}

TEST(KernelTest, PendingCallbacksAreDestroyedWithTheKernel) {
  auto token = std::make_shared<int>(0);
  {
    Kernel k;
    k.ScheduleAt(milliseconds{1}, [token] {});
    k.SchedulePeriodic(milliseconds{1}, milliseconds{1}, [token] {});
    EXPECT_EQ(token.use_count(), 3);
  }
  EXPECT_EQ(token.use_count(), 1);
}

TEST(KernelTest, MutableLambdaStatePersistsAcrossPeriodicFires) {
  Kernel k;
  std::vector<int> seen;
  k.SchedulePeriodic(kZeroTime, milliseconds{1}, [&seen, n = 0]() mutable { seen.push_back(++n); });
  k.RunUntil(milliseconds{3});
  EXPECT_EQ(seen, (std::vector<int>{1, 2, 3, 4}));
}

TEST(CallbackTest, StoresSmallLargeAndNonTrivialCallables) {
  Kernel k;
  std::vector<std::string> log;
  const std::string text = "a string longer than the small-string buffer of libstdc++";
  std::array<std::int64_t, 16> big{};  // 128 bytes: stored out of line
  big[15] = 42;
  auto token = std::make_shared<int>(7);
  k.ScheduleAt(milliseconds{1}, [&log, text] { log.push_back(text); });
  k.ScheduleAt(milliseconds{2}, [&log, big] { log.push_back(std::to_string(big[15])); });
  k.ScheduleAt(milliseconds{3}, [&log, token] { log.push_back(std::to_string(*token)); });
  std::function<void()> std_fn = [&log] { log.push_back("std::function"); };
  k.ScheduleAt(milliseconds{4}, std_fn);
  k.RunUntil(milliseconds{10});
  EXPECT_EQ(log, (std::vector<std::string>{text, "42", "7", "std::function"}));
  EXPECT_EQ(token.use_count(), 1);
}

TEST(CallbackTest, CopiesAreIndependent) {
  int calls = 0;
  std::vector<int> counts;
  Callback a = [&counts, n = 0]() mutable { counts.push_back(++n); };
  a();
  Callback b = a;  // copies the state (n == 1)
  a();
  b();
  Callback big = [&calls, pad = std::array<char, 100>{}] { calls += 1 + pad[0]; };
  Callback big_copy = big;
  Callback moved = std::move(big);
  big_copy();
  moved();
  EXPECT_EQ(counts, (std::vector<int>{1, 2, 2}));
  EXPECT_EQ(calls, 2);
}

TEST(CallbackTest, EmptyCallablesAreRejected) {
  Kernel k;
  const std::function<void()> empty_std_fn;
  void (*null_fn)() = nullptr;
  EXPECT_FALSE(Callback(empty_std_fn));
  EXPECT_FALSE(Callback(null_fn));
  EXPECT_FALSE(Callback(nullptr));
  EXPECT_THROW(k.ScheduleAt(kZeroTime, empty_std_fn), std::invalid_argument);
  EXPECT_THROW(k.ScheduleAt(kZeroTime, null_fn), std::invalid_argument);
  EXPECT_THROW(Callback{}(), std::bad_function_call);
  EXPECT_EQ(k.pending(), 0u);
}

TEST(KernelTest, CallbacksMayGrowTheQueueWhileRunning) {
  // The queue starts small; a periodic timer that schedules thousands of events from inside its
  // callback makes it grow (and move its storage) while that callback runs.
  Kernel k;
  std::vector<int> order;
  int fires = 0;
  const EventId timer = k.SchedulePeriodic(kZeroTime, milliseconds{1}, [&, payload = 7] {
    ++fires;
    for (int i = 0; i < 5000; ++i) {
      k.ScheduleIn(microseconds{500} + nanoseconds{i % 7}, [&order, i] { order.push_back(i); });
    }
    EXPECT_EQ(payload, 7);
  });
  k.RunUntil(milliseconds{1});
  EXPECT_EQ(fires, 2);
  EXPECT_EQ(order.size(), 5000u);
  for (std::size_t i = 1; i < order.size(); ++i) {
    // ordered by time (i % 7 ns after 0.5 ms), then insertion
    ASSERT_TRUE(order[i - 1] % 7 < order[i] % 7 ||
                (order[i - 1] % 7 == order[i] % 7 && order[i - 1] < order[i]));
  }
  EXPECT_EQ(k.pending(), 5001u);
  EXPECT_TRUE(k.Cancel(timer));
  k.RunUntil(milliseconds{2});
  EXPECT_EQ(order.size(), 10000u);
  EXPECT_EQ(k.pending(), 0u);
}

TEST(KernelTest, HeavyCancellationKeepsOrder) {
  // Enough entries that the kernel purges cancelled ones from its queue (see CompactIfMostlyStale).
  Kernel k;
  std::mt19937_64 gen(7);
  std::vector<int> order;
  std::vector<EventId> ids;
  std::vector<std::int64_t> times;
  for (int i = 0; i < 20000; ++i) {
    times.push_back(static_cast<std::int64_t>(gen() % 1000));
    ids.push_back(k.ScheduleAt(nanoseconds{times.back()}, [&order, i] { order.push_back(i); }));
  }
  std::multimap<std::int64_t, int> expected;  // equal times keep insertion order
  for (int i = 0; i < 20000; ++i) {
    if (gen() % 10 != 0) {
      ASSERT_TRUE(k.Cancel(ids[i]));
    } else {
      expected.emplace(times[i], i);
    }
  }
  EXPECT_EQ(k.pending(), expected.size());
  k.RunUntil(milliseconds{1});
  std::vector<int> expected_order;
  for (const auto& [t, i] : expected) expected_order.push_back(i);
  EXPECT_EQ(order, expected_order);
}

// Randomized comparison with a reference queue: a std::map keyed by (time, priority, insertion
// sequence), the ordering the kernel promises. Callbacks schedule and cancel too.
class ReferenceModel {
 public:
  explicit ReferenceModel(std::uint64_t seed) : gen_(seed) {}

  void Run(int operations) {
    for (int op = 0; op < operations; ++op) {
      const std::uint64_t dice = gen_() % 100;
      if (dice < 40) {
        Schedule();
      } else if (dice < 55) {
        CancelSome();
      } else if (dice < 57) {
        ASSERT_NO_FATAL_FAILURE(RunUntilSome());
      } else {
        Step();
      }
      ASSERT_EQ(kernel_.pending(), queue_.size());
      ASSERT_EQ(kernel_.executed(), executed_);
      ASSERT_EQ(kernel_.Now().count(), now_);
    }
    // Drain: stop the timers, then everything else must run in model order.
    for (auto& [label, id] : ids_) {
      if (periods_[label] > 0) CancelLabel(label);
    }
    while (!queue_.empty()) Step();
    ASSERT_FALSE(kernel_.Step());
    EXPECT_GT(executed_, static_cast<std::uint64_t>(operations) / 3);
  }

 private:
  using Key = std::tuple<std::int64_t, int, std::uint64_t>;

  void Schedule() {
    const int label = next_label_++;
    const std::int64_t at = now_ + static_cast<std::int64_t>(gen_() % 20);  // many ties
    const int priority = static_cast<int>(gen_() % 5) - 2;
    std::int64_t period = 0;
    if (gen_() % 10 == 0 && active_timers_ < 5) {
      period = 1 + static_cast<std::int64_t>(gen_() % 30);
      ++active_timers_;
    }
    auto fire = [this, label] { OnFire(label); };
    ids_[label] =
        period > 0 ? kernel_.SchedulePeriodic(nanoseconds{at}, nanoseconds{period}, fire, priority)
                   : kernel_.ScheduleAt(nanoseconds{at}, fire, priority);
    periods_[label] = period;
    priorities_[label] = priority;
    Insert(label, at);
  }

  void Insert(int label, std::int64_t at) {
    const Key key{at, priorities_[label], next_seq_++};
    queue_.emplace(key, label);
    key_of_[label] = key;
  }

  void CancelLabel(int label) {
    const bool expected = key_of_.count(label) > 0;
    EXPECT_EQ(kernel_.Cancel(ids_[label]), expected) << "label " << label;
    if (expected) {
      queue_.erase(key_of_[label]);
      key_of_.erase(label);
      if (periods_[label] > 0) --active_timers_;
    }
  }

  void CancelSome() {
    if (next_label_ == 0) return;
    CancelLabel(static_cast<int>(gen_() % static_cast<std::uint64_t>(next_label_)));
  }

  void Step() {
    const bool expected = !queue_.empty();
    EXPECT_EQ(kernel_.Step(), expected);
  }

  void RunUntilSome() {
    const std::int64_t end = now_ + static_cast<std::int64_t>(gen_() % 10);
    kernel_.RunUntil(nanoseconds{end});
    ASSERT_TRUE(queue_.empty() || std::get<0>(queue_.begin()->first) > end);
    now_ = end;
  }

  // The kernel just ran `label`: it must be the model's first entry.
  void OnFire(int label) {
    ASSERT_FALSE(queue_.empty());
    const auto [key, expected] = *queue_.begin();
    ASSERT_EQ(label, expected) << "at " << std::get<0>(key);
    queue_.erase(queue_.begin());
    key_of_.erase(label);
    now_ = std::get<0>(key);
    ++executed_;
    EXPECT_EQ(kernel_.Now().count(), now_);
    if (periods_[label] > 0) Insert(label, now_ + periods_[label]);  // re-armed before the callback
    // Reentrant work from inside the callback.
    const std::uint64_t dice = gen_() % 10;
    if (dice < 3) Schedule();
    if (dice == 3) CancelSome();
    if (dice == 4 && periods_[label] > 0) CancelLabel(label);
  }

  std::mt19937_64 gen_;
  Kernel kernel_;
  std::map<Key, int> queue_;
  std::map<int, Key> key_of_;
  std::map<int, EventId> ids_;
  std::map<int, std::int64_t> periods_;
  std::map<int, int> priorities_;
  std::int64_t now_{0};
  std::uint64_t next_seq_{0};
  std::uint64_t executed_{0};
  int next_label_{0};
  int active_timers_{0};
};

TEST(KernelTest, MatchesReferenceModelUnderRandomScheduleAndCancel) {
  for (std::uint64_t seed = 1; seed <= 20; ++seed) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    ReferenceModel model(seed);
    ASSERT_NO_FATAL_FAILURE(model.Run(20000));
  }
}

}  // namespace
}  // namespace autonomsim::sim
