// drivetap-simbus: simulated RS-485 Modbus RTU bus on a pty (docs/protocols.md §1, §2).
//
// A master polls drives 1..3 and an absent station; each byte leaves at its time on the wire for
// the given line settings, or in bursts like a USB adapter's latency timer. A capture program
// opens the pty's slave (through --link) as it would open /dev/ttyUSB0; --truth writes what was
// sent as a drivetap byte log to compare the capture with.
#include <fmt/format.h>
#include <sys/stat.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <atomic>
#include <cerrno>
#include <charconv>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <string>
#include <string_view>

#include "core/serial_config.hpp"
#include "tools/simbus_core.hpp"

namespace {

using namespace drivetap;
using namespace drivetap::simbus;

std::atomic<bool> g_stop{false};
static_assert(std::atomic<bool>::is_always_lock_free, "the stop flag is set in a signal handler");

void on_signal(int) {
  g_stop.store(true, std::memory_order_relaxed);
}

[[noreturn]] void die(const std::string& message, int code) {
  std::fprintf(stderr, "simbus: %s\n", message.c_str());
  std::exit(code);
}

bool parse_chars(std::string_view text, double* out) {
  const auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), *out);
  return ec == std::errc{} && ptr == text.data() + text.size() && *out >= 0 && *out <= 1e6;
}

// --gap N (both gaps) or REPLY,NEXT, in characters.
void parse_gap(const std::string& text, TrafficOptions* t) {
  const std::size_t comma = text.find(',');
  const std::string_view all(text);
  double reply = 0;
  double next = 0;
  const bool ok = comma == std::string::npos ? parse_chars(all, &reply) && parse_chars(all, &next)
                                             : parse_chars(all.substr(0, comma), &reply) &&
                                                   parse_chars(all.substr(comma + 1), &next);
  if (!ok)
    die(fmt::format("--gap: expected characters as N or REPLY,NEXT (e.g. 5,10), not '{}'", text),
        2);
  t->gap_reply_chars = reply;
  t->gap_next_chars = next;
}

// The link is a symlink to the slave, put in place with rename() so that a reader never sees the
// path missing. An existing symlink (a previous run's) is replaced; anything else is refused, as
// --link given a capture file by mistake must not delete it.
void make_link(const std::string& link, const std::string& target) {
  struct stat st {};
  if (lstat(link.c_str(), &st) == 0 && !S_ISLNK(st.st_mode))
    die(fmt::format("--link {}: exists and is not a symlink (not replaced)", link), 1);
  const std::string tmp = fmt::format("{}.simbus-{}", link, getpid());
  unlink(tmp.c_str());
  if (symlink(target.c_str(), tmp.c_str()) != 0 || rename(tmp.c_str(), link.c_str()) != 0) {
    const int e = errno;
    unlink(tmp.c_str());
    die(fmt::format("--link {}: {}", link, std::strerror(e)), 1);
  }
}

