// Message: a frame decoded by a dissector — protocol, direction, field tree with byte spans and
// the checksum verdict. Dissectors fill it; they never print.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/anomaly.hpp"
#include "core/checksum.hpp"
#include "core/field.hpp"
#include "core/frame.hpp"

namespace drivetap {

enum class Protocol : std::uint8_t { unknown, modbus_rtu, modbus_ascii, danfoss_fc, easydrive };
enum class Direction : std::uint8_t { unknown, request, response };

const char* protocol_id(Protocol p);     // "modbus-rtu": JSON ids, stable
const char* protocol_label(Protocol p);  // "Modbus RTU": column text
const char* direction_id(Direction d);   // "request" / "response" / "unknown"

struct Message {
  Frame frame;
  std::vector<std::uint8_t> bytes;  // frame.events' bytes, for dissectors and sinks
  Protocol protocol = Protocol::unknown;
  Direction direction = Direction::unknown;
  int address = -1;   // station address, -1 when none
  int function = -1;  // function code as on the wire (with the exception bit), -1 when none
  bool is_exception = false;
  int exception_code = -1;
  ChecksumResult checksum;
  // The frame spells its bytes as hex text (Modbus ASCII): `bytes` fields show their characters.
  bool text_encoded = false;
  std::vector<FieldNode> fields;
  // The decode in one line, like Wireshark's Info column: "Read Holding Registers 0x0000 x4".
  std::string info;
  // What the frame means to its drive, from the bound drive profile; empty when none is bound.
  std::string drive_info;
  // Findings about this frame (checksum, gaps, malformed content, UART errors), in byte order.
  std::vector<Anomaly> anomalies;
  // Filled by the pairing stage on responses: request end -> response start, ns; -1 when
  // unpaired or not measurable (no silence visible before the reply).
  TimeNs latency = -1;
  std::uint64_t request_number = 0;  // frame number of the paired request
};

inline constexpr std::size_t kTypicalFieldCount = 16;

// What every dissector starts from: the frame, its bytes, protocol and direction.
inline Message begin_message(Frame frame, Protocol protocol, Direction direction) {
  Message m;
  m.frame = std::move(frame);
  m.bytes = m.frame.bytes();
  m.fields.reserve(kTypicalFieldCount);  // one allocation instead of a doubling series
  m.protocol = protocol;
  m.direction = direction;
  return m;
}

// A finding that the frame's length or content breaks its protocol's rules.
inline void add_malformed(Message& m, std::string detail) {
  m.anomalies.push_back(
      {AnomalyKind::malformed, m.frame.start(), m.frame.channel, 0, std::move(detail)});
}

// Puts the finding for a bad or byte-swapped checksum first among the message's anomalies:
// "CRC on wire DA 27, computed DA 26" (+ `hint`); nothing for a good or absent checksum.
void add_checksum_anomaly(Message& m, std::string_view hint = {});

}  // namespace drivetap
