// JSON-lines sink (contract: README "JSON lines"; keys stable, more may be added).
#include "sinks/json_sink.hpp"

#include <fmt/format.h>

#include <algorithm>

#include "sinks/format.hpp"
#include "sinks/text_sink.hpp"

namespace drivetap {

std::string json_quote(std::string_view s) {
  std::string out = "\"";
  for (const char c : s) {
    switch (c) {
      case '"':
        out += "\\\"";
        break;
      case '\\':
        out += "\\\\";
        break;
      case '\n':
        out += "\\n";
        break;
      case '\r':
        out += "\\r";
        break;
      case '\t':
        out += "\\t";
        break;
      default:
        if (static_cast<unsigned char>(c) < 0x20)
          out += fmt::format("\\u{:04x}", static_cast<unsigned char>(c));
        else
          out += c;
    }
  }
  out += '"';
  return out;
}

namespace {

std::string seconds(TimeNs t) {
  return format_seconds(t, 9);
}

// Field nodes keyed by dotted id, in first-seen order; repeated ids become arrays.
std::string fields_object(const Message& m) {
  std::vector<std::pair<std::string_view, std::vector<std::string>>> entries;
  for (const FieldNode& node : m.fields) {
    std::string value;
    switch (node.desc->type) {
      case FieldType::group:
        continue;
      case FieldType::bytes:
        value = json_quote(field_bytes_hex(node, m.bytes, m.text_encoded));
        break;
      case FieldType::text:
        value = json_quote(node.text);
        break;
      default:
        value = fmt::format("{}", node.value);
        break;
    }
    auto it = std::find_if(entries.begin(), entries.end(),
                           [&](const auto& e) { return e.first == node.desc->id; });
    if (it == entries.end()) {
      entries.push_back({node.desc->id, {std::move(value)}});
    } else {
      it->second.push_back(std::move(value));
    }
  }
  std::string out = "{";
  for (std::size_t i = 0; i < entries.size(); ++i) {
    out += fmt::format("{}{}:", i ? "," : "", json_quote(entries[i].first));
    const auto& values = entries[i].second;
    if (values.size() == 1) {
      out += values[0];
    } else {
      out += '[';
      for (std::size_t j = 0; j < values.size(); ++j) out += (j ? "," : "") + values[j];
      out += ']';
    }
  }
  return out + "}";
}

const char* close_id(FrameClose c) {
  switch (c) {
    case FrameClose::silence:
      return "silence";
    case FrameClose::content:
      return "content";
    case FrameClose::end_of_input:
      return "end_of_input";
  }
  return "silence";
}

}  // namespace

JsonSink::JsonSink(std::FILE* out, const ChannelTable& channels, TimeNs character_time,
                   bool show_latency)
    : out_(out),
      channels_(channels),
      character_time_(character_time),
      show_latency_(show_latency) {}

void JsonSink::write(std::string& line) {
  line += '\n';
  if (std::fwrite(line.data(), 1, line.size(), out_) != line.size()) write_failed_ = true;
}

void JsonSink::on_frame(const Message& m) {
  const TimeNs t_end = m.frame.events.empty() ? 0 : m.frame.events.back().time + character_time_;
  std::string line = fmt::format(
      "{{\"type\":\"frame\",\"n\":{},\"t\":{},\"t_end\":{},\"channel\":{},\"dir\":\"{}\","
      "\"protocol\":\"{}\",\"addr\":{},\"fc\":{},\"hex\":\"{}\",\"checksum\":\"{}\"",
      m.frame.number, seconds(m.frame.start()), seconds(t_end),
      json_quote(channels_.at(m.frame.channel).name), direction_id(m.direction),
      protocol_id(m.protocol), m.address < 0 ? std::string("null") : fmt::format("{}", m.address),
      m.function < 0 ? std::string("null") : fmt::format("{}", m.function), hex_bytes(m.bytes, ""),
      to_string(m.checksum.verdict));
  if (m.checksum.verdict != ChecksumVerdict::none)
    line += fmt::format(",\"checksum_stated\":\"{}\",\"checksum_computed\":\"{}\"",
                        wire_hex(m.checksum.stated_wire, m.checksum.width, ""),
                        wire_hex(m.checksum.computed_wire, m.checksum.width, ""));
  if (m.is_exception) line += fmt::format(",\"exception\":{}", m.exception_code);
  if (!m.drive_info.empty()) line += fmt::format(",\"drive\":{}", json_quote(m.drive_info));
  if (m.request_number != 0)
    line += fmt::format(",\"latency_ms\":{},\"request_n\":{}",
                        m.latency >= 0 && show_latency_ ? format_ms(m.latency) : "null",
                        m.request_number);
  if (m.frame.gap_before >= 0 && show_latency_)
    line += fmt::format(",\"gap_before_ms\":{}", format_ms(m.frame.gap_before));
  line += fmt::format(",\"close\":\"{}\",\"fields\":{},\"summary\":{}}}", close_id(m.frame.close),
                      fields_object(m), json_quote(frame_summary(m, show_latency_)));
  write(line);
}

void JsonSink::on_noise(const Frame& f) {
  const std::vector<std::uint8_t> bytes = f.bytes();
  const TimeNs t_end = f.events.empty() ? 0 : f.events.back().time + character_time_;
  std::string line = fmt::format(
      "{{\"type\":\"noise\",\"n\":{},\"t\":{},\"t_end\":{},\"channel\":{},\"hex\":\"{}\"}}",
      f.number, seconds(f.start()), seconds(t_end), json_quote(channels_.at(f.channel).name),
      hex_bytes(bytes, ""));
  write(line);
}

void JsonSink::on_anomaly(const Anomaly& a) {
  std::string line = fmt::format(
      "{{\"type\":\"anomaly\",\"t\":{},\"kind\":\"{}\",\"channel\":{},\"frame\":{},\"detail\":{}}}",
      seconds(a.time), anomaly_id(a.kind), json_quote(channels_.at(a.channel).name),
      a.frame_number == 0 ? std::string("null") : fmt::format("{}", a.frame_number),
      json_quote(a.detail));
  write(line);
}

void JsonSink::on_event(const BusEvent& e) {
  std::string line = fmt::format(
      "{{\"type\":\"event\",\"t\":{},\"channel\":{},\"kind\":\"{}\",\"protocol\":\"{}\"",
      seconds(e.time), json_quote(channels_.at(e.channel).name), e.kind, protocol_id(e.protocol));
  if (!e.confidence.empty()) line += fmt::format(",\"confidence\":\"{}\"", e.confidence);
  if (e.address >= 0)
    line +=
        fmt::format(",\"address\":{},\"profile\":{},\"frame\":{},\"from\":{},\"to\":{}", e.address,
                    json_quote(e.profile), e.frame, json_quote(e.from), json_quote(e.to));
  line += fmt::format(",\"detail\":{}}}", json_quote(e.detail));
  write(line);
}

void JsonSink::on_transaction(const Transaction& t) {
  auto opt_time = [](TimeNs v) { return v < 0 ? std::string("null") : seconds(v); };
  auto opt_num = [](std::uint64_t v) {
    return v == 0 ? std::string("null") : fmt::format("{}", v);
  };
  std::string line = fmt::format(
      "{{\"type\":\"transaction\",\"outcome\":\"{}\",\"channel\":{},\"protocol\":\"{}\","
      "\"addr\":{},\"fc\":{},\"request_n\":{},\"response_n\":{},\"request_t\":{},"
      "\"response_t\":{},\"latency_ms\":{}",
      outcome_id(t.outcome), json_quote(channels_.at(t.channel).name), protocol_id(t.protocol),
      t.address, t.function, opt_num(t.request_number), opt_num(t.response_number),
      opt_time(t.request_time), opt_time(t.response_time),
      t.latency < 0 || !show_latency_ ? std::string("null") : format_ms(t.latency));
  if (t.exception_code >= 0) line += fmt::format(",\"exception\":{}", t.exception_code);
  if (!t.detail.empty()) line += fmt::format(",\"detail\":{}", json_quote(t.detail));
  line += "}";
  write(line);
}

void JsonSink::on_summary(const Stats& s) {
  const auto& c = s.checksum;
  const auto& o = s.outcomes;
  std::string anomalies;
  for (std::size_t k = 0; k < kAnomalyKindCount; ++k)
    anomalies += fmt::format("{}\"{}\":{}", k ? "," : "", anomaly_id(static_cast<AnomalyKind>(k)),
                             s.anomalies[k]);
  std::string latency = "null";
  if (s.latency_count > 0 && show_latency_)
    latency = fmt::format("{{\"min\":{},\"avg\":{},\"max\":{}}}", format_ms(s.latency_min),
                          format_ms(s.latency_sum / static_cast<TimeNs>(s.latency_count)),
                          format_ms(s.latency_max));
  std::string line = fmt::format(
      "{{\"type\":\"summary\",\"bytes\":{},\"frames\":{},\"noise_records\":{},\"noise_bytes\":{},"
      "\"checksum\":{{\"good\":{},\"bad\":{},\"swapped\":{},\"none\":{}}},"
      "\"transactions\":{{\"total\":{},\"ok\":{},\"exception\":{},\"timeout\":{},\"broadcast\":{},"
      "\"unsolicited\":{}}},\"latency_ms\":{},\"anomalies_total\":{},\"anomalies\":{{{}}}}}",
      s.bytes, s.frames, s.noise_records, s.noise_bytes, c[1], c[2], c[3], c[0], s.transactions,
      o[0], o[1], o[2], o[3], o[4], latency, s.anomaly_total, anomalies);
  line.pop_back();  // the closing brace: drives follow
  line += ",\"drives\":[";
  for (std::size_t i = 0; i < s.drives.size(); ++i) {
    const DriveSummary& d = s.drives[i];
    line += fmt::format(
        "{}{{\"link\":{},\"address\":{},\"profile\":{},\"profile_name\":{},\"binding\":{},"
        "\"state\":{},\"events\":{}}}",
        i ? "," : "", d.link, d.address, json_quote(d.profile), json_quote(d.profile_name),
        json_quote(d.binding), json_quote(d.state), d.events);
  }
  line += "]";
  if (!s.source_notes.empty()) {
    line += ",\"source_notes\":[";
    for (std::size_t i = 0; i < s.source_notes.size(); ++i)
      line += (i ? "," : "") + json_quote(s.source_notes[i]);
    line += "]";
  }
  line += "}";
  write(line);
}

bool JsonSink::flush() {
  return std::fflush(out_) == 0 && !write_failed_ && !std::ferror(out_);
}

}  // namespace drivetap