// Removed only while it still points at our pty: another run may have taken the path over.
void remove_link(const std::string& link, const std::string& target) {
  char buf[256];
  const ssize_t n = readlink(link.c_str(), buf, sizeof buf);
  if (n > 0 && std::string_view(buf, static_cast<std::size_t>(n)) == target) unlink(link.c_str());
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "drivetap-simbus: a simulated RS-485 bus (Modbus RTU master polling drives) on a "
      "pseudo-terminal"};
  std::string link;
  int wait_ms = 500;
  std::uint64_t frames = 0;
  double duration = 0;
  std::uint64_t seed = 1;
  std::string serial_text;
  std::string gap_text;
  bool back_to_back = false;
  int burst_ms = 0;
  double noise = 0;
  std::string truth_path;
  bool soak = false;
  bool verbose = false;
  bool realtime = false;
  int spin_us = static_cast<int>(kDefaultSpin / kNsPerUs);
  app.add_option("--link", link, "Make the pty's slave reachable at PATH (a symlink)")
      ->type_name("PATH");
  app.add_option("--wait-ms", wait_ms, "Wait before sending, for a reader to open the pty")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_option("--frames", frames, "Stop after N frames (default, 0: no limit)");
  app.add_option("--duration", duration, "Stop after S seconds (default: no limit; --soak 600)")
      ->check(CLI::Range(1e-3, 1e7));
  app.add_option("--seed", seed, "Seed of the traffic (same seed, same bytes)")
      ->capture_default_str();
  app.add_option("-s,--serial", serial_text,
                 "Line settings, e.g. \"19200 8E1\" (default 9600 8N1; --soak 115200 8N1)");
  auto* gap = app.add_option("--gap", gap_text,
                             "Silence between frames in characters: N, or REPLY,NEXT (request -> "
                             "reply, reply -> next request; default 5,10)");
  app.add_flag("--back-to-back", back_to_back, "Frames exactly 3.5 characters apart")
      ->excludes(gap);
  app.add_option("--burst", burst_ms,
                 "Write what is due every MS milliseconds in one write(), like a USB adapter's "
                 "latency timer (default: byte by byte)")
      ->check(CLI::Range(1, 10000));
  app.add_option("--noise", noise, "Probability per gap of 1..3 garbage bytes in it")
      ->check(CLI::Range(0.0, 1.0));
  app.add_option("--truth", truth_path, "Write what was sent to FILE as a drivetap byte log")
      ->type_name("FILE");
  app.add_flag("--soak", soak,
               "Soak: 115200 8N1 (unless -s), back to back, 600 s (unless --duration), bytes "
               "written every 10 s");
  auto* spin = app.add_option("--spin-us", spin_us,
                              "Byte by byte: busy-wait the last US microseconds before each byte "
                              "(at most half a character; default 50, 0 with --soak)")
                   ->check(CLI::Range(0, 1000));
  app.add_flag("--realtime", realtime,
               "Run at SCHED_FIFO priority 10 (root): bytes stay on time on a busy machine");
  app.add_flag("-v,--verbose", verbose, "Also print how late bytes left against their schedule");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  }

  TrafficOptions t;
  t.seed = seed;
  t.noise_rate = noise;
  t.back_to_back = back_to_back || soak;
  if (!gap_text.empty()) parse_gap(gap_text, &t);
  if (soak && !gap_text.empty()) die("--gap: not with --soak (frames are back to back)", 2);
  SerialConfig base;
  if (soak) base.baud = 115200;
  if (!serial_text.empty()) {
    std::string err;
    auto s = SerialConfig::parse(serial_text, &err, base);
    if (!s) die(fmt::format("--serial: {}", err), 2);
    base = *s;
  }
  t.serial = base;
  if (soak && duration == 0) duration = 600;

  RunOptions r;
  r.frames = frames;
  r.duration = static_cast<TimeNs>(duration * 1e9);
  r.burst = static_cast<TimeNs>(burst_ms) * kNsPerMs;
  r.progress_every = soak ? 10 * kNsPerSecond : 0;
  // The soak is about throughput, and spinning for 10 minutes would take a core from the reader.
  r.spin = soak && spin->count() == 0 ? 0 : static_cast<TimeNs>(spin_us) * kNsPerUs;

  std::FILE* truth = nullptr;
  if (!truth_path.empty()) {
    truth = std::fopen(truth_path.c_str(), "w");
    if (truth == nullptr) die(fmt::format("--truth {}: {}", truth_path, std::strerror(errno)), 1);
    // A large buffer: the file is written from the timing loop and should rarely touch the disk.
    std::setvbuf(truth, nullptr, _IOFBF, 1 << 20);
  }
  std::string err;
  auto pty = Pty::open(&err);
  if (!pty) die(fmt::format("pty: {}", err), 1);
  if (!link.empty()) {
    make_link(link, pty->slave_path());
    fmt::print(stderr, "simbus: {} -> {}\n", link, pty->slave_path());
  } else {
    fmt::print(stderr, "simbus: {}\n", pty->slave_path());
  }

  struct sigaction sa {};
  sa.sa_handler = on_signal;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = 0;  // no SA_RESTART: a signal ends clock_nanosleep at once
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);

  const TimeNs wait_end = monotonic_now() + static_cast<TimeNs>(wait_ms) * kNsPerMs;
  while (!g_stop.load() && monotonic_now() < wait_end) {
    const TimeNs left = std::min<TimeNs>(wait_end - monotonic_now(), 100 * kNsPerMs);
    if (left > 0) {
      timespec ts{static_cast<time_t>(left / kNsPerSecond), static_cast<long>(left % kNsPerSecond)};
      nanosleep(&ts, nullptr);
    }
  }

  // Not the default: it needs the privilege and, spinning, may take the CPU the reader needs on
  // a one-core machine.
  if (std::string why; realtime && !set_realtime(10, &why))
    fmt::print(stderr, "simbus: --realtime: {}; running at normal priority\n", why);
  r.t0 = monotonic_now();
  Traffic traffic(t);
  RunHooks hooks;
  if (truth != nullptr) {
    write_truth_header(truth, t, r);
    hooks.sent = [truth, t15 = t.serial.t15()](const Record& rec, std::size_t dropped) {
      write_truth_record(truth, rec, dropped, t15);
    };
  }
  hooks.progress = [](const RunStats& s) {
    fmt::print(stderr, "simbus: {} s: {} bytes written{}\n", s.elapsed / kNsPerSecond, s.bytes,
               s.dropped > 0 ? fmt::format(", {} dropped (pty buffer full)", s.dropped) : "");
  };
  const RunStats st = g_stop.load() ? RunStats{} : run(pty->master(), traffic, r, &g_stop, hooks);

  pty->drain(200 * kNsPerMs);  // nobody reading: give up after 200 ms
  if (!link.empty()) remove_link(link, pty->slave_path());
  int status = 0;
  if (truth != nullptr) {
    if (st.dropped > 0)
      fmt::print(truth, "# {} bytes dropped in all: the pty's buffer was full\n", st.dropped);
    const bool failed = std::ferror(truth) != 0;
    if (std::fclose(truth) != 0 || failed) {
      fmt::print(stderr, "simbus: --truth {}: write error\n", truth_path);
      status = 1;
    }
  }
  fmt::print(stderr, "simbus: sent {} frames ({} garbage records), {} bytes in {:.3f} s{}\n",
             st.frames, st.garbage, st.bytes, static_cast<double>(st.elapsed) / 1e9,
             st.dropped > 0
                 ? fmt::format(", {} bytes dropped (pty buffer full: nobody reading)", st.dropped)
                 : "");
  if (verbose && st.late.count() > 0)
    fmt::print(stderr,
               "simbus: bytes written late against schedule: median {} us, 99% {} us, "
               "max {} us\n",
               st.late.quantile(0.5) / kNsPerUs, st.late.quantile(0.99) / kNsPerUs,
               st.late.max() / kNsPerUs);
  if (!st.error.empty()) {
    fmt::print(stderr, "simbus: {}\n", st.error);
    status = 1;
  }
  return status;
}
