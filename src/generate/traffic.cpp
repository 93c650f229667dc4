// Capture generator: the four links' masters and drives (layout and rules in traffic.hpp).
#include "generate/traffic.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <span>

#include "core/byte_event.hpp"
#include "dissectors/danfoss_fc/fc_dissector.hpp"
#include "dissectors/easydrive/eds_dissector.hpp"
#include "dissectors/modbus/rtu_framer.hpp"

namespace drivetap::generate {

std::optional<Mix> mix_from_name(std::string_view name) {
  if (name == "all") return Mix::all;
  if (name == "modbus-rtu") return Mix::modbus_rtu;
  return std::nullopt;
}
const char* const kMixHelp =
    "all (default): Modbus RTU, Danfoss FC, Easydrive and Modbus ASCII links; modbus-rtu: the "
    "Modbus RTU link only";
const char* const kMixNames = "all or modbus-rtu";

namespace {

using Bytes = std::vector<std::uint8_t>;
using modbus::kRtuMinFrame;

// splitmix64: a small, fast generator whose output is fixed by its definition on every platform.
class Rng {
 public:
  explicit Rng(std::uint64_t seed) : state_(seed) {}
  std::uint64_t next() {
    std::uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  // Uniform enough in [0, n) for traffic (the modulo bias is below 2^-40).
  std::uint32_t below(std::uint32_t n) { return static_cast<std::uint32_t>(next() % n); }
  int between(int lo, int hi) {
    return lo + static_cast<int>(below(static_cast<std::uint32_t>(hi - lo + 1)));
  }
  // True `per_10000` times in 10 000.
  bool chance(std::uint32_t per_10000) { return below(10000) < per_10000; }

 private:
  std::uint64_t state_;
};

void put16(Bytes& b, unsigned v) {
  b.push_back(static_cast<std::uint8_t>(v >> 8));
  b.push_back(static_cast<std::uint8_t>(v));
}

constexpr char kHex[] = "0123456789ABCDEF";
void put_hex(Bytes& b, unsigned v, int digits) {
  for (int d = digits - 1; d >= 0; --d)
    b.push_back(static_cast<std::uint8_t>(kHex[(v >> (4 * d)) & 0xF]));
}
bool is_hex_char(std::uint8_t c) {
  return (c >= '0' && c <= '9') || (c >= 'A' && c <= 'F');
}

// ---- Modbus RTU framing checks ----

// A good frame the framer would cut short: a length its function code predicts (as request or as
// reply) ends inside it in a valid CRC. Rare (about 1 in 16 000); such frames are not sent.
bool rtu_cut_short(std::span<const std::uint8_t> b) {
  const modbus::RtuRules& rules = modbus::RtuFramer::rules();
  std::size_t lengths[2];
  bool needs_more = false;
  rules.predicted_lengths(b, lengths, &needs_more);
  for (std::size_t len : lengths)
    if (len >= kRtuMinFrame && len < b.size() && rules.checksum_matches(b.first(len))) return true;
  return false;
}

// A damaged frame in which some other span, starting anywhere, ends in a valid CRC (in either
// byte order): the framer might take that span for a frame. Damage of that kind is drawn again.
bool rtu_inner_crc(std::span<const std::uint8_t> b) {
  const std::size_t n = b.size();
  for (std::size_t q = 0; q + 4 <= n; ++q) {
    std::uint16_t crc = 0xFFFF;
    for (std::size_t e = q; e + 2 <= n; ++e) {
      if (e - q >= 2 && !(q == 0 && e + 2 == n)) {
        const unsigned lo = b[e], hi = b[e + 1];
        if (crc == (lo | (hi << 8)) || crc == ((lo << 8) | hi)) return true;
      }
      crc = crc16_modbus_update(crc, b[e]);
    }
  }
  return false;
}

Bytes with_crc(std::uint8_t address, const Bytes& pdu) {
  Bytes f;
  f.reserve(pdu.size() + 3);
  f.push_back(address);
  for (std::uint8_t b : pdu) f.push_back(b);
  const std::uint16_t crc = crc16_modbus(f);
  f.push_back(static_cast<std::uint8_t>(crc));
  f.push_back(static_cast<std::uint8_t>(crc >> 8));
  return f;
}

// ":" ADDR PDU LRC CR LF in upper-case hex (docs/protocols.md §3).
Bytes ascii_frame(std::uint8_t address, const Bytes& pdu) {
  Bytes bin;
  bin.reserve(pdu.size() + 2);
  bin.push_back(address);
  for (std::uint8_t b : pdu) bin.push_back(b);
  bin.push_back(lrc8(bin));
  Bytes f{':'};
  for (std::uint8_t v : bin) put_hex(f, v, 2);
  f.push_back('\r');
  f.push_back('\n');
  return f;
}

// STX LGE ADR DATA BCC (docs/protocols.md §4); addresses 1..31 in the short format.
Bytes fc_telegram(std::uint8_t address, const Bytes& data) {
  Bytes f;
  f.reserve(data.size() + 4);
  f.push_back(danfoss_fc::kStxByte);
  f.push_back(static_cast<std::uint8_t>(data.size() + 2));
  f.push_back(address);
  for (std::uint8_t b : data) f.push_back(b);
  f.push_back(danfoss_fc::bcc(f));
  return f;
}

// A telegram with a valid BCC starting inside a corrupted one: the framer might take it.
bool fc_inner_telegram(std::span<const std::uint8_t> b) {
  for (std::size_t q = 1; q + 4 <= b.size(); ++q) {
    if (b[q] != danfoss_fc::kStxByte || b[q + 1] < 2) continue;
    const std::size_t len = std::size_t{b[q + 1]} + 2;
    if (q + len <= b.size() && danfoss_fc::bcc(b.subspan(q, len - 1)) == b[q + len - 1])
      return true;
  }
  return false;
}

// '~' TEXT SUM CR (docs/protocols.md §5).
Bytes eds_frame(const std::string& text) {
  Bytes f;
  f.reserve(text.size() + 6);
  f.push_back('~');
  for (char c : text) f.push_back(static_cast<std::uint8_t>(c));
  const std::uint16_t sum = easydrive::ascii_sum(std::span(f).subspan(1));
  put_hex(f, sum, 4);
  f.push_back('\r');
  return f;
}

// ---- drives ----

// What a drive is doing: the values its replies report.
struct DriveState {
  bool running = false;
  int setpoint = 5000;  // 0.01 Hz
  int output = 0;       // 0.01 Hz
  int fault = 0;
  int previous_fault = 0;

