// Unit tests: the serial-port capture source (src/sources/live/serial_port.hpp) — PARMRK unmarking,
// per-byte time back-dating, the USB burst rule, open() errors, and a real pseudo-terminal.
#include <gtest/gtest.h>

// termios2 for reading back what the port was set to (not <termios.h>: see serial_port.cpp).
#include <asm/termbits.h>
#include <fcntl.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <unistd.h>

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <memory>
#include <random>
#include <set>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "core/byte_event.hpp"
#include "core/serial_config.hpp"
#include "sources/live/line_scan.hpp"
#include "sources/live/serial_port.hpp"

using namespace drivetap;

namespace {

::testing::AssertionResult HasSub(const std::string& s, std::string_view sub) {
  if (s.find(sub) != std::string::npos) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << "'" << s << "' does not contain '" << sub << "'";
}

bool any_has(const std::vector<std::string>& lines, std::string_view sub) {
  for (const std::string& l : lines)
    if (l.find(sub) != std::string::npos) return true;
  return false;
}

struct Char {
  std::uint8_t byte;
  std::uint8_t flags;
  friend bool operator==(const Char&, const Char&) = default;
};

std::ostream& operator<<(std::ostream& os, const Char& c) {
  char text[16];
  std::snprintf(text, sizeof text, "%02X/%u", c.byte, c.flags);
  return os << text;
}

std::vector<Char> chars(const std::vector<ByteEvent>& events) {
  std::vector<Char> out;
  for (const ByteEvent& e : events) out.push_back({e.byte, e.flags});
  return out;
}

// Decodes `marked` pushed in pieces ending at `cuts` (ascending offsets).
std::vector<Char> decode_in_pieces(const std::vector<std::uint8_t>& marked,
                                   const std::vector<std::size_t>& cuts, bool parity_checked,
                                   UartErrorCounts counts = {}) {
  ParmrkDecoder decoder(parity_checked);
  std::vector<ByteEvent> out;
  std::size_t begin = 0;
  for (const std::size_t cut : cuts) {
    decoder.push(std::span(marked).subspan(begin, cut - begin), counts, out);
    begin = cut;
  }
  decoder.push(std::span(marked).subspan(begin), counts, out);
  EXPECT_FALSE(decoder.holding());
  return chars(out);
}

constexpr std::uint8_t kFP = kUartFramingError | kUartParityError;

// Every kind of PARMRK sequence, with plain 0x00 and 0xFF around them.
const std::vector<std::uint8_t> kMarked = {
    0x01,                    // plain
    0xFF, 0xFF,              // data 0xFF
    0x00,                    // plain 0x00 (unmarked)
    0xFF, 0x00, 0x00,        // break
    0x02,                    //
    0xFF, 0x00, 0x41,        // 'A' with an error
    0xFF, 0xFF, 0xFF, 0xFF,  // two data 0xFF
    0xFF, 0x00, 0xFF,        // 0xFF with an error (not doubled)
    0xFF, 0x00, 0x00,        // break again
    0x7E,                    //
};
const std::vector<Char> kUnmarkedNoCounts = {
    {0x01, 0}, {0xFF, 0}, {0x00, 0},   {0x00, kUartBreak}, {0x02, 0}, {0x41, kFP},
    {0xFF, 0}, {0xFF, 0}, {0xFF, kFP}, {0x00, kUartBreak}, {0x7E, 0},
};

TEST(ParmrkDecoder, WholeStream) {
  EXPECT_EQ(decode_in_pieces(kMarked, {}, true), kUnmarkedNoCounts);
}

TEST(ParmrkDecoder, EverySplitPoint) {
  for (std::size_t cut = 0; cut <= kMarked.size(); ++cut)
    EXPECT_EQ(decode_in_pieces(kMarked, {cut}, true), kUnmarkedNoCounts) << "cut at " << cut;
}

TEST(ParmrkDecoder, EveryPairOfSplitPoints) {
  for (std::size_t a = 0; a <= kMarked.size(); ++a)
    for (std::size_t b = a; b <= kMarked.size(); ++b)
      EXPECT_EQ(decode_in_pieces(kMarked, {a, b}, true), kUnmarkedNoCounts)
          << "cuts at " << a << ", " << b;
}

TEST(ParmrkDecoder, OneByteAtATime) {
  std::vector<std::size_t> cuts;
  for (std::size_t i = 1; i < kMarked.size(); ++i) cuts.push_back(i);
  EXPECT_EQ(decode_in_pieces(kMarked, cuts, true), kUnmarkedNoCounts);
}

TEST(ParmrkDecoder, HoldsACutSequence) {
  ParmrkDecoder decoder(true);
  UartErrorCounts none;
  std::vector<ByteEvent> out;
  const std::uint8_t first[] = {0x05, 0xFF};
  decoder.push(first, none, out);
  EXPECT_TRUE(decoder.holding());
  EXPECT_EQ(out.size(), 1u);
  const std::uint8_t second[] = {0x00};
  decoder.push(second, none, out);
  EXPECT_TRUE(decoder.holding());
  EXPECT_EQ(out.size(), 1u);
  const std::uint8_t third[] = {0x33};
  decoder.push(third, none, out);
  EXPECT_FALSE(decoder.holding());
  EXPECT_EQ(chars(out), (std::vector<Char>{{0x05, 0}, {0x33, kFP}}));
}

TEST(ParmrkDecoder, UnknownEscapeKeepsBothBytes) {
  // Linux never writes \377 followed by anything but \377 or \0; no byte is lost if it did.
  EXPECT_EQ(decode_in_pieces({0xFF, 0x41, 0x42}, {}, true),
            (std::vector<Char>{{0xFF, 0}, {0x41, 0}, {0x42, 0}}));
  EXPECT_EQ(decode_in_pieces({0xFF, 0x41}, {1}, true), (std::vector<Char>{{0xFF, 0}, {0x41, 0}}));
}

TEST(ParmrkDecoder, ErrorKindFromCounts) {
  const std::vector<std::uint8_t> one_mark = {0xFF, 0x00, 0x41};
  // Only framing counted -> framing; only parity -> parity; spent as marks use them.
  EXPECT_EQ(decode_in_pieces(one_mark, {}, true, {.framing = 1}),
            (std::vector<Char>{{0x41, kUartFramingError}}));
  EXPECT_EQ(decode_in_pieces(one_mark, {}, true, {.parity = 1}),
            (std::vector<Char>{{0x41, kUartParityError}}));
  // Both counted: the kind with more counts, parity on a tie.
  EXPECT_EQ(decode_in_pieces(one_mark, {}, true, {.framing = 2, .parity = 1}),
            (std::vector<Char>{{0x41, kUartFramingError}}));
  EXPECT_EQ(decode_in_pieces(one_mark, {}, true, {.framing = 1, .parity = 1}),
            (std::vector<Char>{{0x41, kUartParityError}}));
  // Nothing counted: the driver did not say which.
  EXPECT_EQ(decode_in_pieces(one_mark, {}, true), (std::vector<Char>{{0x41, kFP}}));
  // Parity not checked: always framing.
  EXPECT_EQ(decode_in_pieces(one_mark, {}, false), (std::vector<Char>{{0x41, kUartFramingError}}));
  EXPECT_EQ(decode_in_pieces(one_mark, {}, false, {.parity = 3}),
            (std::vector<Char>{{0x41, kUartFramingError}}));

  // Counts are spent mark by mark: one framing and one parity error over two marks.
  const std::vector<std::uint8_t> two_marks = {0xFF, 0x00, 0x41, 0xFF, 0x00, 0x42};
  EXPECT_EQ(decode_in_pieces(two_marks, {}, true, {.framing = 1, .parity = 1}),
            (std::vector<Char>{{0x41, kUartParityError}, {0x42, kUartFramingError}}));
  // More marks than counts: the rest are unknown.
  EXPECT_EQ(decode_in_pieces(two_marks, {}, true, {.framing = 1}),
            (std::vector<Char>{{0x41, kUartFramingError}, {0x42, kFP}}));
}

TEST(ParmrkDecoder, BreakOrDamagedZero) {
  const std::vector<std::uint8_t> zero_mark = {0xFF, 0x00, 0x00};
  EXPECT_EQ(decode_in_pieces(zero_mark, {}, true), (std::vector<Char>{{0x00, kUartBreak}}));
  EXPECT_EQ(decode_in_pieces(zero_mark, {}, true, {.breaks = 1}),
            (std::vector<Char>{{0x00, kUartBreak}}));
  // No break counted but a framing (parity) error: a 0x00 received with that error.
  EXPECT_EQ(decode_in_pieces(zero_mark, {}, true, {.framing = 1}),
            (std::vector<Char>{{0x00, kUartFramingError}}));
  EXPECT_EQ(decode_in_pieces(zero_mark, {}, true, {.parity = 1}),
            (std::vector<Char>{{0x00, kUartParityError}}));
  EXPECT_EQ(decode_in_pieces(zero_mark, {}, false, {.framing = 1}),
            (std::vector<Char>{{0x00, kUartFramingError}}));
  // A break counted wins over the errors.
  EXPECT_EQ(decode_in_pieces(zero_mark, {}, true, {.framing = 1, .breaks = 1}),
            (std::vector<Char>{{0x00, kUartBreak}}));
}

// --- time back-dating ----------------------------------------------------------------------

TEST(ByteTimeBackdater, ReadEndsWithItsLastCharacter) {
  constexpr TimeNs ct = 1'000'000;  // 1 ms
  ByteTimeBackdater backdater(ct);
  std::vector<ByteEvent> read(3);
  backdater.stamp(read, 100 * ct);
  EXPECT_EQ(read[0].time, 97 * ct);
  EXPECT_EQ(read[1].time, 98 * ct);
  EXPECT_EQ(read[2].time, 99 * ct);  // ends at the read

  // A read soon after: back-dating would overlap the previous read's last character.
  std::vector<ByteEvent> soon(3);
  backdater.stamp(soon, 101 * ct);
  EXPECT_EQ(soon[0].time, 100 * ct);
  EXPECT_EQ(soon[1].time, 101 * ct);
  EXPECT_EQ(soon[2].time, 102 * ct);

  // After a silence: back-dated again from its own read time.
  std::vector<ByteEvent> later(2);
  backdater.stamp(later, 200 * ct);
  EXPECT_EQ(later[0].time, 198 * ct);
  EXPECT_EQ(later[1].time, 199 * ct);

  // Partly overlapping: the first characters are pushed after the previous one, the rest keep
  // their back-dated times.
  std::vector<ByteEvent> partly(4);
  backdater.stamp(partly, 203 * ct);
  EXPECT_EQ(partly[0].time, 200 * ct);  // back-dated 199, but 199 + 1 ended the previous one
  EXPECT_EQ(partly[1].time, 201 * ct);
  EXPECT_EQ(partly[2].time, 202 * ct);
  EXPECT_EQ(partly[3].time, 203 * ct);

  std::vector<ByteEvent> none;
  backdater.stamp(none, 300 * ct);  // nothing to do, nothing changes
  std::vector<ByteEvent> one(1);
  backdater.stamp(one, 300 * ct);
  EXPECT_EQ(one[0].time, 299 * ct);
}

// Bytes faster than the line rate (a pty, a wrong -s): the stamps run ahead of the reads up to
// kMaxLead, then stay there; they never fall, so that merging the ports by time keeps each port's
// arrival order (they once stepped back 500 ms, and the merge spliced later bytes before earlier).
TEST(ByteTimeBackdater, BytesFasterThanTheLineKeepTheirOrder) {
  constexpr TimeNs ct = 1'000'000;  // 1 ms a character; 10 characters read every 1 ms
  ByteTimeBackdater backdater(ct);
  TimeNs previous = -1;
  TimeNs read_time = 1000 * ct;
  for (int read = 0; read < 200; ++read, read_time += ct) {
    std::vector<ByteEvent> chars(10);
    backdater.stamp(chars, read_time);
    for (const ByteEvent& e : chars) {
      EXPECT_GE(e.time, previous) << "read " << read;
      EXPECT_LE(e.time, read_time + ByteTimeBackdater::kMaxLead) << "read " << read;
      previous = e.time;
    }
  }
  // 2000 characters in 200 ms: the lead reached 500 ms after some 55 reads.
  EXPECT_GT(backdater.overrun_reads(), 100u);
  EXPECT_LT(backdater.overrun_reads(), 160u);
  // The line falls silent: a read a second later is back-dated as usual.
  std::vector<ByteEvent> after(2);
  backdater.stamp(after, read_time + 2000 * ct);
  EXPECT_EQ(after[0].time, read_time + 1998 * ct);
  EXPECT_EQ(after[1].time, read_time + 1999 * ct);
}

// --- USB burst rule ------------------------------------------------------------------------

SerialConfig config(std::string_view text) {
  std::string error;
  auto c = SerialConfig::parse(text, &error);
  EXPECT_TRUE(c.has_value()) << error;
  return *c;
}

constexpr TimeNs kStart = 1'700'000'000 * kNsPerSecond;

TEST(ReadPatternMonitor, OneCharacterPerCharacterTimeIsTrusted) {
  const SerialConfig serial = config("115200 8N1");
  ReadPatternMonitor monitor(serial);
  TimeNs t = kStart;
  for (int frame = 0; frame < 200; ++frame) {
    for (int k = 0; k < 8; ++k) {
      t += serial.character_time();
      monitor.add_read(t, 1);
    }
    t += 5 * kNsPerMs;  // silence between frames
  }
  EXPECT_TRUE(monitor.timing_trusted()) << monitor.verdict();
  EXPECT_TRUE(HasSub(monitor.verdict(), "timing trusted"));
  EXPECT_EQ(monitor.reads(), 1600u);
  EXPECT_EQ(monitor.largest_read(), 1u);
}

TEST(ReadPatternMonitor, ChunksEvery16msAt115200AreNotTrusted) {
  // Continuous traffic through an adapter that hands over what it received every 16 ms, in
  // 62-byte USB packets read back to back (FTDI, latency_timer 16).
  const SerialConfig serial = config("115200 8N1");
  ReadPatternMonitor monitor(serial);
  const std::size_t per_period =
      static_cast<std::size_t>(16 * kNsPerMs / serial.character_time());  // 184
  TimeNs t = kStart;
  for (int period = 0; period < 20; ++period) {
    t += 16 * kNsPerMs;
    std::size_t left = per_period;
    TimeNs read_time = t;
    while (left > 0) {
      const std::size_t n = std::min<std::size_t>(left, 62);
      monitor.add_read(read_time, n);
      if (period == 0 && left == per_period) {
        EXPECT_TRUE(monitor.timing_trusted());  // one bunch is not yet a pattern
      }
      read_time += 30 * kNsPerUs;
      left -= n;
    }
  }
  EXPECT_FALSE(monitor.timing_trusted());
  EXPECT_TRUE(HasSub(monitor.verdict(), "timing not trusted: USB burst artefacts"))
      << monitor.verdict();
  EXPECT_TRUE(HasSub(monitor.verdict(), "16 or more characters at once, up to 62"))
      << monitor.verdict();
}

TEST(ReadPatternMonitor, SparsePollsOnA16msGridAreNotTrusted) {
  // 115200 baud, a poll every 100 ms and the reply 3 ms later: through a 16 ms latency timer the
  // request and reply come in whole frames (too short for the bunch rule), on the timer's grid.
  const SerialConfig serial = config("115200 8N1");
  ReadPatternMonitor monitor(serial);
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> usb_jitter(-400, 400);  // us
  TimeNs grid = kStart;
  for (int poll = 0; poll < 30; ++poll) {
    grid += 16 * kNsPerMs * (poll % 2 == 0 ? 6 : 7);         // ~100 ms between polls
    monitor.add_read(grid + usb_jitter(rng) * kNsPerUs, 8);  // request
    monitor.add_read(grid + 16 * kNsPerMs + usb_jitter(rng) * kNsPerUs, 9);  // reply, next tick
  }
  EXPECT_FALSE(monitor.timing_trusted());
  EXPECT_TRUE(HasSub(monitor.verdict(), "on a 16 ms grid")) << monitor.verdict();
}

TEST(ReadPatternMonitor, NativeUartAt9600IsTrusted) {
  // A 16550 at 9600 8N1: 8-byte receive trigger, so an 8-byte request comes in one read and a
  // 25-byte reply in 8 + 8 + 8 + 1; replies after 2..40 ms, polls every 50..150 ms.
  const SerialConfig serial = config("9600 8N1");
  const TimeNs ct = serial.character_time();
  ReadPatternMonitor monitor(serial);
  std::mt19937 rng(11);
  std::uniform_int_distribution<int> reply_delay_us(2000, 40000);
  std::uniform_int_distribution<int> poll_gap_ms(50, 150);
  TimeNs t = kStart;
  for (int poll = 0; poll < 200; ++poll) {
    t += poll_gap_ms(rng) * kNsPerMs;
    t += 8 * ct;
    monitor.add_read(t + 100 * kNsPerUs, 8);
    t += reply_delay_us(rng) * kNsPerUs;
    for (int k = 0; k < 3; ++k) {
      t += 8 * ct;
      monitor.add_read(t + 100 * kNsPerUs, 8);
    }
    t += ct;
    monitor.add_read(t + 4 * ct, 1);  // the 16550's character timeout
  }
  EXPECT_TRUE(monitor.timing_trusted()) << monitor.verdict();
}

TEST(ReadPatternMonitor, OneBacklogIsNotABurstPattern) {
  // The reader fell behind once (a 200-byte backlog), otherwise prompt reads.
  const SerialConfig serial = config("115200 8N1");
  ReadPatternMonitor monitor(serial);
  TimeNs t = kStart;
  monitor.add_read(t, 200);
  for (int k = 0; k < 100; ++k) {
    t += serial.character_time();
    monitor.add_read(t, 1);
  }
  EXPECT_TRUE(monitor.timing_trusted()) << monitor.verdict();
}

// A 19200 8E1 bus read with -s "9600 8E1" through a port that hands each character over as it
// comes (a pty, a native UART): every byte arrives intact, 573 us apart, where 9600 8E1 needs
// 1146 us for one. The monitor says the line runs faster and names the rate the arrivals imply;
// at the right setting, with the same scheduling jitter, it trusts the timing.
TEST(ReadPatternMonitor, CharactersFasterThanTheConfiguredRateAreNamedWithTheirRate) {
  for (const char* given : {"9600 8E1", "19200 8E1"}) {
    SCOPED_TRACE(given);
    const SerialConfig serial = config(given);
    const TimeNs wire = config("19200 8E1").character_time();  // 573 us
    ReadPatternMonitor monitor(serial);
    std::mt19937 rng(5);
    std::uniform_int_distribution<int> jitter_us(-60, 60);
    TimeNs t = kStart;
    for (int poll = 0; poll < 20; ++poll) {
      t += 50 * kNsPerMs;
      for (int k = 0; k < 8; ++k) {
        t += wire;
        monitor.add_read(t + jitter_us(rng) * kNsPerUs, 1);
      }
    }
    const bool wrong = std::string(given) == "9600 8E1";
    EXPECT_EQ(monitor.timing_trusted(), !wrong) << monitor.verdict();
    if (wrong) {
      EXPECT_TRUE(HasSub(monitor.verdict(), "faster than 9600 8E1 carries one (1145 us)"))
          << monitor.verdict();
      EXPECT_TRUE(HasSub(monitor.verdict(), "the line runs at 19200 baud (11 bits a character)"))
          << monitor.verdict();
    }
  }
}

// --- open() errors -------------------------------------------------------------------------

class TempDir {
 public:
  TempDir() {
    char pattern[] = "/tmp/drivetap-serial-XXXXXX";
    path_ = ::mkdtemp(pattern);
  }
  ~TempDir() { std::filesystem::remove_all(path_); }
  [[nodiscard]] const std::string& path() const { return path_; }

