// The discrete-event kernel: one instance per simulation run (never a singleton), single-threaded.
//
// Order: events run by (time, priority, insertion sequence). At equal time a lower priority value
// runs first; at equal time and priority, events run in the order they were scheduled. A periodic
// timer's next occurrence is inserted just before its callback runs, so it counts as scheduled
// before anything that callback schedules. This order is total, so a run is reproducible bit for
// bit.
//
// Reentrancy: callbacks may call Now, ScheduleAt/In/Periodic (at Now() too: such an event runs
// after the current one, in the same RunUntil), Cancel (any id, including the running periodic
// timer's own), Stop, pending and executed. They may not call Step or RunUntil (std::logic_error).
// An exception from a callback propagates out of Step/RunUntil; the event counts as executed,
// Now() stays at its time, a periodic timer stays armed (unless cancelled) and the kernel remains
// usable.
//
// Errors in arguments (time before Now(), negative delay, period <= 0, priority outside
// [kMinPriority, kMaxPriority] = int16, empty callback, time overflow) throw std::logic_error or
// a subclass of it and leave the kernel unchanged.
//
// Cost: scheduling, cancelling and running an event are O(log n) in the peak number of pending
// events, and allocate nothing once the queue has reached that peak (for callables of up to
// Callback::kInlineBytes). Not thread-safe: a kernel belongs to one thread at a time.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <functional>
#include <limits>
#include <new>
#include <type_traits>
#include <utility>
#include <vector>

#include "world/time.h"

namespace autonomsim::sim {

namespace detail {
template <class T>
inline constexpr bool kIsStdFunction = false;
template <class R, class... A>
inline constexpr bool kIsStdFunction<std::function<R(A...)>> = true;
}  // namespace detail

// What an event runs: like std::function<void()> (copyable, accepts any copyable callable, empty
// when default-constructed), but callables of up to kInlineBytes are stored inline, where
// std::function (libstdc++) allocates for anything over 16 bytes or not trivially copyable; and
// trivially copyable ones are moved and dropped without an indirect call. An event therefore
// allocates nothing as long as its lambda captures at most 40 bytes; bigger callables (or ones
// whose move may throw) live on the heap, one allocation per Callback, as with std::function.
class Callback {
 public:
  static constexpr std::size_t kInlineBytes = 40;

  Callback() noexcept = default;
  Callback(std::nullptr_t) noexcept {}  // NOLINT: implicit, like std::function

  template <class F, class D = std::decay_t<F>>
  Callback(F&& f)  // NOLINT: implicit, so that lambdas convert
      requires(!std::is_same_v<D, Callback> && std::is_invocable_v<D&> &&
               std::is_copy_constructible_v<D>) {
    if constexpr (std::is_pointer_v<D> || detail::kIsStdFunction<D>) {
      if (!f) return;  // a null function pointer or empty std::function gives an empty Callback
    }
    if constexpr (kInline<D>) {
      ::new (static_cast<void*>(buf_)) D(std::forward<F>(f));
    } else {
      ::new (static_cast<void*>(buf_)) D*(new D(std::forward<F>(f)));
    }
    ops_ = &kOps<D>;
  }

  Callback(const Callback& other) : ops_(other.ops_) {
    if (ops_ == nullptr) return;
    if (ops_->copy != nullptr) {
      ops_->copy(buf_, other.buf_);
    } else {
      std::memcpy(buf_, other.buf_, kInlineBytes);
    }
  }
  Callback(Callback&& other) noexcept : ops_(other.ops_) { StealFrom(other); }
  Callback& operator=(const Callback& other) {
    if (this != &other) *this = Callback(other);
    return *this;
  }
  Callback& operator=(Callback&& other) noexcept {
    if (this != &other) {
      Reset();
      ops_ = other.ops_;
      StealFrom(other);
    }
    return *this;
  }
  ~Callback() { Reset(); }