  // Between two polls: the output ramps towards the setpoint (or zero), now and then a fault
  // trips the drive.
  void tick(Rng& rng, int fault_code) {
    const int target = running ? setpoint : 0;
    const int step = rng.between(100, 400);
    output = output < target ? std::min(target, output + step) : std::max(target, output - step);
    if (running && fault == 0 && rng.chance(15)) {
      previous_fault = fault;
      fault = fault_code;
      running = false;
      output = 0;
    }
  }
  [[nodiscard]] int volts() const { return output * 380 / 5000; }             // V at 50 Hz: 380
  [[nodiscard]] int amps() const { return running ? 18 + output / 200 : 0; }  // 0.1 A
};

// One Modbus exchange: request and reply PDUs (function code onwards).
struct Exchange {
  Bytes request, reply;
  bool exception = false;
};

Bytes read_request(std::uint8_t fc, unsigned start, unsigned count) {
  Bytes b{fc};
  put16(b, start);
  put16(b, count);
  return b;
}
Bytes read_reply(std::uint8_t fc, std::initializer_list<int> words) {
  Bytes b{fc, static_cast<std::uint8_t>(2 * words.size())};
  for (int w : words) put16(b, static_cast<unsigned>(w) & 0xFFFF);
  return b;
}
Exchange read(std::uint8_t fc, unsigned start, std::initializer_list<int> words) {
  return {read_request(fc, start, static_cast<unsigned>(words.size())), read_reply(fc, words),
          false};
}
Exchange write_one(unsigned reg, int value) {  // FC 06: the reply echoes the request
  Bytes b{0x06};
  put16(b, reg);
  put16(b, static_cast<unsigned>(value) & 0xFFFF);
  return {b, b, false};
}
Exchange write_many(unsigned start, std::initializer_list<int> words) {  // FC 16
  Bytes q{0x10};
  put16(q, start);
  put16(q, static_cast<unsigned>(words.size()));
  q.push_back(static_cast<std::uint8_t>(2 * words.size()));
  for (int w : words) put16(q, static_cast<unsigned>(w) & 0xFFFF);
  Bytes r{0x10};
  put16(r, start);
  put16(r, static_cast<unsigned>(words.size()));
  return {q, r, false};
}
Exchange write_coil(unsigned coil) {  // FC 05 ON: the reply echoes the request
  Bytes b{0x05};
  put16(b, coil);
  put16(b, 0xFF00);
  return {b, b, false};
}
Exchange refused(std::uint8_t fc, unsigned start, unsigned count, std::uint8_t code) {
  return {read_request(fc, start, count), Bytes{static_cast<std::uint8_t>(fc | 0x80), code}, true};
}

// A Modbus drive: its registers per its profile (dissectors/profiles/<id>.toml, docs/protocols.md
// §2).
class ModbusDrive {
 public:
  ModbusDrive(std::uint8_t address, std::string profile)
      : address_(address), profile_(std::move(profile)) {}
  virtual ~ModbusDrive() = default;
  [[nodiscard]] std::uint8_t address() const { return address_; }
  [[nodiscard]] const std::string& profile() const { return profile_; }

