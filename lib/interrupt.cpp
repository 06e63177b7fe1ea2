// Ctrl-C and SIGTERM: recorded by the handler, acted on by the time loop (interrupt.hpp).
#include "interrupt.hpp"

#include <csignal>

namespace ltl {

namespace {

volatile std::sig_atomic_t g_signal = 0;

extern "C" void record_signal(int signal) {
  g_signal = signal;
}

}  // namespace

InterruptScope::InterruptScope() {
  g_signal = 0;
  struct sigaction action {};
  action.sa_handler = record_signal;
  sigemptyset(&action.sa_mask);
  // SA_RESETHAND: a second Ctrl-C takes the default action (ends the process at once).
  action.sa_flags = SA_RESETHAND | SA_RESTART;
  sigaction(SIGINT, &action, &sigint_);
  sigaction(SIGTERM, &action, &sigterm_);
}

InterruptScope::~InterruptScope() {
  sigaction(SIGINT, &sigint_, nullptr);
  sigaction(SIGTERM, &sigterm_, nullptr);
}

int interrupt_signal() {
  return g_signal;
}

std::string signal_name(int signal) {
  if (signal == SIGINT) return "SIGINT (Ctrl-C)";
  if (signal == SIGTERM) return "SIGTERM";
  return cat("signal ", signal);
}

void check_interrupt(int signal) {
  if (signal) throw Interrupted(signal, cat("interrupted by ", signal_name(signal)));
}

}  // namespace ltl
