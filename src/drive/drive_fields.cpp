// The drive layer's record fields (`drive.*`) (src/drive/drive_fields.hpp): a frame's drive values
// read again through its profile when a filter, a field list or the JSON asks for them.
#include "drive/drive_fields.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <memory>
#include <optional>
#include <string_view>

#include "drive/annotate.hpp"
#include "drive/records.hpp"
#include "filter/record_fields.hpp"

namespace drivetap {
namespace {

// The names every family shares, in the order drive_field_values() gives them.
constexpr std::string_view kSharedIds[] = {
    "station", "family",    "setpoint", "output_frequency", "output_current", "output_voltage",
    "running", "direction", "fault",    "fault_name",       "status_word",    "control_word",
};
constexpr int kSharedCount = static_cast<int>(std::size(kSharedIds));

bool is_shared_id(std::string_view id) {
  for (const std::string_view s : kSharedIds)
    if (s == id) return true;
  return false;
}

// Decimals a scale shows (0.01 -> 2, 1 -> 0), as the annotation prints its values.
int scale_decimals(double scale) {
  int d = 0;
  double s = std::fabs(scale);
  while (d < 6 && std::fabs(s - std::round(s)) > 1e-9) {
    s *= 10;
    ++d;
  }
  return d;
}

// `v` spelt with `decimals`, and read back: the number a reader of the text gets.
void set_number(DriveFieldValue& f, double v, int decimals) {
  // (to_chars, not snprintf: the same correctly rounded digits, without the locale and format
  // parsing that made this the largest cost of JSON with drive profiles.)
  char buf[400];  // the most a double takes in fixed notation with up to 17 decimals
  const auto [end, ec] =
      std::to_chars(buf, buf + sizeof buf, v, std::chars_format::fixed, decimals);
  f.text.assign(buf, ec == std::errc() ? static_cast<std::size_t>(end - buf) : 0);
  // (A negative value that rounds to zero is spelt without its sign.)
  if (f.text.starts_with('-') && f.text.find_first_not_of("-0.") == std::string::npos)
    f.text.erase(0, 1);
  f.is_number = true;
  f.value = 0;
  std::from_chars(f.text.data(), f.text.data() + f.text.size(), f.value);
}

DriveFieldValue& add(std::vector<DriveFieldValue>& out, std::string_view id) {
  DriveFieldValue& f = out.emplace_back();
  f.id = id;
  return f;
}

void add_quantity(std::vector<DriveFieldValue>& out, std::string_view id,
                  const std::optional<Quantity>& q) {
  if (!q) return;
  DriveFieldValue& f = add(out, id);
  if (q->reg) {
    set_number(f, q->value, scale_decimals(q->reg->scale));
    f.unit = q->reg->unit;
    f.has_raw = true;
    f.raw = q->raw;
  } else {
    set_number(f, q->value, 6);
    // (A value no register describes: its text as written, when it is a number.)
    double v = 0;
    const auto [end, ec] =
        std::from_chars(q->written.data(), q->written.data() + q->written.size(), v);
    if (ec == std::errc() && end == q->written.data() + q->written.size()) f.text = q->written;
  }
}

void add_integer(std::vector<DriveFieldValue>& out, std::string_view id, std::int64_t v) {
  DriveFieldValue& f = add(out, id);
  set_number(f, static_cast<double>(v), 0);
}

void add_text(std::vector<DriveFieldValue>& out, std::string_view id, std::string_view text) {
  DriveFieldValue& f = add(out, id);
  f.is_number = false;
  f.text = text;
}

// A register's value under its id (and the raw status and control words).
void add_register(std::vector<DriveFieldValue>& out, const DriveProfile& p, const RegisterDef& r,
                  std::uint32_t raw, bool double_word) {
  if (r.role == RegisterRole::status) add_integer(out, "status_word", raw);
  if (r.role == RegisterRole::control) add_integer(out, "control_word", raw);
  if (r.field_id.empty() || is_shared_id(r.field_id)) return;
  add_quantity(out, r.field_id, Quantity::of(p, r, raw, double_word));
}

// The registers a telegram's records carry values of (as read_records() in annotate.cpp walks
// them).
void add_registers(std::vector<DriveFieldValue>& out, const DriveProfile& p, Direction direction,
                   const DriveRecords& records) {
  for (const DriveRecord& a : records.records) {
    const std::span<const std::uint32_t> values = records.values_of(a);
    if (a.type == DriveRecordType::process_words) {
      const auto& slots = direction == Direction::request ? p.pcd_to_drive : p.pcd_from_drive;
      for (std::size_t i = 0; i < slots.size() && i < values.size(); ++i)
        if (const RegisterDef* r = p.find(RegisterKind::holding, slots[i]))
          add_register(out, p, *r, values[i], false);
      continue;
    }
    if (a.type != DriveRecordType::access || (a.op != AccessOp::write && a.op != AccessOp::value))
      continue;
    if (a.kind == RegisterKind::parameter) {
      if (const RegisterDef* r = p.find(RegisterKind::parameter, a.first); r && !values.empty())
        add_register(out, p, *r, values[0], a.double_word);
      continue;
    }
    for (std::size_t i = 0; i < values.size(); ++i) {
      const std::uint32_t address = a.first + static_cast<std::uint32_t>(i);
      const RegisterDef* r =
          a.kind == RegisterKind::holding ? p.find_holding(address) : p.find(a.kind, address);
      if (!r) continue;
      std::uint32_t raw = values[i];
      const bool double_word = r->words == 2 && i + 1 < values.size() &&
                               a.kind != RegisterKind::coil && a.kind != RegisterKind::discrete;
      if (double_word) raw = raw << 16 | values[++i];
      add_register(out, p, *r, raw, double_word);
    }
  }
}

// The `drive.*` names: the shared ones a loaded profile can give, then the registers' ids.
class DriveFieldSource final : public RecordFieldSource {
 public:
  explicit DriveFieldSource(std::span<const DriveProfile* const> profiles)
      : names_(drive_field_ids(profiles)) {}