 private:
  std::string path_;
};

std::unique_ptr<SerialPort> open_port(const std::string& path, std::string* error,
                                      std::string_view serial = "9600 8N1",
                                      const std::string& sysfs_root = "/nonexistent-sysfs") {
  ChannelTable channels;
  SerialPortOptions o;
  o.path = path;
  o.serial = config(serial);
  o.sysfs_root = sysfs_root;
  return SerialPort::open(o, channels, error);
}

TEST(SerialPortOpen, NonexistentPath) {
  std::string error;
  EXPECT_EQ(open_port("/dev/ttyDOES_NOT_EXIST", &error), nullptr);
  EXPECT_EQ(error, "/dev/ttyDOES_NOT_EXIST: cannot open (No such file or directory)");
}

TEST(SerialPortOpen, Directory) {
  TempDir dir;
  std::string error;
  EXPECT_EQ(open_port(dir.path(), &error), nullptr);
  EXPECT_EQ(error, dir.path() + ": not a serial port (Is a directory)");
}

TEST(SerialPortOpen, RegularFile) {
  TempDir dir;
  const std::string file = dir.path() + "/capture.log";
  std::ofstream(file) << "0.0 bus 01 02\n";
  std::string error;
  EXPECT_EQ(open_port(file, &error), nullptr);
  EXPECT_EQ(error, file + ": not a serial port (Inappropriate ioctl for device)");
}

TEST(SerialPortOpen, CharacterDeviceThatIsNoTty) {
  std::string error;
  EXPECT_EQ(open_port("/dev/null", &error), nullptr);
  EXPECT_EQ(error, "/dev/null: not a serial port (Inappropriate ioctl for device)");
}

// --- a real pseudo-terminal ----------------------------------------------------------------

// A pty pair: the test writes to the master, SerialPort reads the slave as it would an adapter.
class Pty {
 public:
  Pty() {
    master_ = ::posix_openpt(O_RDWR | O_NOCTTY | O_CLOEXEC);
    EXPECT_GE(master_, 0);
    EXPECT_EQ(::grantpt(master_), 0);
    EXPECT_EQ(::unlockpt(master_), 0);
    slave_path_ = ::ptsname(master_);
  }
  ~Pty() { close_master(); }
  [[nodiscard]] const std::string& slave_path() const { return slave_path_; }
  void write(const std::vector<std::uint8_t>& bytes) const {
    ASSERT_EQ(::write(master_, bytes.data(), bytes.size()), static_cast<ssize_t>(bytes.size()));
  }
  void close_master() {
    if (master_ >= 0) ::close(master_);
    master_ = -1;
  }