  explicit operator bool() const noexcept { return ops_ != nullptr; }
  // Throws std::bad_function_call if empty.
  void operator()() const {
    if (ops_ == nullptr) throw std::bad_function_call();
    ops_->invoke(buf_);
  }

 private:
  struct Ops {
    void (*invoke)(void* buf);
    void (*copy)(void* dst, const void* src);         // nullptr: copy the bytes
    void (*relocate)(void* dst, void* src) noexcept;  // move to dst, end src; nullptr: bytes
    void (*destroy)(void* buf) noexcept;              // nullptr: nothing to do
  };

  template <class D>
  static constexpr bool kInline =
      sizeof(D) <= kInlineBytes &&
      alignof(D) <= alignof(std::max_align_t) && std::is_nothrow_move_constructible_v<D>;
  template <class D>
  static constexpr bool kTrivial =
      std::conjunction_v<std::bool_constant<kInline<D>>, std::is_trivially_copyable<D>>;

  template <class D>
  static D& Inline(void* buf) {
    return *std::launder(static_cast<D*>(buf));
  }
  template <class D>
  static D*& Boxed(void* buf) {
    return *std::launder(static_cast<D**>(buf));
  }

  template <class D>
  static constexpr Ops MakeOps() {
    if constexpr (kTrivial<D>) {
      return {[](void* b) { std::invoke(Inline<D>(b)); }, nullptr, nullptr, nullptr};
    } else if constexpr (kInline<D>) {
      return {[](void* b) { std::invoke(Inline<D>(b)); },
              [](void* d, const void* s) { ::new (d) D(Inline<D>(const_cast<void*>(s))); },
              [](void* d, void* s) noexcept {
                ::new (d) D(std::move(Inline<D>(s)));
                Inline<D>(s).~D();
              },
              [](void* b) noexcept { Inline<D>(b).~D(); }};
    } else {  // boxed: the buffer holds a D*, which moves as bytes
      return {[](void* b) { std::invoke(*Boxed<D>(b)); },
              [](void* d, const void* s) { ::new (d) D*(new D(*Boxed<D>(const_cast<void*>(s)))); },
              nullptr, [](void* b) noexcept { delete Boxed<D>(b); }};
    }
  }
  template <class D>
  static constexpr Ops kOps = MakeOps<D>();

  void StealFrom(Callback& other) noexcept {
    if (ops_ == nullptr) return;
    if (ops_->relocate != nullptr) {
      ops_->relocate(buf_, other.buf_);
    } else {
      std::memcpy(buf_, other.buf_, kInlineBytes);
    }
    other.ops_ = nullptr;
  }
  void Reset() noexcept {
    if (ops_ != nullptr && ops_->destroy != nullptr) ops_->destroy(buf_);
    ops_ = nullptr;
  }

  alignas(std::max_align_t) mutable unsigned char buf_[kInlineBytes];
  const Ops* ops_{nullptr};
};

// Priorities are stored in 16 bits next to the insertion sequence (48 bits).
inline constexpr int kMinPriority = -32768;
inline constexpr int kMaxPriority = 32767;

// Names one scheduled event or periodic timer for Cancel. A default-constructed id is not valid()
// and cancels nothing. Ids of fired or cancelled events go stale; a stale id could only alias a new
// event after its slot has been reused 2^31 times.
struct EventId {
  std::uint32_t slot{~0u};
  std::uint32_t generation{0};

  bool valid() const { return slot != ~0u; }
  friend bool operator==(const EventId&, const EventId&) = default;
};

class Kernel {
 public:
  Kernel();
  // Callbacks usually capture the kernel's address, so it stays put.
  Kernel(const Kernel&) = delete;
  Kernel& operator=(const Kernel&) = delete;
  ~Kernel();

  // The time of the event running now, or of the last one run, or the last RunUntil end.
  Time Now() const { return Time{now_}; }

