// Drive-level reading of Modbus, Danfoss FC and Easydrive frames from a drive profile
// (dissectors/profiles/README.md; frame layouts PROTOCOLS.md §2-§5).
#include "drive/annotate.hpp"

#include <fmt/compile.h>
#include <fmt/format.h>

#include <array>
#include <cmath>
#include <iterator>
#include <string_view>
#include <vector>

#include "core/format.hpp"
#include "dissectors/danfoss_fc/fc_protocol.hpp"
#include "dissectors/easydrive/eds_dissector.hpp"
#include "dissectors/easydrive/eds_protocol.hpp"
#include "dissectors/modbus/ascii_dissector.hpp"
#include "dissectors/modbus/modbus_protocol.hpp"

namespace drivetap {
namespace {

std::uint16_t be16(std::span<const std::uint8_t> b, std::size_t at) {
  return static_cast<std::uint16_t>((b[at] << 8) | b[at + 1]);
}

// Decimals a scaled value is shown with: those of a decimal scale (0.01 -> 2), else 2 (a
// binary scale such as Danfoss's 100/16384 % would print noise digits).
int decimals_of(double scale) {
  int d = 0;
  for (double s = scale; d < 6 && std::fabs(s - std::round(s)) > 1e-9; s *= 10) ++d;
  return d >= 6 ? 2 : d;
}

// The raw value as the register holds it: signed registers read as 16- or 32-bit two's
// complement.
std::int64_t raw_value(const RegisterDef& r, std::uint32_t raw, bool double_word) {
  if (!r.is_signed) return raw;
  return double_word ? static_cast<std::int32_t>(raw) : static_cast<std::int16_t>(raw & 0xFFFF);
}

double scaled(const RegisterDef& r, std::uint32_t raw, bool double_word) {
  return static_cast<double>(raw_value(r, raw, double_word)) * r.scale;
}

// The decimal scales append_scaled() prints as exact decimals, from integers (then two different
// values never print alike): 10^-i at index i.
constexpr double kDecimalScales[] = {1, 0.1, 0.01, 0.001, 0.0001, 0.00001};

// The number of decimals of `scale` when it is one of kDecimalScales; -1 otherwise.
int decimal_scale_index(double scale) {
  for (int i = 0; i < static_cast<int>(std::size(kDecimalScales)); ++i)
    if (scale == kDecimalScales[i]) return i;
  return -1;
}

// The scaled value as "{:.Nf}" prints it, N = decimals_of(scale). A scale of 1, 0.1, 0.01 ...
// or a whole one makes it an exact decimal, printed from integers: the double's rounding error
// is far below half the last digit for any 32-bit raw value, so the text is the same.
void append_scaled(std::string& out, const RegisterDef& r, std::uint32_t raw, bool double_word) {
  static constexpr std::int64_t kPowersOfTen[] = {1, 10, 100, 1000, 10000, 100000};
  static_assert(std::size(kPowersOfTen) == std::size(kDecimalScales));
  const std::int64_t value = raw_value(r, raw, double_word);
  // A decimal scale, the usual one, is looked up in the table: decimals_of() gives each entry
  // its index (ProfileSchema.ScaledValuesReadAsTheDoublePrinted), and its loop of roundings costs
  // more than the rest of the value.
  if (const int decimals = decimal_scale_index(r.scale); decimals >= 0) {
    const auto unit = static_cast<std::uint64_t>(kPowersOfTen[decimals]);
    const std::uint64_t magnitude =
        static_cast<std::uint64_t>(value < 0 ? -value : value);  // |value| < 2^32
    if (value < 0) out += '-';
    append_uint(out, magnitude / unit);
    if (decimals > 0) append_fraction(out, magnitude % unit, decimals);
    return;
  }
  const int decimals = decimals_of(r.scale);
  if (decimals == 0 && r.scale > 0 && r.scale <= 1e6 && r.scale == std::round(r.scale)) {
    append_int(out, value * static_cast<std::int64_t>(r.scale));
    return;
  }
  fmt::format_to(std::back_inserter(out), FMT_COMPILE("{:.{}f}"), scaled(r, raw, double_word),
                 decimals);
}

bool any_bit(const std::vector<int>& bits, std::uint32_t raw) {
  for (int b : bits)
    if ((raw >> b) & 1) return true;
  return false;
}

// The "; "-separated parts of an annotation, appended in place to the reading's text (whose
// storage the pipeline reuses from frame to frame); `lead` goes before the first part ("set ").
// Off (nothing written) when no sink shows the text: the observation is still made. It also
// carries whether the observation is wanted (observing(): the readers apply the register roles
// only then; the text never depends on them).
class Parts {
 public:
  Parts(std::string& out, DriveReadingWants wants, std::string_view lead = {})
      : out_(out),
        enabled_(wants != DriveReadingWants::observation),
        observing_(wants != DriveReadingWants::text),
        lead_(lead) {}
  [[nodiscard]] bool enabled() const { return enabled_; }
  [[nodiscard]] bool observing() const { return observing_; }
  // The text with the lead or a separator appended: append the next part to it.
  std::string& next() {
    out_ += count_++ > 0 ? std::string_view("; ") : lead_;
    return out_;
  }
  void add(std::string_view part) {
    if (enabled_) next() += part;
  }
  template <typename... Args>
  void add(fmt::format_string<Args...> format, Args&&... args) {
    if (enabled_) fmt::format_to(std::back_inserter(next()), format, std::forward<Args>(args)...);
  }

