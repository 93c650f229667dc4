// Drive-level reading of a telegram's drive records (core/drive_records.hpp, read by its
// protocol's decoder) from a drive profile (dissectors/profiles/README.md).
#include "drive/annotate.hpp"

#include <fmt/compile.h>
#include <fmt/format.h>

#include <array>
#include <cmath>
#include <iterator>
#include <string_view>
#include <vector>

#include "core/format.hpp"
#include "core/word_bits.hpp"

namespace drivetap {

int scale_decimals(double scale) {
  int d = 0;
  for (double s = scale; d < 6 && std::fabs(s - std::round(s)) > 1e-9; s *= 10) ++d;
  if (d < 6) return d;
  // Its resolution: the fewest decimals in which one step of the raw value shows.
  double step = 1;
  for (d = 0; d < 6 && step > std::fabs(scale) * (1 + 1e-9); ++d) step /= 10;
  return d;
}

namespace {

double scaled(const RegisterDef& r, std::uint32_t raw, bool double_word) {
  return static_cast<double>(register_raw_value(r, raw, double_word)) * r.scale;
}

// The decimal scales append_scaled() prints as exact decimals, from integers (then two different
// values never print alike): 10^-i at index i.
constexpr double kDecimalScales[] = {1, 0.1, 0.01, 0.001, 0.0001, 0.00001};

}  // namespace

int decimal_scale_index(double scale) {
  for (int i = 0; i < static_cast<int>(std::size(kDecimalScales)); ++i)
    if (scale == kDecimalScales[i]) return i;
  return -1;
}

namespace {

// The scaled value as "{:.Nf}" prints it, N = scale_decimals(scale). A scale of 1, 0.1, 0.01 ...
// or a whole one makes it an exact decimal, printed from integers: the double's rounding error
// is far below half the last digit for any 32-bit raw value, so the text is the same.
template <class Out>
void append_scaled(Out& out, const RegisterDef& r, std::uint32_t raw, bool double_word) {
  const std::int64_t value = register_raw_value(r, raw, double_word);
  // A decimal scale, the usual one, is looked up in the table: scale_decimals() gives each entry
  // its index (ProfileSchema.ScaledValuesReadAsTheDoublePrinted), and its loop of roundings costs
  // more than the rest of the value.
  if (const int decimals = decimal_scale_index(r.scale); decimals >= 0) {
    static constexpr std::uint64_t kPowersOfTen[] = {1, 10, 100, 1000, 10000, 100000};
    const std::uint64_t unit = kPowersOfTen[decimals];
    const std::uint64_t magnitude =
        static_cast<std::uint64_t>(value < 0 ? -value : value);  // |value| < 2^32
    if (value < 0) out += '-';
    append_uint(out, magnitude / unit);
    if (decimals > 0) append_fraction(out, magnitude % unit, decimals);
    return;
  }
  const int decimals = scale_decimals(r.scale);
  if (decimals == 0 && r.scale > 0 && r.scale <= 1e6 && r.scale == std::round(r.scale)) {
    append_int(out, value * static_cast<std::int64_t>(r.scale));
    return;
  }
  fmt::format_to(std::back_inserter(out), FMT_COMPILE("{:.{}f}"), scaled(r, raw, double_word),
                 decimals);
}

// append_value() into `out`: std::string, or the LineBuffer an annotation is built in.
template <class Out>
void append_value_to(Out& out, const DriveProfile& p, const RegisterDef& r, std::uint32_t raw,
                     bool double_word) {
  if (!r.enum_name.empty()) {
    const auto& names = p.enums.at(r.enum_name);
    const auto it = names.find(raw);
    append_uint(out, raw);
    if (it == names.end()) {
      out += std::string_view(" (not in the manual's table)");
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
    append_bit_names(out, r.bits, raw);
    out += ']';
    return;
  }
  append_scaled(out, r, raw, double_word);
  if (!r.unit.empty()) {
    out += ' ';
    out += r.unit;
  }
}

bool any_bit(const std::vector<int>& bits, std::uint32_t raw) {
  for (int b : bits)
    if ((raw >> b) & 1) return true;
  return false;
}

// The "; "-separated parts of an annotation, appended in place to the reading's line (whose
// storage the pipeline reuses from frame to frame).
// Off (nothing written) when no sink shows the text: the observation is still made. It also
// carries whether the observation is wanted (observing(): the readers apply the register roles
// only then; the text never depends on them).
class Parts {
 public:
  Parts(LineBuffer& out, DriveReadingWants wants)
      : out_(out),
        enabled_(wants != DriveReadingWants::observation),
        observing_(wants != DriveReadingWants::text) {}
  [[nodiscard]] bool enabled() const { return enabled_; }
  [[nodiscard]] bool observing() const { return observing_; }
  // The text with a separator appended, or `lead` before the first part ("set "): append the
  // next part to it.
  LineBuffer& next(std::string_view lead = {}) {
    out_ += count_++ > 0 ? std::string_view("; ") : lead;
    return out_;
  }
  void add(std::string_view part) {
    if (enabled_) next() += part;
  }

 private:
  LineBuffer& out_;
  bool enabled_;
  bool observing_;
  std::size_t count_ = 0;
};

template <class Out>
void append_display_name(Out& out, const RegisterDef& r) {
  if (r.kind == RegisterKind::parameter) {
    out += r.number;
    out += ' ';
  }
  out += r.name;
}

// Sets `state` from the bits of a control or status word when the profile names any
// (`inverted`: set when none of them is, a forward bit read as reverse).
void observe_bits(std::optional<bool>& state, const std::vector<int>& bits, std::uint32_t raw,
                  bool inverted = false) {
  if (!bits.empty()) state = any_bit(bits, raw) != inverted;
}

// The quantities a drive reports, by the role of the register that holds them.
struct ReportedQuantity {
  RegisterRole role;
  std::optional<Quantity> DriveObservation::*member;
};
constexpr ReportedQuantity kReportedQuantities[] = {
    {RegisterRole::setpoint, &DriveObservation::setpoint},
    {RegisterRole::output_frequency, &DriveObservation::output_frequency},
    {RegisterRole::current, &DriveObservation::current},
    {RegisterRole::voltage, &DriveObservation::voltage},
};

// Applies one value to the observation by the register's role. `written`: the master wrote it
// (a command), else the drive reported it. (A quantity's text is made only when shown.)
void observe(const DriveProfile& p, const RegisterDef& r, std::uint32_t raw, bool double_word,
             bool written, DriveObservation& o) {
  o.registers.push_back({&r, raw, double_word});
  const StateBits& s = r.state;
  if (written) {
    switch (r.role) {
      case RegisterRole::control:
        observe_bits(o.run_command, s.run, raw);
        observe_bits(o.reverse_command, s.reverse, raw);
        observe_bits(o.reverse_command, s.forward, raw, true);
        if (any_bit(s.reset, raw)) o.reset_command = true;
        break;
      case RegisterRole::setpoint:
        o.setpoint_command = Quantity::of(p, r, raw, double_word);
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
  if (r.role == RegisterRole::status) {
    observe_bits(o.running, s.running, raw);
    observe_bits(o.reverse, s.reverse, raw);
    observe_bits(o.reverse, s.forward, raw, true);
    observe_bits(o.fault_active, s.fault, raw);
    observe_bits(o.warning, s.warning, raw);
  } else if (r.role == RegisterRole::fault) {
    o.fault_code = raw;
    o.fault = Quantity::of(p, r, raw, double_word);
  } else {
    for (const ReportedQuantity& q : kReportedQuantities)
      if (q.role == r.role) o.*q.member = Quantity::of(p, r, raw, double_word);
  }
}

// The text of a parameter the profile does not name: "parameter 4-14", or what its manual calls
// one ("function code F2.11"): the profile's rule says how the manual numbers its parameters.
std::string_view unnamed_parameter_noun(const DriveProfile& p) {
  return p.parameter_rule ? p.parameter_rule->noun : "parameter ";
}

// "frequency setpoint", "16-13 frequency", "parameter 4-14", "register 0x0123", appended: how
// the profile names `address` of `kind`. An address it does not name reads as the parameter
// the addressing rule puts there, else as a register's number.
template <class Out>
void append_name_at(Out& out, const DriveProfile& p, RegisterKind kind, std::uint32_t address) {
  std::string label;
  const RegisterDef* r =
      kind == RegisterKind::holding ? p.find_holding(address, &label) : p.find(kind, address);
  if (r) {
    append_display_name(out, *r);
  } else if (kind == RegisterKind::parameter) {
    out += unnamed_parameter_noun(p);
    out += p.parameter_label(address);
  } else if (!label.empty()) {
    out += "parameter ";
    out += label;
  } else {
    out += "register ";
    append_hex(out, address, 4);
  }
}

// Reads consecutive values from `start` in the space of `kind` (holding registers also reach
// parameters through the addressing rule); collects "name value" parts, the first after `lead`.
// A register of two words takes the next value as its low word.
void read_registers(const DriveProfile& p, RegisterKind kind, std::uint32_t start,
                    std::span<const std::uint32_t> values, bool written, std::string_view lead,
                    Parts& parts, DriveObservation& o) {
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
      LineBuffer& text = parts.next(lead);
      append_display_name(text, *r);
      text += ' ';
      append_value_to(text, p, *r, raw, double_word);
    }
    if (parts.observing()) observe(p, *r, raw, double_word, written, o);
  }
}

// Coils from `start`, one value (0 or 1) each: "name ON" parts.
void read_coils(const DriveProfile& p, RegisterKind kind, std::uint32_t start,
                std::span<const std::uint32_t> values, bool written, std::string_view lead,
                Parts& parts, DriveObservation& o) {
  for (std::size_t i = 0; i < values.size(); ++i) {
    const RegisterDef* r = p.find(kind, start + static_cast<std::uint32_t>(i));
    if (!r) continue;
    if (parts.enabled()) {
      LineBuffer& text = parts.next(lead);
      text += r->name;
      text += values[i] ? std::string_view(" ON") : std::string_view(" OFF");
    }
    if (parts.observing()) observe(p, *r, values[i], false, written, o);
  }
}

// A read request: "read frequency setpoint .. output current". Coils are not announced (the
// reply shows each one's state), nor a running value the profile does not name.
void announce_read(const DriveProfile& p, const DriveRecord& a, Parts& parts) {
  if (!parts.enabled() || a.kind == RegisterKind::coil || a.kind == RegisterKind::discrete) return;
  if (a.kind == RegisterKind::running && !p.find(a.kind, a.first)) return;
  LineBuffer& text = parts.next();
  text += "read ";
  append_name_at(text, p, a.kind, a.first);
  if (a.count > 1) {
    text += " .. ";
    append_name_at(text, p, a.kind, a.first + a.count - 1);
  }
}

// A parameter's value written or reported: "set 4-14 ... = 100.0 Hz (RAM and EEPROM)", "4-14
// ... 100.0 Hz". A parameter the profile does not name shows its raw value, unless the reply
// does not carry its number.
void read_parameter_value(const DriveProfile& p, const DriveRecord& a, std::uint32_t raw,
                          Parts& parts, DriveObservation& o) {
  const RegisterDef* r = p.find(RegisterKind::parameter, a.first);
  const bool written = a.op == AccessOp::write;
  if (!r && a.addressed_by_request) return;
  if (parts.enabled()) {
    LineBuffer& text = parts.next();
    if (written) text += "set ";
    append_name_at(text, p, RegisterKind::parameter, a.first);
    text += written ? std::string_view(" = ") : std::string_view(" ");
    if (r)
      append_value_to(text, p, *r, raw, a.double_word);
    else
      append_uint(text, raw);
    if (a.permanent) text += " (RAM and EEPROM)";
  }
  if (r && parts.observing()) observe(p, *r, raw, a.double_word, written, o);
}

void read_access(const DriveProfile& p, const DriveRecord& a, std::span<const std::uint32_t> values,
                 Parts& parts, DriveObservation& o) {
  switch (a.op) {
    case AccessOp::read:
      announce_read(p, a, parts);
      break;
    case AccessOp::write:
    case AccessOp::value: {
      if (a.kind == RegisterKind::parameter) {
        if (!values.empty()) read_parameter_value(p, a, values[0], parts, o);
        break;
      }
      // A request's parts say what the master sets.
      const bool written = a.op == AccessOp::write;
      const std::string_view lead = written ? "set " : "";
      if (a.kind == RegisterKind::coil || a.kind == RegisterKind::discrete)
        read_coils(p, a.kind, a.first, values, written, lead, parts, o);
      else
        read_registers(p, a.kind, a.first, values, written, lead, parts, o);
      break;
    }
    case AccessOp::refused:
      if (parts.enabled() && !values.empty()) {
        LineBuffer& text = parts.next();
        text += "cannot execute on ";
        append_name_at(text, p, a.kind, a.first);
        text += ": error ";
        append_uint(text, values[0]);
        if (const auto it = p.parameter_errors.find(values[0]); it != p.parameter_errors.end()) {
          text += " (";
          text += it->second;
          text += ')';
        }
      }
      break;
    case AccessOp::text:
      if (parts.enabled()) {
        LineBuffer& text = parts.next();
        text += "text of ";
        append_name_at(text, p, a.kind, a.first);
      }
      break;
    case AccessOp::other:
      break;
  }
}

// Process data words, mapped to registers by the profile for the telegram's direction.
void read_process_words(const DriveProfile& p, bool to_drive, std::span<const std::uint32_t> values,
                        Parts& parts, DriveObservation& o) {
  const std::vector<std::uint32_t>& slots = to_drive ? p.pcd_to_drive : p.pcd_from_drive;
  for (std::size_t i = 0; i < slots.size() && i < values.size(); ++i) {
    const RegisterDef* r = p.find(RegisterKind::holding, slots[i]);
    if (!r) continue;
    if (parts.enabled()) {
      LineBuffer& text = parts.next();
      text += r->name;
      text += ' ';
      append_value_to(text, p, *r, values[i], false);
    }
    if (parts.observing()) observe(p, *r, values[i], false, to_drive, o);
  }
}

// What each RunCommand commands (in the enum's order); `label` "" when the setpoint it carries
// is all it says.
struct RunCommandMeaning {
  const char* label;
  std::optional<bool> run, reverse;
  bool reset;
};
constexpr RunCommandMeaning kRunCommands[] = {
    {"", std::nullopt, std::nullopt, false},            // setpoint
    {"run", true, std::nullopt, false},                 // run
    {"run forward", true, false, false},                // run_forward
    {"run reverse", true, true, false},                 // run_reverse
    {"stop", false, std::nullopt, false},               // stop
    {"fault reset", std::nullopt, std::nullopt, true},  // fault_reset
    {"emergency stop", false, std::nullopt, false},     // emergency_stop
};
static_assert(std::size(kRunCommands) == static_cast<std::size_t>(RunCommand::emergency_stop) + 1);

void read_command(const DriveProfile& p, const DriveRecord& c,
                  std::span<const std::uint32_t> values, Parts& parts, DriveObservation& o) {
  const RunCommandMeaning& meaning = kRunCommands[static_cast<std::size_t>(c.command)];
  if (*meaning.label) parts.add(std::string_view(meaning.label));
  if (meaning.run) o.run_command = meaning.run;
  if (meaning.reverse) o.reverse_command = meaning.reverse;
  if (meaning.reset) o.reset_command = true;
  if (values.empty()) return;
  // The setpoint it carries reads as the profile's setpoint of the command's space.
  const RegisterDef* setpoint = nullptr;
  for (const RegisterDef& r : p.registers)
    if (r.kind == c.kind && r.role == RegisterRole::setpoint) setpoint = &r;
  if (!setpoint) return;
  o.setpoint_command = Quantity::of(p, *setpoint, values[0], false);
  if (parts.enabled()) {
    LineBuffer& text = parts.next();
    text += "setpoint ";
    append_value_to(text, p, *setpoint, values[0], false);
  }
}

// The drive's current fault code: "fault 3 (overcurrent at constant speed)" when there is one.
void read_fault(const DriveProfile& p, std::uint32_t code, Parts& parts, DriveObservation& o) {
  o.fault_code = code;
  const auto names = p.enums.find("fault");
  const std::string* name = nullptr;
  if (names != p.enums.end()) {
    const auto it = names->second.find(code);
    if (it != names->second.end() && !it->second.empty()) name = &it->second;
  }
  // (Not append_value(): a code the manual's table lacks is shown bare.)
  o.fault.value = static_cast<double>(code);
  std::string& text = o.fault.written;
  text.clear();  // keeps its storage
  append_uint(text, code);
  if (name) {
    text += " (";
    text += *name;
    text += ')';
  }
  if (code > 0 && parts.enabled()) {
    LineBuffer& line = parts.next();
    line += "fault ";
    line += text;
  }
}

// Appends the annotation of the telegram's records to `out` (after the caller's "drive N
// (name): ") and fills the observation.
void read_records(const DriveProfile& p, Direction direction, const DriveRecords& records,
                  DriveReadingWants wants, LineBuffer& out, DriveObservation& o) {
  Parts parts(out, wants);
  for (const DriveRecord& r : records.records) {
    const std::span<const std::uint32_t> values = records.values_of(r);
    switch (r.type) {
      case DriveRecordType::access:
        read_access(p, r, values, parts, o);
        break;
      case DriveRecordType::exception:
        // Named even when no text is wanted (read_for_drive()).
        if (const auto it = p.exceptions.find(r.code); it != p.exceptions.end()) {
          LineBuffer& text = parts.next();
          text += "error ";
          append_hex(text, r.code, 2);
          text += ": ";
          text += it->second;
        }
        break;
      case DriveRecordType::process_words:
        read_process_words(p, direction == Direction::request, values, parts, o);
        break;
      case DriveRecordType::command:
        read_command(p, r, values, parts, o);
        break;
      case DriveRecordType::status_query:
        parts.add(std::string_view("status query"));
        break;
      case DriveRecordType::readiness:
        parts.add(std::string_view(r.code ? "ready" : "not ready"));
        break;
      case DriveRecordType::fault:
        read_fault(p, r.code, parts, o);
        break;
    }
  }
}

}  // namespace

std::string display_name(const RegisterDef& r) {
  std::string name;
  append_display_name(name, r);
  return name;
}

void append_value(std::string& out, const DriveProfile& p, const RegisterDef& r, std::uint32_t raw,
                  bool double_word) {
  append_value_to(out, p, r, raw, double_word);
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
      const bool same = register_raw_value(a, raw, double_word) ==
                        register_raw_value(b, other.raw, other.double_word);
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
  read_for_drive_into(p, m, out.records.read(m, request), wants, out);
}

void read_for_drive_into(const DriveProfile& p, const TelegramHead& m, const DriveRecords& records,
                         DriveReadingWants wants, DriveReading& out) {
  out.observed.clear();
  // "drive 2 (ERMAN E-9P/9G): ...", taken back when the profile says nothing of the frame. An
  // observation alone has text only for an exception reply the profile names: the lead is put
  // before that text then, not written for every frame.
  auto append_lead = [&](auto& to) {
    to += std::string_view("drive ");
    append_int(to, m.address);
    to += std::string_view(" (");
    to += std::string_view(p.name);
    to += std::string_view("): ");
  };
  LineBuffer& line = out.line;
  line.clear();  // keeps its storage, as `text` does
  const bool lead_first = wants != DriveReadingWants::observation;
  if (lead_first) append_lead(line);
  const std::size_t lead = line.size();
  read_records(p, m.direction, records, wants, line, out.observed);
  // A telegram whose checksum or plausibility fails says nothing reliable, nor does a reply that
  // is not the answer to its request or answers none seen: what it would mean is shown, marked,
  // and observes nothing (no drive value, state or event comes of it).
  const bool damaged = !good_telegram(m);
  const bool unused = damaged || records.not_the_answer || records.request_unseen;
  if (unused) out.observed.clear();
  std::string& text = out.text;
  text.clear();
  if (line.size() == lead) return;
  if (!lead_first) append_lead(text);
  const std::size_t after_lead = lead_first ? lead : text.size();
  text.append(line.data(), line.size());
  if (damaged) {
    text.insert(after_lead, "damaged telegram, not used: ");
  } else if (records.request_unseen) {
    text.insert(after_lead, "no request seen, not used: ");
  } else if (unused) {
    text.insert(after_lead,
                fmt::format(FMT_COMPILE("not the answer to its request ({} asked for), not used: "),
                            records.asked));
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
