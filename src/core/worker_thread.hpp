// Worker threads of a run (read-ahead, the threaded sink): started with SIGINT and SIGTERM
// blocked, so that the handlers, which set the flag the main loop reads, always run on the main
// thread (a volatile sig_atomic_t is only guaranteed for a handler on the thread that reads it).
#pragma once

#include <pthread.h>

#include <csignal>
#include <thread>
#include <utility>

namespace drivetap {

template <class Function>
std::thread start_worker_thread(Function&& function) {
  sigset_t blocked, previous;
  sigemptyset(&blocked);
  sigaddset(&blocked, SIGINT);
  sigaddset(&blocked, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &blocked, &previous);
  std::thread thread(std::forward<Function>(function));  // inherits the mask
  pthread_sigmask(SIG_SETMASK, &previous, nullptr);
  return thread;
}

}  // namespace drivetap
