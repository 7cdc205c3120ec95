#include "tools/interrupt.h"

#include <atomic>
#include <csignal>

namespace autonomsim::cli {
namespace {

// A signal handler can reach nothing but a lock-free atomic of static storage: this one flag is
// the process's, by the nature of signals.
std::atomic<bool> g_stop_requested{false};
static_assert(std::atomic<bool>::is_always_lock_free);

extern "C" void OnStopSignal(int signal) {
  g_stop_requested.store(true, std::memory_order_relaxed);
  std::signal(signal, SIG_DFL);  // a second one ends the process
}

}  // namespace

void InstallInterruptHandlers() {
  std::signal(SIGINT, OnStopSignal);
  std::signal(SIGTERM, OnStopSignal);
}

bool InterruptRequested() { return g_stop_requested.load(std::memory_order_relaxed); }

void ThrowIfInterrupted() {
  if (InterruptRequested()) throw Interrupted();
}

}  // namespace autonomsim::cli