  // The master's next exchange with this drive: mostly status reads, now and then a command
  // (setpoint, start, stop, fault reset). `reads_only`: after an unanswered request (an echoed
  // write would then look like the missing reply).
  Exchange poll(Rng& rng, bool reads_only) {
    s_.tick(rng, fault_code(rng));
    const std::uint32_t r = rng.below(100);
    if (reads_only || r < 70) return status();
    if (s_.fault != 0 && r < 85) {
      s_.previous_fault = s_.fault;
      s_.fault = 0;
      return reset();
    }
    if (r < 82) {
      s_.setpoint = rng.between(4, 10) * 500;  // 20.00 .. 50.00 Hz
      return setpoint();
    }
    if (r < 92 && s_.fault == 0) {
      s_.running = !s_.running;
      return run_command();
    }
    return secondary();
  }
  // A request the drive refuses with an exception (an address it does not have).
  virtual Exchange rejected() = 0;

 protected:
  virtual Exchange status() = 0;
  virtual Exchange secondary() = 0;
  virtual Exchange setpoint() = 0;
  virtual Exchange run_command() = 0;
  virtual Exchange reset() = 0;
  virtual int fault_code(Rng& rng) = 0;
  DriveState s_;

 private:
  std::uint8_t address_;
  std::string profile_;
};

// ERMAN E-9 (000 §4-5): FC 03 0x0000.., FC 10 0x0010..; no reset bit (panel reset).
class E9 final : public ModbusDrive {
 public:
  using ModbusDrive::ModbusDrive;
  Exchange rejected() override { return refused(0x03, 0x0020, 2, 0x03); }

 protected:
  Exchange status() override {
    const int status = (s_.running ? 1 : 0) | 2 | (s_.fault ? 8 : 0);
    return read(0x03, 0x0000, {status, s_.setpoint, s_.output, s_.volts(), s_.amps()});
  }
  Exchange secondary() override { return read(0x03, 0x000B, {s_.fault, s_.previous_fault}); }
  Exchange setpoint() override { return write_many(0x0011, {s_.setpoint}); }
  Exchange run_command() override { return write_many(0x0010, {s_.running ? 1 : 0, s_.setpoint}); }
  Exchange reset() override { return status(); }  // cleared at the panel; the master just reads
  int fault_code(Rng& rng) override { return rng.between(1, 0x1F); }
};

// E5-8200 (004): monitor block 0x2520..0x2527 (FC 03), control 0x2501 and setpoint 0x2502
// (FC 06); vendor exception 0x52 "address error".
class E5 final : public ModbusDrive {
 public:
  using ModbusDrive::ModbusDrive;
  Exchange rejected() override { return refused(0x03, 0x2530, 2, 0x52); }

 protected:
  Exchange status() override {
    const int status = s_.fault ? 0x0002 : s_.running ? 0x0007 : 0x0006;
    return read(0x03, 0x2520,
                {status, s_.fault, 0, s_.setpoint, s_.output, s_.volts() * 10, 540, s_.amps()});
  }
  Exchange secondary() override { return read(0x03, 0x252F, {0x0110}); }
  Exchange setpoint() override { return write_one(0x2502, s_.setpoint); }
  Exchange run_command() override { return write_one(0x2501, s_.running ? 0x0001 : 0x0000); }
  Exchange reset() override { return write_one(0x2501, 0x0008); }
  int fault_code(Rng& rng) override { return rng.between(1, 46); }
};

// ERMAN ER-G (003): input registers with FC 04, command coils with FC 05, setpoint 0x0002 in
// 0.1 Hz with FC 06.
class Erg final : public ModbusDrive {
 public:
  using ModbusDrive::ModbusDrive;
  Exchange rejected() override { return refused(0x03, 0x0030, 1, 0x02); }

 protected:
  Exchange status() override {
    return read(0x04, 0x0001, {s_.output / 10, 0, s_.amps(), 0, 540, 30 + s_.output / 500});
  }
  Exchange secondary() override {
    const int state = !s_.running               ? 0
                      : s_.output < s_.setpoint ? 2
                      : s_.output > s_.setpoint ? 3
                                                : 1;
    return read(0x04, 0x0400, {state, 0, s_.fault ? 0x0010 : 0, 0});
  }
  Exchange setpoint() override { return write_one(0x0002, s_.setpoint / 10); }
  Exchange run_command() override { return write_coil(s_.running ? 0 : 1); }
  Exchange reset() override { return write_coil(9); }
  int fault_code(Rng&) override { return 4; }
};

// Danfoss VLT AQUA over Modbus (002 §7.8-7.10): STW 50200 and MAV 50210 read, CTW 50000 and
// REF 50010 written (wire addresses one less).
class VltModbus final : public ModbusDrive {
 public:
  using ModbusDrive::ModbusDrive;
  Exchange rejected() override { return refused(0x03, 60000, 1, 0x02); }

 protected:
  Exchange status() override { return read(0x03, 50199, {stw()}); }
  Exchange secondary() override { return read(0x03, 50209, {s_.output * 0x4000 / 5000}); }
  Exchange setpoint() override { return write_one(50009, s_.setpoint * 0x4000 / 5000); }
  Exchange run_command() override { return write_one(49999, s_.running ? 0x047C : 0x043C); }
  Exchange reset() override { return write_one(49999, 0x04BC); }
  int fault_code(Rng&) override { return 1; }

