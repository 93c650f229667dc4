// drivetap command line: the stop signals and their watchdog (src/app/stop_signals.hpp).
#include "app/stop_signals.hpp"

#include <semaphore.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <thread>

namespace drivetap::app {

volatile std::sig_atomic_t g_stop = 0;

namespace {

sem_t g_stop_posted;  // posted by on_signal (sem_post is async-signal-safe): wakes the watchdog
void on_signal(int) {
  g_stop = 1;
  ::sem_post(&g_stop_posted);
}

// SIGINT and SIGTERM end a run with its outputs closed (on_signal sets g_stop, which the loops
// check), also a run whose output blocks (a FIFO or pipe whose reader stopped reading), where a
// thread sits in write() and the decoding thread waits for it: a watchdog thread, woken by the
// signal, gives the run a grace second, then sends every other thread SIGUSR1 (a handler that does
// nothing, installed without SA_RESTART) until the run ends. A blocked write() returns EINTR, the
// output counts as failed and is not written to again, and the run closes its other outputs and
// ends as interrupted. Commands that do not catch the signals end at once, as by default.
void start_stop_watchdog() {
  ::sem_init(&g_stop_posted, 0, 0);
  struct sigaction wake {};
  wake.sa_handler = [](int) {};
  sigemptyset(&wake.sa_mask);
  wake.sa_flags = 0;  // no SA_RESTART: the blocked call returns EINTR
  ::sigaction(SIGUSR1, &wake, nullptr);
  std::thread([] {
    while (::sem_wait(&g_stop_posted) != 0) continue;  // EINTR: a signal landed on this thread
    std::this_thread::sleep_for(std::chrono::seconds(1));
    const pid_t self = static_cast<pid_t>(::syscall(SYS_gettid));
    for (;;) {
      std::error_code ec;
      for (const auto& task : std::filesystem::directory_iterator("/proc/self/task", ec)) {
        const long tid = std::strtol(task.path().filename().c_str(), nullptr, 10);
        if (tid > 0 && tid != self) ::syscall(SYS_tgkill, ::getpid(), tid, SIGUSR1);
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
  }).detach();
}

}  // namespace

// SIGINT and SIGTERM set g_stop for the rest of this run, with the watchdog behind them.
void catch_stop_signals() {
  static bool watching = false;
  if (!watching) start_stop_watchdog();
  watching = true;
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
}

}  // namespace drivetap::app