  // Throws std::logic_error (naming both times) if at < Now().
  EventId ScheduleAt(Time at, Callback fn, int priority = 0);
  // Throws std::logic_error if delay < 0.
  EventId ScheduleIn(Duration delay, Callback fn, int priority = 0);
  // Fires at first, first + period, first + 2 period, ... (exact integer nanoseconds, no drift)
  // until cancelled; first >= Now(), period > 0. The id stays the same for the timer's life. A
  // timer whose next time would overflow Time ends after its last representable occurrence.
  EventId SchedulePeriodic(Time first, Duration period, Callback fn, int priority = 0);

  // True if the event (or periodic timer) was pending and is now cancelled; false for stale,
  // fired, already cancelled or invalid ids. Cancelling a periodic timer from inside its own
  // callback stops it after that callback.
  bool Cancel(EventId id);

  // Runs the next pending event; false (and Now() unchanged) if there is none.
  bool Step();
  // Runs every event with time <= end, including those scheduled meanwhile, then sets Now() to
  // end. If a callback calls Stop(), returns after that event instead, with Now() at its time.
  // Throws std::logic_error if end < Now().
  void RunUntil(Time end);
  // Makes the RunUntil in progress return after the current event. Outside RunUntil it has no
  // effect (each RunUntil starts un-stopped).
  void Stop() { stop_requested_ = true; }

  // Live events: scheduled, not yet run and not cancelled (a periodic timer counts as one).
  std::size_t pending() const { return pending_; }
  // Callbacks invoked so far (one per firing of a periodic timer), including ones that threw.
  std::uint64_t executed() const { return executed_; }

 private:
  // The queue is a tournament (winner) tree over the slots: leaf i holds slot i's key, each inner
  // node the index of the earliest leaf below it, the root the next event. A schedule, cancel or
  // run changes one key and costs one walk from its leaf to the root, log2(capacity) steps without
  // data-dependent branches. Cancelled events leave at once (no lazy deletion). The capacity is a
  // power of two, grows by doubling when every slot is in use and never shrinks: memory follows
  // the peak number of pending events, about 90 bytes each.
  struct Key {
    std::int64_t time;
    std::uint64_t order;  // (priority + 2^15) << 48 | insertion sequence
  };
  // A free slot's key: after every real key (real sequences stay below 2^48 - 1).
  static constexpr Key kFreeKey{std::numeric_limits<std::int64_t>::max(), ~std::uint64_t{0}};
  // Generation is odd while the slot holds a pending event and even while it is free.
  struct Slot {
    Callback fn;
    std::int64_t period{0};  // ns; 0 for a one-shot event
    std::uint32_t generation{0};
    std::uint32_t next_free{0};
  };

  EventId Insert(std::int64_t at, int priority, std::int64_t period, Callback&& fn);
  bool RunNext(std::int64_t end);
  void Dispatch(std::uint32_t slot);
  void Release(std::uint32_t slot);
  void Replay(std::uint32_t leaf, Key key);
  void FlushReplay();
  void Grow();
  void CheckNotInCallback(const char* what) const;

  std::vector<Key> keys_;            // per slot; a key above all real ones when the slot is free
  std::vector<std::uint32_t> tree_;  // [1, capacity): inner nodes; [capacity, 2 capacity): leaves
  std::vector<Slot> slots_;
  std::uint32_t capacity_{0};     // a power of two
  std::uint32_t free_head_{~0u};  // a free list threaded through Slot::next_free; ~0u ends it
  // A leaf whose key changed but whose walk to the root is still owed. Deferring it lets the
  // common "run an event, its callback schedules the next one in the freed slot" pay one walk.
  std::uint32_t replay_owed_{~0u};  // ~0u: none
  std::int64_t now_{0};
  std::uint64_t next_seq_{0};
  std::size_t pending_{0};
  std::uint64_t executed_{0};
  bool in_callback_{false};
  bool stop_requested_{false};
};

}  // namespace autonomsim::sim