 private:
  [[nodiscard]] int stw() const {
    if (s_.fault) return 0x060A;
    if (!s_.running) return 0x0607;
    return s_.output == s_.setpoint ? 0x0F07 : 0x0E07;
  }
};

}  // namespace

// ---- links ----

// One link: a master and its drives on one channel. transaction() appends the records of the
// master's next exchange (noise before it, request, reply), in time order, to the link's queue.
class Link {
 public:
  Link(std::uint64_t seed, TimeNs offset)
      : rng_(seed), char_(Generator::serial().character_time()) {
    end_ = offset;
    not_before_ = offset;
  }
  virtual ~Link() = default;
  virtual void transaction(std::deque<Record>& q) = 0;

 protected:
  [[nodiscard]] TimeNs chars(int n) const { return n * char_; }
  static TimeNs ms(int n) { return n * kNsPerMs; }
  // Microseconds between lo and hi ms: delays are not whole milliseconds on a real bus.
  TimeNs ms_between(int lo, int hi) {
    return static_cast<TimeNs>(rng_.between(lo * 1000, hi * 1000)) * kNsPerUs;
  }
  [[nodiscard]] TimeNs end_of(const Record& r) const {
    return r.start + static_cast<TimeNs>(r.bytes.size()) * char_;
  }

  // A record `gap` after the link's last byte (and not before not_before_).
  Record& add(std::deque<Record>& q, RecordKind kind, Bytes bytes, TimeNs gap) {
    Record& r = q.emplace_back();
    r.kind = kind;
    r.start = std::max(end_ + gap, not_before_);
    r.flags.assign(bytes.size(), 0);
    r.bytes = std::move(bytes);
    end_ = end_of(r);
    return r;
  }

  // 1..3 garbage bytes with silence either side: the first byte never starts a frame of any of
  // the protocols (above 247, not STX, ':' or '~'), none is CR or LF. Parity marks on some.
  void noise(std::deque<Record>& q, bool parity) {
    Bytes b;
    b.push_back(static_cast<std::uint8_t>(0xF8 + rng_.below(8)));
    const int extra = rng_.between(0, 2);
    for (int i = 0; i < extra; ++i) b.push_back(static_cast<std::uint8_t>(0x80 + rng_.below(0x80)));
    Record& r = add(q, RecordKind::noise, std::move(b), chars(rng_.between(5, 10)));
    if (parity)
      for (std::size_t i = 0; i < r.bytes.size(); ++i)
        if (rng_.chance(3000)) {
          r.flags[i] = kUartParityError;
          ++r.parity_errors;
        }
    r.note = r.parity_errors ? "noise, parity errors" : "noise";
  }

  // Changes one byte in [from, to) (one bit flipped); a parity mark on it when `parity`.
  // `ambiguous` says when the damage would let the framer cut the frame elsewhere: then another
  // byte or bit is tried, and when none will do (a valid CRC inside the frame that no change in
  // the range breaks) the frame goes out undamaged.
  template <typename Check>
  void corrupt_binary(Record& r, std::size_t from, std::size_t to, bool parity, Check ambiguous) {
    const Bytes original = r.bytes;
    for (int attempt = 0; attempt < 64; ++attempt) {
      const std::size_t i = from + rng_.below(static_cast<std::uint32_t>(to - from));
      r.bytes[i] ^= static_cast<std::uint8_t>(1u << rng_.below(8));
      if (!ambiguous(r.bytes)) {
        if (parity) {
          r.flags[i] = kUartParityError;
          r.parity_errors = 1;
        }
        r.checksum = ChecksumVerdict::bad;
        r.note = parity ? "parity error: byte changed" : "checksum error: byte changed";
        return;
      }
      r.bytes = original;
    }
  }

  // Changes one hex character in [from, to) into another hex character.
  void corrupt_text(Record& r, std::size_t from, std::size_t to) {
    std::size_t i = from + rng_.below(static_cast<std::uint32_t>(to - from));
    while (!is_hex_char(r.bytes[i])) i = from + (i + 1 - from) % (to - from);
    std::uint8_t c = r.bytes[i];
    while (c == r.bytes[i]) c = static_cast<std::uint8_t>(kHex[rng_.below(16)]);
    r.bytes[i] = c;
    r.checksum = ChecksumVerdict::bad;
    r.note = "checksum error: character changed";
  }