 private:
  int master_ = -1;
  std::string slave_path_;
};

// Reads until `count` events arrived (or 2 s passed); false if the port failed.
bool read_until(SerialPort& port, std::vector<ByteEvent>& out, std::size_t count) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(2);
  while (out.size() < count && std::chrono::steady_clock::now() < deadline) {
    pollfd p{port.fd(), POLLIN, 0};
    ::poll(&p, 1, 50);
    if (!port.read_available(out)) return false;
  }
  return true;
}

TimeNs wall_now() {
  timespec ts{};
  ::clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<TimeNs>(ts.tv_sec) * kNsPerSecond + ts.tv_nsec;
}

TEST(SerialPortPty, OpensListenOnlyInRawMode) {
  Pty pty;
  ChannelTable channels;
  SerialPortOptions o;
  o.path = pty.slave_path();
  o.serial = config("10700 8E1");
  o.sysfs_root = "/nonexistent-sysfs";
  std::string error;
  auto port = SerialPort::open(o, channels, &error);
  ASSERT_NE(port, nullptr) << error;

  const int fl = ::fcntl(port->fd(), F_GETFL);
  EXPECT_EQ(fl & O_ACCMODE, O_RDONLY);
  EXPECT_NE(fl & O_NONBLOCK, 0);
  EXPECT_NE(::fcntl(port->fd(), F_GETFD) & FD_CLOEXEC, 0);

  // TCSETS2 with BOTHER takes a non-standard rate on a pty: no fallback needed.
  termios2 tio{};
  ASSERT_EQ(::ioctl(port->fd(), TCGETS2, &tio), 0);
  EXPECT_EQ(tio.c_cflag & CBAUD, static_cast<tcflag_t>(BOTHER));
  EXPECT_EQ(tio.c_ispeed, 10700u);
  EXPECT_EQ(tio.c_ospeed, 10700u);
  EXPECT_EQ(tio.c_cflag & CSIZE, static_cast<tcflag_t>(CS8));
  // The pty driver forces CS8 without parity (pty_set_termios): the port says so.
  EXPECT_EQ(tio.c_cflag & PARENB, 0u);
  EXPECT_EQ(tio.c_cflag & CSTOPB, 0u);
  EXPECT_TRUE(any_has(port->warnings(), pty.slave_path() +
                                            ": the driver set 8N1, not 8E1: the adapter does not "
                                            "support that format"));
  EXPECT_NE(tio.c_cflag & CREAD, 0u);
  EXPECT_NE(tio.c_cflag & CLOCAL, 0u);
  EXPECT_EQ(tio.c_cflag & CRTSCTS, 0u);
  EXPECT_EQ(tio.c_iflag, static_cast<tcflag_t>(INPCK | PARMRK));
  EXPECT_EQ(tio.c_lflag, 0u);
  EXPECT_EQ(tio.c_cc[VTIME], 0);

  // Named after the device, a bus of its own.
  const Channel& ch = channels.at(port->channel());
  EXPECT_EQ(ch.name, pty.slave_path().substr(5));  // "pts/N"
  EXPECT_EQ(ch.role, ChannelRole::bus);

  // A pty has neither low-latency mode nor counters: a warning, not an error.
  EXPECT_TRUE(any_has(port->warnings(), "low-latency mode not supported by this driver"));
  EXPECT_FALSE(port->counters_available());
  EXPECT_TRUE(any_has(port->notes(), "no kernel counters"));
}

