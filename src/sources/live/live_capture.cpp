// Live capture from serial ports: the listening loop (src/sources/live/live_capture.hpp).
#include "sources/live/live_capture.hpp"

#include <fmt/format.h>

#include <poll.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <ctime>
#include <filesystem>
#include <limits>
#include <utility>

#include "pipeline/pipeline.hpp"

namespace drivetap {

LiveCapture::LiveCapture(LiveCaptureOptions options, ChannelTable& channels)
    : options_(std::move(options)),
      channels_(channels),
      clock_(CaptureClock::take()),
      ports_(options_.ports.size()) {}

bool LiveCapture::open_port(std::size_t k, std::string* error) {
  SerialPortOptions so;
  const std::string& port = options_.ports[k];
  const std::size_t eq = port.find('=');
  so.path = port.substr(0, eq);
  if (eq != std::string::npos) so.channel_name = port.substr(eq + 1);
  so.clock = clock_;
  so.serial = options_.serial;
  ports_[k] = SerialPort::open(so, channels_, error);
  return ports_[k] != nullptr;
}

LiveCaptureEnd LiveCapture::run(Pipeline& pipeline, const LiveCaptureHooks& hooks,
                                const volatile std::sig_atomic_t& stop) {
  const std::vector<std::string>& names = options_.ports;
  const std::uint64_t max_frames = options_.max_frames;
  const TimeNs started = clock_.now();
  std::vector<ByteEvent> pending;  // read, not yet pushed: sorted by time before each push
  std::size_t sorted_pending = 0;  // pending[0, sorted_pending) is in time order
  std::vector<ByteEvent> fresh;
  std::vector<bool> said_too_fast(ports_.size(), false);
  std::vector<bool> distrusted(ports_.size(), false);
  auto limit_reached = [&] { return max_frames > 0 && pipeline.stats().frames >= max_frames; };
  LiveCaptureEnd end = LiveCaptureEnd::stopped;
  while (!stop) {
    const TimeNs now = clock_.now();
    if (options_.duration > 0 && now - started >= options_.duration) {
      end = LiveCaptureEnd::duration_reached;
      break;
    }
    if (limit_reached()) {
      end = LiveCaptureEnd::frame_limit;
      break;
    }
    // Sleep until a port has bytes, the next frame can close, or 100 ms pass.
    TimeNs wake = 100 * kNsPerMs;
    const TimeNs deadline = pipeline.next_deadline();
    if (!pending.empty()) wake = std::min(wake, kHold);
    if (deadline != std::numeric_limits<TimeNs>::max())
      wake = std::min(wake, std::max<TimeNs>(0, deadline + kHold - now));
    std::vector<pollfd> fds;
    std::vector<std::size_t> which;
    for (std::size_t k = 0; k < ports_.size(); ++k)
      if (ports_[k]) {
        fds.push_back({ports_[k]->fd(), POLLIN, 0});
        which.push_back(k);
      }
    if (fds.empty()) {
      // Every adapter gone, waiting to reconnect.
      ::usleep(200'000);
    } else {
      const timespec timeout{static_cast<time_t>(wake / kNsPerSecond),
                             static_cast<long>(wake % kNsPerSecond)};
      const int ready = ::ppoll(fds.data(), fds.size(), &timeout, nullptr);
      if (ready < 0 && errno != EINTR) {
        poll_errno_ = errno;
        end = LiveCaptureEnd::poll_failed;
        break;
      }
    }
    for (std::size_t f = 0; f < fds.size(); ++f) {
      if (!(fds[f].revents & (POLLIN | POLLHUP | POLLERR))) continue;
      const std::size_t k = which[f];
      fresh.clear();
      const bool alive = ports_[k]->read_available(fresh);
      pending.insert(pending.end(), fresh.begin(), fresh.end());
      if (!said_too_fast[k] && ports_[k]->line_rate_exceeded()) {
        said_too_fast[k] = true;
        if (hooks.warn)
          hooks.warn(
              fmt::format("{}: bytes come faster than {} can carry: wrong line settings, "
                          "or a pty or network port; they keep their arrival order, their "
                          "times do not follow the line",
                          names[k].substr(0, names[k].find('=')), options_.serial.to_string()));
      }
      if (!distrusted[k] && !ports_[k]->timing_trusted()) {
        // From here on the port's bytes carry no silence: latencies and silence rules would
        // measure the adapter, not the bus (the bytes still held below follow the same rule).
        distrusted[k] = true;
        pipeline.distrust_silences(ports_[k]->channel());
        if (hooks.warn)
          hooks.warn(fmt::format("{}: {}; from here on no latency or silence rule is judged",
                                 names[k].substr(0, names[k].find('=')),
                                 ports_[k]->timing_verdict()));
      }
      if (!alive) {
        hooks.port_lost(ports_[k]->error());
        for (const std::string& n : ports_[k]->notes()) pipeline.add_source_note(n);
        ports_[k].reset();
        if (!options_.reconnect) end = LiveCaptureEnd::adapter_lost;
      }
    }
    if (end == LiveCaptureEnd::adapter_lost) break;
    if (options_.reconnect)
      for (std::size_t k = 0; k < ports_.size(); ++k) {
        if (ports_[k] || !std::filesystem::exists(names[k].substr(0, names[k].find('=')))) continue;
        std::string error;
        if (open_port(k, &error)) hooks.port_back(names[k]);
      }
    // Push what is older than the hold, in time order; then let silences close frames.
    const TimeNs settled = clock_.now() - kHold;
    // What was held is in order already: the new bytes are sorted and merged in (a flooded port
    // would make a full sort of the backlog every round cost more than the bytes).
    const auto by_time = [](const ByteEvent& a, const ByteEvent& b) { return a.time < b.time; };
    const auto fresh_from = pending.begin() + static_cast<std::ptrdiff_t>(sorted_pending);
    std::stable_sort(fresh_from, pending.end(), by_time);
    std::inplace_merge(pending.begin(), fresh_from, pending.end(), by_time);
    std::size_t pushed = 0;
    while (pushed < pending.size() && pending[pushed].time <= settled && !limit_reached())
      pipeline.push(pending[pushed++]);
    pending.erase(pending.begin(), pending.begin() + static_cast<std::ptrdiff_t>(pushed));
    sorted_pending = pending.size();
    if (!limit_reached()) pipeline.advance(settled);
    if (!hooks.flush()) {
      end = LiveCaptureEnd::output_failed;
      break;
    }
  }
  // Whatever stopped the run: what was read is decoded and summarised — except after the frame
  // limit, where the bytes after the last frame are not wanted.
  const bool counted_out = limit_reached();
  if (!counted_out)
    for (const ByteEvent& e : pending) pipeline.push(e);
  // The ports' own findings (kernel error counters, USB bursts) go into the summary.
  for (const auto& port : ports_)
    if (port)
      for (const std::string& n : port->notes()) pipeline.add_source_note(n);
  pipeline.finish(/*cut_partial=*/!counted_out);
  return end;
}

}  // namespace drivetap
