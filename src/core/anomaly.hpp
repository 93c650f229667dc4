// Anomalies: typed, counted findings about the bus — never exceptions (docs/protocols.md §1, §6).
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "core/byte_event.hpp"
#include "core/byte_events.hpp"
#include "core/time.hpp"

namespace drivetap {

enum class AnomalyKind : std::uint8_t {
  checksum_bad,          // checksum does not match
  checksum_swapped,      // valid CRC sent high byte first
  intra_frame_gap,       // silence > t1.5 between two bytes of one frame
  short_interframe_gap,  // visible silence before a frame shorter than t3.5
  noise,                 // bytes that fit no frame
  malformed,             // length or field content that breaks the protocol's rules
  implausible,           // breaks a plausibility rule: not a telegram of its protocol at all
  unanswered_request,    // no reply within the timeout (or before the next request)
  unsolicited_response,  // a reply with no matching request
  uart_framing,          // UART framing error on a byte
  uart_parity,           // UART parity error on a byte
  uart_break,            // line held low for longer than a character
  uart_overrun,          // receiver overrun: bytes were lost before this one
  time_reversed,         // a byte's timestamp is earlier than the previous byte's
  packet_split_frame,    // a capture packet held only part of a frame (source framed badly)
  packet_merged_frames,  // a capture packet held more than one frame (source framed badly)
  timing_rule,           // a drive's timing rule (from its profile) was broken
  kCount
};

inline constexpr std::size_t kAnomalyKindCount = static_cast<std::size_t>(AnomalyKind::kCount);

// How much a finding weighs, as Wireshark's expert info does: `error` means the frame or the
// line is wrong (a bad checksum, a telegram that cannot be one), `warning` that a rule of timing
// or conversation is broken, `note` that the capture tool, not the bus, did something odd.
enum class Severity : std::uint8_t { note, warning, error };

const char* anomaly_id(AnomalyKind k);     // stable snake_case id, as in JSON `kind`
const char* anomaly_label(AnomalyKind k);  // short human text
Severity anomaly_severity(AnomalyKind k);  // declared with the kind (anomaly.cpp)
const char* severity_id(Severity s);       // "note" / "warning" / "error", as in JSON

// A finding a protocol declares, as Wireshark's expert infos (ei[]): a stable dotted id
// ("mbrtu.length_short"), its severity, the generic kind it counts under (the JSON `kind`) and the
// template of its detail text. Each protocol lists its own beside its fields
// (dissectors/<protocol>/, ProtocolDesc::findings).
struct FindingDesc {
  const char* id;
  AnomalyKind kind;
  Severity severity;
  std::string_view text;  // fmt template of the detail
};

// A drive timing rule a telegram broke, typed (pipeline check_drive_timing; the profile's
// limits): diagnosis groups and fixes the breaks by the rule, never by the wording.
enum class TimingRule : std::uint8_t {
  none,
  silence_before_request,  // characters of silence before a request, under the drive's minimum
  request_after_reply,     // ms from the drive's last reply to the next request, under its minimum
  reply_too_soon,          // a reply's latency under the drive's minimum delay
  reply_too_late,          // a reply's latency over the drive's maximum
};

struct TimingBreak {
  TimingRule rule = TimingRule::none;
  double measured = 0;  // characters (silence_before_request) or ms
  double limit = 0;     // in the same unit
  // The rule's source: the profile's name and its manual's section (views into the profile,
  // which outlives the run's findings).
  std::string_view profile, section;
};

// "the drive keeps at least 10 ms (E5-8200, 000 §5.2)": the rule and where it is stated.
std::string timing_rule_text(const TimingBreak& b);
// "reply 3.8 ms after the request; the drive keeps at least 10 ms (E5-8200, 000 §5.2)".
std::string timing_break_text(const TimingBreak& b);

struct Anomaly {
  AnomalyKind kind = AnomalyKind::malformed;
  TimeNs time = 0;
  ChannelId channel = 0;
  std::uint64_t frame_number = 0;  // frame it belongs to, 0 when none
  std::string detail;
  const FindingDesc* finding = nullptr;  // the protocol's own finding, nullptr for a generic one
  // The station it concerns, for a finding handed on after the frame it belongs to (held with
  // its drive's binding); -1: the station of the frame it follows, or none.
  int address = -1;
  TimingBreak timing{};  // timing_rule: which rule, by how much
};

using AnomalyCounts = std::array<std::uint64_t, kAnomalyKindCount>;

// The detail of the `noise` finding of a noise record: "3 bytes outside any frame: 01 02 03".
std::string noise_detail(const ByteEvents& events);

// One anomaly per UART mark on `events` (framing, parity, break, overrun), naming the byte.
void append_uart_anomalies(const ByteEvents& events, std::uint64_t frame_number,
                           std::vector<Anomaly>& out);

}  // namespace drivetap
