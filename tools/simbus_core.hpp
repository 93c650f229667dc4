// Simulated RS-485 Modbus RTU bus on a pseudo-terminal (docs/protocols.md §1 timing, §2 RTU).
//
// Three parts, each usable alone so that tests can check them without running the program:
//   Traffic   a seeded, reproducible master polling drives: requests, replies, exceptions,
//             requests to an absent station, garbage between frames; each record carries the
//             time of its first start bit, counted from the start of the run.
//   Pty       a pseudo-terminal pair in raw mode whose slave a capture program opens.
//   run()     writes the traffic to a file descriptor at the times the bytes would leave a UART:
//             byte by byte, or in bursts like a USB adapter's latency timer.
// Times are CLOCK_MONOTONIC nanoseconds (core/time.hpp's TimeNs).
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "core/serial_config.hpp"
#include "core/time.hpp"

namespace drivetap::simbus {

// ---- traffic ----

struct TrafficOptions {
  SerialConfig serial;
  std::uint64_t seed = 1;
  double gap_reply_chars = 5;  // end of a request -> start of its reply
  double gap_next_chars = 10;  // end of a reply (or of the master's timeout) -> next request
  // Every gap exactly 3.5 characters (the soak mode), the master's timeout included.
  bool back_to_back = false;
  double noise_rate = 0;  // per gap between two frames: 1..3 garbage bytes in it
};

enum class RecordKind : std::uint8_t { request, reply, exception, garbage };

struct Record {
  RecordKind kind = RecordKind::request;
  std::uint8_t station = 0;
  bool answered = false;  // requests: a reply follows
  bool cut = false;       // a stop ended the run inside it: `bytes` are those sent
  TimeNs start = 0;       // start bit of the first byte, from the start of the run
  std::vector<std::uint8_t> bytes;
  // Written byte by byte: the longest silence between two of its bytes that a reader stamping
  // each write() back from its end would see. The schedule has none; a writer preempted in the
  // middle of a frame makes one, a real gap on the wire. 0 in bursts (their gaps are the point).
  TimeNs pause = 0;
  // Written byte by byte: how long after its scheduled end the write() carrying its latest byte
  // returned. A writer preempted around a write() (before it, or between it and reading the
  // clock) leaves the silence before or after the record uncertain by that much: a garbage
  // record can run into the next frame, a frame come apart, although `pause` saw none. 0 in
  // bursts (they are late on purpose).
  TimeNs late = 0;

  [[nodiscard]] bool is_frame() const { return kind != RecordKind::garbage; }
};

const char* to_string(RecordKind k);

// Stations that answer, and the one the master polls that never does.
inline constexpr std::array<std::uint8_t, 3> kDriveStations = {1, 2, 3};
inline constexpr std::uint8_t kAbsentStation = 10;
inline constexpr int kRegisters = 64;  // holding registers 0x0000..0x003F per drive
// The master waits this long after the reply would have started before it gives up on a
// station, then keeps its usual gap before the next request.
inline constexpr double kTimeoutChars = 40;
// Silence on either side of a garbage record: t3.5 and one character more. At exactly t3.5 the
// capture's own jitter (a read stamped a few hundred microseconds late) decides whether the
// silence shows as longer or shorter than t3.5, and the garbage could run into the next frame
// (seen once in CI under the sanitizers: 80 frames, 79 with a good CRC).
inline constexpr double kGarbageClearChars = 4.5;

// An endless, reproducible sequence of records: the same options give the same records on any
// platform (own generator, no std:: distributions, whose results the standard leaves open).
class Traffic {
 public:
  explicit Traffic(const TrafficOptions& options);
  Record next();
  [[nodiscard]] const TrafficOptions& options() const { return o_; }

 private:
  std::uint64_t random();
  std::uint32_t below(std::uint32_t n);  // uniform in [0, n)
  TimeNs chars(double n) const;
  Record make_request();

  TrafficOptions o_;
  TimeNs char_ns_;
  std::uint64_t state_;        // the frames
  std::uint64_t noise_state_;  // the garbage: a stream of its own
  std::array<std::array<std::uint16_t, kRegisters>, kDriveStations.size()> registers_{};
  std::size_t next_drive_ = 0;
  TimeNs end_ = 0;     // end of the last record's last character
  TimeNs gap_ = 0;     // silence before the next frame
  bool first_ = true;  // nothing sent yet: the first frame starts at 0
  bool garbage_done_ = false;
  std::optional<Record> reply_;  // the reply due after the last request
};

// ---- pseudo-terminal ----

class Pty {
 public:
  // A pty pair: master non-blocking (a full buffer is EAGAIN, not a stall), the slave opened
  // once to put it in raw mode (cfmakeraw: no echo, no CR/LF mapping, no signals, 8 bits) and
  // kept open, so that the line discipline passes every byte untouched and the pty is not hung
  // up between two readers. Returns nullopt with *error set to one line.
  static std::optional<Pty> open(std::string* error);
  Pty(Pty&& other) noexcept;
  Pty& operator=(Pty&&) = delete;
  Pty(const Pty&) = delete;
  ~Pty();

