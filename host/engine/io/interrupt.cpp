#include "io/interrupt.hpp"

#include <atomic>
#include <cstdlib>
#include <cstring>
#include <string>

namespace vkmech {

namespace {
volatile std::sig_atomic_t g_signal = 0;
std::atomic<int> g_depth{0};

extern "C" void on_signal(int signo) {
    g_signal = signo;
    // A second signal of this kind acts at once (default action).
    struct sigaction dfl {};
    dfl.sa_handler = SIG_DFL;
    sigemptyset(&dfl.sa_mask);
    ::sigaction(signo, &dfl, nullptr);
}
}  // namespace

Interrupted::Interrupted(int signo)
    : std::runtime_error(signo == SIGTERM  ? "terminated (SIGTERM)"
                         : signo == SIGINT ? "interrupted (SIGINT)"
                                           : "interrupted by a signal"),
      signo_(signo) {}

SignalGuard::SignalGuard() {
    if (g_depth++ == 0) g_signal = 0;
    struct sigaction sa {};
    sa.sa_handler = on_signal;
    sigemptyset(&sa.sa_mask);
    sa.sa_flags = SA_RESTART;  // library calls in flight finish normally; the run checks at its next safe point
    ::sigaction(SIGINT, &sa, &old_int_);
    ::sigaction(SIGTERM, &sa, &old_term_);
}

SignalGuard::~SignalGuard() {
    ::sigaction(SIGINT, &old_int_, nullptr);
    ::sigaction(SIGTERM, &old_term_, nullptr);
    --g_depth;
}

int pending_signal() { return g_signal; }

void throw_if_interrupted() {
    if (int s = g_signal) throw Interrupted(s);
}

void fault_point(const char* point) {
    const char* spec = std::getenv("VKMECH_FAULT");
    if (!spec) return;
    std::string s(spec);
    auto colon = s.find(':');
    if (colon == std::string::npos || s.compare(0, colon, point) != 0) return;
    std::string sig = s.substr(colon + 1);
    int signo = sig == "INT" ? SIGINT : sig == "TERM" ? SIGTERM : sig == "KILL" ? SIGKILL : 0;
    if (signo) std::raise(signo);
}

}  // namespace vkmech
