// The drive layer's record fields (`drive.*`) (src/drive/drive_fields.hpp): a frame's drive values
// collected from the pipeline's observation, spelt when a filter, a field list or the JSON asks.
#include "drive/drive_fields.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstring>
#include <memory>
#include <optional>
#include <string_view>
#include <utility>

#include <fmt/format.h>

#include "drive/annotate.hpp"
#include "drive/records.hpp"
#include "filter/record_fields.hpp"

namespace drivetap {
namespace {

// The names every family shares, in the order drive_field_values() gives them, with their names,
// descriptions and units: one unit per id, whatever the family (a family that reports a
// percentage of its reference has the *_pct ids).
struct SharedId {
  std::string_view id, name, blurb, unit;
};
constexpr SharedId kShared[] = {
    {"station", "Station", "The bound drive's address", ""},
    {"family", "Drive family", "The id of the drive profile that read the frame", ""},
    {"setpoint", "Setpoint",
     "The setpoint the drive reports, else the one the master writes, in Hz", "Hz"},
    {"setpoint_pct", "Setpoint (of reference)",
     "The setpoint the drive reports, else the one the master writes, in % of its reference", "%"},
    {"output_frequency", "Output frequency", "The drive's output frequency, in Hz", "Hz"},
    {"output_frequency_pct", "Output frequency (of reference)",
     "The drive's output frequency (its main actual value), in % of its reference", "%"},
    {"output_current", "Output current", "The drive's output current, in A", "A"},
    {"output_voltage", "Output voltage", "The drive's output voltage, in V", "V"},
    {"running", "Running", "1: the drive says it runs, 0: stopped", ""},
    {"direction", "Direction", "forward or reverse, as the drive says", ""},
    {"fault", "Fault code", "The drive's fault code (0: none)", ""},
    {"fault_name", "Fault", "The fault code's name in the drive's manual", ""},
    {"status_word", "Status word", "The drive's status word, raw", ""},
    {"control_word", "Control word", "The control word the master wrote, raw", ""},
};

const SharedId* shared_id(std::string_view id) {
  for (const SharedId& s : kShared)
    if (s.id == id) return &s;
  return nullptr;
}

// The shared ids of the roles that are quantities, by unit.
struct RoleIds {
  RegisterRole role;
  std::string_view word;  // the role's name in a profile
  std::string_view id, unit, pct_id;
};
constexpr RoleIds kRoleIds[] = {
    {RegisterRole::setpoint, "setpoint", "setpoint", "Hz", "setpoint_pct"},
    {RegisterRole::output_frequency, "output_frequency", "output_frequency", "Hz",
     "output_frequency_pct"},
    {RegisterRole::current, "current", "output_current", "A", ""},
    {RegisterRole::voltage, "voltage", "output_voltage", "V", ""},
};

bool is_shared_id(std::string_view id) {
  return shared_id(id) != nullptr;
}

// A register's unit as its values carry it: none for bits or a table of values (a word, a code).
std::string_view register_unit(const RegisterDef& r) {
  return r.bits.empty() && r.enum_name.empty() ? std::string_view(r.unit) : std::string_view();
}

// `v` with `decimals` decimals, as std::to_chars spells the double (correctly rounded), into
// `at`; returns the end. A negative value that rounds to zero is spelt without its sign.
char* write_fixed(char* at, char* end, double v, int decimals) {
  const auto [last, ec] = std::to_chars(at, end, v, std::chars_format::fixed, decimals);
  if (ec != std::errc()) return at;
  if (*at == '-' && std::string_view(at, last).find_first_not_of("-0.") == std::string_view::npos) {
    std::memmove(at, at + 1, static_cast<std::size_t>(last - at - 1));
    return last - 1;
  }
  return last;
}

// `v` in decimal digits into `at`; returns the end.
char* write_integer(char* at, std::int64_t v) {
  return std::to_chars(at, at + 24, v).ptr;
}

// A register's value in the profile's unit with scale_decimals() decimals: the text of the
// double value raw * scale. Under a scale of 1, 0.1, 0.01 ... or a whole one (nearly every
// register) the value is an exact decimal and is spelt from integers: the double's rounding error
// is far below half its last digit for any 32-bit raw value, so the text is the same.
char* write_register_value(char* at, char* end, const RegisterDef& r, std::uint32_t raw,
                           bool double_word) {
  const std::int64_t value = register_raw_value(r, raw, double_word);
  if (const int decimals = decimal_scale_index(r.scale); decimals >= 0)
    return write_decimal_scaled(at, value, decimals);
  if (r.scale == std::round(r.scale) && std::fabs(r.scale) <= 1e6)
    return write_integer(at, value * static_cast<std::int64_t>(r.scale));
  return write_fixed(at, end, static_cast<double>(value) * r.scale, scale_decimals(r.scale));
}

DriveValue& add(std::vector<DriveValue>& out, std::string_view id, DriveValue::Kind kind) {
  DriveValue& v = out.emplace_back();
  v.id = id;
  v.kind = kind;
  return v;
}

void add_integer(std::vector<DriveValue>& out, std::string_view id, std::int64_t integer) {
  add(out, id, DriveValue::Kind::integer).integer = integer;
}

void add_text(std::vector<DriveValue>& out, std::string_view id, std::string_view text) {
  add(out, id, DriveValue::Kind::text).text = text;
}

void add_register_value(std::vector<DriveValue>& out, std::string_view id, const RegisterDef& r,
                        std::uint32_t raw, bool double_word) {
  DriveValue& v = add(out, id, DriveValue::Kind::reg);
  v.reg = &r;
  v.raw = raw;
  v.double_word = double_word;
}

// A reported quantity: always a register's value (Quantity::of()), under its role's id for its
// unit.
void add_quantity(std::vector<DriveValue>& out, const std::optional<Quantity>& q) {
  if (!q || !q->reg) return;
  const std::string_view id = role_value_id(q->reg->role, q->reg->unit);
  if (!id.empty()) add_register_value(out, id, *q->reg, q->raw, q->double_word);
}

// The name in a fault's text "4 (overcurrent)" (Quantity::text()): what stands between its
// first " (" and a closing ')' at its end; nullopt when there is none. Taken from where the text
// takes it, the profile, so that it outlives the frame.
std::optional<std::string_view> fault_name(const DriveProfile& p, std::uint32_t code,
                                           const Quantity& fault) {
  if (!fault.reg) {
    // A fault report (its text made by the annotation: the code, and its name from the
    // profile's fault table when it has one).
    const auto names = p.enums.find("fault");
    if (names == p.enums.end()) return std::nullopt;
    const auto it = names->second.find(code);
    if (it == names->second.end() || it->second.empty()) return std::nullopt;
    return std::string_view(it->second);
  }
  const RegisterDef& r = *fault.reg;
  if (!r.enum_name.empty()) {  // "4 (overcurrent)", or the table's lack said so
    const auto& names = p.enums.at(r.enum_name);
    const auto it = names.find(fault.raw);
    if (it == names.end()) return std::string_view("not in the manual's table");
    return std::string_view(it->second);
  }
  if (!r.bits.empty()) return std::nullopt;  // "0x0004 [...]"
  // A number and its unit: the digits hold no " (", so the name is the unit's.
  const std::string_view unit = r.unit;
  if (unit.empty() || !unit.ends_with(')')) return std::nullopt;
  std::size_t from = 1;
  if (!unit.starts_with('(')) {
    const std::size_t open = unit.find(" (");
    if (open == std::string_view::npos) return std::nullopt;
    from = open + 2;
  }
  return unit.substr(from, unit.size() - from - 1);
}

// The `drive.*` names: the shared ones a loaded profile can give, then the registers' ids.
class DriveFieldSource final : public RecordFieldSource {
 public:
  explicit DriveFieldSource(std::span<const DriveProfile* const> profiles)
      : names_(drive_field_ids(profiles)) {}

