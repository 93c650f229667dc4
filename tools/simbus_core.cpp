// Simulated Modbus RTU bus on a pty: traffic, pty pair, timed writer (docs/protocols.md §1, §2).
#include "tools/simbus_core.hpp"

#include <fcntl.h>
#include <fmt/format.h>
#include <pthread.h>
#include <sched.h>
#include <sys/ioctl.h>
#include <sys/prctl.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <deque>
#include <span>
#include <utility>

#include "core/checksum.hpp"

namespace drivetap::simbus {
namespace {

// splitmix64 (Steele, Lea, Flood 2014): tiny, fully specified, so a seed means the same traffic
// everywhere.
std::uint64_t splitmix64(std::uint64_t& state) {
  std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

void push16(std::vector<std::uint8_t>& b, std::uint16_t v) {
  b.push_back(static_cast<std::uint8_t>(v >> 8));
  b.push_back(static_cast<std::uint8_t>(v & 0xFF));
}

// Appends the CRC, low byte first (docs/protocols.md §2).
void add_crc(std::vector<std::uint8_t>& b) {
  const std::uint16_t crc = crc16_modbus(b);
  b.push_back(static_cast<std::uint8_t>(crc & 0xFF));
  b.push_back(static_cast<std::uint8_t>(crc >> 8));
}

Record frame(RecordKind kind, std::vector<std::uint8_t> body) {
  Record r;
  r.kind = kind;
  r.station = body.at(0);
  r.bytes = std::move(body);
  add_crc(r.bytes);
  return r;
}

Record exception_reply(std::uint8_t station, std::uint8_t function, std::uint8_t code) {
  return frame(RecordKind::exception, {station, static_cast<std::uint8_t>(function | 0x80), code});
}

// Interrupted by a signal: false, so that the caller looks at its stop flag.
bool sleep_until(TimeNs t) {
  timespec ts{};
  ts.tv_sec = static_cast<time_t>(t / kNsPerSecond);
  ts.tv_nsec = static_cast<long>(t % kNsPerSecond);
  return clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == 0;
}

std::string seconds(TimeNs t) {
  return fmt::format("{}.{:09d}", t / kNsPerSecond, t % kNsPerSecond);
}

}  // namespace

const char* to_string(RecordKind k) {
  switch (k) {
    case RecordKind::request:
      return "request";
    case RecordKind::reply:
      return "reply";
    case RecordKind::exception:
      return "exception";
    case RecordKind::garbage:
      return "garbage";
  }
  return "?";
}

// ---- traffic ----

Traffic::Traffic(const TrafficOptions& options)
    : o_(options),
      char_ns_(options.serial.character_time()),
      state_(options.seed),
      // The noise has a stream of its own, so that --noise moves frames in time but never
      // changes them: the same seed gives the same frames with or without garbage.
      noise_state_(options.seed ^ 0x6E6F697365ull) {
  for (auto& drive : registers_)
    for (std::uint16_t& reg : drive) reg = static_cast<std::uint16_t>(below(0x8000));
}

std::uint64_t Traffic::random() {
  return splitmix64(state_);
}

std::uint32_t Traffic::below(std::uint32_t n) {
  return static_cast<std::uint32_t>(((random() >> 32) * n) >> 32);
}

// Gaps in multiples of the same rounded character time that spaces the bytes (and that the byte
// log reader uses), so that the truth file's times add up exactly.
TimeNs Traffic::chars(double n) const {
  return std::llround(n * static_cast<double>(char_ns_));
}

// One poll of the master. Drives keep 64 holding registers; 0..7 are measurements that move
// between reads. Reads past the map get exception 02 (illegal data address), writes of a value
// with the top bit set exception 03 (illegal data value), so that exceptions follow from the
// requests as on a real drive.
Record Traffic::make_request() {
  const bool absent = below(8) == 0;
  std::size_t drive = 0;
  std::uint8_t station = kAbsentStation;
  if (!absent) {
    drive = next_drive_;
    next_drive_ = (next_drive_ + 1) % kDriveStations.size();
    station = kDriveStations[drive];
  }
  Record request;
  if (below(10) < 7) {  // read holding registers (FC 03)
    const auto quantity = static_cast<std::uint16_t>(1 + below(8));
    const bool bad = below(100) < 8;
    const auto start =
        static_cast<std::uint16_t>(bad ? 0x0100 + below(0x100) : below(kRegisters - quantity + 1));
    std::vector<std::uint8_t> body = {station, 0x03};
    push16(body, start);
    push16(body, quantity);
    request = frame(RecordKind::request, std::move(body));
    if (!absent) {
      if (bad) {
        reply_ = exception_reply(station, 0x03, 0x02);
      } else {
        auto& regs = registers_[drive];
        for (int i = 0; i < 8; ++i)
          regs[i] = static_cast<std::uint16_t>((regs[i] + below(5) + 0x7FFE) & 0x7FFF);
        std::vector<std::uint8_t> reply = {station, 0x03, static_cast<std::uint8_t>(2 * quantity)};
        for (int i = 0; i < quantity; ++i) push16(reply, regs[start + i]);
        reply_ = frame(RecordKind::reply, std::move(reply));
      }
    }
  } else {  // write single register (FC 06); a valid request is echoed
    const auto reg = static_cast<std::uint16_t>(below(kRegisters));
    const bool bad = below(100) < 5;
    const auto value = static_cast<std::uint16_t>((bad ? 0x8000 : 0) | below(0x8000));
    std::vector<std::uint8_t> body = {station, 0x06};
    push16(body, reg);
    push16(body, value);
    request = frame(RecordKind::request, body);
    if (!absent) {
      if (bad) {
        reply_ = exception_reply(station, 0x06, 0x03);
      } else {
        registers_[drive][reg] = value;
        reply_ = frame(RecordKind::reply, std::move(body));
      }
    }
  }
  request.answered = !absent;
  return request;
}

Record Traffic::next() {
  // Garbage goes into the gap after a frame, kGarbageClearChars clear of it and of the next
  // frame; the next frame keeps its time when the gap has room, else the gap widens.
  if (!first_ && !garbage_done_ && o_.noise_rate > 0 &&
      static_cast<double>(splitmix64(noise_state_) >> 11) * 0x1.0p-53 < o_.noise_rate) {
    garbage_done_ = true;
    Record g;
    g.kind = RecordKind::garbage;
    const std::size_t n = 1 + splitmix64(noise_state_) % 3;
    for (std::size_t i = 0; i < n; ++i)
      g.bytes.push_back(static_cast<std::uint8_t>(splitmix64(noise_state_)));
    const TimeNs guard = chars(kGarbageClearChars);
    const TimeNs next_start = end_ + gap_;
    g.start = end_ + guard;
    end_ = g.start + static_cast<TimeNs>(n) * char_ns_;
    gap_ = std::max(guard, next_start - end_);
    return g;
  }
  Record r;
  if (reply_) {
    r = std::move(*reply_);
    reply_.reset();
  } else {
    r = make_request();
  }
  r.start = first_ ? 0 : end_ + gap_;
  first_ = false;
  garbage_done_ = false;
  end_ = r.start + static_cast<TimeNs>(r.bytes.size()) * char_ns_;
  if (o_.back_to_back)
    gap_ = chars(3.5);
  else if (r.kind != RecordKind::request)
    gap_ = chars(o_.gap_next_chars);
  else if (r.answered)
    gap_ = chars(o_.gap_reply_chars);
  else
    gap_ = chars(o_.gap_reply_chars + kTimeoutChars + o_.gap_next_chars);
  return r;
}

// ---- pseudo-terminal ----

std::optional<Pty> Pty::open(std::string* error) {
  Pty p;
  auto fail = [&](const char* what) {
    *error = fmt::format("{}: {}", what, std::strerror(errno));
    return std::nullopt;
  };
  p.master_ = posix_openpt(O_RDWR | O_NOCTTY);
  if (p.master_ < 0) return fail("posix_openpt");
  if (grantpt(p.master_) != 0) return fail("grantpt");
  if (unlockpt(p.master_) != 0) return fail("unlockpt");
  const int flags = fcntl(p.master_, F_GETFL);
  if (flags < 0 || fcntl(p.master_, F_SETFL, flags | O_NONBLOCK) != 0 ||
      fcntl(p.master_, F_SETFD, FD_CLOEXEC) != 0)
    return fail("fcntl on the pty master");
  char name[128];
  if (ptsname_r(p.master_, name, sizeof name) != 0) return fail("ptsname_r");
  p.slave_path_ = name;
  p.slave_ = ::open(name, O_RDWR | O_NOCTTY | O_CLOEXEC);
  if (p.slave_ < 0) return fail(name);
  termios t{};
  if (tcgetattr(p.slave_, &t) != 0) return fail(name);
  cfmakeraw(&t);
  if (tcsetattr(p.slave_, TCSANOW, &t) != 0) return fail(name);
  return std::optional<Pty>(std::move(p));
}

Pty::Pty(Pty&& other) noexcept
    : master_(std::exchange(other.master_, -1)),
      slave_(std::exchange(other.slave_, -1)),
      slave_path_(std::move(other.slave_path_)) {}

bool Pty::drain(TimeNs max_wait) const {
  const TimeNs end = monotonic_now() + max_wait;
  int empty_polls = 0;
  // Two empty looks 1 ms apart: bytes still in the kernel's flip buffer (on their way to the
  // queue TIOCINQ counts) land within microseconds.
  while (empty_polls < 2) {
    int queued = 0;
    if (ioctl(slave_, TIOCINQ, &queued) != 0) return false;
    empty_polls = queued == 0 ? empty_polls + 1 : 0;
    if (monotonic_now() >= end) return false;
    const timespec ms{0, 1'000'000};
    nanosleep(&ms, nullptr);
  }
  return true;
}

Pty::~Pty() {
  if (slave_ >= 0) ::close(slave_);
  if (master_ >= 0) ::close(master_);
}

// ---- writing on schedule ----

TimeNs monotonic_now() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<TimeNs>(ts.tv_sec) * kNsPerSecond + ts.tv_nsec;
}

void LatenessHistogram::add(TimeNs late) {
  late = std::max<TimeNs>(late, 0);
  const auto us = static_cast<std::size_t>(late / kNsPerUs);
  ++bins_[std::min(us, kBins)];
  ++count_;
  max_ = std::max(max_, late);
}

TimeNs LatenessHistogram::quantile(double q) const {
  if (count_ == 0) return 0;
  const auto rank = static_cast<std::uint64_t>(std::ceil(q * static_cast<double>(count_)));
  std::uint64_t seen = 0;
  for (std::size_t i = 0; i < kBins; ++i) {
    seen += bins_[i];
    if (seen >= std::max<std::uint64_t>(rank, 1)) return static_cast<TimeNs>(i) * kNsPerUs;
  }
  return max_;
}

RunStats run(int fd, Traffic& traffic, const RunOptions& o, const std::atomic<bool>* stop,
             const RunHooks& hooks) {
  prctl(PR_SET_TIMERSLACK, 1UL, 0UL, 0UL, 0UL);
  const TimeNs c = traffic.options().serial.character_time();
  // A long silence is slept in slices, so that a stop never waits for more than one.
  constexpr TimeNs kSlice = 100 * kNsPerMs;
  const TimeNs spin = o.burst > 0 ? 0 : std::clamp<TimeNs>(o.spin, 0, c / 2);
  RunStats st;

  struct Pending {
    Record rec;
    std::size_t next = 0;  // bytes written (or dropped) so far
    std::size_t dropped = 0;
    TimeNs last_end = -1;  // its last byte written: where a back-dating reader puts its end
  };
  std::deque<Pending> q;  // records not yet reported, in order
  bool exhausted = false;
  std::uint64_t frames_taken = 0;
  auto fetch = [&]() {
    exhausted = exhausted || (o.frames != 0 && frames_taken >= o.frames);
    if (exhausted) return false;
    Record r = traffic.next();
    exhausted = o.duration != 0 && r.start >= o.duration;
    if (exhausted) return false;
    if (r.is_frame()) ++frames_taken;
    q.push_back({std::move(r)});
    return true;
  };
  auto report = [&](Pending& p) {
    ++(p.rec.is_frame() ? st.frames : st.garbage);
    if (hooks.sent) hooks.sent(p.rec, p.dropped);
  };
  // The first record with bytes left, fetching as needed; q.size() when the traffic is over.
  auto first_open = [&](std::size_t from) {
    for (std::size_t i = from;; ++i) {
      if (i == q.size() && !fetch()) return i;
      if (q[i].next < q[i].rec.bytes.size()) return i;
    }
  };

  std::vector<std::uint8_t> buf;
  std::vector<std::size_t> owner;
  std::vector<TimeNs> due;
  TimeNs last_write = o.t0;  // last write() made, taken or refused
  TimeNs next_progress = o.t0 + o.progress_every;
  for (;;) {
    if (stop != nullptr && stop->load(std::memory_order_relaxed)) break;
    std::size_t i = first_open(0);
    if (i == q.size()) break;
    TimeNs wake = o.t0 + due_time(q[i].rec, q[i].next, c);
    if (o.burst > 0) wake = o.t0 + (wake - o.t0 + o.burst - 1) / o.burst * o.burst;
    if (const TimeNs slice_end = monotonic_now() + kSlice; wake > slice_end) {
      sleep_until(slice_end);
      continue;
    }
    if (!sleep_until(wake - spin)) continue;
    while (spin > 0 && monotonic_now() < wake) {
    }
    // Byte by byte, everything due by now goes out (catching up after a late wake-up keeps the
    // schedule: it never drifts); in bursts, everything due by the tick.
    const TimeNs limit = o.burst > 0 ? wake : monotonic_now();
    buf.clear();
    owner.clear();
    due.clear();
    for (; i < q.size(); i = first_open(i)) {
      Pending& p = q[i];
      const TimeNs d = o.t0 + due_time(p.rec, p.next, c);
      if (d > limit) break;
      buf.push_back(p.rec.bytes[p.next++]);
      owner.push_back(i);
      due.push_back(d);
    }
    ssize_t n = 0;
    do n = ::write(fd, buf.data(), buf.size());
    while (n < 0 && errno == EINTR);
    const bool failed = n < 0 && errno != EAGAIN && errno != EWOULDBLOCK;
    if (failed) st.error = fmt::format("write to the pty master: {}", std::strerror(errno));
    const auto written = static_cast<std::size_t>(std::max<ssize_t>(n, 0));
    const TimeNs after = monotonic_now();
    last_write = after;
    for (std::size_t k = 0; k < written; ++k) {
      st.late.add(after - due[k]);
      if (o.burst > 0) continue;
      // A reader stamps the bytes of one read back from its time, one character each.
      Pending& p = q[owner[k]];
      p.rec.late = std::max(p.rec.late, after - due[k]);
      const TimeNs end = after - static_cast<TimeNs>(written - k - 1) * c;
      if (p.last_end >= 0) p.rec.pause = std::max(p.rec.pause, end - c - p.last_end);
      p.last_end = end;
    }
    for (std::size_t k = written; k < buf.size(); ++k) ++q[owner[k]].dropped;
    st.bytes += written;
    st.dropped += buf.size() - written;
    if (failed) break;
    while (!q.empty() && q.front().next == q.front().rec.bytes.size()) {
      report(q.front());
      q.pop_front();
    }
    if (o.progress_every > 0 && after >= next_progress) {
      st.elapsed = after - o.t0;
      if (hooks.progress) hooks.progress(st);
      while (next_progress <= after) next_progress += o.progress_every;
    }
  }
  // A stop cuts the record being written: it is reported with the bytes that went out.
  for (Pending& p : q) {
    if (p.next == 0) break;
    p.rec.cut = p.next < p.rec.bytes.size();
    p.rec.bytes.resize(p.next);
    report(p);
  }
  st.elapsed = last_write - o.t0;
  return st;
}

bool set_realtime(int priority, std::string* error) {
  sched_param sp{};
  sp.sched_priority = priority;
  const int e = pthread_setschedparam(pthread_self(), SCHED_FIFO, &sp);
  if (e != 0) *error = std::strerror(e);
  return e == 0;
}

// ---- truth file ----

void write_truth_header(std::FILE* f, const TrafficOptions& t, const RunOptions& r) {
  fmt::print(f, "# drivetap-simbus: a Modbus RTU master polling drives {} and absent station {}\n",
             fmt::format("{}, {}, {}", kDriveStations[0], kDriveStations[1], kDriveStations[2]),
             kAbsentStation);
  if (t.back_to_back)
    fmt::print(f, "# seed {}, frames back to back (3.5 characters apart)", t.seed);
  else
    fmt::print(f, "# seed {}, gaps {} characters before a reply, {} before the next request",
               t.seed, t.gap_reply_chars, t.gap_next_chars);
  if (t.noise_rate > 0) fmt::print(f, ", garbage in {:g} of the gaps", t.noise_rate);
  if (r.burst > 0) fmt::print(f, ", written in bursts every {} ms", r.burst / kNsPerMs);
  // t0 on both clocks, so that a capture stamped with either lines up with the schedule.
  timespec real{};
  clock_gettime(CLOCK_REALTIME, &real);
  const TimeNs to_real =
      static_cast<TimeNs>(real.tv_sec) * kNsPerSecond + real.tv_nsec - monotonic_now();
  fmt::print(f,
             "\n# times: scheduled start bit of each line's first byte, from t0 = CLOCK_MONOTONIC "
             "{} s = CLOCK_REALTIME {} s;\n# each byte was written to the pty at the end of its "
             "stop bit, one character time after its own time\n",
             seconds(r.t0), seconds(r.t0 + to_real));
  fmt::print(f, "#! serial {}\n", t.serial.to_string());
}

void write_truth_record(std::FILE* f, const Record& record, std::size_t dropped, TimeNs max_pause) {
  std::string line = seconds(record.start) + " bus";
  for (std::uint8_t b : record.bytes) line += fmt::format(" {:02X}", b);
  line += " # ";
  line += to_string(record.kind);
  if (record.kind == RecordKind::request && !record.answered) line += ", no reply";
  if (record.cut) line += ", cut short by the stop";
  if (dropped > 0) line += fmt::format(", {} bytes dropped (pty buffer full)", dropped);
  if (record.pause > max_pause)
    line += fmt::format(", a {} us pause inside as written (the writer was late)",
                        record.pause / kNsPerUs);
  if (record.late > max_pause)
    line += fmt::format(", written up to {} us behind its schedule", record.late / kNsPerUs);
  line += '\n';
  std::fputs(line.c_str(), f);
}

}  // namespace drivetap::simbus
