// SIGINT and SIGTERM during a run (docs/reliability.md): the handler only records the
// signal (async-signal-safe); the run checks it at safe points (between
// batches, between output files), throws Interrupted, and the unwinding
// removes its temporaries (OutputSet, atomic writes). main() then exits with
// 128 + the signal (130 for SIGINT, 143 for SIGTERM). A second signal of the
// same kind kills at once (default action); whatever that leaves is cleaned by
// the next run in the same directory.
#pragma once

#include <csignal>
#include <stdexcept>

namespace vkmech {

class Interrupted : public std::runtime_error {
public:
    explicit Interrupted(int signo);
    int signo() const { return signo_; }
    int exit_code() const { return 128 + signo_; }

private:
    int signo_;
};

// Installs the handlers for its lifetime (nested guards are fine).
class SignalGuard {
public:
    SignalGuard();
    ~SignalGuard();
    SignalGuard(const SignalGuard&) = delete;
    SignalGuard& operator=(const SignalGuard&) = delete;

private:
    struct sigaction old_int_ {
    }, old_term_{};
};

// The signal received since the outermost guard was installed, or 0.
int pending_signal();
// Throws Interrupted when a signal is pending.
void throw_if_interrupted();

// Test hook (fault injection, docs/reliability.md): when $VKMECH_FAULT is "<point>:<signal>"
// (signal INT, TERM or KILL) and `point` matches, raises that signal in this
// process. Used by the tests to interrupt output writing at an exact step.
void fault_point(const char* point);

}  // namespace vkmech