TEST(SerialPortPty, TakesAnyIntegerBaudRate) {
  for (const char* serial : {"250000 8N1", "10700 7O2", "1200 8N1", "921600 8N1"}) {
    Pty pty;
    std::string error;
    auto port = open_port(pty.slave_path(), &error, serial);
    ASSERT_NE(port, nullptr) << error;
    EXPECT_FALSE(any_has(port->warnings(), "baud")) << serial;
  }
}

TEST(SerialPortPty, BytesExactlyInOrderWithIncreasingTimes) {
  Pty pty;
  ChannelTable channels;
  SerialPortOptions o;
  o.path = pty.slave_path();
  // Fast enough that the pty, which passes bytes on far quicker than any line, does not push
  // the back-to-back times of this burst past the pause below.
  o.serial = config("921600 8N1");
  o.sysfs_root = "/nonexistent-sysfs";
  std::string error;
  auto port = SerialPort::open(o, channels, &error);
  ASSERT_NE(port, nullptr) << error;

  // Every byte value, 0xFF and 0x00 and the XON/XOFF/CR/NL/^C a cooked tty would eat, then a
  // 0xFF on its own: PARMRK doubles it to \377 \377 and it must come out as one data byte.
  std::vector<std::uint8_t> sent;
  for (int round = 0; round < 3; ++round)
    for (int b = 0; b < 256; ++b) sent.push_back(static_cast<std::uint8_t>(b ^ (round * 0x5A)));
  std::vector<ByteEvent> got;
  const TimeNs before = wall_now();
  for (std::size_t i = 0; i < sent.size(); i += 256) {
    pty.write(std::vector<std::uint8_t>(sent.begin() + i, sent.begin() + i + 256));
    ASSERT_TRUE(read_until(*port, got, i + 256)) << port->error();
  }
  pty.write({0xFF});
  ASSERT_TRUE(read_until(*port, got, sent.size() + 1)) << port->error();
  sent.push_back(0xFF);
  // A pause, then two more.
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  pty.write({0xFF, 0x00});
  ASSERT_TRUE(read_until(*port, got, sent.size() + 2)) << port->error();
  sent.push_back(0xFF);
  sent.push_back(0x00);
  const TimeNs after = wall_now();

  ASSERT_EQ(got.size(), sent.size());
  for (std::size_t i = 0; i < sent.size(); ++i) {
    EXPECT_EQ(got[i].byte, sent[i]) << "byte " << i;
    EXPECT_EQ(got[i].flags, 0) << "byte " << i;
    EXPECT_EQ(got[i].channel, port->channel());
    if (i > 0) {
      EXPECT_GE(got[i].time, got[i - 1].time + o.serial.character_time()) << "byte " << i;
    }
  }
  // Wall-clock times (ns since the Unix epoch), back-dated at most the whole transfer's wire time.
  const TimeNs wire = static_cast<TimeNs>(sent.size()) * o.serial.character_time();
  EXPECT_GE(got.front().time, before - wire);
  EXPECT_LE(got.back().time, after + wire);
  // The 50 ms pause is visible before the last two bytes (less the push-forward of the burst).
  EXPECT_GE(got[got.size() - 2].time - got[got.size() - 3].time, 35 * kNsPerMs);

  const SerialPort::Counters c = port->counters();
  EXPECT_EQ(c.rx, 0u);
  EXPECT_EQ(c.frame, 0u);
  EXPECT_TRUE(any_has(port->notes(), "reads, "));
  EXPECT_TRUE(any_has(port->notes(), std::to_string(sent.size()) + " characters"));
  EXPECT_TRUE(any_has(port->notes(), "timing "));
}