  [[nodiscard]] std::optional<int> resolve(std::string_view name) const override {
    if (!name.starts_with("drive.")) return std::nullopt;
    name.remove_prefix(6);
    for (std::size_t i = 0; i < names_.size(); ++i)
      if (names_[i] == name) return static_cast<int>(i);
    return std::nullopt;
  }

  [[nodiscard]] RecordFieldNeeds needs(int) const override {
    return {};  // read from the message's bytes and its profile
  }

  bool values(int slot, const RecordView& record, std::string& scratch,
              ValueVisitor& visit) const override {
    if (!record.message || !record.message->drive_read_with) return false;
    // A frame's values are read once for all the fields asked of it (a thread's own: the filter
    // and a writer thread's field list may read at once).
    thread_local const Message* read_message = nullptr;
    thread_local std::uint64_t read_number = 0;
    thread_local TimeNs read_start = 0;
    thread_local std::vector<DriveFieldValue> read;
    const Message& m = *record.message;
    if (read_message != &m || read_number != m.frame.number || read_start != m.frame.start()) {
      drive_field_values(m, read);
      read_message = &m;
      read_number = m.frame.number;
      read_start = m.frame.start();
    }
    const std::string& id = names_[static_cast<std::size_t>(slot)];
    for (const DriveFieldValue& f : read) {
      if (f.id != id) continue;
      scratch = f.text;
      if (visit.visit({f.is_number, f.value, scratch})) return true;
    }
    return false;
  }

 private:
  std::vector<std::string> names_;  // without `drive.`
};

}  // namespace

void drive_field_values(const Message& m, std::vector<DriveFieldValue>& out) {
  out.clear();
  if (!m.drive_read_with) return;
  const DriveProfile& p = *m.drive_read_with;
  thread_local DriveReading reading;
  const TelegramHead head = head_of(m);
  const DriveRecords& records = reading.records.read(head, m.request);
  read_for_drive_into(p, head, records, DriveReadingWants::observation, reading);
  const DriveObservation& o = reading.observed;
  if (m.address >= 0) add_integer(out, "station", m.address);
  add_text(out, "family", p.id);
  add_quantity(out, "setpoint", o.setpoint);
  add_quantity(out, "output_frequency", o.output_frequency);
  add_quantity(out, "output_current", o.current);
  add_quantity(out, "output_voltage", o.voltage);
  if (o.running) add_integer(out, "running", *o.running ? 1 : 0);
  if (o.reverse) add_text(out, "direction", *o.reverse ? "reverse" : "forward");
  if (o.fault_code) {
    add_integer(out, "fault", *o.fault_code);
    // "4 (overcurrent)": the name between the parentheses.
    const std::string w = o.fault.text();
    const std::size_t open = w.find(" (");
    if (open != std::string::npos && w.ends_with(')'))
      add_text(out, "fault_name", std::string_view(w).substr(open + 2, w.size() - open - 3));
  }
  add_registers(out, p, m.direction, records);
}

std::vector<std::string> drive_field_ids(std::span<const DriveProfile* const> profiles) {
  std::vector<std::string> names;
  auto has_role = [&](RegisterRole role) {
    for (const DriveProfile* p : profiles)
      for (const RegisterDef& r : p->registers)
        if (r.role == role) return true;
    return false;
  };
  for (int i = 0; i < kSharedCount; ++i) {
    const std::string_view id = kSharedIds[i];
    bool can = !profiles.empty();
    if (id == "setpoint") can = has_role(RegisterRole::setpoint);
    if (id == "output_frequency") can = has_role(RegisterRole::output_frequency);
    if (id == "output_current") can = has_role(RegisterRole::current);
    if (id == "output_voltage") can = has_role(RegisterRole::voltage);
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

}  // namespace drivetap