  // Waits (at most max_wait) until a reader has taken every byte written: closing the master
  // hangs the pty up, and the kernel drops what is still unread. False on timeout.
  bool drain(TimeNs max_wait) const;

  [[nodiscard]] int master() const { return master_; }
  [[nodiscard]] const std::string& slave_path() const { return slave_path_; }

 private:
  Pty() = default;
  int master_ = -1;
  int slave_ = -1;
  std::string slave_path_;
};

// ---- writing on schedule ----

TimeNs monotonic_now();

// How late bytes were written against their schedule: 1 us bins up to 50 ms, then one bin.
class LatenessHistogram {
 public:
  void add(TimeNs late);
  [[nodiscard]] std::uint64_t count() const { return count_; }
  [[nodiscard]] TimeNs max() const { return max_; }
  // The q-quantile (0..1), to 1 us; 0 when empty.
  [[nodiscard]] TimeNs quantile(double q) const;

 private:
  static constexpr std::size_t kBins = 50'000;
  std::vector<std::uint64_t> bins_ = std::vector<std::uint64_t>(kBins + 1);
  std::uint64_t count_ = 0;
  TimeNs max_ = 0;
};

// Byte by byte, the writer wakes this long before a byte is due and spins to the due time:
// clock_nanosleep alone wakes 25..60 us late on a loaded VM (a character is 87 us at 115200);
// with the spin the median is under 1 us. Capped at half a character (the CPU it costs).
inline constexpr TimeNs kDefaultSpin = 50 * kNsPerUs;

struct RunOptions {
  TimeNs t0 = 0;               // CLOCK_MONOTONIC time of the run's time 0 (the first start bit)
  TimeNs burst = 0;            // 0: byte by byte; else one write of what is due every `burst`
  TimeNs spin = kDefaultSpin;  // byte by byte: busy-wait the last `spin` before a byte is due
  std::uint64_t frames = 0;    // stop after this many frames (garbage not counted); 0: no limit
  TimeNs duration = 0;         // no record starting at or after this time; 0: no limit
  TimeNs progress_every = 0;   // 0: no progress calls
};

struct RunStats {
  std::uint64_t frames = 0;   // frames written (a frame cut by a stop counts)
  std::uint64_t garbage = 0;  // garbage records written
  std::uint64_t bytes = 0;    // bytes the pty took
  std::uint64_t dropped = 0;  // bytes it refused (EAGAIN: its buffer was full)
  TimeNs elapsed = 0;         // from t0 to the last write() (taken or refused)
  LatenessHistogram late;     // per byte: write() returned this long after the byte was due
  std::string error;          // a write error that ended the run, one line
};

struct RunHooks {
  // A record after its last byte was written (with the bytes written so far when a stop cut
  // it), and how many of its bytes the pty refused.
  std::function<void(const Record&, std::size_t dropped)> sent;
  std::function<void(const RunStats&)> progress;
};

// The time at which byte `index` of `record` is written: the end of its stop bit, when a UART
// receiver would hand it on. The byte's own time (its start bit) is one character earlier.
inline TimeNs due_time(const Record& record, std::size_t index, TimeNs char_ns) {
  return record.start + static_cast<TimeNs>(index + 1) * char_ns;
}

// Writes `traffic` to `fd` (non-blocking) until a limit, a write error or *stop. Sleeps with
// clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME) to each byte's due time (or to the next burst
// tick; byte by byte the last options.spin is busy-waited) and writes every byte due by then in
// one write(). Sets this thread's timer slack to 1 ns: the default 50 us would be half a
// character at 115200 baud.
RunStats run(int fd, Traffic& traffic, const RunOptions& options, const std::atomic<bool>* stop,
             const RunHooks& hooks);

// Puts the calling thread at SCHED_FIFO `priority` (needs root or CAP_SYS_NICE). On a busy
// machine a normal thread is preempted for whole scheduler slices, milliseconds, many characters;
// a real-time one is not. False with *error set when refused.
bool set_realtime(int priority, std::string* error);

// ---- truth file (a drivetap byte log: docs/formats.md "The byte log") ----

// "#! serial" header and comments naming the traffic and the run's t0.
void write_truth_header(std::FILE* f, const TrafficOptions& options, const RunOptions& run);
// One line per record: its start time, channel `bus`, the bytes, a comment saying what it is,
// and its pause and lateness where longer than `max_pause` (t1.5: the frame may be broken on the
// wire, or its silence from a neighbour gone).
void write_truth_record(std::FILE* f, const Record& record, std::size_t dropped, TimeNs max_pause);

}  // namespace drivetap::simbus