TEST(SerialPortPty, MasterClosedIsAdapterGone) {
  Pty pty;
  std::string error;
  auto port = open_port(pty.slave_path(), &error);
  ASSERT_NE(port, nullptr) << error;
  std::vector<ByteEvent> got;
  pty.write({0x01, 0x02});
  ASSERT_TRUE(read_until(*port, got, 2)) << port->error();
  EXPECT_TRUE(port->read_available(got));  // nothing there: not an error
  EXPECT_EQ(got.size(), 2u);

  // Linux hangs the slave up when the master closes: reads then return 0 with POLLHUP (or EIO).
  pty.close_master();
  EXPECT_FALSE(port->read_available(got));
  EXPECT_TRUE(HasSub(port->error(), pty.slave_path() + ": adapter unplugged or gone ("))
      << port->error();
  EXPECT_FALSE(port->read_available(got));  // stays failed
  EXPECT_EQ(got.size(), 2u);
}

TEST(SerialPortPty, FtdiLatencyTimerWarning) {
  Pty pty;
  const std::string name = pty.slave_path().substr(pty.slave_path().rfind('/') + 1);
  TempDir sysfs;
  const std::string device = sysfs.path() + "/bus/usb-serial/devices/" + name;
  std::filesystem::create_directories(device);
  std::ofstream(device + "/latency_timer") << "16\n";

  std::string error;
  auto port = open_port(pty.slave_path(), &error, "115200 8N1", sysfs.path());
  ASSERT_NE(port, nullptr) << error;
  const std::string expected = pty.slave_path() +
                               ": FTDI latency_timer is 16 ms: the adapter holds received bytes up "
                               "to 16 ms and the silence between frames is lost; fix: echo 1 > " +
                               device + "/latency_timer";
  EXPECT_TRUE(any_has(port->warnings(), expected));

  // The class/tty path is looked at first; 1 ms is what we want: no warning.
  const std::string class_device = sysfs.path() + "/class/tty/" + name + "/device";
  std::filesystem::create_directories(class_device);
  std::ofstream(class_device + "/latency_timer") << "1\n";
  port = open_port(pty.slave_path(), &error, "115200 8N1", sysfs.path());
  ASSERT_NE(port, nullptr) << error;
  EXPECT_FALSE(any_has(port->warnings(), "latency_timer"));
}

