// Wireshark "exported PDU" TLVs: the link-layer header of LINKTYPE_WIRESHARK_UPPER_PDU (252).
// (Wireshark epan/exported_pdu_tlvs.h.) Each TLV: type (2, big-endian), length (2, big-endian),
// value padded with zero bytes to a multiple of 4; the list ends with type 0, length 0.
//
//   +--------+--------+----------------------+ ... +--------+--------+------------------+
//   | type   | length | value (padded to 4)  |     |   0    |   0    | payload (frame)  |
//   +--------+--------+----------------------+ ... +--------+--------+------------------+
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace drivetap::upper_pdu {

inline constexpr std::uint32_t kDirectionSent = 0;      // P2P_DIR_SENT: master -> slave
inline constexpr std::uint32_t kDirectionReceived = 1;  // P2P_DIR_RECV: slave -> master

struct Tags {
  std::string dissector;        // "mbrtu", "data"
  std::string protocol_column;  // COL_PROTOCOL text
  std::string info_column;      // COL_INFO text
  std::optional<std::uint32_t> direction;
  std::optional<std::uint32_t> source_port;
  std::optional<std::uint32_t> destination_port;
};

// Appends the TLVs of `tags` and the end marker to `out`.
void append_tags(const Tags& tags, std::vector<std::uint8_t>& out);

// Parses the TLVs at the start of `packet`. Returns the tags and the payload offset, or nullopt
// with *error naming the offset inside the packet.
// Tags as read from a packet: the strings are views into the packet (no copies on the read
// path), trailing NUL padding removed.
struct TagView {
  std::string_view dissector;
  std::string_view protocol_column;
  std::string_view info_column;
  std::optional<std::uint32_t> direction;
  std::optional<std::uint32_t> source_port;
  std::optional<std::uint32_t> destination_port;
};

struct Parsed {
  TagView tags;
  std::size_t payload_offset = 0;
};
std::optional<Parsed> parse_tags(std::span<const std::uint8_t> packet, std::string* error);

}  // namespace drivetap::upper_pdu
