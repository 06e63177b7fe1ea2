// Ctrl-C (SIGINT) and SIGTERM during a run: the run stops cleanly at the next iteration instead of
// dying where it stands. The handler only records the signal (async-signal-safe); the time loop
// (lib/simulation.cpp) checks it once per iteration and per step, marks the results file
// "interrupted ...", releases the lock and ends with one message and exit status 128 + signal
// (130 for Ctrl-C, 143 for SIGTERM), the file resumable with --resume. A second signal ends the
// process at once (the handler is reset after the first): the results file is only ever
// replaced whole, so even then it is the previous complete file or the new one.
#pragma once

#include <csignal>
#include <string>

#include "error.hpp"

namespace ltl {

/// Installs the SIGINT and SIGTERM handlers while it lives (the time loop of one run), and
/// restores the previous dispositions after. Outside such a scope (meshing, factorization) the
/// signals keep their default action: the process ends at once, before any output exists.
class InterruptScope {
 public:
  InterruptScope();
  InterruptScope(const InterruptScope&) = delete;
  InterruptScope& operator=(const InterruptScope&) = delete;
  ~InterruptScope();

 private:
  struct sigaction sigint_ {
  }, sigterm_{};  ///< the dispositions restored at the end
};

/// The signal received inside the current InterruptScope (SIGINT, SIGTERM), or 0.
int interrupt_signal();

/// "SIGINT (Ctrl-C)", "SIGTERM", "signal N".
std::string signal_name(int signal);

/// A run stopped by a signal: the message says what was kept; guarded_main (lib/cli.hpp) prints
/// it and exits with 128 + signal().
class Interrupted : public Error {
 public:
  Interrupted(int signal, const std::string& message) : Error(message), signal_(signal) {}
  int signal() const { return signal_; }

 private:
  int signal_;
};

/// Throws Interrupted (with a provisional message; the time loop rewrites it) for `signal`, the
/// signal received inside the current InterruptScope (interrupt_signal(); the time loop's
/// run_signal, lib/simulation.cpp, decides it over the MPI ranks), unless it is 0.
void check_interrupt(int signal);

}  // namespace ltl