  Rng rng_;
  TimeNs char_;
  TimeNs end_ = 0;         // end of the link's last character
  TimeNs not_before_ = 0;  // the master's next request starts no earlier (its timeout, its cycle)
};

namespace {

// What becomes of one exchange (rolled once per request, per 10 000).
enum class Fate {
  normal,
  timeout,
  request_bad,
  exception,
  reply_bad,
  reply_swapped,
  reply_parity,
  late
};

Fate roll_fate(Rng& rng, bool swaps, bool parity) {
  const std::uint32_t r = rng.below(10000);
  if (r < 150) return Fate::timeout;
  if (r < 250) return Fate::request_bad;
  if (r < 400) return Fate::exception;
  if (r < 550) return Fate::reply_bad;
  if (r < 650) return swaps ? Fate::reply_swapped : Fate::normal;
  if (r < 720) return parity ? Fate::reply_parity : Fate::normal;
  if (r < 820) return Fate::late;
  return Fate::normal;
}

// Modbus RTU or ASCII: a master polling Modbus drives. The timing rules kept (and broken on
// purpose) are the profiles': E-9 24 characters of silence before a request and 200 ms from its
// reply to the next request; E5-8200 at least 10 ms before replying; VLT AQUA within 20 ms.
class ModbusLink final : public Link {
 public:
  ModbusLink(std::uint64_t seed, TimeNs offset, bool ascii) : Link(seed, offset), ascii_(ascii) {
    if (ascii) {
      drives_.push_back(std::make_unique<E5>(9, "e5-8200"));
    } else {
      drives_.push_back(std::make_unique<E9>(1, "e9"));
      drives_.push_back(std::make_unique<E5>(2, "e5-8200"));
      drives_.push_back(std::make_unique<Erg>(3, "erg"));
      drives_.push_back(std::make_unique<VltModbus>(4, "vlt-aqua"));
    }
  }
  std::string drives() const {
    std::string s;
    for (const auto& d : drives_)
      s += fmt::format("{}{}={}", s.empty() ? "" : " ", d->address(), d->profile());
    return s;
  }

  void transaction(std::deque<Record>& q) override {
    if (rng_.chance(ascii_ ? 100 : 150)) noise(q, !ascii_);
    // The master's pause before the request: RTU polls fast, ASCII slowly.
    const TimeNs pause = ascii_ ? ms_between(100, 160) : chars(rng_.between(5, 12));
    // The drive: a random one, not the one that just failed to answer; the E-9 only 200 ms
    // after its last reply unless this request breaks the rule on purpose.
    std::size_t d = rng_.below(static_cast<std::uint32_t>(drives_.size()));
    bool early = false;
    const TimeNs e9_pause = chars(rng_.between(30, 40));
    for (std::size_t tries = 0; tries < drives_.size(); ++tries, d = (d + 1) % drives_.size()) {
      if (drives_.size() > 1 && drives_[d]->address() == avoid_) continue;
      if (drives_[d]->profile() != "e9" || e9_reply_end_ < 0) break;
      const TimeNs since = std::max(end_ + e9_pause, not_before_) - e9_reply_end_;
      if (since >= ms(205)) break;
      if (since >= ms(40) && since < ms(195) && rng_.chance(300)) {
        early = true;
        break;
      }
    }
    ModbusDrive& drive = *drives_[d];
    const bool e9 = drive.profile() == "e9";
    const Fate fate = roll_fate(rng_, !ascii_, !ascii_);
    Exchange x = fate == Fate::exception ? drive.rejected() : drive.poll(rng_, reads_only_);
    reads_only_ = false;
    avoid_ = -1;

    // A request the framer would cut short is replaced by a status read.
    while (!ascii_ && rtu_cut_short(with_crc(drive.address(), x.request)))
      x = drive.poll(rng_, true);
    Record& req =
        add(q, RecordKind::request, frame(drive.address(), x.request), e9 ? e9_pause : pause);
    if (early) {
      req.timing_breaks = 1;
      req.note = "timing: request less than 200 ms after the E-9's reply";
    }
    const TimeNs request_end = end_;
    // A reply the framer would cut short is not sent: that request goes unanswered.
    const bool unanswerable = !ascii_ && rtu_cut_short(with_crc(drive.address(), x.reply));
    if (fate == Fate::timeout || fate == Fate::request_bad || unanswerable) {
      if (fate == Fate::request_bad) damage(req, x.request[0]);
      req.note += std::string(req.note.empty() ? "" : "; ") + "no reply";
      // The master gives up after 100 ms; its next request goes to another drive or reads.
      not_before_ = request_end + ms(100);
      avoid_ = drive.address();
      reads_only_ = true;
      return;
    }
    // Reply delays per family; `late` breaks the E5-8200's or the VLT's rule, others keep theirs.
    TimeNs delay = ms_between(3, 8);
    int breaks = 0;
    const std::string& profile = drive.profile();
    if (profile == "e9") delay = ms_between(12, 20);
    if (profile == "e5-8200") {
      delay = fate == Fate::late ? ms_between(3, 8) : ms_between(11, 20);
      breaks = fate == Fate::late;
    }
    if (profile == "vlt-aqua") {
      delay = fate == Fate::late ? ms_between(25, 40) : ms_between(3, 12);
      breaks = fate == Fate::late;
    }
    Record& rsp = add(q, RecordKind::reply, frame(drive.address(), x.reply), delay);
    rsp.exception = x.exception;
    rsp.timing_breaks = breaks;
    if (x.exception) rsp.note = "exception";
    if (breaks)
      rsp.note = profile == "vlt-aqua" ? "timing: reply later than 20 ms"
                                       : "timing: reply sooner than 10 ms";
    if (fate == Fate::reply_bad || fate == Fate::reply_parity)
      damage(rsp, x.request[0], fate == Fate::reply_parity);
    if (fate == Fate::reply_swapped) {
      std::swap(rsp.bytes[rsp.bytes.size() - 2], rsp.bytes[rsp.bytes.size() - 1]);
      rsp.checksum = ChecksumVerdict::swapped;
      rsp.note = "CRC sent high byte first";
      if (rsp.bytes[rsp.bytes.size() - 2] == rsp.bytes.back() || rtu_inner_crc(rsp.bytes)) {
        // A CRC whose two bytes are equal cannot be swapped; a swap that leaves the frame
        // ambiguous is not made.
        std::swap(rsp.bytes[rsp.bytes.size() - 2], rsp.bytes[rsp.bytes.size() - 1]);
        rsp.checksum = ChecksumVerdict::good;
        rsp.note.clear();
      }
    }
    if (e9) e9_reply_end_ = end_;
  }

