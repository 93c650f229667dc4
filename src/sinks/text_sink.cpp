// Text sink: annotated lines for a field engineer (format documented in docs/formats.md "Text
// output").
#include "sinks/text_sink.hpp"

#include <fmt/compile.h>
#include <fmt/format.h>

#include <algorithm>
#include <cstring>
#include <iterator>
#include <span>
#include <string_view>

#include "core/enum_text.hpp"
#include "core/format.hpp"
#include "sinks/color.hpp"

namespace drivetap {

namespace {

std::string_view direction_tag(Direction d) {
  static constexpr std::string_view kDirectionTags[] = {"???", "req", "rsp"};
  static_assert(std::size(kDirectionTags) == static_cast<std::size_t>(Direction::response) + 1);
  return enum_text(d, kDirectionTags, std::string_view{"???"});
}

template <class Out>
void append_checksum_text(Out& out, const ChecksumResult& c) {
  auto wire = [&](std::uint32_t v) { return wire_hex(v, c.width, c.text ? "" : " "); };
  switch (c.verdict) {
    case ChecksumVerdict::good: {
      // (the names are ASCII: no locale call per frame)
      const std::string_view name = c.name;
      const std::span<char> room(append_room(out, name.size() + 3), name.size() + 3);
      std::transform(name.begin(), name.end(), room.begin(), [](char ch) {
        return ch >= 'A' && ch <= 'Z' ? static_cast<char>(ch - 'A' + 'a') : ch;
      });
      std::memcpy(room.subspan(name.size()).data(), " ok", 3);
      return;
    }
    case ChecksumVerdict::bad:
      fmt::format_to(std::back_inserter(out), FMT_COMPILE("{} BAD (wire {}, computed {})"), c.name,
                     wire(c.stated_wire), wire(c.computed_wire));
      return;
    case ChecksumVerdict::swapped:
      fmt::format_to(std::back_inserter(out),
                     FMT_COMPILE("{} SWAPPED (wire {}, expected {}: sent high byte first)"), c.name,
                     wire(c.stated_wire), wire(c.computed_wire));
      return;
    case ChecksumVerdict::none:
      break;
  }
  out += "no checksum";
}

}  // namespace

template <class Out>
void append_frame_summary(Out& out, const Message& m, bool with_latency) {
  out += protocol_label(m.protocol);
  out += "  ";
  if (m.address == 0) {
    out += "broadcast";
  } else if (m.address < 0) {
    out += "addr ?";
  } else {
    out += "addr ";
    append_int(out, m.address);
  }
  out += "  ";
  out += m.info;
  out += "  ";
  append_checksum_text(out, m.checksum);
  if (m.request_number != 0) {
    // The pairing's outcome (Outcome::bad_reply): a reply whose checksum fails answers nothing.
    out += m.checksum.verdict == ChecksumVerdict::bad ? "  bad reply to #" : "  reply to #";
    append_uint(out, m.request_number);
    if (!with_latency) return;
    if (m.latency >= 0) {
      out += " in ";
      append_ms(out, m.latency);
      out += " ms";
    } else {
      out += m.silences_trusted ? " (latency hidden: no silence before it)"
                                : " (latency hidden: timing not trusted)";
    }
  }
}

template void append_frame_summary(std::string&, const Message&, bool);
template void append_frame_summary(LineBuffer&, const Message&, bool);

std::string frame_summary(const Message& m, bool with_latency) {
  std::string s;
  append_frame_summary(s, m, with_latency);
  return s;
}

std::string shown_hex(std::span<const std::uint8_t> bytes) {
  if (bytes.size() <= kShownHexBytes) return hex_bytes(bytes);
  return fmt::format(FMT_COMPILE("{} … (+{} bytes)"), hex_bytes(bytes.first(kShownHexBytes)),
                     bytes.size() - kShownHexBytes);
}

std::string hex_dump(std::span<const std::uint8_t> bytes, std::string_view indent) {
  std::string out;
  for (std::size_t at = 0; at < bytes.size(); at += 16) {
    const std::span<const std::uint8_t> row =
        bytes.subspan(at, std::min<std::size_t>(16, bytes.size() - at));
    out += indent;
    fmt::format_to(std::back_inserter(out), FMT_COMPILE("{:04x}  "), at);
    for (std::size_t k = 0; k < 16; ++k) {
      if (k < row.size())
        fmt::format_to(std::back_inserter(out), FMT_COMPILE("{:02x} "), row[k]);
      else
        out += "   ";
    }
    out += "  ";
    for (const std::uint8_t b : row) out += b >= 0x20 && b < 0x7F ? static_cast<char>(b) : '.';
    out += '\n';
  }
  return out;
}

TextSink::TextSink(std::FILE* out, const ChannelTable& channels, TextSinkOptions options)
    : LineFormattingSink(out), channels_(channels), options_(options) {}

namespace {

// The most characters a prefix takes besides its channel's name: a number of up to 20 digits and
// a space; a time of a sign, up to 20 whole digits, a point and 6 decimals, and a space; the 3
// spaces written after the name (those past its padding to 3 columns are written over) and a
// space.
constexpr std::size_t kPrefixMostChars = 21 + 29 + 4;

// -x dump lines are indented as the other lines under a frame.
constexpr std::string_view kDumpIndent = "        ";

// Where `count` characters right-aligned in Width columns start, at `at`: the Width spaces are
// written in one fixed-size store, the characters then go over the last of them.
template <std::size_t Width>
char* right_aligned_start(char* at, std::size_t count) {
  std::memset(at, ' ', Width);
  return at + (count < Width ? Width - count : 0);
}

}  // namespace

template <class Out>
void append_text_prefix(Out& out, std::uint64_t number, TimeNs time, bool show_time,
                        std::string_view channel) {
  // The pieces are written through a pointer into room for the most they can take: no capacity
  // check and no reload of the line's members per piece (appended piece by piece, the prefix
  // took a fourteenth of text's samples). The widths are fixed, so each column's spaces are one
  // store.
  append_at_most(out, kPrefixMostChars + channel.size(), [&](char* at) {
    if (number) {  // right-aligned in 5 columns
      const std::size_t count = decimal_digit_count(number);
      at = right_aligned_start<5>(at, count);
      write_decimal_digits(std::span<char>(at, count), number);
      at += count;
    } else {
      std::memcpy(at, "    -", 5);
      at += 5;
    }
    *at++ = ' ';
    if (show_time) {  // seconds with 6 decimals, right-aligned in 14 columns
      const SecondsParts parts = split_seconds(time, 6);
      const std::size_t whole = decimal_digit_count(parts.whole);
      at = right_aligned_start<14>(at, (parts.negative ? 1 : 0) + whole + 7);
      if (parts.negative) *at++ = '-';
      write_decimal_digits(std::span<char>(at, whole), parts.whole);
      at += whole;
      *at++ = '.';
      write_decimal_digits(std::span<char>(at, 6), parts.fraction);
      at += 6;
      *at++ = ' ';
    }
    at = write_chars(at, channel);  // left-aligned in 3 columns
    std::memcpy(at, "   ", 3);
    at += channel.size() < 3 ? 3 - channel.size() : 0;
    *at++ = ' ';
    return at;
  });
}

template void append_text_prefix(std::string&, std::uint64_t, TimeNs, bool, std::string_view);
template void append_text_prefix(LineBuffer&, std::uint64_t, TimeNs, bool, std::string_view);

TimeReference TextSink::time_reference() const {
  TimeReference reference = options_.clock ? *options_.clock : TimeReference{};
  // (Every record this sink gets is displayed: a display filter drops them before it.)
  reference.previous_captured = previous_record_time_;
  reference.previous_displayed = previous_record_time_;
  return reference;
}

namespace {

// The prefix with a calendar time (-t a, ad, u, ud): right-aligned in 14 columns or as wide as
// it is.
template <class Out>
[[gnu::noinline]] void append_calendar_prefix(Out& out, std::uint64_t number, TimeNs time,
                                              TimeFormat format, const TimeReference& reference,
                                              std::string_view name) {
  char text[kMaxTimeChars];
  const std::size_t length = format_time(text, time, format, reference);
  if (number)
    fmt::format_to(std::back_inserter(out), FMT_COMPILE("{:>5} "), number);
  else
    out += "    - ";
  fmt::format_to(std::back_inserter(out), FMT_COMPILE("{:>14} {:<3} "),
                 std::string_view(text, length), name);
}

}  // namespace

// Inlined where it is called: a frame line's prefix is the text's hottest piece, and the call
// with its branches on the time format cost more than the prefix's own digits.
template <class Out>
[[gnu::always_inline]] inline void TextSink::append_prefix(Out& out, std::uint64_t number,
                                                           TimeNs time, ChannelId channel) const {
  const std::string_view name = channels_.at(channel).name;
  // One call of append_text_prefix(), which the compiler then writes in place (the text's
  // hottest piece).
  TimeNs shown = time;
  if (options_.show_time && options_.clock && options_.time_format == TimeFormat::relative) {
    shown = time_since(time, options_.clock->origin);
  } else if (options_.show_time && options_.time_format != TimeFormat::relative) {
    const TimeReference reference = time_reference();
    const std::optional<TimeNs> seconds = shown_seconds(time, options_.time_format, reference);
    if (!seconds) {
      append_calendar_prefix(out, number, time, options_.time_format, reference, name);
      return;
    }
    shown = *seconds;
  }
  append_text_prefix(out, number, shown, options_.show_time, name);
}

std::string TextSink::prefix(std::uint64_t number, TimeNs time, ChannelId channel) const {
  std::string s;
  append_prefix(s, number, time, channel);
  return s;
}

void TextSink::on_frame(const Message& m) {
  last_frame_number_ = m.frame.number;
  if (!options_.frames) return;
  LineBuffer& line = lines_.buffer();  // the line is built where it will be written from
  append_prefix(line, m.frame.number, m.frame.start(), m.frame.channel);
  note_record_time(m.frame.start());
  line += direction_tag(m.direction);
  line += "  ";
  const bool colored = options_.color && (m.checksum.verdict == ChecksumVerdict::bad ||
                                          m.checksum.verdict == ChecksumVerdict::swapped);
  if (colored) line += color::kRed;
  append_frame_summary(line, m, options_.show_time);
  if (colored) line += color::kReset;
  lines_.end_line();
  if (!m.drive_info.empty()) {
    line.append(8, ' ');
    line += "= ";
    line += m.drive_info;
    lines_.end_line();
  }
  if (options_.verbose) write_field_tree(m);
  if (options_.hex_dump) lines_.write_lines(hex_dump(m.bytes, kDumpIndent));
}

void TextSink::write_field_tree(const Message& m) {
  if (m.text_encoded) {
    std::string text;
    const std::span<const std::uint8_t> shown =
        std::span<const std::uint8_t>(m.bytes).first(std::min(m.bytes.size(), kShownHexBytes));
    for (const std::uint8_t b : shown) {
      if (b == '\r')
        text += "\\r";
      else if (b == '\n')
        text += "\\n";
      else if (b >= 0x20 && b < 0x7F)
        text += static_cast<char>(b);
      else
        text += fmt::format(FMT_COMPILE("\\x{:02X}"), b);
    }
    if (shown.size() < m.bytes.size())
      text += fmt::format(FMT_COMPILE("\" … (+{} bytes)"), m.bytes.size() - shown.size());
    else
      text += '"';
    lines_.write(fmt::format(FMT_COMPILE("{:>8}text: \"{}"), "", text));
  } else {
    lines_.write(fmt::format(FMT_COMPILE("{:>8}bytes: {}"), "", shown_hex(m.bytes)));
  }
  for (const FieldNode& node : m.fields) {
    const std::string span = node.length <= 1 ? fmt::format(FMT_COMPILE("[{}]"), node.offset)
                                              : fmt::format(FMT_COMPILE("[{}-{}]"), node.offset,
                                                            node.offset + node.length - 1);
    lines_.write(fmt::format(FMT_COMPILE("{:>8}{:<9} {:{}}{:<26} {}: {}"), "", span, "",
                             node.depth * 2u, node.desc->id, node.desc->name,
                             format_field_value(m.fields, node, m.bytes, m.text_encoded)));
  }
}

void TextSink::on_noise(const Frame& f) {
  last_frame_number_ = f.number;
  if (!options_.frames) return;
  const std::span<const std::uint8_t> bytes = f.events.bytes();
  const std::string line_start = prefix(f.number, f.start(), f.channel);
  note_record_time(f.start());
  const std::string_view on = options_.color ? color::kYellow : "";
  const std::string_view off = options_.color ? color::kReset : "";
  if (std::string nine = nine_bit_hex(f.events); !nine.empty()) {
    lines_.write(line_start + fmt::format(FMT_COMPILE("{}---  noise: {} 9-bit character{} {}{}"),
                                          on, bytes.size(), bytes.size() == 1 ? "" : "s", nine,
                                          off));
    return;
  }
  lines_.write(line_start + fmt::format(FMT_COMPILE("{}---  noise: {} byte{} {}{}"), on,
                                        bytes.size(), bytes.size() == 1 ? "" : "s",
                                        shown_hex(bytes), off));
  if (options_.hex_dump) lines_.write_lines(hex_dump(bytes, kDumpIndent));
}

void TextSink::on_anomaly(const Anomaly& a) {
  if (!options_.frames) return;
  // Checksum verdicts are already on the frame line; noise is its own line.
  if (a.kind == AnomalyKind::checksum_bad || a.kind == AnomalyKind::checksum_swapped ||
      a.kind == AnomalyKind::noise)
    return;
  const std::string_view on = options_.color ? color::of(anomaly_severity(a.kind)) : "";
  const std::string_view off = options_.color ? color::kReset : "";
  if (a.address >= 0 && a.frame_number != 0) {
    // Held with its drive's binding until the binder was sure of the family, or the input ended.
    lines_.write(prefix(0, a.time, a.channel) +
                 fmt::format(FMT_COMPILE("{}!!!  {} (#{}, held while drive {}'s family was "
                                         "not yet sure): {}{}"),
                             on, anomaly_label(a.kind), a.frame_number, a.address, a.detail, off));
    return;
  }
  if (a.frame_number != 0 && a.frame_number == last_frame_number_ &&
      a.kind != AnomalyKind::unanswered_request && a.kind != AnomalyKind::unsolicited_response) {
    lines_.write(fmt::format(FMT_COMPILE("{:>8}{}! {}: {}{}"), "", on, anomaly_label(a.kind),
                             a.detail, off));
    return;
  }
  lines_.write(prefix(0, a.time, a.channel) + fmt::format(FMT_COMPILE("{}!!!  {}: {}{}"), on,
                                                          anomaly_label(a.kind), a.detail, off));
}

void TextSink::on_event(const BusEvent& e) {
  if (!options_.frames) return;
  if (options_.color)
    lines_.write(prefix(0, e.time, e.channel) +
                 fmt::format(FMT_COMPILE("{}***  {}{}"), color::kCyan, e.detail, color::kReset));
  else
    lines_.write(prefix(0, e.time, e.channel) + fmt::format(FMT_COMPILE("***  {}"), e.detail));
}

void TextSink::on_summary(const Stats& s) {
  if (!options_.summary) return;
  lines_.write("");
  lines_.write("--- summary ---");
  if (s.frames + s.noise_records > 0 && options_.show_time) {
    // The span in the -t format; a delta format gives it relative.
    TimeFormat format = options_.time_format;
    if (format == TimeFormat::delta || format == TimeFormat::delta_displayed)
      format = TimeFormat::relative;
    TimeReference reference = options_.clock ? *options_.clock : TimeReference{};
    const bool seconds = shown_seconds(s.first_time, format, reference).has_value();
    lines_.write(fmt::format(FMT_COMPILE("capture:      {} .. {}{}, {} bytes"),
                             format_time(s.first_time, format, reference),
                             format_time(s.last_time, format, reference), seconds ? " s" : "",
                             s.bytes));
  } else {
    lines_.write(fmt::format(FMT_COMPILE("capture:      {} bytes"), s.bytes));
  }
  const auto& c = s.checksum;
  const std::uint64_t ok = c[static_cast<int>(ChecksumVerdict::good)];
  // Telegrams whose checksum matches but which break a plausibility rule are said apart (only
  // then: a drive bus has none).
  const std::string good = ok == s.good_telegrams
                               ? std::string()
                               : fmt::format(FMT_COMPILE("; good telegrams {}"), s.good_telegrams);
  lines_.write(fmt::format(
      FMT_COMPILE(
          "frames:       {} (checksum ok {}, bad {}, swapped {}{}); noise: {} record{}, {} byte{}"),
      s.frames, ok, c[static_cast<int>(ChecksumVerdict::bad)],
      c[static_cast<int>(ChecksumVerdict::swapped)], good, s.noise_records,
      s.noise_records == 1 ? "" : "s", s.noise_bytes, s.noise_bytes == 1 ? "" : "s"));
  const auto& o = s.outcomes;
  std::string tx = fmt::format(
      FMT_COMPILE(
          "transactions: {} (ok {}, exception {}, timeout {}, broadcast {}, unsolicited {}, bad "
          "reply {}, pending {})"),
      s.transactions, o[static_cast<int>(Outcome::ok)], o[static_cast<int>(Outcome::exception)],
      o[static_cast<int>(Outcome::timeout)], o[static_cast<int>(Outcome::broadcast)],
      o[static_cast<int>(Outcome::unsolicited)], o[static_cast<int>(Outcome::bad_reply)],
      o[static_cast<int>(Outcome::pending)]);
  if (s.latency_count > 0 && options_.show_time)
    tx += fmt::format(
        FMT_COMPILE("; reply latency min {} / avg {} / max {} ms"), format_ms(s.latency_min),
        format_ms(s.latency_sum / static_cast<TimeNs>(s.latency_count)), format_ms(s.latency_max));
  lines_.write(tx);
  std::string an = fmt::format(FMT_COMPILE("anomalies:    {}"), s.anomaly_total);
  bool first = true;
  for (std::size_t k = 0; k < kAnomalyKindCount; ++k) {
    if (s.anomalies[k] == 0) continue;
    an += fmt::format(FMT_COMPILE("{}{} {}"), first ? " (" : ", ",
                      anomaly_id(static_cast<AnomalyKind>(k)), s.anomalies[k]);
    first = false;
  }
  if (!first) an += ")";
  lines_.write(an);
  for (const std::string& note : s.source_notes)
    lines_.write(fmt::format(FMT_COMPILE("source:       {}"), note));
  if (s.silences_unjudged > 0)
    lines_.write(fmt::format(
        FMT_COMPILE("timing:       not trusted (the source's verdict above): {} telegram{} not "
                    "judged by t1.5, t3.5 or a drive's timing rule, {} reply latenc{} hidden"),
        s.silences_unjudged, s.silences_unjudged == 1 ? "" : "s", s.latencies_unjudged,
        s.latencies_unjudged == 1 ? "y" : "ies"));
  if (!s.display_filter.empty()) {
    std::string line = fmt::format(FMT_COMPILE("filter:       -Y '{}' matched {} of {} frames"),
                                   s.display_filter, s.filter_matched, s.filter_records);
    if (s.filter_late_findings > 0)
      line += fmt::format(FMT_COMPILE(", and {} finding{} reported after {} frame"),
                          s.filter_late_findings, s.filter_late_findings == 1 ? "" : "s",
                          s.filter_late_findings == 1 ? "its" : "their");
    lines_.write(line);
  }
  for (const DriveSummary& d : s.drives) {
    lines_.write(
        fmt::format(FMT_COMPILE("drive {:<7} {}{}{}"), d.address, d.profile_name,
                    d.binding.empty() ? "" : " (" + d.binding + ")",
                    d.link ? fmt::format(FMT_COMPILE(" on link {}"), d.link) : std::string()));
    if (!d.state.empty())
      lines_.write(fmt::format(FMT_COMPILE("{:14}last state: {}; {} event{}"), "", d.state,
                               d.events, d.events == 1 ? "" : "s"));
  }
}

}  // namespace drivetap
