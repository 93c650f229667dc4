// Serial-port capture source (docs/protocols.md §1 line and timing): a tty opened
// listen-only in raw mode, each byte stamped from the read that brought it, UART errors kept.
//
// Opening: O_RDONLY|O_NOCTTY|O_NONBLOCK|O_CLOEXEC (the port is never written to), then termios2
// (TCSETS2 with BOTHER, so any integer baud rate: 10700, 250000) in raw mode: CREAD|CLOCAL, no
// flow control, no input translation, INPCK|PARMRK so that parity and framing errors and breaks
// are marked in the byte stream instead of passed on as plain bytes or dropped. Input received
// before the settings took effect is discarded. The settings are read back: a rate more than 1 %
// off or a format the driver did not take is a warning (a pty's driver forces 8N1 whatever is
// asked), and marks count as parity errors only where parity is really checked. TCSETS2 with
// BOTHER works on pseudo-terminals (the speed reads back as set), so ptys need no fallback.
//
// VMIN is 1, not 0: with O_NONBLOCK neither blocks, but with VMIN=0 a read of an empty tty
// returns 0 exactly as a hung-up one does (a pty whose master closed, an unplugged USB adapter),
// while with VMIN=1 an empty tty gives EAGAIN and 0 means the other end is gone. A 0 is still
// confirmed with poll() (POLLHUP), since termios are shared by every process holding the port.
//
// Times: CLOCK_MONOTONIC right after each read(), mapped to wall time (ns since the Unix epoch)
// by one offset CLOCK_REALTIME - CLOCK_MONOTONIC taken at open, so times never jump when NTP
// steps the clock. Bytes are back-dated from the read time by the character time
// (ByteTimeBackdater). ByteEvent::origin stays 0: reads are not packets, and a read holding
// several frames or part of one is how serial ports work, not a capture tool's mistake.
//
// Modem lines are left as the driver sets them on open (usually DTR and RTS raised): dropping
// them would stop converters powered from DTR/RTS, and keeping them cannot make a USB-RS485
// adapter with automatic direction control transmit. An RS-232 converter that enables its
// transmitter with RTS would drive the bus: do not tap a bus through one.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "core/byte_event.hpp"
#include "core/serial_config.hpp"
#include "core/time.hpp"

namespace drivetap {

// CLOCK_MONOTONIC mapped to the wall clock once. Every port of a capture and the capture loop share
// one mapping, so that byte times of different ports (and of a port reopened after --reconnect)
// compare with each other and with the loop's clock, and an NTP step during the run moves nothing.
struct CaptureClock {
  TimeNs wall_offset = 0;  // CLOCK_REALTIME - CLOCK_MONOTONIC when taken

  static CaptureClock take();
  static TimeNs monotonic();
  [[nodiscard]] TimeNs now() const { return monotonic() + wall_offset; }  // wall time
};

struct SerialPortOptions {
  std::string path;         // /dev/ttyUSB0, /dev/serial/by-id/..., /dev/pts/3
  SerialConfig serial;      // baud (any integer rate), data bits, parity, stop bits
  bool low_latency = true;  // ASYNC_LOW_LATENCY where the driver supports it
  // Where sysfs is mounted (tests put a fake latency_timer under a temporary directory).
  std::string sysfs_root = "/sys";
  // Empty: the port's name as given, under /dev or else its file name ("ttyUSB0", "bus0"), role
  // bus, a link of its own.
  // Otherwise interned as written, so "m"/"s" or "link.m"/"link.s" give a direction and a link
  // (two ports on the two pairs of a 4-wire line).
  std::string channel_name;
  // The capture's clock; unset: taken when the port opens.
  std::optional<CaptureClock> clock;
};

// Error marks the kernel counted (TIOCGICOUNT deltas) that no PARMRK mark has been matched with
// yet: the decoder spends them on the marks it meets to tell which error each one was.
struct UartErrorCounts {
  std::uint64_t framing = 0;
  std::uint64_t parity = 0;
  std::uint64_t breaks = 0;
};

// Undoes PARMRK marking, across arbitrary read boundaries (a sequence cut by the end of one push
// is completed by the next):
//   \377 \377  -> data byte 0xFF
//   \377 \0 X  -> X received with a parity or framing error (X may be 0xFF: not doubled then)
//   \377 \0 \0 -> a break (byte 0x00, kUartBreak), or a 0x00 with a parity or framing error:
//                 the kernel marks both the same way
//   \377 Y     -> (never written by Linux) 0xFF as data, then Y read afresh
// Linux does not say which error a mark stands for; the kernel's counters do, per port. The
// mark takes the kind `unexplained` has counts of, spending one:
//   \377 \0 X (X != 0): parity not checked (8N1, 8N2) -> framing; only framing counted ->
//     framing; only parity counted -> parity; both -> the kind with more counts, on a tie parity
//     (the 8250 and ftdi_sio count a character with both errors as a parity error); neither (a
//     pty, a driver without counters) -> kUartFramingError|kUartParityError: "one of the two, the
//     driver did not say which" — a damaged character either way, and diagnosis then says
//     settings-mismatch rather than guessing parity-mismatch.
//   \377 \0 \0: breaks counted -> break; else framing or parity counted -> 0x00 with that error
//     (as above); nothing counted -> break (PARMRK's documented meaning).
// Output events carry byte and flags only (time 0, channel 0): the caller stamps them.
class ParmrkDecoder {
 public:
  explicit ParmrkDecoder(bool parity_checked) : parity_checked_(parity_checked) {}

