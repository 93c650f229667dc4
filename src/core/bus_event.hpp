// BusEvent: something drivetap concluded about the bus or a drive rather than about one frame —
// the protocol a channel speaks, the profile a station was bound to, and the drive-state timeline
// (start commanded, fault appeared, setpoint changed; dissectors/profiles/README.md).
#pragma once

#include <cstdint>
#include <iterator>
#include <string>
#include <string_view>

#include "core/byte_event.hpp"
#include "core/message.hpp"
#include "core/time.hpp"

namespace drivetap {

// What an event is about: detection and binding, then the drive-state kinds.
enum class EventKind : std::uint8_t {
  protocol_detected,
  drive_bound,
  command,
  running,
  direction,
  setpoint,
  fault,
  warning,
};

// The stable id of a kind, as in JSON `kind` ("protocol_detected", "drive_bound", "command",
// "running", "direction", "setpoint", "fault", "warning").
constexpr std::string_view event_kind_id(EventKind kind) {
  constexpr std::string_view kIds[] = {"protocol_detected", "drive_bound", "command", "running",
                                       "direction",         "setpoint",    "fault",   "warning"};
  const auto at = static_cast<std::size_t>(kind);
  return at < std::size(kIds) ? kIds[at] : std::string_view("unknown");
}

// A drive-state kind (the timeline's), not detection or binding.
constexpr bool is_drive_state(EventKind kind) {
  return kind != EventKind::protocol_detected && kind != EventKind::drive_bound;
}

struct BusEvent {
  TimeNs time = 0;
  ChannelId channel = 0;
  EventKind kind = EventKind::protocol_detected;
  Protocol protocol = Protocol::unknown;
  std::string confidence;  // "high", "medium", "low" (detection and binding)
  std::string detail;      // human text with the evidence: the line a field engineer reads
  // protocol_detected, no drive protocol: what the line carries instead ("56 bytes of printable
  // ASCII text"), the part of `detail` diagnosis names the line by.
  std::string carries;
  // Drive events: the station, its profile, the frame that showed it, and the state change.
  int address = -1;
  std::string profile;      // profile id ("e9"), "generic" when no family fits
  std::uint64_t frame = 0;  // frame number the event was read from; 0 when none
  std::string from, to;     // previous and new value ("" when unknown / not applicable)
  // fault: read from the status word's fault bit, not from a fault code.
  bool status_word = false;
  // drive_bound: the timing-rule findings made under the binding it ends, withdrawn with it.
  std::uint64_t withdrawn = 0;
};

}  // namespace drivetap
