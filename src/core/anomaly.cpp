// Anomaly kinds declared as data (id, label, severity) and direction ids (output contract of the
// JSON sink).
#include "core/anomaly.hpp"

#include <fmt/compile.h>
#include <fmt/format.h>

#include <iterator>

#include "core/enum_text.hpp"
#include "core/message.hpp"

namespace drivetap {

namespace {

// Every kind of finding, declared once: its id, its label and its severity, in AnomalyKind order.
struct AnomalyKindInfo {
  AnomalyKind kind;
  const char* id;
  const char* label;
  Severity severity;
};
constexpr AnomalyKindInfo kAnomalyKinds[] = {
    {AnomalyKind::checksum_bad, "checksum_bad", "bad checksum", Severity::error},
    {AnomalyKind::checksum_swapped, "checksum_swapped", "byte-swapped CRC", Severity::warning},
    {AnomalyKind::intra_frame_gap, "intra_frame_gap", "gap inside frame", Severity::warning},
    {AnomalyKind::short_interframe_gap, "short_interframe_gap", "silence before frame < t3.5",
     Severity::warning},
    {AnomalyKind::noise, "noise", "noise bytes", Severity::warning},
    {AnomalyKind::malformed, "malformed", "malformed frame", Severity::error},
    {AnomalyKind::implausible, "implausible", "not a telegram of its protocol", Severity::error},
    {AnomalyKind::unanswered_request, "unanswered_request", "unanswered request",
     Severity::warning},
    {AnomalyKind::unsolicited_response, "unsolicited_response", "unsolicited response",
     Severity::warning},
    {AnomalyKind::uart_framing, "uart_framing", "UART framing error", Severity::error},
    {AnomalyKind::uart_parity, "uart_parity", "UART parity error", Severity::error},
    {AnomalyKind::uart_break, "uart_break", "UART break", Severity::warning},
    {AnomalyKind::uart_overrun, "uart_overrun", "UART overrun", Severity::error},
    {AnomalyKind::time_reversed, "time_reversed", "timestamp went backwards", Severity::note},
    {AnomalyKind::packet_split_frame, "packet_split_frame", "frame split over packets",
     Severity::note},
    {AnomalyKind::packet_merged_frames, "packet_merged_frames", "packet holds several frames",
     Severity::note},
    {AnomalyKind::timing_rule, "timing_rule", "drive timing rule broken", Severity::warning},
};
static_assert(std::size(kAnomalyKinds) == kAnomalyKindCount, "one entry per AnomalyKind");
constexpr bool in_kind_order() {
  for (std::size_t k = 0; k < std::size(kAnomalyKinds); ++k)
    if (static_cast<std::size_t>(kAnomalyKinds[k].kind) != k) return false;
  return true;
}
static_assert(in_kind_order(), "kAnomalyKinds is indexed by AnomalyKind");

const AnomalyKindInfo* info_of(AnomalyKind k) {
  const auto i = static_cast<std::size_t>(k);
  return i < std::size(kAnomalyKinds) ? &kAnomalyKinds[i] : nullptr;
}

}  // namespace

const char* anomaly_id(AnomalyKind k) {
  const AnomalyKindInfo* info = info_of(k);
  return info ? info->id : "unknown";
}

const char* anomaly_label(AnomalyKind k) {
  const AnomalyKindInfo* info = info_of(k);
  return info ? info->label : "unknown";
}

Severity anomaly_severity(AnomalyKind k) {
  const AnomalyKindInfo* info = info_of(k);
  return info ? info->severity : Severity::error;
}

const char* severity_id(Severity s) {
  static constexpr const char* kSeverityIds[] = {"note", "warning", "error"};
  static_assert(std::size(kSeverityIds) == static_cast<std::size_t>(Severity::error) + 1);
  return enum_text(s, kSeverityIds, static_cast<const char*>("error"));
}

std::string noise_detail(const ByteEvents& events) {
  std::string hex;
  for (std::size_t i = 0; i < events.size() && i < 16; ++i)
    hex += fmt::format(FMT_COMPILE("{}{:02X}"), i ? " " : "", events[i].byte);
  if (events.size() > 16) hex += " ...";
  return fmt::format(FMT_COMPILE("{} byte{} outside any frame: {}"), events.size(),
                     events.size() == 1 ? "" : "s", hex);
}

void append_uart_anomalies(const ByteEvents& events, std::uint64_t frame_number,
                           std::vector<Anomaly>& out) {
  if (!events.any_flags()) return;  // the usual case: no look at each byte
  for (std::size_t i = 0; i < events.size(); ++i) {
    if (events.flags(i) == 0) continue;
    const ByteEvent e = events[i];
    auto add = [&](AnomalyKind kind, const char* what) {
      out.push_back({kind, e.time, e.channel, frame_number,
                     fmt::format(FMT_COMPILE("{} on byte {} (0x{:02X})"), what, i, e.byte)});
    };
    if (e.flags & kUartFramingError) add(AnomalyKind::uart_framing, "framing error");
    if (e.flags & kUartParityError) add(AnomalyKind::uart_parity, "parity error");
    if (e.flags & kUartBreak) add(AnomalyKind::uart_break, "break");
    if (e.flags & kUartOverrun) add(AnomalyKind::uart_overrun, "overrun (bytes lost before)");
  }
}

void add_checksum_anomaly(Message& m, std::string_view hint) {
  const ChecksumResult& c = m.checksum;
  if (c.verdict != ChecksumVerdict::bad && c.verdict != ChecksumVerdict::swapped) return;
  const char* separator = c.text ? "" : " ";
  const std::string stated = wire_hex(c.stated_wire, c.width, separator);
  const std::string computed = wire_hex(c.computed_wire, c.width, separator);
  Anomaly a{AnomalyKind::checksum_bad, m.frame.start(), m.frame.channel, 0, {}};
  if (c.verdict == ChecksumVerdict::bad) {
    a.detail =
        fmt::format(FMT_COMPILE("{} on wire {}, computed {}{}"), c.name, stated, computed, hint);
  } else if (c.verdict == ChecksumVerdict::swapped) {
    a.kind = AnomalyKind::checksum_swapped;
    a.detail = fmt::format(FMT_COMPILE("{} sent high byte first: on wire {}, expected {}{}"),
                           c.name, stated, computed, hint);
  } else {
    return;
  }
  m.anomalies.insert(m.anomalies.begin(), std::move(a));
}

std::string_view direction_id(Direction d) {
  static constexpr std::string_view kDirectionIds[] = {"unknown", "request", "response"};
  static_assert(std::size(kDirectionIds) == static_cast<std::size_t>(Direction::response) + 1);
  return enum_text(d, kDirectionIds, std::string_view{"unknown"});
}

namespace {

// Each timing rule's texts, in TimingRule order: what was measured, and the rule.
struct TimingRuleTexts {
  TimingRule rule;
  const char* measured;
  const char* limit;
};
constexpr TimingRuleTexts kTimingRuleTexts[] = {
    {TimingRule::none, "", ""},
    {TimingRule::silence_before_request, "{:.1f} characters of silence before the request",
     "the drive needs {:g}"},
    {TimingRule::request_after_reply, "request {:.1f} ms after the drive's last reply",
     "the drive needs {:g} ms"},
    {TimingRule::reply_too_soon, "reply {:.1f} ms after the request",
     "the drive keeps at least {:g} ms"},
    {TimingRule::reply_too_late, "reply {:.1f} ms after the request",
     "the drive answers within {:g} ms"},
};
static_assert(std::size(kTimingRuleTexts) ==
              static_cast<std::size_t>(TimingRule::reply_too_late) + 1);

const TimingRuleTexts& texts_of(TimingRule rule) {
  const auto at = static_cast<std::size_t>(rule);
  return at < std::size(kTimingRuleTexts) && kTimingRuleTexts[at].rule == rule
             ? kTimingRuleTexts[at]
             : kTimingRuleTexts[0];
}

}  // namespace

std::string timing_rule_text(const TimingBreak& b) {
  const TimingRuleTexts& t = texts_of(b.rule);
  if (t.rule == TimingRule::none) return {};
  std::string text = fmt::format(fmt::runtime(t.limit), b.limit);
  text += fmt::format(" ({}", b.profile);
  if (!b.section.empty()) text += fmt::format(", {}", b.section);
  text += ')';
  return text;
}

std::string timing_break_text(const TimingBreak& b) {
  const TimingRuleTexts& t = texts_of(b.rule);
  if (t.rule == TimingRule::none) return {};
  return fmt::format(fmt::runtime(t.measured), b.measured) + "; " + timing_rule_text(b);
}

}  // namespace drivetap
