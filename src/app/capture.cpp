// `drivetap capture`: live, listen-only capture from serial ports, and `capture --scan`, which
// tries each standard line setting in turn (docs/reference.md "Live capture").
#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include <poll.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "app/capture.hpp"
#include "app/commands.hpp"
#include "app/common.hpp"
#include "app/outputs.hpp"
#include "app/stop_signals.hpp"
#include "core/printable.hpp"
#include "diagnose/line_diagnosis.hpp"
#include "pipeline/pipeline.hpp"
#include "sinks/ring_capture_sink.hpp"
#include "sources/live/live_capture.hpp"
#include "sources/live/serial_port.hpp"

namespace drivetap::app {
namespace {

ScanResult scan_one(const CommonOptions& o, const std::string& path, const SerialConfig& serial,
                    double seconds) {
  ScanResult r;
  r.serial = serial;
  ChannelTable channels;
  SerialPortOptions so;
  so.path = path;
  so.serial = serial;
  auto port = SerialPort::open(so, channels, &r.error);
  if (!port) return r;
  CommonOptions line = o;
  line.serial = serial.to_string();
  PipelineOptions p = make_pipeline_options(line, RunSettings{});
  p.drives.clear();
  p.auto_candidates.clear();
  LineEvidence evidence;
  DiagnosisSink sink(evidence, p.timing);
  Pipeline pipeline(p, channels, sink);
  const TimeNs end = CaptureClock::monotonic() + static_cast<TimeNs>(seconds * 1e9);
  std::vector<ByteEvent> events;
  while (!g_stop && CaptureClock::monotonic() < end) {
    pollfd fd{port->fd(), POLLIN, 0};
    ::poll(&fd, 1, 50);
    events.clear();
    const bool alive = port->read_available(events);
    for (const ByteEvent& e : events) {
      pipeline.push(e);
      ++r.bytes;
      if (e.flags) ++r.uart_errors;
    }
    if (!alive) {
      r.error = port->error();
      break;
    }
  }
  pipeline.finish();
  r.frames = evidence.frames;
  r.frames_ok = evidence.frames_checksum_ok;
  return r;
}

// Options that do nothing with the others: --scan-time without --scan; with --scan (which only
// prints its table) the outputs, -c and the options of a capture run.
void refuse_idle_capture_options(const CommonOptions& o, const CaptureOptions& c,
                                 bool scan_time_given) {
  if (!c.scan) {
    if (scan_time_given) die("--scan-time: only with --scan");
    return;
  }
  const std::pair<bool, const char*> idle[] = {
      {!o.write.empty(), "-w"},    {!o.output.empty(), "-o"},
      {o.count > 0, "-c"},         {!c.autostop.empty(), "-a"},
      {!c.ring.empty(), "-b"},     {c.reconnect, "--reconnect"},
      {o.format != "text", "-T"},  {o.quiet || o.stats_only, o.quiet ? "-q" : "--stats"},
      {o.events_only, "--events"}, {o.verbose, "-V"},
      {o.hex_dump, "-x"},          {!o.time_format.empty(), "-t"},
  };
  for (const auto& [given, option] : idle)
    if (given)
      die(fmt::format("{}: not with --scan (it prints only its table of settings)", option));
}

// `drivetap capture --scan -i PORT`: listens at each standard rate and format in turn and says
// which gives frames with good checksums (for a tap on a bus whose settings nobody knows).
int run_scan(const CommonOptions& o, const CaptureOptions& c) {
  if (c.ports.size() != 1) die("--scan: give exactly one port with -i");
  if (!(c.scan_seconds > 0) || c.scan_seconds > 3600)
    die(fmt::format("--scan-time {}: expected seconds between 0 and 3600", c.scan_seconds));
  const std::string path = c.ports.front().substr(0, c.ports.front().find('='));
  catch_stop_signals();
  std::printf("scan %s: %g s per setting (listen only)\n", path.c_str(), c.scan_seconds);
  std::fflush(stdout);
  const ScanVerdict verdict = scan_line_settings(o, path, c.scan_seconds, [](const ScanResult& r) {
    std::printf("  %-11s %6llu bytes, %5llu with UART errors, %4llu frames, %4llu checksum ok\n",
                r.serial.to_string().c_str(), static_cast<unsigned long long>(r.bytes),
                static_cast<unsigned long long>(r.uart_errors),
                static_cast<unsigned long long>(r.frames),
                static_cast<unsigned long long>(r.frames_ok));
    std::fflush(stdout);
  });
  if (g_stop) {
    std::printf("interrupted\n");
    return 130;
  }
  if (verdict.best.empty()) {
    std::printf(
        "no setting gave a frame with a good checksum (check the wiring: drivetap "
        "diagnose on a logic-analyser capture tells more)\n");
    return 1;
  }
  const ScanResult& best = verdict.best.front();
  if (verdict.best.size() == 1) {
    std::printf(
        "best: %s (%llu frames with a good checksum, %llu UART errors); capture with -s \"%s\"\n",
        best.serial.to_string().c_str(), static_cast<unsigned long long>(best.frames_ok),
        static_cast<unsigned long long>(best.uart_errors), best.serial.to_string().c_str());
    return 0;
  }
  // A tie is said as one: naming one of them would pass a guess for a measurement.
  std::string tied;
  for (const ScanResult& r : verdict.best)
    tied += (tied.empty() ? "" : ", ") + r.serial.to_string();
  const auto [fewest, most] = std::minmax_element(
      verdict.best.begin(), verdict.best.end(),
      [](const ScanResult& a, const ScanResult& b) { return a.frames_ok < b.frames_ok; });
  std::printf("best: %zu settings alike (%llu to %llu frames with a good checksum): %s\n",
              verdict.best.size(), static_cast<unsigned long long>(fewest->frames_ok),
              static_cast<unsigned long long>(most->frames_ok), tied.c_str());
  std::printf("%s; capture with -s set as the bus's devices are\n", verdict.untold.c_str());
  return 0;
}

}  // namespace

ScanVerdict scan_line_settings(const CommonOptions& o, const std::string& path, double seconds,
                               const std::function<void(const ScanResult&)>& tried) {
  std::vector<ScanResult> results;
  for (const SerialConfig& serial : scan_settings()) {
    if (g_stop) break;
    ScanResult r = scan_one(o, path, serial, seconds);
    if (!r.error.empty() && r.bytes == 0) die(r.error, 1);
    tried(r);
    results.push_back(std::move(r));
  }
  return judge_scan(results);
}

// `drivetap capture -i PORT...`: live, listen-only capture from serial ports (src/sources/live/
// live_capture.hpp). A frame is printed about t3.5 + 3 ms after its last byte and every output is
// flushed each round; Ctrl-C, SIGTERM, -c, -a, an unplugged adapter (without --reconnect) or a
// failed write end the run with every file closed valid.
int run_capture(const CommonOptions& o, const CaptureOptions& c, const CaptureVoice& voice) {
  if (c.ports.empty()) die("capture: give at least one port with -i (e.g. -i /dev/ttyUSB0)");
  refuse_shared_files({{"-o", o.output}, {"-w", o.write}});
  // One port given twice (by two names too: a by-id link and its tty) would have two readers
  // share its bytes between them.
  std::vector<std::filesystem::path> paths;
  for (const std::string& port : c.ports) {
    const std::string path = port.substr(0, port.find('='));
    std::error_code ec;
    const std::filesystem::path real = std::filesystem::canonical(path, ec);
    paths.push_back(ec ? std::filesystem::path(path).lexically_normal() : real);
  }
  for (std::size_t k = 0; k < paths.size(); ++k)
    for (std::size_t j = 0; j < k; ++j)
      if (paths[k] == paths[j])
        die(fmt::format("-i {}: the same port as -i {}: give each port once",
                        printable(c.ports[k], false), printable(c.ports[j], false)),
            2);
  TimeNs autostop = 0;
  for (const std::string& a : c.autostop) {
    if (!a.starts_with("duration:")) die(fmt::format("-a {}: expected duration:SECONDS", a));
    double seconds = 0;
    std::size_t used = 0;
    try {
      seconds = std::stod(a.substr(9), &used);
    } catch (...) {
      used = 0;
    }
    if (used == 0 || used != a.size() - 9 || !(seconds > 0) || seconds > 1e9)
      die(fmt::format("-a {}: expected duration:SECONDS (e.g. duration:60)", a));
    autostop = static_cast<TimeNs>(seconds * 1e9);
  }
  std::optional<RingOptions> ring;
  for (const std::string& b : c.ring) {
    if (!ring) ring.emplace();
    if (const std::string why = parse_ring_option(b, *ring); !why.empty()) die(why);
  }
  RunSettings given;
  PipelineOptions p = make_pipeline_options(o, given);
  p.max_frames = o.count;
  ChannelTable channels;
  LiveCaptureOptions live_options;
  live_options.ports = c.ports;
  live_options.serial = p.serial;
  live_options.max_frames = o.count;
  live_options.duration = autostop;
  live_options.reconnect = c.reconnect;
  LiveCapture live(std::move(live_options), channels);
  for (std::size_t k = 0; k < c.ports.size(); ++k) {
    std::string error;
    if (!live.open_port(k, &error)) die(error, 1);
    for (const std::string& w : live.port(k).warnings()) {
      if (voice.chatty) say("warning: " + w);
      if (voice.warning) voice.warning(w);
    }
  }
  if (voice.chatty)
    std::fprintf(stderr, "drivetap: capturing on %s at %s (listen only; Ctrl-C stops)\n",
                 fmt::format("{}", fmt::join(c.ports, ", ")).c_str(), p.serial.to_string().c_str());
  Outputs out(o, channels, p, /*timed=*/true, ring ? &*ring : nullptr);
  out.set_reader_may_leave(voice.reader_may_leave);
  if (voice.outputs_open) voice.outputs_open();
  // Live times are wall-clock time; -t r counts from the start of the capture.
  out.set_clock(true, std::chrono::duration_cast<std::chrono::nanoseconds>(
                          std::chrono::system_clock::now().time_since_epoch())
                          .count());
  Pipeline pipeline(p, channels, out.sink());
  catch_stop_signals();

  LiveCaptureHooks hooks;
  hooks.port_lost = [](const std::string& error) { say(error); };
  hooks.warn = [&voice](const std::string& warning) {
    if (voice.chatty) say("warning: " + warning);
    if (voice.warning) voice.warning(warning);
  };
  hooks.port_back = [&voice](const std::string& port) {
    if (voice.chatty) std::fprintf(stderr, "drivetap: %s: reconnected\n", port.c_str());
  };
  hooks.flush = [&out, &pipeline, &voice] {
    const bool ok = out.flush();
    if (voice.each_round) voice.each_round(pipeline.stats());
    return ok;
  };
  const LiveCaptureEnd end = live.run(pipeline, hooks, g_stop);
  out.close();
  if (g_stop) {
    if (voice.chatty) std::fprintf(stderr, "drivetap: interrupted; output flushed and closed\n");
    return 130;
  }
  if (out.reader_left()) return 0;
  switch (end) {
    case LiveCaptureEnd::stopped:
      return 0;
    case LiveCaptureEnd::duration_reached:
      if (voice.chatty) say("capture stopped: autostop duration reached");
      return 0;
    case LiveCaptureEnd::frame_limit:
      if (voice.chatty) say(fmt::format("capture stopped: {} frames captured (-c)", o.count));
      return 0;
    case LiveCaptureEnd::adapter_lost:
      // (The port's own line said why.)
      if (voice.chatty) say("capture stopped: adapter lost");
      return 1;
    case LiveCaptureEnd::poll_failed:
      say(fmt::format("capture stopped: poll: {}", std::strerror(live.poll_errno())));
      return 1;
    case LiveCaptureEnd::output_failed:
      say("capture stopped: output write failed");
      return 1;
  }
  return 1;
}

Command add_capture_command(CLI::App& app) {
  auto o = std::make_shared<CommonOptions>();
  auto c = std::make_shared<CaptureOptions>();
  CLI::App* capture = app.add_subcommand(
      "capture", "Capture live from serial ports (listen only), decode as it comes");
  add_common_options(capture, *o, kCaptureCommand);
  capture
      ->add_option("-i,--interface", c->ports,
                   "Serial port to listen on, PATH or PATH=NAME (repeatable; NAME line.m and "
                   "line.s: the master and slave pairs of one 4-wire link)")
      ->allow_extra_args(false);
  capture->add_option("-a,--autostop", c->autostop, "Stop after duration:SECONDS");
  capture->add_option("-b,--ring-buffer", c->ring,
                      "With -w FILE: a ring of files, filesize:MB, duration:S, files:N");
  capture->add_flag("--reconnect", c->reconnect,
                    "Wait for an unplugged adapter to come back and go on");
  capture->add_flag("--scan", c->scan,
                    "Listen at each standard rate and format in turn (48 settings), say which "
                    "gives frames with good checksums, or which it cannot tell apart");
  capture->add_option("--scan-time", c->scan_seconds, "--scan: seconds per setting (default 2)");
  // How many times --scan-time was given: it does nothing without --scan.
  CLI::Option* scan_time = capture->get_option("--scan-time");
  return {capture, [o, c, scan_time] {
            refuse_idle_options(*o, kCaptureCommand);
            refuse_idle_capture_options(*o, *c, scan_time->count() > 0);
            return c->scan ? run_scan(*o, *c) : run_capture(*o, *c);
          }};
}

}  // namespace drivetap::app