  // drive.<id>, and drive.<id>.unit (slot names_.size() + i): the unit of each value it has.
  [[nodiscard]] std::optional<int> resolve(std::string_view name) const override {
    if (!name.starts_with("drive.")) return std::nullopt;
    name.remove_prefix(6);
    const bool unit = name.ends_with(".unit");
    if (unit) name.remove_suffix(5);
    for (std::size_t i = 0; i < names_.size(); ++i)
      if (names_[i] == name) return static_cast<int>(i + (unit ? names_.size() : 0));
    return std::nullopt;
  }

  [[nodiscard]] RecordFieldNeeds needs(int) const override {
    RecordFieldNeeds n;
    // The message's (Message::drive_values), or those the pipeline hands over with a telegram
    // judged by its head (DeferredTelegram::drive_values).
    n.drive_values = true;
    return n;
  }

  bool values(int slot, const RecordView& record, std::string& scratch,
              ValueVisitor& visit) const override {
    const auto at = static_cast<std::size_t>(slot);
    const bool unit = at >= names_.size();
    const std::string& id = names_[unit ? at - names_.size() : at];
    for (const DriveValue& v : record.drive_values()) {
      if (v.id != id) continue;
      if (unit) {
        // (A register's own unit: the shared ids' are theirs by the profile loader's rule.)
        scratch = v.kind == DriveValue::Kind::reg ? register_unit(*v.reg) : std::string_view();
        if (!scratch.empty() && visit.visit({false, 0, scratch})) return true;
        continue;
      }
      char buffer[kDriveNumberChars];
      scratch = drive_value_text(v, buffer);
      const bool is_number = v.kind != DriveValue::Kind::text;
      double number = 0;
      if (is_number)  // the number a reader of the text gets
        std::from_chars(scratch.data(), scratch.data() + scratch.size(), number);
      if (visit.visit({is_number, number, scratch})) return true;
    }
    return false;
  }

