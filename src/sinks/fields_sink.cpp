// `-T fields` (src/sinks/fields_sink.hpp; tshark's -T fields, -e and -E).
#include "sinks/fields_sink.hpp"

#include <fmt/format.h>

namespace drivetap {
namespace {

// "/t" a tab, "/s" a space, else the one character given.
std::optional<char> character_of(std::string_view v) {
  if (v == "/t") return '\t';
  if (v == "/s") return ' ';
  if (v.size() == 1) return v[0];
  return std::nullopt;
}

// Collects a field's values as text: every one, or the first or last.
class Collect final : public ValueVisitor {
 public:
  Collect(std::string& out, char occurrence, char aggregator)
      : out_(out), occurrence_(occurrence), aggregator_(aggregator) {}
  bool visit(const RecordValue& v) override {
    if (occurrence_ == 'l') out_.clear();
    if (count_++ != 0 && occurrence_ == 'a') out_ += aggregator_;
    out_.append(v.text);
    return occurrence_ == 'f';
  }

 private:
  std::string& out_;
  char occurrence_;
  char aggregator_;
  std::size_t count_ = 0;
};

}  // namespace

std::optional<FieldsOptions> parse_fields_options(const std::vector<std::string>& names,
                                                  const std::vector<std::string>& settings,
                                                  std::string* error) {
  FieldsOptions o;
  if (names.empty()) {
    *error = "-T fields: name at least one field with -e (e.g. -e n -e addr -e modbus.func_code)";
    return std::nullopt;
  }
  for (const std::string& name : names) {
    const std::optional<RecordField> f = resolve_record_field(name);
    if (!f) {
      *error = fmt::format(
          "-e {}: unknown field (names: JSON keys, field ids, finding ids, see "
          "docs/reference.md)",
          name);
      return std::nullopt;
    }
    o.fields.push_back(*f);
    o.names.push_back(name);
  }
  for (const std::string& s : settings) {
    const std::size_t eq = s.find('=');
    const std::string_view key = std::string_view(s).substr(0, eq);
    const std::string_view value =
        eq == std::string::npos ? std::string_view{} : std::string_view(s).substr(eq + 1);
    bool ok = eq != std::string::npos;
    if (!ok) {
    } else if (key == "separator") {
      const std::optional<char> c = character_of(value);
      ok = c.has_value();
      if (ok) o.separator = *c;
    } else if (key == "aggregator") {
      const std::optional<char> c = character_of(value);
      ok = c.has_value();
      if (ok) o.aggregator = *c;
    } else if (key == "header") {
      ok = value == "y" || value == "n";
      o.header = value == "y";
    } else if (key == "quote") {
      ok = value == "d" || value == "s" || value == "n";
      o.quote = value == "d" ? '"' : value == "s" ? '\'' : 0;
    } else if (key == "occurrence") {
      ok = value == "f" || value == "l" || value == "a";
      if (ok) o.occurrence = value[0];
    } else {
      ok = false;
    }
    if (!ok) {
      *error = fmt::format(
          "-E {}: expected separator=/t|/s|C, header=y|n, quote=d|s|n, occurrence=f|l|a or "
          "aggregator=C",
          s);
      return std::nullopt;
    }
  }
  return o;
}

FieldsSink::FieldsSink(std::FILE* out, FieldsOptions options, const ChannelTable& channels,
                       TimeNs character_time, bool show_latency)
    : options_(std::move(options)), views_(channels, character_time, show_latency), lines_(out) {
  // The header first, even when no record follows (as tshark writes it).
  if (!options_.header) return;
  for (std::size_t i = 0; i < options_.names.size(); ++i) {
    if (i != 0) lines_.buffer() += options_.separator;
    append_value(options_.names[i]);
  }
  lines_.end_line();
}

SinkNeeds FieldsSink::needs() const {
  SinkNeeds n = SinkNeeds::none();
  n.records = true;
  for (const RecordField& f : options_.fields) {
    const RecordFieldNeeds fn = f.needs();
    n.detail = n.detail || fn.detail || fn.tree;
    n.fields = n.fields || fn.tree;
    n.drive_values = n.drive_values || fn.drive_values;
  }
  return n;
}

namespace {
bool starts_formula(std::string_view text) {
  if (text.empty() || std::string_view("=+-@\t\r").find(text[0]) == std::string_view::npos)
    return false;
  // A number (-12, +3.5) is no formula.
  std::size_t i = 1, digits = 0, points = 0;
  for (; i < text.size(); ++i) {
    if (text[i] >= '0' && text[i] <= '9')
      ++digits;
    else if (text[i] == '.' && points == 0)
      ++points;
    else
      break;
  }
  return !(text[0] == '-' || text[0] == '+') || i != text.size() || digits == 0;
}
}  // namespace

// A value as the line holds it: quoted when -E quote says, a quote inside doubled (as CSV has it).
void FieldsSink::append_value(std::string_view text) {
  LineBuffer& line = lines_.buffer();
  if (options_.quote == 0) {
    line += text;
    return;
  }
  line += options_.quote;
  // A spreadsheet (quote=d is CSV for one) runs a cell that starts with = + - @ as a formula: such
  // a cell from the bus or the capture gets a leading ' (OWASP's advice); numbers stay numbers.
  if (options_.quote == '"' && starts_formula(text)) line += '\'';
  for (const char c : text) {
    if (c == options_.quote) line += c;
    line += c;
  }
  line += options_.quote;
}

void FieldsSink::write_record(const RecordView& record, TimeNs time, TimeNs end) {
  for (std::size_t i = 0; i < options_.fields.size(); ++i) {
    if (i != 0) lines_.buffer() += options_.separator;
    value_.clear();
    const RecordField& field = options_.fields[i];
    if (options_.clock && field.kind == RecordField::Kind::key &&
        (field.key == RecordKey::t || field.key == RecordKey::t_end)) {
      // t and t_end on the clock -t names (d and dd: since the previous record's start).
      // (Every record this sink gets is displayed: a display filter drops them before it.)
      TimeReference reference = *options_.clock;
      reference.previous_captured = previous_time_;
      reference.previous_displayed = previous_time_;
      value_ = format_time(field.key == RecordKey::t ? time : end, options_.time_format,
                           reference);
    } else {
      Collect collect(value_, options_.occurrence, options_.aggregator);
      record_values(field, record, scratch_, collect);
    }
    append_value(value_);
  }
  lines_.end_line();
  previous_time_ = time;
}

void FieldsSink::on_frame(const Message& m) {
  const RecordView r = views_.of(m);
  write_record(r, m.frame.start(), m.frame.events.back().time + r.character_time);
}

void FieldsSink::on_noise(const Frame& f) {
  const RecordView r = views_.of(f);
  write_record(r, f.start(), f.events.empty() ? 0 : f.events.back().time + r.character_time);
}

}  // namespace drivetap
