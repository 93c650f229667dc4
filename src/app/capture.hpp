// drivetap command line: the live capture run that `drivetap capture` and the Wireshark extcap
// (src/app/extcap.cpp) share (docs/reference.md "Live capture").
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "app/common.hpp"
#include "core/serial_config.hpp"
#include "core/stats.hpp"
#include "sources/live/line_scan.hpp"

namespace drivetap::app {

// Options of `drivetap capture` besides the common ones.
struct CaptureOptions {
  std::vector<std::string> ports;     // -i
  std::vector<std::string> autostop;  // -a duration:S
  std::vector<std::string> ring;      // -b filesize:MB|duration:S|files:N
  bool reconnect = false;
  bool scan = false;
  double scan_seconds = 2;
};

// Listens `seconds` at each setting of scan_settings() in turn on `path` (`tried` hears of each)
// and judges them (judge_scan()). A port that cannot be opened: die(), exit 1. Stops early on
// g_stop.
ScanVerdict scan_line_settings(const CommonOptions& o, const std::string& path, double seconds,
                               const std::function<void(const ScanResult&)>& tried);

// Who hears of the run besides its outputs.
struct CaptureVoice {
  // The lines on stderr that say how the run goes (capturing on..., why it stopped, port
  // warnings); errors are said whatever this is.
  bool chatty = true;
  // Port warnings when not chatty (e.g. to Wireshark's log).
  std::function<void(const std::string& warning)> warning;
  // Each round of the capture loop, after the outputs were flushed: the counts so far.
  std::function<void(const Stats& stats)> each_round;
  // The outputs are open (-w's file or FIFO among them).
  std::function<void()> outputs_open;
  // The reader of the -w stream may go away (Wireshark stopping the capture): that ends the run
  // as a stop, without an error.
  bool reader_may_leave = false;
};

// `drivetap capture -i PORT...` (without --scan): the exit status (0 done, 1 a port or an output
// failed, 130 interrupted).
int run_capture(const CommonOptions& o, const CaptureOptions& c, const CaptureVoice& voice = {});

}  // namespace drivetap::app