TEST(SerialPortPty, ChannelNameGiven) {
  Pty pty;
  ChannelTable channels;
  SerialPortOptions o;
  o.path = pty.slave_path();
  o.sysfs_root = "/nonexistent-sysfs";
  o.channel_name = "drive1.m";
  std::string error;
  auto port = SerialPort::open(o, channels, &error);
  ASSERT_NE(port, nullptr) << error;
  EXPECT_EQ(channels.at(port->channel()).name, "drive1.m");
  EXPECT_EQ(channels.at(port->channel()).link, "drive1");
  EXPECT_EQ(channels.at(port->channel()).role, ChannelRole::master);
}

TEST(SerialPortPty, LowLatencyNotAskedNoWarning) {
  Pty pty;
  ChannelTable channels;
  SerialPortOptions o;
  o.path = pty.slave_path();
  o.sysfs_root = "/nonexistent-sysfs";
  o.low_latency = false;
  std::string error;
  auto port = SerialPort::open(o, channels, &error);
  ASSERT_NE(port, nullptr) << error;
  EXPECT_TRUE(port->warnings().empty());
}

}  // namespace

// --- capture --scan's judgement ----------------------------------------------------------

namespace {
ScanResult scanned(const char* serial, std::uint64_t ok, std::uint64_t uart_errors) {
  ScanResult r;
  r.serial = config(serial);
  r.bytes = 300;
  r.frames = 30;
  r.frames_ok = ok;
  r.uart_errors = uart_errors;
  return r;
}
}  // namespace

