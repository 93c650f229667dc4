// JSON-lines sink (contract: docs/formats.md "JSON lines"; keys stable, more may be added).
#include "sinks/json_sink.hpp"

#include <fmt/compile.h>
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cstring>

#if defined(__SSE2__)
#include <emmintrin.h>
#include <iterator>
#endif

#include "core/enum_text.hpp"
#include "core/format.hpp"
#include "core/printable.hpp"
#include "drive/drive_fields.hpp"
#include "drive/profile.hpp"
#include "sinks/text_sink.hpp"

namespace drivetap {

using namespace std::string_view_literals;

namespace {

// Characters a JSON string cannot hold as they are: '"', '\\' and the controls below 0x20; and
// every byte from 0x80, which must be checked for well-formed UTF-8 (a name from a hostile file
// may be anything).
constexpr std::array<bool, 256> kNeedsEscape = [] {
  std::array<bool, 256> table{};
  for (int c = 0; c < 0x20; ++c) table[static_cast<std::size_t>(c)] = true;
  for (int c = 0x80; c < 0x100; ++c) table[static_cast<std::size_t>(c)] = true;
  table['"'] = table['\\'] = true;
  return table;
}();

}  // namespace

template <class Out>
void append_json_quoted(Out& out, std::string_view s) {
  out += '"';
  append_json_escaped(out, s);
  out += '"';
}

namespace {

bool any_needs_escape(std::string_view s) {
  std::size_t i = 0;
#if defined(__SSE2__)
  // Sixteen characters at a time where SSE2 is there (every x86-64): a control is one that
  // min(c, 0x1F) leaves as it is.
  const __m128i quotes = _mm_set1_epi8('"'), backslashes = _mm_set1_epi8('\\');
  const __m128i last_controls = _mm_set1_epi8(0x1F);
  for (; i + 16 <= s.size(); i += 16) {
    const __m128i x = _mm_loadu_si128(reinterpret_cast<const __m128i*>(s.data() + i));
    const __m128i hit =
        _mm_or_si128(_mm_or_si128(_mm_cmpeq_epi8(x, quotes), _mm_cmpeq_epi8(x, backslashes)),
                     _mm_cmpeq_epi8(_mm_min_epu8(x, last_controls), x));
    if ((_mm_movemask_epi8(hit) | _mm_movemask_epi8(x)) != 0) return true;  // or a byte >= 0x80
  }
#endif
  // Eight characters at a time: a byte below 0x20, '"' or '\\' sets its high bit in `hit`
  // (the classic zero-byte test; a borrow can only mark bytes above a true hit, so the answer,
  // whether any is set, is exact).
  constexpr std::uint64_t kOnes = 0x0101010101010101u, kHighs = 0x8080808080808080u;
  for (; i + 8 <= s.size(); i += 8) {
    std::uint64_t x;
    std::memcpy(&x, s.data() + i, 8);
    const std::uint64_t quote = x ^ (kOnes * '"');
    const std::uint64_t backslash = x ^ (kOnes * '\\');
    const std::uint64_t control = (x - kOnes * 0x20) & ~x;
    const std::uint64_t is_quote = (quote - kOnes) & ~quote;
    const std::uint64_t is_backslash = (backslash - kOnes) & ~backslash;
    if (((control | is_quote | is_backslash | x) & kHighs) != 0) return true;  // x: >= 0x80
  }
  for (; i < s.size(); ++i)
    if (kNeedsEscape[static_cast<unsigned char>(s[i])]) return true;
  return false;
}

}  // namespace

template <class Out>
void escape_json_tail(Out& out, std::size_t from) {
  const std::string_view written(out.data() + from, out.size() - from);
  if (!any_needs_escape(written)) return;
  const std::string tail(written);
  out.resize(from);
  append_json_escaped(out, tail);
}

template <class Out>
void append_json_escaped(Out& out, std::string_view s) {
  // Nearly every string (a drive annotation runs to some 300 characters) has nothing to escape:
  // one scan sixteen characters at a time, and one copy.
  if (!any_needs_escape(s)) {
    out.append(s);
    return;
  }
  std::size_t plain = 0;  // start of the run of characters that need no escape
  for (std::size_t i = 0; i < s.size(); ++i) {
    const char c = s[i];
    if (!kNeedsEscape[static_cast<unsigned char>(c)]) continue;  // nearly every character
    const char* escape = nullptr;
    switch (c) {
      case '"':
        escape = "\\\"";
        break;
      case '\\':
        escape = "\\\\";
        break;
      case '\n':
        escape = "\\n";
        break;
      case '\r':
        escape = "\\r";
        break;
      case '\t':
        escape = "\\t";
        break;
      default:
        if (static_cast<unsigned char>(c) >= 0x80) {
          // Well-formed UTF-8 stays as it is (C1 controls escaped); a malformed byte becomes
          // U+FFFD, as a decoder would show it.
          const std::size_t n = utf8_length(s, i, /*allow_c1=*/false);
          if (n > 0) {
            i += n - 1;
            continue;
          }
          out.append(s.substr(plain, i - plain));
          if (utf8_length(s, i, /*allow_c1=*/true) == 2) {  // U+0080..U+009F
            const unsigned code = (static_cast<unsigned char>(c) & 0x1Fu) << 6 |
                                  (static_cast<unsigned char>(s[i + 1]) & 0x3Fu);
            fmt::format_to(std::back_inserter(out), FMT_COMPILE("\\u{:04x}"), code);
            ++i;
          } else {
            out += "\\ufffd";
          }
          plain = i + 1;
          continue;
        } else if (static_cast<unsigned char>(c) >= 0x20) {
          continue;
        }
        break;
    }
    out.append(s.substr(plain, i - plain));
    if (escape)
      out += escape;
    else
      fmt::format_to(std::back_inserter(out), FMT_COMPILE("\\u{:04x}"),
                     static_cast<unsigned char>(c));
    plain = i + 1;
  }
  out.append(s.substr(plain));
}

template void append_json_quoted(std::string&, std::string_view);

namespace {

// A short string quoted (a profile's id, a unit: a few characters, nearly never anything to
// escape): checked character by character and copied at once, not scanned as a long one.
void append_short_json_quoted(LineBuffer& line, std::string_view s) {
  constexpr std::size_t kShort = 32;
  if (s.size() <= kShort) {
    bool plain = true;
    for (const char c : s) plain &= !kNeedsEscape[static_cast<unsigned char>(c)];
    if (plain) {
      char* at = line.extend(s.size() + 2);
      at[0] = '"';
      std::memcpy(at + 1, s.data(), s.size());
      at[s.size() + 1] = '"';
      return;
    }
  }
  append_json_quoted(line, s);
}

// One bit of 64 for a value's register and id: values given twice (the same register under the
// same id) have the same bit, so a value whose bit is not yet set was not given before. (The id's
// length and last character, not its address: equal ids may be different strings.)
std::uint64_t identity_bit(const DriveValue& v) {
  std::uint64_t h = (reinterpret_cast<std::uintptr_t>(v.reg) >> 4) + v.id.size() * 31 +
                    (v.id.empty() ? 0u : static_cast<unsigned char>(v.id.back()));
  h *= 0x9E3779B97F4A7C15u;
  return std::uint64_t{1} << (h >> 58);
}

// `s` quoted: as it is when `plain` (a text of a profile whose texts are plain), else escaped.
void append_profile_text_quoted(LineBuffer& line, std::string_view s, bool plain) {
  if (!plain) return append_json_quoted(line, s);
  char* at = line.extend(s.size() + 2);
  at[0] = '"';
  std::memcpy(at + 1, s.data(), s.size());
  at[s.size() + 1] = '"';
}

}  // namespace
template void append_json_quoted(LineBuffer&, std::string_view);
template void append_json_escaped(std::string&, std::string_view);
template void append_json_escaped(LineBuffer&, std::string_view);
template void escape_json_tail(std::string&, std::size_t);
template void escape_json_tail(LineBuffer&, std::size_t);

std::string json_quote(std::string_view s) {
  std::string out;
  append_json_quoted(out, s);
  return out;
}

namespace {

std::string seconds(TimeNs t) {
  return format_seconds(t, 9);
}

// A bytes or text node's value.
[[gnu::noinline]] void append_field_string(LineBuffer& out, const Message& m,
                                           const FieldNode& node) {
  if (node.desc->type == FieldType::text) return append_json_quoted(out, m.fields.text(node));
  // Bytes, written into the record (no temporary string); a text frame's characters escaped
  // where they must be.
  out += '"';
  const std::size_t from = out.size();
  append_field_bytes_hex(out, node, m.bytes, m.text_encoded);
  if (m.text_encoded) escape_json_tail(out, from);
  out += '"';
}

// A node's value: a number, but for bytes and text nodes (rare: the call stays out of line).
[[gnu::always_inline]] inline void append_field_value(LineBuffer& out, const Message& m,
                                                      const FieldNode& node) {
  const FieldType type = node.desc->type;
  if (type == FieldType::bytes || type == FieldType::text) return append_field_string(out, m, node);
  append_int(out, node.value);
}

std::string_view close_id(FrameClose c) {
  static constexpr std::string_view kCloseIds[] = {"silence", "content", "end_of_input"};
  static_assert(std::size(kCloseIds) == static_cast<std::size_t>(FrameClose::end_of_input) + 1);
  return enum_text(c, kCloseIds, std::string_view{"silence"});
}

}  // namespace

// The field tree as an object keyed by dotted id, in first-seen order; an id seen more than once
// (registers) has an array of its values. Ids are dotted lower-case (tests/test_field_table.cpp):
// written without escaping.
void JsonSink::append_fields_object(LineBuffer& out, const Message& m) {
  // Ids compare as their descriptors' keys (FieldDesc::key): a pointer each, no string.
  std::vector<FieldKey>& keys = field_keys_;
  keys.clear();
  for (std::size_t i = 0; i < m.fields.size(); ++i) {
    const FieldDesc* desc = m.fields[i].desc;
    if (desc->type == FieldType::group) continue;
    const FieldDesc* id = desc->key();
    // A repeat of the id just before (registers) is the usual one: no search for it.
    if (!keys.empty() && keys.back().key == id) {
      ++keys.back().count;
      continue;
    }
    auto key =
        std::find_if(keys.begin(), keys.end(), [id](const FieldKey& k) { return k.key == id; });
    if (key == keys.end())
      keys.push_back({id, i, 1});
    else
      ++key->count;
  }
  out += '{';
  for (std::size_t k = 0; k < keys.size(); ++k) {
    const FieldKey& key = keys[k];
    if (k != 0) out += ',';
    out += '"';
    out += key.key->id;
    out += "\":"sv;
    if (key.count == 1) {
      append_field_value(out, m, m.fields[key.first]);
      continue;
    }
    out += '[';
    // Each pass looks at one node; the key's values are its nodes from `first` on.
    for (std::size_t j = key.first, written = 0; written < key.count; ++j) {
      const FieldDesc* desc = m.fields[j].desc;
      if (desc->type == FieldType::group || desc->key() != key.key) continue;
      if (written++ != 0) out += ',';
      append_field_value(out, m, m.fields[j]);
    }
    out += ']';
  }
  out += '}';
}

const JsonSink::RegisterPieces* JsonSink::switch_pieces(const DriveProfile& p) {
  auto known = std::find_if(profile_pieces_.begin(), profile_pieces_.end(),
                            [&p](const ProfilePieces& k) { return k.profile == &p; });
  if (known == profile_pieces_.end()) {
    ProfilePieces made{&p, std::vector<RegisterPieces>(p.registers.size())};
    for (std::size_t i = 0; i < p.registers.size(); ++i) {
      const RegisterDef& r = p.registers[i];
      RegisterPieces& pieces = made.registers[i];
      // (Field ids are letters, digits and '_' (valid_register_field_id()): nothing to escape.)
      const std::string key = fmt::format(",\"{}\":{{\"value\":", r.field_id);
      std::string tail = r.unit.empty() ? std::string() : ",\"unit\":" + json_quote(r.unit);
      tail += ",\"raw\":";
      const int decimals = decimal_scale_index(r.scale);
      if (decimals < 0 || key.size() > RegisterPieces::kPieceChars ||
          tail.size() > RegisterPieces::kPieceChars)
        continue;
      std::memcpy(pieces.key.data(), key.data(), key.size());
      std::memcpy(pieces.tail.data(), tail.data(), tail.size());
      pieces.key_size = static_cast<std::uint8_t>(key.size());
      pieces.tail_size = static_cast<std::uint8_t>(tail.size());
      pieces.decimals = static_cast<std::int8_t>(decimals);
    }
    profile_pieces_.push_back(std::move(made));
    known = profile_pieces_.end() - 1;
  }
  pieces_profile_ = &p;
  pieces_ = known->registers.data();  // (a vector's storage stays where it is when it moves)
  return pieces_;
}

namespace {

// A literal copied to `at`; returns the end.
template <std::size_t N>
char* put(char* at, const char (&literal)[N]) {
  std::memcpy(at, literal, N - 1);
  return at + N - 1;
}

// `v`'s decimal digits to `at`; returns the end.
char* put_uint(char* at, std::uint64_t v) {
  const std::size_t count = decimal_digit_count(v);
  write_decimal_digits(std::span<char>(at, count), v);
  return at + count;
}

}  // namespace

// The frame's `drive` object: the annotation's text, the station and family, and the values
// under their `drive.*` ids (without the prefix; a value given twice is shown once, the first),
// as the pipeline's drive level read them (Message::drive_values). Nothing for a frame no
// profile says anything of. Written through a pointer into room taken ahead (a capacity check
// for each piece cost more than the pieces).
void JsonSink::append_drive_object(LineBuffer& line, const Message& m) {
  // (The station and family, which collect_drive_values() gives first, are keys of their own.)
  std::span<const DriveValue> values = m.drive_values;
  while (!values.empty() && (values.front().id == "station" || values.front().id == "family"))
    values = values.subspan(1);
  if (m.drive_info.empty() && values.empty()) return;
  // The annotation and the values' texts are made of the profile's texts, literals and numbers
  // (DriveProfile::texts_plain): escaped only when the profile's texts may need it.
  const DriveProfile* profile = m.drive_read_with;
  const bool plain = profile && profile->texts_plain;
  if (plain) {
    const std::string_view info = m.drive_info, family = profile->id;
    constexpr std::size_t kHeadChars = 80;  // the head's characters but the two texts
    char* at = line.extend(kHeadChars + info.size() + family.size());
    const char* const start = at;
    at = put(at, ",\"drive\":{\"text\":\"");
    std::memcpy(at, info.data(), info.size());
    at += info.size();
    *at++ = '"';
    if (m.address >= 0) at = put_uint(put(at, ",\"station\":"), static_cast<unsigned>(m.address));
    at = put(at, ",\"family\":\"");
    at = write_chars(at, family);
    at = put(at, "\",\"values\":");
    line.resize(line.size() - kHeadChars - info.size() - family.size() +
                static_cast<std::size_t>(at - start));
  } else {
    line += ",\"drive\":{\"text\":";
    append_json_quoted(line, m.drive_info);
    if (profile) {
      if (m.address >= 0) {
        line += ",\"station\":";
        append_int(line, m.address);
      }
      line += ",\"family\":";
      append_json_quoted(line, profile->id);
    }
    line += ",\"values\":";
  }
  // A register of the profile is written from its pieces.
  const RegisterPieces* pieces = profile ? pieces_for(*profile) : nullptr;
  const auto registers_at =
      reinterpret_cast<std::uintptr_t>(profile ? profile->registers.data() : nullptr);
  const std::size_t register_count = profile ? profile->registers.size() : 0;
  // The room: [at, room_end) taken past the line's characters (which end at `at`).
  constexpr std::size_t kIdChars = 32;    // the longest id written through the pointer
  constexpr std::size_t kTextChars = 64;  // the longest text value written so
  constexpr std::size_t kValueChars = 2 * RegisterPieces::kPieceChars + kDecimalScaledChars +
                                      kTextChars + 20 + 1;  // the most a value takes so
  static_assert(2 + kIdChars + 11 <= RegisterPieces::kPieceChars);
  char* at = line.extend(values.size() * kValueChars + 1);
  char* room_end = at + values.size() * kValueChars + 1;
  char separator = '{';     // before the next value: the object's brace, then commas
  std::uint64_t given = 0;  // identity_bit() of the values shown
  for (std::size_t i = 0; i < values.size(); ++i) {
    const DriveValue& v = values[i];
    const std::uint64_t bit = identity_bit(v);
    if ((given & bit) != 0) {  // perhaps given before: the values before it say
      bool repeated = false;
      for (std::size_t k = 0; k < i && !repeated; ++k)
        repeated = values[k].reg == v.reg && values[k].id == v.id;
      if (repeated) continue;
    }
    given |= bit;
    const RegisterPieces* p = nullptr;
    if (v.kind == DriveValue::Kind::reg && pieces) {
      const std::uintptr_t offset = reinterpret_cast<std::uintptr_t>(v.reg) - registers_at;
      const std::size_t index = offset / sizeof(RegisterDef);
      if (offset % sizeof(RegisterDef) == 0 && index < register_count &&
          pieces[index].decimals >= 0)
        p = &pieces[index];
    }
    const bool own_id = p && v.id.data() == v.reg->field_id.data();
    const bool through_pointer =
        (own_id || v.id.size() <= kIdChars) &&
        (v.kind == DriveValue::Kind::integer || p ||
         (v.kind == DriveValue::Kind::text && plain && v.text.size() <= kTextChars));
    if (!through_pointer) {
      // The general way, by appends: the line is given its size, and room taken afresh after.
      const std::size_t room = static_cast<std::size_t>(room_end - at);
      line.resize(line.size() - room);
      line += separator;
      line += '"';
      line += v.id;
      line += "\":{\"value\":";
      if (v.kind == DriveValue::Kind::text) {
        append_profile_text_quoted(line, v.text, plain);
      } else {
        // The number's digits are written in place: room for the most, then cut to what they
        // took.
        const std::size_t from = line.size();
        char* digits = line.extend(kDriveNumberChars);
        const std::string_view text =
            drive_value_text(v, std::span<char, kDriveNumberChars>(digits, kDriveNumberChars));
        line.resize(from + text.size());
        if (v.kind == DriveValue::Kind::reg) {
          if (!v.reg->unit.empty()) {
            line += ",\"unit\":";
            append_short_json_quoted(line, v.reg->unit);
          }
          line += ",\"raw\":";
          append_uint(line, v.raw);
        }
      }
      line += '}';
      separator = ',';
      const std::size_t more = (values.size() - i) * kValueChars + 1;
      at = line.extend(more);
      room_end = at + more;
      continue;
    }
    if (own_id) {
      std::memcpy(at, p->key.data(), RegisterPieces::kPieceChars);
      at[0] = separator;
      at += p->key_size;
    } else {
      at[0] = separator;
      at[1] = '"';
      at = write_chars(at + 2, v.id);
      at = put(at, "\":{\"value\":");
    }
    separator = ',';
    if (p) {
      // The value's digits from integers (drive_value_text() spells them so), and the raw
      // value's: the same digits when the value is the raw one.
      const std::int64_t value = register_raw_value(*v.reg, v.raw, v.double_word);
      char* const digits = at;
      at = write_decimal_scaled(at, value, p->decimals);
      const auto digit_count = static_cast<std::size_t>(at - digits);
      std::memcpy(at, p->tail.data(), RegisterPieces::kPieceChars);
      at += p->tail_size;
      if (p->decimals == 0 && value == static_cast<std::int64_t>(v.raw))
        at = write_chars(at, std::string_view(digits, digit_count));
      else
        at = put_uint(at, v.raw);
    } else if (v.kind == DriveValue::Kind::integer) {
      if (v.integer < 0) *at++ = '-';
      at = put_uint(at, v.integer < 0 ? 0 - static_cast<std::uint64_t>(v.integer)
                                      : static_cast<std::uint64_t>(v.integer));
    } else {
      *at++ = '"';
      std::memcpy(at, v.text.data(), v.text.size());
      at += v.text.size();
      *at++ = '"';
    }
    *at++ = '}';
  }
  if (separator == '{') *at++ = '{';  // no value
  line.resize(line.size() - static_cast<std::size_t>(room_end - at));
  line += "}}";
}

JsonSink::JsonSink(std::FILE* out, const ChannelTable& channels, TimeNs character_time,
                   bool show_latency)
    : LineFormattingSink(out),
      channels_(channels),
      character_time_(character_time),
      show_latency_(show_latency) {}

std::string_view JsonSink::quoted_channel(ChannelId id) {
  const Channel& channel = channels_.at(id);  // throws for an id of no channel, as before
  if (id >= quoted_channels_.size()) quoted_channels_.resize(std::size_t{id} + 1);
  std::string& quoted = quoted_channels_[id];
  if (quoted.empty()) quoted = json_quote(channel.name);  // never empty once made
  return quoted;
}

void JsonSink::on_frame(const Message& m) {
  const TimeNs t_end = m.frame.events.empty() ? 0 : m.frame.events.back().time + character_time_;
  LineBuffer& line = lines_.buffer();  // the record is built where it will be written from
  line += "{\"type\":\"frame\",\"n\":"sv;
  append_uint(line, m.frame.number);
  line += ",\"t\":"sv;
  append_seconds(line, m.frame.start(), 9);
  line += ",\"t_end\":"sv;
  append_seconds(line, t_end, 9);
  line += ",\"channel\":"sv;
  line += quoted_channel(m.frame.channel);
  line += ",\"dir\":\""sv;
  line += direction_id(m.direction);
  line += "\",\"protocol\":\""sv;
  line += protocol_id(m.protocol);
  line += "\",\"addr\":"sv;
  if (m.address < 0)
    line += "null"sv;
  else
    append_int(line, m.address);
  line += ",\"fc\":"sv;
  if (m.function < 0)
    line += "null"sv;
  else
    append_int(line, m.function);
  line += ",\"hex\":\""sv;
  append_hex_bytes(line, m.bytes, "");
  line += "\",\"checksum\":\""sv;
  line += to_string(m.checksum.verdict);
  line += '"';
  if (m.checksum.verdict != ChecksumVerdict::none) {
    line += ",\"checksum_stated\":\""sv;
    append_wire_hex(line, m.checksum.stated_wire, m.checksum.width, "");
    line += "\",\"checksum_computed\":\""sv;
    append_wire_hex(line, m.checksum.computed_wire, m.checksum.width, "");
    line += '"';
  }
  if (m.is_exception) {
    line += ",\"exception\":"sv;
    append_int(line, m.exception_code);
  }
  if (!m.drive_info.empty() || !m.drive_values.empty()) append_drive_object(line, m);
  if (m.request_number != 0) {
    line += ",\"latency_ms\":"sv;
    if (m.latency >= 0 && show_latency_)
      append_ms(line, m.latency);
    else
      line += "null"sv;
    line += ",\"request_n\":"sv;
    append_uint(line, m.request_number);
  }
  if (m.frame.gap_before >= 0 && show_latency_ && m.silences_trusted) {
    line += ",\"gap_before_ms\":"sv;
    append_ms(line, m.frame.gap_before);
  }
  line += ",\"close\":\""sv;
  line += close_id(m.frame.close);
  line += "\",\"fields\":"sv;
  append_fields_object(line, m);
  // The summary is written straight into the line, then escaped there if it needs it (rarely).
  line += ",\"summary\":\""sv;
  const std::size_t summary_at = line.size();
  append_frame_summary(line, m, show_latency_);
  escape_json_tail(line, summary_at);
  line += "\"}"sv;
  lines_.end_line();
}

void JsonSink::on_noise(const Frame& f) {
  const std::span<const std::uint8_t> bytes = f.events.bytes();
  const TimeNs t_end = f.events.empty() ? 0 : f.events.back().time + character_time_;
  std::string line = fmt::format(
      FMT_COMPILE(
          "{{\"type\":\"noise\",\"n\":{},\"t\":{},\"t_end\":{},\"channel\":{},\"hex\":\"{}\"}}"),
      f.number, seconds(f.start()), seconds(t_end), quoted_channel(f.channel),
      hex_bytes(bytes, ""));
  // A 9-bit line: "hex" keeps the low 8 bits (what the framers read), "chars9" the characters.
  if (std::string nine = nine_bit_hex(f.events); !nine.empty()) {
    line.pop_back();
    line += fmt::format(FMT_COMPILE(",\"chars9\":\"{}\"}}"), nine);
  }
  lines_.write(line);
}

void JsonSink::on_anomaly(const Anomaly& a) {
  // `finding`: the protocol's typed id (mbrtu.intra_frame_gap), where the finding has one.
  std::string line = fmt::format(
      FMT_COMPILE("{{\"type\":\"anomaly\",\"t\":{},\"kind\":\"{}\",{}\"severity\":\"{}\","
                  "\"channel\":{},\"frame\":{},\"detail\":{}}}"),
      seconds(a.time), anomaly_id(a.kind),
      a.finding ? fmt::format(FMT_COMPILE("\"finding\":\"{}\","), a.finding->id) : std::string(),
      severity_id(anomaly_severity(a.kind)), quoted_channel(a.channel),
      a.frame_number == 0 ? std::string("null") : fmt::format(FMT_COMPILE("{}"), a.frame_number),
      json_quote(a.detail));
  // Held with its drive's binding and handed on after later frames: it names its station.
  if (a.address >= 0) {
    line.pop_back();
    fmt::format_to(std::back_inserter(line), FMT_COMPILE(",\"held\":true,\"addr\":{}}}"),
                   a.address);
  }
  lines_.write(line);
}

void JsonSink::on_event(const BusEvent& e) {
  std::string line = fmt::format(
      FMT_COMPILE(
          "{{\"type\":\"event\",\"t\":{},\"channel\":{},\"kind\":\"{}\",\"protocol\":\"{}\""),
      seconds(e.time), quoted_channel(e.channel), event_kind_id(e.kind), protocol_id(e.protocol));
  if (!e.confidence.empty())
    line += fmt::format(FMT_COMPILE(",\"confidence\":\"{}\""), e.confidence);
  if (e.address >= 0)
    line += fmt::format(
        FMT_COMPILE(",\"address\":{},\"profile\":{},\"frame\":{},\"from\":{},\"to\":{}"), e.address,
        json_quote(e.profile), e.frame, json_quote(e.from), json_quote(e.to));
  if (e.withdrawn > 0) line += fmt::format(FMT_COMPILE(",\"withdrawn\":{}"), e.withdrawn);
  line += fmt::format(FMT_COMPILE(",\"detail\":{}}}"), json_quote(e.detail));
  lines_.write(line);
}

void JsonSink::on_transaction(const Transaction& t) {
  LineBuffer& line = lines_.buffer();  // the record is built where it will be written from
  auto number_or_null = [&line](std::uint64_t v) {
    if (v == 0)
      line += "null"sv;
    else
      append_uint(line, v);
  };
  auto time_or_null = [&line](TimeNs v) {
    if (v < 0)
      line += "null"sv;
    else
      append_seconds(line, v, 9);
  };
  line += "{\"type\":\"transaction\",\"outcome\":\""sv;
  line += outcome_id(t.outcome);
  line += "\",\"channel\":"sv;
  line += quoted_channel(t.channel);
  line += ",\"protocol\":\""sv;
  line += protocol_id(t.protocol);
  line += "\",\"addr\":"sv;
  append_int(line, t.address);
  line += ",\"fc\":"sv;
  append_int(line, t.function);
  line += ",\"request_n\":"sv;
  number_or_null(t.request_number);
  line += ",\"response_n\":"sv;
  number_or_null(t.response_number);
  line += ",\"request_t\":"sv;
  time_or_null(t.request_time);
  line += ",\"response_t\":"sv;
  time_or_null(t.response_time);
  line += ",\"latency_ms\":"sv;
  if (t.latency < 0 || !show_latency_)
    line += "null"sv;
  else
    append_ms(line, t.latency);
  if (t.exception_code >= 0) {
    line += ",\"exception\":"sv;
    append_int(line, t.exception_code);
  }
  if (!t.detail.empty()) {
    line += ",\"detail\":"sv;
    append_json_quoted(line, t.detail);
  }
  line += '}';
  lines_.end_line();
}

void JsonSink::on_summary(const Stats& s) {
  const auto& c = s.checksum;
  const auto& o = s.outcomes;
  std::string anomalies;
  for (std::size_t k = 0; k < kAnomalyKindCount; ++k)
    anomalies += fmt::format(FMT_COMPILE("{}\"{}\":{}"), k ? "," : "",
                             anomaly_id(static_cast<AnomalyKind>(k)), s.anomalies[k]);
  std::string latency = "null";
  if (s.latency_count > 0 && show_latency_)
    latency = fmt::format(
        FMT_COMPILE("{{\"min\":{},\"avg\":{},\"max\":{}}}"), format_ms(s.latency_min),
        format_ms(s.latency_sum / static_cast<TimeNs>(s.latency_count)), format_ms(s.latency_max));
  std::string line = fmt::format(
      "{{\"type\":\"summary\",\"bytes\":{},\"frames\":{},\"noise_records\":{},\"noise_bytes\":{},"
      "\"checksum\":{{\"good\":{},\"bad\":{},\"swapped\":{},\"none\":{}}},\"good_telegrams\":{},"
      "\"transactions\":{{\"total\":{},\"ok\":{},\"exception\":{},\"timeout\":{},\"broadcast\":{},"
      "\"unsolicited\":{},\"bad_reply\":{},\"pending\":{}}},\"latency_ms\":{},"
      "\"anomalies_total\":{},"
      "\"anomalies\":{{{}}}}}",
      s.bytes, s.frames, s.noise_records, s.noise_bytes, c[1], c[2], c[3], c[0], s.good_telegrams,
      s.transactions, o[0], o[1], o[2], o[3], o[4], o[5], o[6], latency, s.anomaly_total,
      anomalies);
  line.pop_back();  // the closing brace: drives follow
  line += ",\"drives\":["sv;
  for (std::size_t i = 0; i < s.drives.size(); ++i) {
    const DriveSummary& d = s.drives[i];
    line += fmt::format(
        "{}{{\"link\":{},\"address\":{},\"profile\":{},\"profile_name\":{},\"binding\":{},"
        "\"state\":{},\"events\":{}}}",
        i ? "," : "", d.link, d.address, json_quote(d.profile), json_quote(d.profile_name),
        json_quote(d.binding), json_quote(d.state), d.events);
  }
  line += "]"sv;
  if (s.silences_unjudged > 0) {
    line += ",\"silences_unjudged\":"sv;
    append_uint(line, s.silences_unjudged);
    line += ",\"latencies_unjudged\":"sv;
    append_uint(line, s.latencies_unjudged);
  }
  if (!s.source_notes.empty()) {
    line += ",\"source_notes\":["sv;
    for (std::size_t i = 0; i < s.source_notes.size(); ++i) {
      if (i) line += ',';
      line += json_quote(s.source_notes[i]);
    }
    line += "]"sv;
  }
  if (!s.display_filter.empty())
    line += fmt::format(
        FMT_COMPILE(
            ",\"filter\":{{\"text\":{},\"matched\":{},\"frames\":{},\"late_findings\":{}}}"),
        json_quote(s.display_filter), s.filter_matched, s.filter_records, s.filter_late_findings);
  line += "}"sv;
  lines_.write(line);
}

}  // namespace drivetap