 private:
  Bytes frame(std::uint8_t address, const Bytes& pdu) const {
    return ascii_ ? ascii_frame(address, pdu) : with_crc(address, pdu);
  }
  // One byte changed: the last register value or the CRC (never the address, function code or a
  // length field, which would change the frame's station or layout); in Modbus ASCII a hex
  // character of the last register value or of the LRC.
  void damage(Record& r, std::uint8_t function, bool parity = false) {
    // Register values of a read reply may change; elsewhere a changed quantity or coil value
    // would also break the layout (a `malformed` finding besides the checksum): only the
    // checksum changes there.
    const std::size_t n = r.bytes.size();
    const bool values =
        r.kind == RecordKind::reply && !r.exception && (function == 0x03 || function == 0x04);
    if (ascii_) {  // the last data byte's or the LRC's hex characters
      corrupt_text(r, values ? n - 6 : n - 4, n - 2);
      return;
    }
    corrupt_binary(r, values ? n - 4 : n - 2, n, parity, [](std::span<const std::uint8_t> b) {
      return check_rtu_crc(b).verdict != ChecksumVerdict::bad || rtu_inner_crc(b);
    });
  }

  bool ascii_;
  std::vector<std::unique_ptr<ModbusDrive>> drives_;
  TimeNs e9_reply_end_ = -1;
  int avoid_ = -1;
  bool reads_only_ = false;
};

// Danfoss FC protocol (002 §7.2-7.5, docs/protocols.md §4): the master sends each VLT AQUA its
// control word and reference every cycle and reads a parameter now and then; the drives answer with
// status word and output frequency within 20 ms (8-35/8-36 defaults).
class FcLink final : public Link {
 public:
  using Link::Link;
  static std::string drives() { return "5=vlt-aqua 6=vlt-aqua"; }

  void transaction(std::deque<Record>& q) override {
    if (rng_.chance(100)) noise(q, false);
    std::size_t d = next_++ % 2;
    if (5 + static_cast<int>(d) == avoid_) d ^= 1;  // order tells FC replies: not the same drive
    avoid_ = -1;
    const std::uint8_t address = static_cast<std::uint8_t>(5 + d);
    DriveState& s = drives_[d];
    s.tick(rng_, 1);
    if (rng_.chance(300)) {
      if (s.fault)
        s.fault = 0;
      else
        s.running = !s.running;
    }
    const int ctw = s.fault ? 0x04BC : s.running ? 0x047C : 0x043C;
    const int ref = s.setpoint * 0x4000 / 5000;
    const int stw = s.fault                  ? 0x060A
                    : !s.running             ? 0x0607
                    : s.output == s.setpoint ? 0x0F07
                                             : 0x0E07;
    const int mav = s.output * 0x4000 / 5000;
    Bytes request, reply;
    std::string note;
    const std::uint32_t kind = rng_.below(100);
    if (kind < 88) {  // process data only (LGE 6)
      put16(request, ctw);
      put16(request, ref);
      put16(reply, stw);
      put16(reply, mav);
    } else {  // parameter block (LGE 14): read 4-14 (PNU 414), 16-14 (1614) or a missing one
      const unsigned pnu = kind < 94 ? 414 : kind < 99 ? 1614 : 4095;
      put16(request, 0x1000 | pnu);  // AK 1: read
      put16(request, 0);
      put16(request, 0);
      put16(request, 0);
      put16(request, ctw);
      put16(request, ref);
      if (pnu == 4095) {  // AK 7: cannot execute, error 0 (illegal PNU)
        put16(reply, 0x7000 | pnu);
        note = "AK 7: illegal parameter";
      } else {
        put16(reply, 0x1000 | pnu);
      }
      put16(reply, 0);
      put16(reply, 0);
      put16(reply, pnu == 414 ? 500 : pnu == 1614 ? s.amps() : 0);
      put16(reply, stw);
      put16(reply, mav);
    }
    Record& req = add(q, RecordKind::request, fc_telegram(address, request), ms_between(60, 100));
    const TimeNs request_end = end_;
    const Fate fate = roll_fate(rng_, false, false);
    if (fate == Fate::timeout || fate == Fate::request_bad) {
      if (fate == Fate::request_bad) damage(req);
      req.note += std::string(req.note.empty() ? "" : "; ") + "no reply";
      not_before_ = request_end + ms(100);
      avoid_ = address;
      return;
    }
    const bool late = fate == Fate::late;
    Record& rsp = add(q, RecordKind::reply, fc_telegram(address, reply),
                      late ? ms_between(25, 40) : ms_between(3, 12));
    rsp.note = note;
    if (late) {
      rsp.timing_breaks = 1;
      rsp.note = "timing: reply later than 20 ms";
    }
    if (fate == Fate::reply_bad || fate == Fate::reply_parity) damage(rsp);
  }

