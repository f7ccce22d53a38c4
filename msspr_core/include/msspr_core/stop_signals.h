// SIGINT / SIGTERM while a tool trains: a flag the training loop polls, so
// that the run stops at a step boundary with its checkpoint written (msspr_train,
// msspr_train_expert). Header-only, no torch.
#pragma once

#include <signal.h>

#include <atomic>

namespace msspr {
namespace core {

// SIGINT / SIGTERM during Train(): set a flag the loop polls, so that the run
// stops at a step boundary with its checkpoint written. SA_RESETHAND: a second
// signal gets the default action and ends the process at once.
static_assert(std::atomic<bool>::is_always_lock_free, "the stop flag is set from a signal handler");
inline std::atomic<bool> g_stop_requested{false};
inline volatile sig_atomic_t g_stop_signal = 0;

extern "C" inline void OnStopSignal(int sig) {
  g_stop_signal = sig;
  g_stop_requested.store(true);
}

class StopOnSignals {
 public:
  StopOnSignals() {
    g_stop_requested.store(false);
    g_stop_signal = 0;
    struct sigaction sa {};
    sa.sa_handler = OnStopSignal;
    sigemptyset(&sa.sa_mask);
    sa.sa_flags = SA_RESETHAND;
    for (int i = 0; i < 2; ++i) {
      sigaction(kSignals[i], nullptr, &old_[i]);
      // A shell starts background jobs with SIGINT ignored: keep it so.
      installed_[i] = !(kSignals[i] == SIGINT && old_[i].sa_handler == SIG_IGN);
      if (installed_[i]) sigaction(kSignals[i], &sa, nullptr);
    }
  }
  ~StopOnSignals() {
    for (int i = 0; i < 2; ++i)
      if (installed_[i]) sigaction(kSignals[i], &old_[i], nullptr);
  }
  StopOnSignals(const StopOnSignals&) = delete;
  StopOnSignals& operator=(const StopOnSignals&) = delete;
  const std::atomic<bool>* flag() const { return &g_stop_requested; }
  int signal() const { return g_stop_signal; }

 private:
  static constexpr int kSignals[2] = {SIGINT, SIGTERM};
  struct sigaction old_[2];
  bool installed_[2] = {false, false};
};

}  // namespace core
}  // namespace msspr
