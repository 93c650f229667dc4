// Live capture from serial ports (docs/protocols.md §1 line and timing, §2 t3.5): the loop
// that listens on every port at once, puts the bytes of all ports in time order and drives a
// pipeline with them as they come, reopening an unplugged adapter when asked.
//
// Bytes of all ports wait kHold in a reorder buffer (read latency differs between ports), are
// pushed in time order, and the pipeline is advanced to now - kHold, so a frame is out about
// t3.5 + kHold after its last byte. The outputs are flushed each round. A stop flag (a signal),
// the frame limit, the duration, an unplugged adapter (without reconnect) or a failed flush end
// the loop; what was read is decoded all the same.
#pragma once

#include <csignal>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "core/byte_event.hpp"
#include "core/serial_config.hpp"
#include "core/time.hpp"
#include "sources/live/serial_port.hpp"

namespace drivetap {

class Pipeline;

struct LiveCaptureOptions {
  // PATH or PATH=NAME each: NAME "line.m" / "line.s" puts the two ports of a 4-wire link on one
  // link as master and slave side (src/core/byte_event.hpp channel naming).
  std::vector<std::string> ports;
  SerialConfig serial;
  std::uint64_t max_frames = 0;  // stop once the pipeline counted this many frames (0: never)
  TimeNs duration = 0;           // stop after this long (0: never)
  bool reconnect = false;        // wait for an unplugged adapter to come back and go on
};

// What the loop tells whoever runs it, as it happens.
struct LiveCaptureHooks {
  std::function<void(const std::string& error)> port_lost;
  std::function<void(const std::string& port)> port_back;  // reopened (reconnect)
  // Said once a port, when bytes first come faster than its line settings can carry.
  std::function<void(const std::string& warning)> warn;
  // Every output flushed, each round; false when a write failed (the loop ends).
  std::function<bool()> flush;
};

// Why the loop ended.
enum class LiveCaptureEnd : std::uint8_t {
  stopped,           // the stop flag was set
  duration_reached,  // LiveCaptureOptions::duration
  frame_limit,       // LiveCaptureOptions::max_frames
  adapter_lost,      // a port went away, without reconnect
  poll_failed,       // ppoll() failed (errno kept in LiveCapture::poll_errno())
  output_failed,     // LiveCaptureHooks::flush() said a write failed
};

class LiveCapture {
 public:
  // Bytes wait this long for those of slower ports before they are pushed.
  static constexpr TimeNs kHold = 3 * kNsPerMs;

  LiveCapture(LiveCaptureOptions options, ChannelTable& channels);
  // Opens options.ports[k]; false with *error.
  bool open_port(std::size_t k, std::string* error);
  [[nodiscard]] const SerialPort& port(std::size_t k) const { return *ports_[k]; }

  // Listens until the loop ends (see above); every byte read is in the pipeline and the pipeline
  // finished when it returns (after the frame limit, the bytes past the last frame are dropped).
  LiveCaptureEnd run(Pipeline& pipeline, const LiveCaptureHooks& hooks,
                     const volatile std::sig_atomic_t& stop);
  [[nodiscard]] int poll_errno() const { return poll_errno_; }

 private:
  LiveCaptureOptions options_;
  ChannelTable& channels_;
  // One clock for the ports and this loop: their byte times and its "now" compare.
  CaptureClock clock_;
  std::vector<std::unique_ptr<SerialPort>> ports_;
  int poll_errno_ = 0;
};

}  // namespace drivetap