 private:
  // One byte of PCD1, PCD2 or the BCC changed (never LGE, ADR or the parameter block's AK).
  void damage(Record& r) {
    corrupt_binary(
        r, r.bytes.size() - 5, r.bytes.size(), false, [](std::span<const std::uint8_t> b) {
          return danfoss_fc::bcc(b.first(b.size() - 1)) == b.back() || fc_inner_telegram(b);
        });
  }
  DriveState drives_[2];
  std::size_t next_ = 0;
  int avoid_ = -1;
};

// Easydrive '~' protocol (001, docs/protocols.md §5): status queries, running values, run control.
// Every reply carries the drive's fault code in AUX; a request with a bad SUM is answered with
// response code 20 (frame error), a frequency out of range with 30.
class EdsLink final : public Link {
 public:
  using Link::Link;
  static std::string drives() { return "7=eds1000 8=eds1000"; }

  void transaction(std::deque<Record>& q) override {
    if (rng_.chance(100)) noise(q, false);
    const std::size_t d = next_++ % 2;
    const int a = 7 + static_cast<int>(d);
    DriveState& s = drives_[d];
    s.tick(rng_, rng_.between(1, 23));
    std::string request, reply;
    const int aux = s.fault;
    const std::uint32_t kind = rng_.below(100);
    if (kind < 50) {
      request = fmt::format("{:02X}0A0000", a);
      reply = fmt::format("{:02X}11{:02X}00", a, aux);
    } else if (kind < 88) {
      static constexpr int kIndex[] = {1, 2, 15};
      const int idx = kIndex[rng_.below(3)];
      const int value = idx == 1 ? s.output : idx == 2 ? s.amps() : (s.running ? 0x0011 : 0);
      request = fmt::format("{:02X}0B00{:02X}", a, idx);
      reply = fmt::format("{:02X}00{:02X}{:02X}{:04X}", a, aux, idx, value);
    } else if (kind < 97) {
      int idx = 0x0007;  // stop
      std::string data;
      if (s.fault) {
        idx = 0x000C;  // fault reset
        s.fault = 0;
      } else if (!s.running) {
        idx = 0x0002;  // run with frequency
        s.setpoint = rng_.between(4, 10) * 500;
        data = fmt::format("{:04X}", s.setpoint);
        s.running = true;
      } else {
        s.running = false;
      }
      request = fmt::format("{:02X}0C{:04X}{}", a, idx, data);
      reply = fmt::format("{:02X}00{:02X}{:02X}", a, aux, idx & 0xFF);
    } else {  // set frequency 100.00 Hz: out of range, refused with 30
      request = fmt::format("{:02X}0C00012710", a);
      reply = fmt::format("{:02X}30{:02X}01", a, aux);
    }
    Record& req = add(q, RecordKind::request, eds_frame(request), ms_between(80, 140));
    const TimeNs request_end = end_;
    const Fate fate = roll_fate(rng_, false, false);
    if (fate == Fate::timeout) {
      req.note = "no reply";
      not_before_ = request_end + ms(100);
      return;
    }
    if (fate == Fate::request_bad) {
      corrupt_text(req, req.bytes.size() - 5, req.bytes.size() - 1);
      reply = fmt::format("{:02X}20{:02X}{}", a, aux, request.substr(6, 2));
    }
    Record& rsp = add(q, RecordKind::reply, eds_frame(reply), ms_between(5, 15));
    if (fate == Fate::request_bad) rsp.note = "response 20: frame error";
    if (fate == Fate::reply_bad || fate == Fate::reply_parity)
      corrupt_text(rsp, rsp.bytes.size() - 5, rsp.bytes.size() - 1);
  }

