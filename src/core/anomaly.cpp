// Names of anomaly kinds and protocol/direction ids (output contract of the JSON sink).
#include "core/anomaly.hpp"

#include <fmt/compile.h>
#include <fmt/format.h>

#include "core/message.hpp"

namespace drivetap {

const char* anomaly_id(AnomalyKind k) {
  switch (k) {
    case AnomalyKind::checksum_bad:
      return "checksum_bad";
    case AnomalyKind::checksum_swapped:
      return "checksum_swapped";
    case AnomalyKind::intra_frame_gap:
      return "intra_frame_gap";
    case AnomalyKind::short_interframe_gap:
      return "short_interframe_gap";
    case AnomalyKind::noise:
      return "noise";
    case AnomalyKind::malformed:
      return "malformed";
    case AnomalyKind::unanswered_request:
      return "unanswered_request";
    case AnomalyKind::unsolicited_response:
      return "unsolicited_response";
    case AnomalyKind::uart_framing:
      return "uart_framing";
    case AnomalyKind::uart_parity:
      return "uart_parity";
    case AnomalyKind::uart_break:
      return "uart_break";
    case AnomalyKind::uart_overrun:
      return "uart_overrun";
    case AnomalyKind::time_reversed:
      return "time_reversed";
    case AnomalyKind::packet_split_frame:
      return "packet_split_frame";
    case AnomalyKind::packet_merged_frames:
      return "packet_merged_frames";
    case AnomalyKind::timing_rule:
      return "timing_rule";
    case AnomalyKind::kCount:
      break;
  }
  return "unknown";
}

const char* anomaly_label(AnomalyKind k) {
  switch (k) {
    case AnomalyKind::checksum_bad:
      return "bad checksum";
    case AnomalyKind::checksum_swapped:
      return "byte-swapped CRC";
    case AnomalyKind::intra_frame_gap:
      return "gap inside frame";
    case AnomalyKind::short_interframe_gap:
      return "silence before frame < t3.5";
    case AnomalyKind::noise:
      return "noise bytes";
    case AnomalyKind::malformed:
      return "malformed frame";
    case AnomalyKind::unanswered_request:
      return "unanswered request";
    case AnomalyKind::unsolicited_response:
      return "unsolicited response";
    case AnomalyKind::uart_framing:
      return "UART framing error";
    case AnomalyKind::uart_parity:
      return "UART parity error";
    case AnomalyKind::uart_break:
      return "UART break";
    case AnomalyKind::uart_overrun:
      return "UART overrun";
    case AnomalyKind::time_reversed:
      return "timestamp went backwards";
    case AnomalyKind::packet_split_frame:
      return "frame split over packets";
    case AnomalyKind::packet_merged_frames:
      return "packet holds several frames";
    case AnomalyKind::timing_rule:
      return "drive timing rule broken";
    case AnomalyKind::kCount:
      break;
  }
  return "unknown";
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

std::string_view protocol_id(Protocol p) {
  switch (p) {
    case Protocol::modbus_rtu:
      return "modbus-rtu";
    case Protocol::modbus_ascii:
      return "modbus-ascii";
    case Protocol::danfoss_fc:
      return "danfoss-fc";
    case Protocol::easydrive:
      return "easydrive";
    case Protocol::unknown:
      break;
  }
  return "unknown";
}

std::string_view protocol_label(Protocol p) {
  switch (p) {
    case Protocol::modbus_rtu:
      return "Modbus RTU";
    case Protocol::modbus_ascii:
      return "Modbus ASCII";
    case Protocol::danfoss_fc:
      return "Danfoss FC";
    case Protocol::easydrive:
      return "Easydrive";
    case Protocol::unknown:
      break;
  }
  return "unknown";
}

std::string_view direction_id(Direction d) {
  switch (d) {
    case Direction::request:
      return "request";
    case Direction::response:
      return "response";
    case Direction::unknown:
      break;
  }
  return "unknown";
}

}  // namespace drivetap