TEST(LineScan, TriesModbusAsciisSevenBitFormatsAtEveryRate) {
  std::set<std::string> tried;
  for (const SerialConfig& s : scan_settings()) tried.insert(s.to_string());
  for (const char* want : {"9600 7E1", "19200 7O1", "1200 7N2", "115200 8E1", "4800 8N1"})
    EXPECT_TRUE(tried.count(want)) << want;
  EXPECT_EQ(tried.size(), 48u);
}

TEST(LineScan, ARealUartTellsParityApartByItsMarks) {
  // A real UART on a 19200 8E1 bus: 8N1 reads the parity bit as the stop bit (framing errors
  // where it is 0), 8O1 flags every character's parity.
  const ScanVerdict v = judge_scan({scanned("19200 8N1", 30, 150), scanned("19200 8E1", 30, 0),
                                    scanned("19200 8O1", 0, 300), scanned("9600 8E1", 0, 80)});
  ASSERT_EQ(v.best.size(), 1u);
  EXPECT_EQ(v.best[0].serial.to_string(), "19200 8E1");
  EXPECT_EQ(v.untold, "");
}

TEST(LineScan, ATieIsSaidWithWhatCouldNotBeToldApartAndWhy) {
  // A pty: no marks, so 8N1 and 8E1 (and 7E1 of an ASCII bus) read alike at 19200.
  ScanVerdict v = judge_scan({scanned("9600 8N1", 0, 0), scanned("19200 8N1", 30, 0),
                              scanned("19200 8E1", 30, 0), scanned("19200 7E1", 12, 0)});
  ASSERT_EQ(v.best.size(), 2u);
  EXPECT_EQ(v.best[0].serial.to_string(), "19200 8N1");  // in the order tried
  EXPECT_TRUE(HasSub(v.untold, "8E1, 8N1 alike: the port reported no parity or framing mark"))
      << v.untold;
  EXPECT_FALSE(HasSub(v.untold, "rates")) << v.untold;
  // Every rate the same: the port applies none.
  v = judge_scan({scanned("9600 8N1", 30, 0), scanned("115200 8N1", 30, 0)});
  ASSERT_EQ(v.best.size(), 2u);
  EXPECT_TRUE(HasSub(v.untold, "2 rates gave the same frames: the port applies no baud rate"))
      << v.untold;
  EXPECT_TRUE(judge_scan({scanned("9600 8N1", 0, 0)}).best.empty());
}