 private:
  std::string& out_;
  bool enabled_;
  bool observing_;
  std::string_view lead_;
  std::size_t count_ = 0;
};

void append_display_name(std::string& out, const RegisterDef& r) {
  if (r.kind == RegisterKind::parameter) {
    out += r.number;
    out += ' ';
  }
  out += r.name;
}

// Applies one value to the observation by the register's role. `written`: the master wrote it
// (a command), else the drive reported it.
void observe(const DriveProfile& p, const RegisterDef& r, std::uint32_t raw, bool double_word,
             bool written, DriveObservation& o) {
  const StateBits& s = r.state;
  // (The quantity's text is made only when shown.)
  auto set_quantity = [&](std::optional<Quantity>& q) { q = Quantity::of(p, r, raw, double_word); };
  if (written) {
    switch (r.role) {
      case RegisterRole::control:
        if (!s.run.empty()) o.run_command = any_bit(s.run, raw);
        if (!s.reverse.empty()) o.reverse_command = any_bit(s.reverse, raw);
        if (!s.forward.empty()) o.reverse_command = !any_bit(s.forward, raw);
        if (any_bit(s.reset, raw)) o.reset_command = true;
        break;
      case RegisterRole::setpoint:
        set_quantity(o.setpoint_command);
        break;
      case RegisterRole::start:
        if (raw) o.run_command = true;
        break;
      case RegisterRole::stop:
        if (raw) o.run_command = false;
        break;
      case RegisterRole::reset:
        if (raw) o.reset_command = true;
        break;
      default:
        break;
    }
    return;
  }
  switch (r.role) {
    case RegisterRole::status:
      if (!s.running.empty()) o.running = any_bit(s.running, raw);
      if (!s.reverse.empty()) o.reverse = any_bit(s.reverse, raw);
      if (!s.forward.empty()) o.reverse = !any_bit(s.forward, raw);
      if (!s.fault.empty()) o.fault_active = any_bit(s.fault, raw);
      if (!s.warning.empty()) o.warning = any_bit(s.warning, raw);
      break;
    case RegisterRole::setpoint:
      set_quantity(o.setpoint);
      break;
    case RegisterRole::output_frequency:
      set_quantity(o.output_frequency);
      break;
    case RegisterRole::current:
      set_quantity(o.current);
      break;
    case RegisterRole::voltage:
      set_quantity(o.voltage);
      break;
    case RegisterRole::fault:
      o.fault_code = raw;
      o.fault = Quantity::of(p, r, raw, double_word);
      break;
    default:
      break;
  }
}

// Reads consecutive 16-bit values starting at `start` in the register space of `kind` (holding
// registers also reach parameters through the addressing rule); collects "name value" parts.
void read_registers(const DriveProfile& p, RegisterKind kind, std::uint32_t start,
                    std::span<const std::uint16_t> values, bool written, Parts& parts,
                    DriveObservation& o) {
  DriveProfile::Walk walk(p, kind, start);
  for (std::size_t i = 0; i < values.size(); ++i) {
    const std::uint32_t address = start + static_cast<std::uint32_t>(i);
    const RegisterDef* r =
        kind == RegisterKind::holding ? p.find_holding(address, walk) : walk.find(address);
    if (!r) continue;  // registers the manual does not name are left to the frame line
    std::uint32_t raw = values[i];
    const bool double_word = r->words == 2 && i + 1 < values.size();
    if (double_word) raw = raw << 16 | values[++i];
    if (parts.enabled()) {
      std::string& text = parts.next();
      append_display_name(text, *r);
      text += ' ';
      append_value(text, p, *r, raw, double_word);
    }
    if (parts.observing()) observe(p, *r, raw, double_word, written, o);
  }
}

void read_coils(const DriveProfile& p, std::uint32_t start, std::size_t count,
                std::span<const std::uint8_t> packed, bool written, Parts& parts,
                DriveObservation& o) {
  for (std::size_t i = 0; i < count && i / 8 < packed.size(); ++i) {
    const RegisterDef* r = p.find(RegisterKind::coil, start + static_cast<std::uint32_t>(i));
    if (!r) continue;
    const bool on = (packed[i / 8] >> (i % 8)) & 1;
    parts.add("{} {}", r->name, on ? "ON" : "OFF");
    if (parts.observing()) observe(p, *r, on, false, written, o);
  }
}

// "frequency setpoint", "16-13 frequency", "parameter 4-14", "register 0x0123", appended.
void append_name_at(std::string& out, const DriveProfile& p, RegisterKind kind,
                    std::uint32_t address) {
  std::string label;
  const RegisterDef* r =
      kind == RegisterKind::holding ? p.find_holding(address, &label) : p.find(kind, address);
  if (r) {
    append_display_name(out, *r);
  } else if (!label.empty()) {
    out += "parameter ";
    out += label;
  } else {
    fmt::format_to(std::back_inserter(out), FMT_COMPILE("register 0x{:04X}"), address);
  }
}

// The big-endian 16-bit values of b[from, end): in `small` when they fit (any frame within
// Modbus's 256 bytes), else in `large`. No allocation for the frames of a poll.
std::span<const std::uint16_t> words_of(std::span<const std::uint8_t> b, std::size_t from,
                                        std::size_t end, std::array<std::uint16_t, 128>& small,
                                        std::vector<std::uint16_t>& large) {
  const std::size_t n = end > from ? (end - from) / 2 : 0;
  std::uint16_t* out = small.data();
  if (n > small.size()) {
    large.resize(n);
    out = large.data();
  }
  for (std::size_t k = 0; k < n; ++k) out[k] = be16(b, from + 2 * k);
  return {out, n};
}

// The readers below append the annotation to `out` (after the caller's "drive N (name): ") and
// fill the observation.
void read_modbus(const DriveProfile& p, const TelegramHead& m,
                 std::span<const std::uint8_t> request, DriveReadingWants wants, std::string& out,
                 DriveObservation& o) {
  std::vector<std::uint8_t> decoded;
  const std::span<const std::uint8_t> b = modbus_binary(m.protocol, m.bytes, decoded);
  if (b.size() < 4) return;
  const std::uint8_t fc = b[1];
  const std::size_t end = b.size() - (m.protocol == protocols::modbus_rtu ? 2 : 1);  // before check
  if (fc & 0x80) {
    const auto it = p.exceptions.find(b[2]);
    if (it != p.exceptions.end())
      fmt::format_to(std::back_inserter(out), FMT_COMPILE("error 0x{:02X}: {}"), b[2], it->second);
    return;
  }
  // A request's parts say what the master sets.
  Parts parts(out, wants, m.direction == Direction::request ? "set " : "");
  if (m.direction == Direction::request) {
    if ((fc == 0x03 || fc == 0x04) && end >= 6) {
      const RegisterKind kind = fc == 0x03 ? RegisterKind::holding : RegisterKind::input;
      const std::uint16_t start = be16(b, 2), count = be16(b, 4);
      if (!parts.enabled()) return;
      out += "read ";
      append_name_at(out, p, kind, start);
      if (count > 1) {
        out += " .. ";
        append_name_at(out, p, kind, static_cast<std::uint32_t>(start) + count - 1);
      }
      return;
    }
    if (fc == 0x06 && end >= 6) {
      const std::uint16_t values[] = {be16(b, 4)};
      read_registers(p, RegisterKind::holding, be16(b, 2), values, true, parts, o);
    } else if (fc == 0x10 && end >= 7) {
      std::array<std::uint16_t, 128> small;
      std::vector<std::uint16_t> large;
      read_registers(p, RegisterKind::holding, be16(b, 2), words_of(b, 7, end, small, large), true,
                     parts, o);
    } else if (fc == 0x05 && end >= 6) {
      const std::uint8_t on = b[4] == 0xFF ? 1 : 0;
      read_coils(p, be16(b, 2), 1, std::span(&on, 1), true, parts, o);
    } else if (fc == 0x0F && end >= 7) {
      read_coils(p, be16(b, 2), be16(b, 4), std::span(b).subspan(7, end - 7), true, parts, o);
    }
    return;
  }
  if (m.direction != Direction::response || request.empty()) return;
  std::vector<std::uint8_t> request_decoded;
  const std::span<const std::uint8_t> q = modbus_binary(m.protocol, request, request_decoded);
  if (q.size() < 6 || q[1] != fc) return;
  if ((fc == 0x03 || fc == 0x04) && end >= 3) {
    std::array<std::uint16_t, 128> small;
    std::vector<std::uint16_t> large;
    read_registers(p, fc == 0x03 ? RegisterKind::holding : RegisterKind::input, be16(q, 2),
                   words_of(b, 3, end, small, large), false, parts, o);
  } else if ((fc == 0x01 || fc == 0x02) && end >= 3) {
    read_coils(p, be16(q, 2), be16(q, 4), std::span(b).subspan(3, end - 3), false, parts, o);
  }
}

// Danfoss FC protocol (PROTOCOLS.md §4):
//   STX LGE ADR [PKE IND PWEhigh PWElow] PCD1 PCD2 BCC        (LGE 6: PCD only; 14: with PKE)
//   PKE = AK(4 bits) PNU(12 bits); PCD1/PCD2 = CTW/REF to the drive, STW/MAV from it.
void read_fc(const DriveProfile& p, const TelegramHead& m, DriveReadingWants wants,
             std::string& out, DriveObservation& o) {
  const std::span<const std::uint8_t> b = m.bytes;
  if (b.size() < 4 || b[0] != 0x02) return;
  const std::size_t lge = b[1];
  if (b.size() != lge + 2 || (lge != 6 && lge != 14)) return;
  const bool to_drive = m.direction == Direction::request;
  if (m.direction == Direction::unknown) return;
  Parts parts(out, wants);
  if (lge == 14) {
    const std::uint16_t pke = be16(b, 3);
    const unsigned ak = pke >> 12;
    const std::uint32_t pnu = pke & 0x0FFF;
    const std::uint32_t pwe = static_cast<std::uint32_t>(be16(b, 7)) << 16 | be16(b, 9);
    const RegisterDef* r = p.find(RegisterKind::parameter, pnu);
    const std::string name = r ? display_name(*r) : "parameter " + p.parameter_label(pnu);
    auto value = [&](bool double_word) {
      const std::uint32_t raw = double_word ? pwe : (pwe & 0xFFFF);
      if (!r) return fmt::format(FMT_COMPILE("{}"), raw);
      return describe_value(p, *r, raw, double_word);
    };
    if (to_drive) {
      switch (ak) {
        case 0x1:
          parts.add("read {}", name);
          break;
        case 0x2:
        case 0xE:
        case 0x3:
        case 0xD: {
          const bool dw = ak == 0x3 || ak == 0xD;
          if (parts.enabled())
            parts.add("set {} = {}{}", name, value(dw), ak >= 0xD ? " (RAM and EEPROM)" : "");
          if (r && parts.observing()) observe(p, *r, dw ? pwe : (pwe & 0xFFFF), dw, true, o);
          break;
        }
        case 0xF:
          parts.add("text of {}", name);
          break;
        default:
          break;
      }
    } else {
      switch (ak) {
        case 0x1:
        case 0x2: {
          const bool dw = ak == 0x2;
          if (parts.enabled()) parts.add("{} {}", name, value(dw));
          if (r && parts.observing()) observe(p, *r, dw ? pwe : (pwe & 0xFFFF), dw, false, o);
          break;
        }
        case 0x7: {
          const std::uint32_t error = pwe & 0xFFFF;
          const auto it = p.parameter_errors.find(error);
          parts.add("cannot execute on {}: error {}{}", name, error,
                    it == p.parameter_errors.end() ? "" : " (" + it->second + ")");
          break;
        }
        case 0xF:
          parts.add("text of {}", name);
          break;
        default:
          break;
      }
    }
  }
  const std::vector<std::uint32_t>& pcd = to_drive ? p.pcd_to_drive : p.pcd_from_drive;
  const std::size_t at = lge == 14 ? 11 : 3;
  for (std::size_t i = 0; i < pcd.size() && i < 2; ++i) {
    const RegisterDef* r = p.find(RegisterKind::holding, pcd[i]);
    if (!r) continue;
    const std::uint16_t raw = be16(b, at + 2 * i);
    if (parts.enabled()) {
      std::string& text = parts.next();
      text += r->name;
      text += ' ';
      append_value(text, p, *r, raw, false);
    }
    if (parts.observing()) observe(p, *r, raw, false, to_drive, o);
  }
}

// Easydrive (PROTOCOLS.md §5), ASCII hex between '~' and CR:
//   request  ~ AA CC IIII [DDDD] SSSS CR     (CC command 0A..0F, IIII index)
//   reply    ~ AA RR FF II [DDDD] SSSS CR    (RR response code, FF current fault, II index low)
// Run control (001, command "12"): what each index commands. `run`/`reverse`: the command it
// carries, if any; `with_frequency`: its data field is the new setpoint.
struct RunAction {
  long index;
  const char* label;  // "" when the setpoint is all it says
  std::optional<bool> run, reverse;
  bool reset, with_frequency;
};
constexpr RunAction kRunActions[] = {
    {0x1, "", std::nullopt, std::nullopt, false, true},
    {0x2, "run", true, std::nullopt, false, true},
    {0x3, "run forward", true, false, false, false},
    {0x4, "run reverse", true, true, false, false},
    {0x5, "run forward", true, false, false, true},
    {0x6, "run reverse", true, true, false, true},
    {0x7, "stop", false, std::nullopt, false, false},
    {0xC, "fault reset", std::nullopt, std::nullopt, true, false},
    {0xE, "emergency stop", false, std::nullopt, false, false},
};

void read_easydrive(const DriveProfile& p, const TelegramHead& m,
                    std::span<const std::uint8_t> request, DriveReadingWants wants,
                    std::string& out, DriveObservation& o) {
  const std::span<const std::uint8_t> f = m.bytes;
  if (f.size() != 14 && f.size() != 18) return;
  const bool has_data = f.size() == 18;
  const long data = has_data ? easydrive::hex_field(f, 9, 4) : -1;
  Parts parts(out, wants);
  const RegisterDef* setpoint = nullptr;
  for (const RegisterDef& r : p.registers)
    if (r.kind == RegisterKind::running && r.role == RegisterRole::setpoint) setpoint = &r;
  if (m.direction == Direction::request) {
    const long cmd = easydrive::hex_field(f, 3, 2), index = easydrive::hex_field(f, 5, 4);
    if (cmd < 0 || index < 0) return;
    const auto u_index = static_cast<std::uint32_t>(index);
    const RegisterDef* par = p.find(RegisterKind::parameter, u_index);
    const std::string par_name =
        par ? display_name(*par) : "function code " + p.parameter_label(u_index);
    switch (cmd) {
      case 0x0A:
        parts.add("status query");
        break;
      case 0x0B:
        if (const RegisterDef* r = p.find(RegisterKind::running, u_index))
          parts.add("read {}", r->name);
        break;
      case 0x0C:
        for (const RunAction& action : kRunActions) {
          if (action.index != index) continue;
          if (*action.label) parts.add(std::string_view(action.label));
          if (action.run) o.run_command = action.run;
          if (action.reverse) o.reverse_command = action.reverse;
          if (action.reset) o.reset_command = true;
          if (action.with_frequency && data >= 0 && setpoint) {
            o.setpoint_command =
                Quantity::of(p, *setpoint, static_cast<std::uint32_t>(data), false);
            if (parts.enabled()) parts.add("setpoint {}", o.setpoint_command->text());
          }
        }
        break;
      case 0x0D:
        parts.add("read {}", par_name);
        break;
      case 0x0E:
        if (data >= 0 && par) {
          if (parts.enabled())
            parts.add("set {} = {}", par_name,
                      describe_value(p, *par, static_cast<std::uint32_t>(data)));
          if (parts.observing()) observe(p, *par, static_cast<std::uint32_t>(data), false, true, o);
        } else if (data >= 0) {
          parts.add("set {} = {}", par_name, data);
        }
        break;
      default:
        break;
    }
    return;
  }
  if (m.direction != Direction::response) return;
  const long code = easydrive::hex_field(f, 3, 2), fault = easydrive::hex_field(f, 5, 2);
  const long cmd = easydrive::hex_field(request, 3, 2), index = easydrive::hex_field(request, 5, 4);
  if (code == 0x20 || code == 0x30) return;  // rejected: the frame line names the reason
  if (cmd == 0x0B && index >= 0 && data >= 0) {
    if (const RegisterDef* r = p.find(RegisterKind::running, static_cast<std::uint32_t>(index))) {
      if (parts.enabled())
        parts.add("{} {}", r->name, describe_value(p, *r, static_cast<std::uint32_t>(data)));
      if (parts.observing()) observe(p, *r, static_cast<std::uint32_t>(data), false, false, o);
    }
  } else if (cmd == 0x0D && index >= 0 && data >= 0) {
    if (const RegisterDef* r = p.find(RegisterKind::parameter, static_cast<std::uint32_t>(index))) {
      if (parts.enabled())
        parts.add("{} {}", display_name(*r),
                  describe_value(p, *r, static_cast<std::uint32_t>(data)));
      if (parts.observing()) observe(p, *r, static_cast<std::uint32_t>(data), false, false, o);
    }
  } else if (cmd == 0x0A && code >= 0x10 && code <= 0x14) {
    parts.add(std::string_view(code == 0x10 ? "not ready" : "ready"));
  }
  // Every accepted reply carries the drive's current fault code (001, AUX of the reply).
  if (fault >= 0) {
    o.fault_code = static_cast<std::uint32_t>(fault);
    const auto names = p.enums.find("fault");
    const std::string* name = nullptr;
    if (names != p.enums.end()) {
      const auto it = names->second.find(static_cast<std::uint32_t>(fault));
      if (it != names->second.end() && !it->second.empty()) name = &it->second;
    }
    // (Not append_value(): a code the manual's table lacks is shown bare.)
    o.fault.value = static_cast<double>(fault);
    std::string& text = o.fault.written;
    text.clear();  // keeps its storage
    append_int(text, fault);
    if (name) {
      text += " (";
      text += *name;
      text += ')';
    }
    if (fault > 0) parts.add("fault {}", text);
  }
}

}  // namespace

std::span<const std::uint8_t> modbus_binary(Protocol protocol, std::span<const std::uint8_t> bytes,
                                            std::vector<std::uint8_t>& storage) {
  if (protocol != protocols::modbus_ascii) return bytes;
  storage = modbus::decode_ascii_hex(bytes).binary;
  return storage;
}

std::string display_name(const RegisterDef& r) {
  std::string name;
  append_display_name(name, r);
  return name;
}

void append_value(std::string& out, const DriveProfile& p, const RegisterDef& r, std::uint32_t raw,
                  bool double_word) {
  if (!r.enum_name.empty()) {
    const auto& names = p.enums.at(r.enum_name);
    const auto it = names.find(raw);
    append_uint(out, raw);
    if (it == names.end()) {
      out += " (not in the manual's table)";
    } else {
      out += " (";
      out += it->second;
      out += ')';
    }
    return;
  }
  if (!r.bits.empty()) {
    append_hex(out, raw, double_word ? 8 : 4);
    out += " [";
    bool first = true;
    for (const RegisterBit& b : r.bits) {
      const std::string& s = ((raw >> b.bit) & 1) ? b.when_set : b.when_clear;
      if (s.empty()) continue;
      if (!first) out += ", ";
      out += s;
      first = false;
    }
    out += ']';
    return;
  }
  append_scaled(out, r, raw, double_word);
  if (!r.unit.empty()) {
    out += ' ';
    out += r.unit;
  }
}

Quantity Quantity::of(const DriveProfile& profile, const RegisterDef& reg, std::uint32_t raw,
                      bool double_word) {
  Quantity q;
  q.value = scaled(reg, raw, double_word);
  q.profile = &profile;
  q.reg = &reg;
  q.raw = raw;
  q.double_word = double_word;
  return q;
}

void Quantity::append_text(std::string& out) const {
  if (reg)
    append_value(out, *profile, *reg, raw, double_word);
  else
    out += written;
}

std::string Quantity::text() const {
  std::string out;
  append_text(out);
  return out;
}

bool Quantity::same_text(const Quantity& other) const {
  if (reg && other.reg) {
    if (reg == other.reg && profile == other.profile && raw == other.raw &&
        double_word == other.double_word)
      return true;
    // Two registers that both show a plain number the same way (one register, or a setpoint
    // read back against the one written) read alike when they hold the same value; under a
    // power of ten (0.01 Hz) different values read differently, a change of setpoint. (Under
    // another scale, Danfoss's 100/16384 %, different values may print alike: those are
    // compared as written.)
    const RegisterDef &a = *reg, &b = *other.reg;
    if (a.enum_name.empty() && b.enum_name.empty() && a.bits.empty() && b.bits.empty() &&
        a.scale == b.scale && a.unit == b.unit) {
      const bool same =
          raw_value(a, raw, double_word) == raw_value(b, other.raw, other.double_word);
      if (same || decimal_scale_index(a.scale) >= 0) return same;
    }
  }
  return text() == other.text();
}

std::string describe_value(const DriveProfile& p, const RegisterDef& r, std::uint32_t raw,
                           bool double_word) {
  std::string out;
  append_value(out, p, r, raw, double_word);
  return out;
}

void read_for_drive_into(const DriveProfile& p, const TelegramHead& m,
                         std::span<const std::uint8_t> request, DriveReadingWants wants,
                         DriveReading& out) {
  out.observed.clear();
  // "drive 2 (ERMAN E-9P/9G): ...", taken back when the profile says nothing of the frame. An
  // observation alone has text only for an exception reply the profile names: the lead is put
  // before that text then, not written for every frame.
  std::string& text = out.text;
  text.clear();  // keeps its storage
  auto append_lead = [&](std::string& to) {
    to += "drive ";
    append_int(to, m.address);
    to += " (";
    to += p.name;
    to += "): ";
  };
  const bool lead_first = wants != DriveReadingWants::observation;
  if (lead_first) append_lead(text);
  const std::size_t lead = text.size();
  if (m.protocol == protocols::modbus_rtu || m.protocol == protocols::modbus_ascii)
    read_modbus(p, m, request, wants, text, out.observed);
  else if (m.protocol == protocols::danfoss_fc)
    read_fc(p, m, wants, text, out.observed);
  else if (m.protocol == protocols::easydrive)
    read_easydrive(p, m, request, wants, text, out.observed);
  if (text.size() == lead) {
    text.clear();
  } else if (!lead_first) {
    std::string led;
    append_lead(led);
    text.insert(0, led);
  }
}

void complete_drive_info(Message& m, DriveReading& scratch) {
  if (!m.drive_profile) return;
  read_for_drive_into(*m.drive_profile, head_of(m), m.request, DriveReadingWants::text, scratch);
  std::swap(m.drive_info, scratch.text);  // both keep their storage
  m.drive_profile = nullptr;
}

DriveReading read_for_drive(const DriveProfile& p, const Message& m,
                            std::span<const std::uint8_t> request, bool want_text) {
  DriveReading out;
  read_for_drive_into(
      p, m, request,
      want_text ? DriveReadingWants::text_and_observation : DriveReadingWants::observation, out);
  return out;
}

}  // namespace drivetap
