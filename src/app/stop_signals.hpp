// drivetap command line: SIGINT and SIGTERM end a run with its outputs closed; a watchdog thread
// unblocks a run stuck writing to an output nobody reads.
#pragma once

#include <csignal>

namespace drivetap::app {

// Set by SIGINT and SIGTERM once catch_stop_signals() was called: the loops check it.
extern volatile std::sig_atomic_t g_stop;

// SIGINT and SIGTERM set g_stop for the rest of this run, with the watchdog behind them.
void catch_stop_signals();

}  // namespace drivetap::app