 private:
  std::vector<std::string> names_;  // without `drive.`
};

}  // namespace

void collect_drive_values(const DriveProfile& p, int station, const DriveObservation& o,
                          std::vector<DriveValue>& out) {
  if (station >= 0) add_integer(out, "station", station);
  add_text(out, "family", p.id);
  // The setpoint the drive reports, else the one the master writes.
  add_quantity(out, o.setpoint ? o.setpoint : o.setpoint_command);
  add_quantity(out, o.output_frequency);
  add_quantity(out, o.current);
  add_quantity(out, o.voltage);
  if (o.running) add_integer(out, "running", *o.running ? 1 : 0);
  if (o.reverse) add_text(out, "direction", *o.reverse ? "reverse" : "forward");
  if (o.fault_code) {
    add_integer(out, "fault", *o.fault_code);
    if (const auto name = fault_name(p, *o.fault_code, o.fault)) add_text(out, "fault_name", *name);
  }
  // A register's value under its id (and the raw status and control words).
  for (const RegisterValue& v : o.registers) {
    const RegisterDef& r = *v.reg;
    if (r.role == RegisterRole::status) add_integer(out, "status_word", v.raw);
    if (r.role == RegisterRole::control) add_integer(out, "control_word", v.raw);
    if (r.field_id.empty() || r.shared_field_id) continue;
    add_register_value(out, r.field_id, r, v.raw, v.double_word);
  }
}

void complete_drive_info_and_values(Message& m, DriveReading& scratch) {
  if (!m.drive_profile) return;
  const DriveProfile& profile = *m.drive_profile;
  read_for_drive_into(profile, head_of(m), m.request, DriveReadingWants::text_and_observation,
                      scratch);
  std::swap(m.drive_info, scratch.text);  // both keep their storage
  m.drive_profile = nullptr;
  collect_drive_values(profile, m.address, scratch.observed, m.drive_values);
}

std::string_view drive_value_text(const DriveValue& v, std::span<char, kDriveNumberChars> buffer) {
  char* const at = buffer.data();
  switch (v.kind) {
    case DriveValue::Kind::text:
      return v.text;
    case DriveValue::Kind::integer:
      return {at, write_integer(at, v.integer)};
    case DriveValue::Kind::reg:
      break;
  }
  return {at, write_register_value(at, at + buffer.size(), *v.reg, v.raw, v.double_word)};
}

bool is_shared_drive_field_id(std::string_view id) {
  return is_shared_id(id);
}

std::string_view role_value_id(RegisterRole role, std::string_view unit) {
  for (const RoleIds& r : kRoleIds)
    if (r.role == role) return unit == "%" && !r.pct_id.empty() ? r.pct_id : r.id;
  return {};
}

std::string role_unit_rule(RegisterRole role, std::string_view unit) {
  for (const RoleIds& r : kRoleIds) {
    if (r.role != role || unit == r.unit || (unit == "%" && !r.pct_id.empty())) continue;
    const std::string pct =
        r.pct_id.empty() ? std::string() : fmt::format(" or % (drive.{})", r.pct_id);
    return fmt::format("role {} is in {} (drive.{}){}, not '{}'", r.word, r.unit, r.id, pct, unit);
  }
  return {};
}

std::string_view drive_field_unit(std::span<const DriveProfile* const> profiles,
                                  std::string_view id) {
  if (const SharedId* shared = shared_id(id)) return shared->unit;
  for (const DriveProfile* p : profiles)
    for (const RegisterDef& r : p->registers)
      if (r.field_id == id && r.bits.empty() && r.enum_name.empty()) return r.unit;
  return {};
}

std::vector<std::string> drive_field_ids(std::span<const DriveProfile* const> profiles) {
  std::vector<std::string> names;
  auto has_role = [&](RegisterRole role) {
    for (const DriveProfile* p : profiles)
      for (const RegisterDef& r : p->registers)
        if (r.role == role) return true;
    return false;
  };
  auto has_value_id = [&](std::string_view id) {
    for (const DriveProfile* p : profiles)
      for (const RegisterDef& r : p->registers)
        if (role_value_id(r.role, r.unit) == id) return true;
    return false;
  };
  for (const SharedId& shared : kShared) {
    const std::string_view id = shared.id;
    bool can = !profiles.empty();
    for (const RoleIds& r : kRoleIds)
      if (id == r.id || id == r.pct_id) can = has_value_id(id);
    if (id == "status_word") can = has_role(RegisterRole::status);
    if (id == "control_word") can = has_role(RegisterRole::control);
    if (can) names.push_back(std::string(id));
  }
  for (const DriveProfile* p : profiles)
    for (const RegisterDef& r : p->registers)
      if (!r.field_id.empty() && !is_shared_id(r.field_id) &&
          std::find(names.begin(), names.end(), r.field_id) == names.end())
        names.push_back(r.field_id);
  return names;
}

DriveFieldKind drive_field_kind(std::string_view id) {
  if (id == "family" || id == "direction" || id == "fault_name") return DriveFieldKind::text;
  if (id == "station" || id == "running" || id == "fault" || id == "status_word" ||
      id == "control_word")
    return DriveFieldKind::integer;
  return DriveFieldKind::number;  // a quantity in its register's unit
}

void add_drive_field_source(std::span<const DriveProfile* const> profiles) {
  add_record_field_source(std::make_unique<DriveFieldSource>(profiles));
}

std::string drive_field_label(const DriveFieldListing& f) {
  const std::string bracketed = "[" + f.unit + "]";
  if (f.unit.empty() || f.name.ends_with(bracketed)) return f.name;
  return f.name + " " + bracketed;
}

std::vector<DriveFieldListing> drive_field_listing(std::span<const DriveProfile* const> profiles) {
  static constexpr std::string_view kKindWords[] = {
      "holding register", "input register", "coil", "discrete input", "running value", "parameter"};
  std::vector<DriveFieldListing> out;
  for (std::string& id : drive_field_ids(profiles)) {
    DriveFieldListing f;
    f.kind = drive_field_kind(id);
    f.wireshark_type = f.kind == DriveFieldKind::text      ? "FT_STRING"
                       : f.kind == DriveFieldKind::integer ? "FT_UINT32"
                                                           : "FT_DOUBLE";
    if (f.kind == DriveFieldKind::integer)
      f.wireshark_base = id.ends_with("_word") ? "BASE_HEX" : "BASE_DEC";
    f.id = std::move(id);
    f.unit = drive_field_unit(profiles, f.id);
    if (const SharedId* shared = shared_id(f.id)) {
      f.name = shared->name;
      f.blurb = shared->blurb;
      out.push_back(std::move(f));
      continue;
    }
    // A profile's own register: named as the first profile that has it names it (capitalised, as
    // Wireshark names fields), with where it is read; the others that have it too are listed
    // after it (each id once per profile).
    for (const DriveProfile* p : profiles) {
      for (const RegisterDef& r : p->registers) {
        if (r.field_id != f.id) continue;
        if (!f.name.empty()) {
          f.blurb += fmt::format("; also {}", p->id);
          break;
        }
        f.name = r.name;
        if (!f.name.empty() && f.name[0] >= 'a' && f.name[0] <= 'z') f.name[0] -= 'a' - 'A';
        const std::string_view kind = kKindWords[static_cast<std::size_t>(r.kind)];
        if (r.kind == RegisterKind::parameter)
          f.blurb = fmt::format("{}: {} {}", p->name, kind, r.number);
        else if (r.kind == RegisterKind::running)
          f.blurb = fmt::format("{}: {} {}", p->name, kind, r.address);
        else
          f.blurb = fmt::format("{}: {} 0x{:04X}", p->name, kind, r.address);
        if (!r.unit.empty()) f.blurb += fmt::format(", in {}", r.unit);
        break;
      }
    }
    out.push_back(std::move(f));
  }
  return out;
}

}  // namespace drivetap