  // Appends one event per character completed in `marked`.
  void push(std::span<const std::uint8_t> marked, UartErrorCounts& unexplained,
            std::vector<ByteEvent>& out);
  // True while a mark sequence cut by the end of the last push waits for its next byte.
  [[nodiscard]] bool holding() const { return state_ != State::data; }

 private:
  enum class State : std::uint8_t { data, after_ff, after_ff_00 };
  void emit_marked(std::uint8_t byte, UartErrorCounts& unexplained, std::vector<ByteEvent>& out);
  [[nodiscard]] std::uint8_t error_flags(UartErrorCounts& unexplained) const;

  bool parity_checked_;
  State state_ = State::data;
};

// Back-dates the characters of each read. A read returns just after its last character arrived:
// character k of n read at `read_time` started at read_time - (n - k) * character_time, but never
// before the previous character of this port ended (bytes on one wire cannot overlap; the
// pipeline relies on it). So times only grow, by one character time per character, until bytes
// come faster than the line rate carries them (a pty, a network port, a wrong -s): then the
// stamps would run ever further ahead of the clock, and past kMaxLead they stay there, equal,
// rather than step back. A port's times never fall: the capture merges its ports by time, and
// arrival order is the one truth the port gives.
class ByteTimeBackdater {
 public:
  explicit ByteTimeBackdater(TimeNs character_time) : character_time_(character_time) {}
  // Sets the time of each event of one read, in order.
  void stamp(std::span<ByteEvent> read_characters, TimeNs read_time);
  static constexpr TimeNs kMaxLead = 500 * kNsPerMs;
  // Reads with a byte held at kMaxLead because the line rate could not be kept.
  [[nodiscard]] std::uint64_t overrun_reads() const { return overrun_reads_; }

 private:
  TimeNs character_time_;
  TimeNs previous_start_ = 0;
  TimeNs previous_end_ = 0;
  bool have_previous_ = false;
  std::uint64_t overrun_reads_ = 0;
};

// Watches the pattern of reads for USB burst artefacts: an adapter that holds received bytes and
// hands them over in bunches (FTDI's latency_timer, 16 ms by default; CH340 and CP210x packets),
// which hides the silence between frames inside a bunch and shifts every gap by up to the hold.
// Either rule below, once met, makes timing untrusted for the rest of the capture:
//   held bunches: reads that brought at least 16 characters (more than a native UART hands over
//     at once: a 16550's receive trigger is at most 14, and it interrupts after 4 silent
//     characters) spanning at least t3.5 on the wire, so an inter-frame silence could be inside
//     them unseen — at least 3 such reads and at least 1 read in 10 (a UART with a deeper FIFO
//     and a high receive trigger, such as a 16C950, can be misjudged in continuous traffic);
//   arrivals faster than the line: characters handed over one a read (a pty, a native UART, a
//     network port), back to back, come a median of less than 3/4 of the configured character
//     time apart (over 32 such arrivals, and again at 64): the line runs faster than -s says
//     (a wrong baud whose bytes still arrive intact), and the rate the arrivals imply is named;
//   latency-timer cadence: only where a 16 ms hold is at least t3.5 (so from about 2400 baud):
//     reads of at least 2 characters that come 14.5..65.5 ms after the previous read, at least 8
//     of them and at least 3 in 4 within 1.5 ms of a multiple of 16 ms (FTDI's default timer,
//     the host polling every 1 ms) — a master's polls or a drive's replies fall on that grid
//     only by chance, about 1 time in 5.
// Cheap: a few counters and the previous read time.
class ReadPatternMonitor {
 public:
  explicit ReadPatternMonitor(const SerialConfig& serial);
  // One read that brought `characters` characters at `read_time` (reads of none are ignored).
  void add_read(TimeNs read_time, std::size_t characters);
  [[nodiscard]] bool timing_trusted() const { return trusted_; }
  // One line: the verdict and its evidence ("timing trusted: ..." / "timing not trusted: ...").
  [[nodiscard]] std::string verdict() const;
  [[nodiscard]] std::uint64_t reads() const { return reads_; }
  [[nodiscard]] std::uint64_t characters() const { return characters_; }
  [[nodiscard]] std::size_t largest_read() const { return largest_read_; }

