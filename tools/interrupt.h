// Ctrl-C and SIGTERM: the first asks the running command to stop (a flag its runs poll, every
// simulated second), so that what it was making unwinds: a run's partial folder is removed, a
// sweep keeps its complete runs and resumes where it stopped. The second ends the process at once
// (the default action, restored by the first).
#pragma once

#include <stdexcept>

namespace autonomsim::cli {

// The exit status of a command stopped by the user: 128 + SIGINT, as a shell reports it.
inline constexpr int kExitInterrupted = 130;

// Thrown from inside a run when the user asked to stop.
class Interrupted : public std::runtime_error {
 public:
  Interrupted() : std::runtime_error("interrupted") {}
};

// Installs the handlers for SIGINT and SIGTERM: only a command that polls (run, check, sweep) does,
// at its start; the others keep the default action (Ctrl-C ends them at once).
void InstallInterruptHandlers();
// Whether the user asked to stop.
bool InterruptRequested();
// Throws Interrupted if the user asked to stop.
void ThrowIfInterrupted();

}  // namespace autonomsim::cli
