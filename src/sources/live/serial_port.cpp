// Serial-port capture source (src/sources/live/serial_port.hpp; docs/protocols.md §1).
#include "sources/live/serial_port.hpp"

// The kernel's termios2 (asm/termbits.h), not glibc's <termios.h>: only termios2 carries any
// integer baud rate (BOTHER). The two define `struct termios` differently, so <termios.h> must
// not be included here.
#include <asm/termbits.h>
#include <fcntl.h>
#include <fmt/format.h>
#include <linux/serial.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <climits>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>

#include "sources/logic/detect.hpp"

namespace drivetap {
namespace {

constexpr std::size_t kReadSize = 4096;              // n_tty's own buffer size
constexpr std::size_t kMaxBytesPerCall = 64 * 1024;  // then poll() again: other ports get a turn

constexpr std::size_t kHeldMinCharacters = 16;
constexpr TimeNs kLatencyPeriod = 16 * kNsPerMs;  // FTDI's default latency_timer
constexpr TimeNs kCadenceTolerance = 1500 * kNsPerUs;
constexpr TimeNs kCadenceMultiples = 4;

TimeNs clock_ns(clockid_t clock) {
  timespec ts{};
  ::clock_gettime(clock, &ts);
  return static_cast<TimeNs>(ts.tv_sec) * kNsPerSecond + ts.tv_nsec;
}

}  // namespace

TimeNs CaptureClock::monotonic() {
  return clock_ns(CLOCK_MONOTONIC);
}

// The realtime reading is paired with the middle of two monotonic ones.
CaptureClock CaptureClock::take() {
  const TimeNs mono_before = clock_ns(CLOCK_MONOTONIC);
  const TimeNs real = clock_ns(CLOCK_REALTIME);
  const TimeNs mono_after = clock_ns(CLOCK_MONOTONIC);
  return CaptureClock{real - (mono_before + (mono_after - mono_before) / 2)};
}

namespace {

ByteEvent plain(std::uint8_t byte) {
  ByteEvent e;
  e.byte = byte;
  return e;
}

// "ttyUSB0" for /dev/ttyUSB0 and for a /dev/serial/by-id link to it, "pts/3" for /dev/pts/3:
// the name under /dev of the device the path leads to, else the path's last component.
std::string device_name(const std::string& resolved) {
  if (resolved.starts_with("/dev/") && resolved.size() > 5) return resolved.substr(5);
  const std::size_t slash = resolved.rfind('/');
  return slash == std::string::npos ? resolved : resolved.substr(slash + 1);
}

std::string resolve(const std::string& path) {
  char* real = ::realpath(path.c_str(), nullptr);
  if (real == nullptr) return path;
  std::string out(real);
  std::free(real);
  return out;
}

std::string base_name(const std::string& path) {
  const std::size_t slash = path.rfind('/');
  return slash == std::string::npos ? path : path.substr(slash + 1);
}

// "8E1" as termios flags say it.
std::string format_text(tcflag_t cflag) {
  int data_bits = 8;
  switch (cflag & CSIZE) {
    case CS5:
      data_bits = 5;
      break;
    case CS6:
      data_bits = 6;
      break;
    case CS7:
      data_bits = 7;
      break;
    default:
      break;
  }
  const char parity = (cflag & PARENB) == 0 ? 'N' : (cflag & PARODD) != 0 ? 'O' : 'E';
  return fmt::format("{}{}{}", data_bits, parity, (cflag & CSTOPB) != 0 ? 2 : 1);
}

tcflag_t format_flags(const SerialConfig& s) {
  tcflag_t flags = 0;
  switch (s.data_bits) {
    case 5:
      flags |= CS5;
      break;
    case 6:
      flags |= CS6;
      break;
    case 7:
      flags |= CS7;
      break;
    default:
      flags |= CS8;
      break;
  }
  if (s.parity != Parity::none) flags |= PARENB;
  if (s.parity == Parity::odd) flags |= PARODD;
  if (s.stop_bits == 2) flags |= CSTOPB;
  return flags;
}

constexpr tcflag_t kFormatMask = CSIZE | PARENB | PARODD | CSTOPB | CMSPAR;

std::uint64_t rise(std::uint32_t now, std::uint32_t before) {
  return static_cast<std::uint32_t>(now - before);  // the kernel's int counters wrap
}

// The kernel's counters as TIOCGICOUNT gives them (32 bits, wrapping).
SerialPort::KernelCounters<std::uint32_t> kernel_counts(const serial_icounter_struct& c) {
  const auto raw = [](int count) { return static_cast<std::uint32_t>(count); };
  return {raw(c.rx), raw(c.frame), raw(c.parity), raw(c.brk), raw(c.overrun), raw(c.buf_overrun)};
}

}  // namespace

// --- ParmrkDecoder -------------------------------------------------------------------------

void ParmrkDecoder::push(std::span<const std::uint8_t> marked, UartErrorCounts& unexplained,
                         std::vector<ByteEvent>& out) {
  for (const std::uint8_t b : marked) {
    switch (state_) {
      case State::data:
        if (b == 0xFF) {
          state_ = State::after_ff;
        } else {
          out.push_back(plain(b));
        }
        break;
      case State::after_ff:
        if (b == 0x00) {
          state_ = State::after_ff_00;
        } else {
          // \377 \377 is a data 0xFF. Linux writes no other \377 Y; should one come, the 0xFF
          // is taken as data and Y read as the next byte, so no byte is lost.
          out.push_back(plain(0xFF));
          if (b != 0xFF) out.push_back(plain(b));
          state_ = State::data;
        }
        break;
      case State::after_ff_00:
        emit_marked(b, unexplained, out);
        state_ = State::data;
        break;
    }
  }
}

void ParmrkDecoder::emit_marked(std::uint8_t byte, UartErrorCounts& unexplained,
                                std::vector<ByteEvent>& out) {
  ByteEvent e = plain(byte);
  if (byte != 0x00) {
    e.flags = error_flags(unexplained);
  } else if (unexplained.breaks > 0) {
    --unexplained.breaks;
    e.flags = kUartBreak;
  } else if (unexplained.framing > 0 || unexplained.parity > 0) {
    e.flags = error_flags(unexplained);
  } else {
    e.flags = kUartBreak;
  }
  out.push_back(e);
}

std::uint8_t ParmrkDecoder::error_flags(UartErrorCounts& unexplained) const {
  if (!parity_checked_) {
    // A UART that checks no parity reports no parity error: the mark is a framing error.
    if (unexplained.framing > 0) --unexplained.framing;
    return kUartFramingError;
  }
  if (unexplained.framing == 0 && unexplained.parity == 0)
    return kUartFramingError | kUartParityError;
  if (unexplained.framing > unexplained.parity) {
    --unexplained.framing;
    return kUartFramingError;
  }
  --unexplained.parity;
  return kUartParityError;
}

// --- ByteTimeBackdater ---------------------------------------------------------------------

void ByteTimeBackdater::stamp(std::span<ByteEvent> read_characters, TimeNs read_time) {
  const auto n = static_cast<TimeNs>(read_characters.size());
  const TimeNs limit = read_time + kMaxLead;
  bool held = false;
  for (TimeNs k = 0; k < n; ++k) {
    TimeNs start = read_time - (n - k) * character_time_;
    if (have_previous_ && start < previous_end_) start = previous_end_;
    if (start > limit) {
      // (not below the previous stamp, should the clock have stepped back)
      start = have_previous_ ? std::max(limit, previous_start_) : limit;
      held = true;
    }
    read_characters[static_cast<std::size_t>(k)].time = start;
    previous_start_ = start;
    previous_end_ = start + character_time_;
    have_previous_ = true;
  }
  if (held) ++overrun_reads_;
}

// --- ReadPatternMonitor --------------------------------------------------------------------

ReadPatternMonitor::ReadPatternMonitor(const SerialConfig& serial)
    : character_time_(serial.character_time()),
      t35_(serial.t35()),
      bits_per_character_(serial.bits_per_character()),
      settings_(serial.to_string()) {}

void ReadPatternMonitor::add_read(TimeNs read_time, std::size_t characters) {
  if (characters == 0) return;
  ++reads_;
  characters_ += characters;
  largest_read_ = std::max(largest_read_, characters);

  const TimeNs wire_span = static_cast<TimeNs>(characters - 1) * character_time_;
  if (characters >= kHeldMinCharacters && wire_span >= t35_) ++held_reads_;

  // A 16 ms hold matters only where it can swallow a t3.5 silence.
  if (have_previous_ && characters >= 2 && kLatencyPeriod >= t35_) {
    const TimeNs gap = read_time - previous_read_time_;
    if (gap >= kLatencyPeriod - kCadenceTolerance &&
        gap <= kCadenceMultiples * kLatencyPeriod + kCadenceTolerance) {
      ++cadence_candidates_;
      const TimeNs nearest = (gap + kLatencyPeriod / 2) / kLatencyPeriod * kLatencyPeriod;
      if (std::abs(gap - nearest) <= kCadenceTolerance) ++cadence_reads_;
    }
  }
  // One character after one character, within a few character times: a stream handed over as it
  // arrives, whose spacing is the line's.
  if (have_previous_ && characters == 1 && previous_characters_ == 1 &&
      arrivals_.size() < kArrivalSamples) {
    const TimeNs gap = read_time - previous_read_time_;
    if (gap > 0 && gap < 4 * character_time_) {
      arrivals_.push_back(gap);
      if (arrivals_.size() == kArrivalSamples / 2 || arrivals_.size() == kArrivalSamples) {
        std::vector<TimeNs> sorted = arrivals_;
        std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
        const TimeNs median = sorted[sorted.size() / 2];
        if (median * 4 < character_time_ * 3) {
          untrusted_by_rate_ = true;
          arrival_median_ = median;
        }
      }
    }
  }
  previous_read_time_ = read_time;
  previous_characters_ = characters;
  have_previous_ = true;

  if (held_reads_ >= 3 && held_reads_ * 10 >= reads_) untrusted_by_held_ = true;
  if (cadence_reads_ >= 8 && cadence_reads_ * 4 >= cadence_candidates_ * 3)
    untrusted_by_cadence_ = true;
  trusted_ = !untrusted_by_held_ && !untrusted_by_cadence_ && !untrusted_by_rate_;
}

std::string ReadPatternMonitor::verdict() const {
  if (trusted_) {
    return fmt::format("timing trusted: {} reads of at most {} characters, no USB burst pattern",
                       reads_, largest_read_);
  }
  std::string evidence;
  if (untrusted_by_held_) {
    evidence = fmt::format("{} of {} reads brought {} or more characters at once, up to {}",
                           held_reads_, reads_, kHeldMinCharacters, largest_read_);
  }
  if (untrusted_by_cadence_) {
    if (!evidence.empty()) evidence += "; ";
    evidence += fmt::format(
        "{} of {} reads 15..65 ms apart fell on a 16 ms grid, as with an FTDI latency_timer",
        cadence_reads_, cadence_candidates_);
  }
  if (untrusted_by_rate_) {
    const double implied = static_cast<double>(bits_per_character_) * kNsPerSecond /
                           static_cast<double>(arrival_median_);
    const double standard = phy::snap_to_standard_baud(implied);
    const std::string rate =
        standard > 0 ? fmt::format("{:.0f}", standard) : fmt::format("about {:.0f}", implied);
    const std::string line = fmt::format(
        "characters arrive every {} us (median of {} back to back), faster than {} carries one "
        "({} us): the line runs at {} baud ({} bits a character), or the port is a pty or a "
        "network port that does not keep the line's pace; check -s",
        arrival_median_ / kNsPerUs, arrivals_.size(), settings_, character_time_ / kNsPerUs, rate,
        bits_per_character_);
    if (evidence.empty()) return "timing not trusted: " + line;
    evidence += "; " + line;
  }
  return fmt::format(
      "timing not trusted: USB burst artefacts ({}): the per-byte times carry no inter-frame "
      "silence, framing must rely on content",
      evidence);
}

// --- SerialPort ----------------------------------------------------------------------------

SerialPort::SerialPort(int fd, const SerialPortOptions& o, ChannelId channel)
    : fd_(fd),
      path_(o.path),
      serial_(o.serial),
      channel_(channel),
      decoder_(o.serial.parity != Parity::none),
      backdater_(o.serial.character_time()),
      monitor_(o.serial) {}

SerialPort::~SerialPort() {
  if (fd_ >= 0) ::close(fd_);
}

std::unique_ptr<SerialPort> SerialPort::open(const SerialPortOptions& o, ChannelTable& channels,
                                             std::string* error) {
  auto fail = [&](const std::string& reason, int err) {
    if (error != nullptr) *error = fmt::format("{}: {} ({})", o.path, reason, std::strerror(err));
    return nullptr;
  };
  const SerialConfig& s = o.serial;
  if (s.data_bits > 8)
    return fail(fmt::format("cannot use line settings {}: a serial port reads 5 to 8 data bits "
                            "(record a 9-bit line with a logic analyser)",
                            s.to_string()),
                EINVAL);
  if (s.baud == 0 || s.data_bits < 5 || s.stop_bits < 1 || s.stop_bits > 2)
    return fail(fmt::format("cannot use line settings {}", s.to_string()), EINVAL);

  const int fd = ::open(o.path.c_str(), O_RDONLY | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) return fail("cannot open", errno);
  // Owns the fd from here: closed on every failure below.
  std::unique_ptr<SerialPort> port(new SerialPort(fd, o, 0));

  struct stat st {};
  if (::fstat(fd, &st) != 0) return fail("cannot open", errno);
  if (S_ISDIR(st.st_mode)) return fail("not a serial port", EISDIR);
  termios2 tio{};
  if (::ioctl(fd, TCGETS2, &tio) != 0) {
    if (errno == ENOTTY || errno == EINVAL) return fail("not a serial port", ENOTTY);
    return fail("cannot read the line settings", errno);
  }

  // Raw: no input translation, no flow control (IXON would eat 0x11/0x13), no echo, no signals.
  // INPCK|PARMRK mark errors; IGNPAR, ISTRIP, IGNBRK and BRKINT stay off, so nothing is dropped
  // or altered. HUPCL is kept as it was: it only concerns the modem lines at close.
  tio.c_iflag = INPCK | PARMRK;
  tio.c_oflag = 0;
  tio.c_lflag = 0;
  tio.c_cflag =
      (tio.c_cflag & HUPCL) | format_flags(s) | CREAD | CLOCAL | BOTHER | (BOTHER << IBSHIFT);
  tio.c_ispeed = s.baud;
  tio.c_ospeed = s.baud;
  std::fill(std::begin(tio.c_cc), std::end(tio.c_cc), cc_t{0});
  tio.c_cc[VMIN] = 1;  // see the header: an empty tty then gives EAGAIN, a gone one 0
  tio.c_cc[VTIME] = 0;
  if (::ioctl(fd, TCSETS2, &tio) != 0)
    return fail(fmt::format("cannot set {}", s.to_string()), errno);

  termios2 set{};
  if (::ioctl(fd, TCGETS2, &set) == 0) {
    // Drivers take the nearest rate their clock divides to, or refuse one and fall back.
    const std::uint32_t got = set.c_ispeed;
    const std::uint64_t off = got > s.baud ? got - s.baud : s.baud - got;
    if (off * 100 > s.baud) {
      port->warnings_.push_back(
          fmt::format("{}: the driver set {} baud, not {}: the adapter cannot make that rate",
                      o.path, got, s.baud));
    }
    // Marks can only be parity errors where the UART really checks parity.
    port->decoder_ = ParmrkDecoder((set.c_cflag & PARENB) != 0);
    if ((set.c_cflag & kFormatMask) != (tio.c_cflag & kFormatMask)) {
      port->warnings_.push_back(
          fmt::format("{}: the driver set {}, not {}: the adapter does not support that format",
                      o.path, format_text(set.c_cflag), format_text(tio.c_cflag)));
    }
  }
  // Whatever arrived before the settings took effect was read at the wrong rate or format.
  ::ioctl(fd, TCFLSH, TCIFLUSH);

  if (o.low_latency) {
    serial_struct info{};
    if (::ioctl(fd, TIOCGSERIAL, &info) != 0) {
      port->warnings_.push_back(
          fmt::format("{}: low-latency mode not supported by this driver", o.path));
    } else if ((info.flags & ASYNC_LOW_LATENCY) == 0) {
      info.flags |= ASYNC_LOW_LATENCY;
      if (::ioctl(fd, TIOCSSERIAL, &info) != 0) {
        port->warnings_.push_back(
            fmt::format("{}: low-latency mode not set ({})", o.path, std::strerror(errno)));
      }
    }
  }

  // FTDI adapters hold received bytes until their latency timer runs out (16 ms by default).
  // Read after setting low latency: ftdi_sio lowers the timer to 1 ms for it.
  const std::string resolved = resolve(o.path);
  const std::string kernel_name = base_name(resolved);
  for (const std::string& timer_path :
       {fmt::format("{}/class/tty/{}/device/latency_timer", o.sysfs_root, kernel_name),
        fmt::format("{}/bus/usb-serial/devices/{}/latency_timer", o.sysfs_root, kernel_name)}) {
    std::FILE* f = std::fopen(timer_path.c_str(), "re");
    if (f == nullptr) continue;
    char text[32] = {};
    const bool read_ok = std::fgets(text, sizeof text, f) != nullptr;
    std::fclose(f);
    if (!read_ok) continue;
    const long ms = std::strtol(text, nullptr, 10);
    if (ms > 1) {
      port->warnings_.push_back(fmt::format(
          "{}: FTDI latency_timer is {} ms: the adapter holds received bytes up to {} ms and the "
          "silence between frames is lost; fix: echo 1 > {}",
          o.path, ms, ms, timer_path));
    }
    break;
  }

  serial_icounter_struct icount{};
  if (::ioctl(fd, TIOCGICOUNT, &icount) == 0) {
    port->counters_available_ = true;
    port->last_kernel_ = kernel_counts(icount);
  }

  port->wall_offset_ = o.clock.value_or(CaptureClock::take()).wall_offset;

  // Named as the user gave it (a udev or test symlink says more than the pts it points to).
  const std::string name = device_name(o.path);
  port->channel_ = o.channel_name.empty() ? channels.intern(name, name, ChannelRole::bus)
                                          : channels.intern(o.channel_name);
  return port;
}

bool SerialPort::hung_up() const {
  pollfd p{fd_, POLLIN, 0};
  return ::poll(&p, 1, 0) > 0 && (p.revents & (POLLHUP | POLLERR | POLLNVAL)) != 0;
}

SerialPort::Counters SerialPort::refresh_counters() {
  Counters up;
  if (!counters_available_) return up;
  serial_icounter_struct icount{};
  if (::ioctl(fd_, TIOCGICOUNT, &icount) != 0) return up;
  const KernelCounts now = kernel_counts(icount);
  // Each counter's rise, added to its total since open.
  const auto count = [&](std::uint64_t Counters::*total, std::uint32_t KernelCounts::*raw) {
    up.*total = rise(now.*raw, last_kernel_.*raw);
    counters_.*total += up.*total;
  };
  count(&Counters::rx, &KernelCounts::rx);
  count(&Counters::frame, &KernelCounts::frame);
  count(&Counters::parity, &KernelCounts::parity);
  count(&Counters::brk, &KernelCounts::brk);
  count(&Counters::overrun, &KernelCounts::overrun);
  count(&Counters::buf_overrun, &KernelCounts::buf_overrun);
  last_kernel_ = now;
  return up;
}

bool SerialPort::read_available(std::vector<ByteEvent>& out) {
  if (!error_.empty()) return false;
  raw_.clear();
  chunks_.clear();
  bool gone = false;
  int failure = 0;  // errno of a read error other than "gone"
  std::uint8_t buffer[kReadSize];
  while (raw_.size() < kMaxBytesPerCall) {
    const ssize_t n = ::read(fd_, buffer, sizeof buffer);
    if (n > 0) {
      const TimeNs read_time = CaptureClock::monotonic() + wall_offset_;
      raw_.insert(raw_.end(), buffer, buffer + n);
      chunks_.push_back({raw_.size(), read_time});
      continue;
    }
    if (n == 0) {
      gone = hung_up();
      break;
    }
    const int err = errno;
    if (err == EINTR) continue;
    if (err == EAGAIN || err == EWOULDBLOCK) break;
    if (err == EIO || err == ENODEV || err == ENXIO) gone = true;
    failure = err;
    break;
  }

  // The kernel counts a character before the line discipline marks it, so the counters read
  // after the reads cover every mark the reads brought.
  const Counters up = refresh_counters();
  unexplained_.framing += up.frame;
  unexplained_.parity += up.parity;
  unexplained_.breaks += up.brk;
  if (up.overrun + up.buf_overrun > 0) overrun_pending_ = true;

  std::size_t begin = 0;
  for (const ReadChunk& chunk : chunks_) {
    const std::size_t first = out.size();
    decoder_.push(std::span(raw_).subspan(begin, chunk.end - begin), unexplained_, out);
    ++reads_;
    bytes_read_ += chunk.end - begin;
    begin = chunk.end;
    const std::span<ByteEvent> fresh = std::span(out).subspan(first);
    for (ByteEvent& e : fresh) e.channel = channel_;
    if (!fresh.empty() && overrun_pending_) {
      fresh.front().flags |= kUartOverrun;  // characters were lost before this one
      overrun_pending_ = false;
    }
    backdater_.stamp(fresh, chunk.time);
    monitor_.add_read(chunk.time, fresh.size());
  }
  // Counts still unmatched may belong to characters the next call brings (counted, not yet
  // passed on); older ones never will (their characters were dropped), so they are let go.
  unexplained_.framing = std::min(unexplained_.framing, up.frame);
  unexplained_.parity = std::min(unexplained_.parity, up.parity);
  unexplained_.breaks = std::min(unexplained_.breaks, up.brk);

  if (gone) {
    const char* why = failure != 0 ? ::strerrorname_np(failure) : "hangup";
    error_ = fmt::format("{}: adapter unplugged or gone ({})", path_, why != nullptr ? why : "?");
    return false;
  }
  if (failure != 0) {
    error_ = fmt::format("{}: read failed ({})", path_, std::strerror(failure));
    return false;
  }
  return true;
}

std::vector<std::string> SerialPort::notes() const {
  std::vector<std::string> out;
  if (counters_available_) {
    out.push_back(fmt::format(
        "{}: kernel counters since open: {} received, {} framing errors, {} parity errors, {} "
        "breaks, {} overruns, {} buffer overruns",
        path_, counters_.rx, counters_.frame, counters_.parity, counters_.brk, counters_.overrun,
        counters_.buf_overrun));
  } else {
    out.push_back(
        fmt::format("{}: no kernel counters (TIOCGICOUNT not supported by this driver)", path_));
  }
  out.push_back(fmt::format("{}: {} reads, {} bytes read, {} characters", path_, reads_,
                            bytes_read_, monitor_.characters()));
  out.push_back(fmt::format("{}: {}", path_, monitor_.verdict()));
  if (backdater_.overrun_reads() > 0)
    out.push_back(fmt::format(
        "{}: bytes came faster than {} can carry ({} reads): their times could not follow the "
        "line rate, and were held at most 500 ms ahead of their arrival, in arrival order "
        "(wrong line settings, a pty or network port, or a flooded port)",
        path_, serial_.to_string(), backdater_.overrun_reads()));
  return out;
}

}  // namespace drivetap