 private:
  TimeNs character_time_;
  TimeNs t35_;
  std::uint32_t bits_per_character_;
  std::string settings_;  // as given (-s)
  bool trusted_ = true;
  // Intervals between single-character reads back to back (the first kArrivalSamples).
  static constexpr std::size_t kArrivalSamples = 64;
  std::vector<TimeNs> arrivals_;
  std::size_t previous_characters_ = 0;
  TimeNs arrival_median_ = 0;  // when too fast
  bool untrusted_by_rate_ = false;
  std::uint64_t reads_ = 0;
  std::uint64_t characters_ = 0;
  std::size_t largest_read_ = 0;
  std::uint64_t held_reads_ = 0;
  std::uint64_t cadence_candidates_ = 0;  // reads 14.5..65.5 ms after the previous one
  std::uint64_t cadence_reads_ = 0;       // ... of them on the 16 ms grid
  TimeNs previous_read_time_ = 0;
  bool have_previous_ = false;
  bool untrusted_by_held_ = false;
  bool untrusted_by_cadence_ = false;
};

class SerialPort {
 public:
  // Opens `o.path` listen-only and sets it up (see the top of this file); the channel is interned
  // in `channels`. nullptr and a one-line "PATH: reason (errno text)" in *error on failure.
  static std::unique_ptr<SerialPort> open(const SerialPortOptions& o, ChannelTable& channels,
                                          std::string* error);
  // Closes the fd and restores nothing: every program that opens a serial port sets its own
  // mode, and the low-latency flag only makes the driver hand bytes over sooner.
  ~SerialPort();
  SerialPort(const SerialPort&) = delete;
  SerialPort& operator=(const SerialPort&) = delete;

  [[nodiscard]] int fd() const { return fd_; }  // for poll()
  [[nodiscard]] ChannelId channel() const { return channel_; }

  // Reads everything available now (non-blocking; reads until EAGAIN, at most 64 KiB a call, so
  // a busy port cannot starve others) and appends time-stamped ByteEvents. False on a fatal error
  // (error() set; the bytes read before it are still appended): EIO, ENODEV, ENXIO or a hangup
  // -> "PATH: adapter unplugged or gone (EIO)"; any other read error -> "PATH: read failed
  // (errno text)". EAGAIN and EINTR are not errors. The kernel's error and overrun counters are
  // read once per call, after the reads; a rise in overruns marks the next byte kUartOverrun.
  bool read_available(std::vector<ByteEvent>& out);
  [[nodiscard]] const std::string& error() const { return error_; }

  // What the user must know at start, one line each: FTDI latency_timer above 1 ms (with the
  // fix), low-latency mode not supported, line settings the driver did not take as asked.
  [[nodiscard]] std::vector<std::string> warnings() const { return warnings_; }
  // For the summary: kernel counters since open, reads and bytes, the USB burst verdict.
  [[nodiscard]] std::vector<std::string> notes() const;
  // False once the read pattern shows USB burst artefacts (ReadPatternMonitor): per-byte times
  // then carry no inter-frame silence and framing must rely on content.
  [[nodiscard]] bool timing_trusted() const { return monitor_.timing_trusted(); }
  [[nodiscard]] std::string timing_verdict() const { return monitor_.verdict(); }
  // Bytes have come faster than the line settings can carry (ByteTimeBackdater).
  [[nodiscard]] bool line_rate_exceeded() const { return backdater_.overrun_reads() > 0; }

  // Kernel counters (TIOCGICOUNT) as deltas since open, as of the last read_available(); all
  // zero where the driver has none (a pty). Kept in 64 bits across the kernel's 32-bit wrap.
  // (The kernel's own, raw and wrapping, are the same counters in 32 bits.)
  template <class Count>
  struct KernelCounters {
    Count rx = 0, frame = 0, parity = 0, brk = 0, overrun = 0, buf_overrun = 0;
  };
  using Counters = KernelCounters<std::uint64_t>;
  [[nodiscard]] Counters counters() const { return counters_; }
  [[nodiscard]] bool counters_available() const { return counters_available_; }

 private:
  using KernelCounts = KernelCounters<std::uint32_t>;  // as TIOCGICOUNT gives them
  struct ReadChunk {
    std::size_t end = 0;  // end offset in raw_
    TimeNs time = 0;
  };

  SerialPort(int fd, const SerialPortOptions& o, ChannelId channel);
  Counters refresh_counters();  // adds the rise since the last call to counters_; returns it
  bool hung_up() const;

  int fd_;
  std::string path_;
  SerialConfig serial_;
  ChannelId channel_;
  TimeNs wall_offset_ = 0;  // CLOCK_REALTIME - CLOCK_MONOTONIC at open
  ParmrkDecoder decoder_;
  ByteTimeBackdater backdater_;
  ReadPatternMonitor monitor_;
  UartErrorCounts unexplained_;
  bool overrun_pending_ = false;
  bool counters_available_ = false;
  KernelCounts last_kernel_;
  Counters counters_;
  std::uint64_t reads_ = 0;
  std::uint64_t bytes_read_ = 0;  // as read, PARMRK marks included
  std::vector<std::uint8_t> raw_;
  std::vector<ReadChunk> chunks_;
  std::vector<std::string> warnings_;
  std::string error_;
};

}  // namespace drivetap