 private:
  DriveState drives_[2];
  std::size_t next_ = 0;
};

}  // namespace

// ---- counts ----

void Counts::add(const Record& r) {
  bytes += r.bytes.size();
  parity_errors += static_cast<std::uint64_t>(r.parity_errors);
  timing_rule += static_cast<std::uint64_t>(r.timing_breaks);
  if (r.kind == RecordKind::noise) {
    ++noise_records;
    noise_bytes += r.bytes.size();
    return;
  }
  ++frames;
  ++(r.kind == RecordKind::request ? requests : replies);
  exceptions += r.exception;
  checksum_bad += r.checksum == ChecksumVerdict::bad;
  checksum_swapped += r.checksum == ChecksumVerdict::swapped;
  bad_replies += r.kind == RecordKind::reply && r.checksum == ChecksumVerdict::bad;
}

// ---- generator ----

SerialConfig Generator::serial() {
  SerialConfig s;
  s.baud = 19200;
  s.parity = Parity::even;
  return s;
}

Generator::Generator(const Options& options) : options_(options) {
  // Each link draws from a stream of its own, so that the links do not shift one another.
  auto seed_of = [&](std::uint64_t link) {
    Rng mixer(options.seed ^ (0xD1B54A32D192ED03ull * (link + 1)));
    return mixer.next();
  };
  auto rtu = std::make_unique<ModbusLink>(seed_of(0), 0, false);
  info_.push_back({"rtu", "modbus-rtu", rtu->drives()});
  links_.push_back(std::move(rtu));
  if (options.mix == Mix::all) {
    links_.push_back(std::make_unique<FcLink>(seed_of(1), 3 * kNsPerMs));
    info_.push_back({"fc", "danfoss-fc", FcLink::drives()});
    links_.push_back(std::make_unique<EdsLink>(seed_of(2), 7 * kNsPerMs));
    info_.push_back({"eds", "easydrive", EdsLink::drives()});
    auto ascii = std::make_unique<ModbusLink>(seed_of(3), 11 * kNsPerMs, true);
    info_.push_back({"ascii", "modbus-ascii", ascii->drives()});
    links_.push_back(std::move(ascii));
  }
  queues_.resize(links_.size());
  counts_.resize(links_.size());
  open_request_end_.assign(links_.size(), -1);
}

Generator::~Generator() = default;

bool Generator::next(Record& out) {
  if (written_ >= options_.frames) return false;
  std::size_t best = 0;
  for (std::size_t i = 0; i < links_.size(); ++i) {
    if (queues_[i].empty()) links_[i]->transaction(queues_[i]);
    if (queues_[i].front().start < queues_[best].front().start) best = i;
  }
  out = std::move(queues_[best].front());
  queues_[best].pop_front();
  out.link = best;
  counts_[best].add(out);
  total_.add(out);
  open_request_end_[best] =
      out.kind == RecordKind::request
          ? out.start + static_cast<TimeNs>(out.bytes.size()) * serial().character_time()
          : -1;
  last_start_ = std::max(last_start_, out.start);
  ++written_;
  return true;
}

std::string Generator::drive_bindings() const {
  std::string s;
  for (const LinkInfo& l : info_) s += (s.empty() ? "" : " ") + l.drives;
  return s;
}

namespace {
std::string counts_json(const Counts& c) {
  return fmt::format(
      "\"frames\":{},\"requests\":{},\"replies\":{},\"ok\":{},\"exceptions\":{},\"timeouts\":{},"
      "\"pending\":{},\"bad_replies\":{},\"checksum_bad\":{},\"checksum_swapped\":{},\"noise_"
      "records\":{},"
      "\"noise_bytes\":{},\"parity_errors\":{},\"timing_rule\":{},\"bytes\":{}",
      c.frames, c.requests, c.replies, c.replies - c.exceptions - c.bad_replies, c.exceptions,
      c.timeouts(), c.pending, c.bad_replies, c.checksum_bad, c.checksum_swapped, c.noise_records,
      c.noise_bytes, c.parity_errors, c.timing_rule, c.bytes);
}
}  // namespace

std::string Generator::truth_json() const {
  // A link's last request, unanswered, is pending unless a later frame (of any link) came past
  // drivetap's default reply timeout (1 s) after it: then it timed out.
  std::vector<Counts> links = counts_;
  Counts total = total_;
  for (std::size_t i = 0; i < links.size(); ++i)
    if (open_request_end_[i] >= 0 && last_start_ - open_request_end_[i] <= kNsPerSecond) {
      ++links[i].pending;
      ++total.pending;
    }
  std::string s = fmt::format(
      "{{\"generator\":\"drivetap generate\",\"seed\":{},\"frames_asked\":{},\"mix\":\"{}\","
      "\"serial\":\"{}\",\"drives\":\"{}\",\n\"total\":{{{}}},\n\"links\":[",
      options_.seed, options_.frames, options_.mix == Mix::all ? "all" : "modbus-rtu",
      serial().to_string(), drive_bindings(), counts_json(total));
  for (std::size_t i = 0; i < info_.size(); ++i)
    s += fmt::format("{}\n{{\"channel\":\"{}\",\"protocol\":\"{}\",\"drives\":\"{}\",{}}}",
                     i ? "," : "", info_[i].channel, info_[i].protocol, info_[i].drives,
                     counts_json(links[i]));
  s += "\n]}\n";
  return s;
}

}  // namespace drivetap::generate
