// Wireshark exported-PDU TLVs (LINKTYPE_WIRESHARK_UPPER_PDU), hand-written: see docs/design.md
// "Decisions worth knowing".
#include "formats/upper_pdu.hpp"

#include <fmt/format.h>

#include "core/cursor.hpp"

namespace drivetap::upper_pdu {
namespace {

void put16(std::vector<std::uint8_t>& out, std::uint16_t v) {
  out.push_back(static_cast<std::uint8_t>(v >> 8));
  out.push_back(static_cast<std::uint8_t>(v));
}

void put_tlv(std::vector<std::uint8_t>& out, std::uint16_t type,
             std::span<const std::uint8_t> value) {
  const std::size_t padded = (value.size() + 3) & ~std::size_t{3};
  put16(out, type);
  put16(out, static_cast<std::uint16_t>(padded));
  out.insert(out.end(), value.begin(), value.end());
  out.insert(out.end(), padded - value.size(), 0);
}

void put_string(std::vector<std::uint8_t>& out, std::uint16_t type, const std::string& s) {
  if (s.empty()) return;
  const std::size_t n = std::min<std::size_t>(s.size(), 0xFFF0);
  put_tlv(out, type, std::span(reinterpret_cast<const std::uint8_t*>(s.data()), n));
}

void put_u32(std::vector<std::uint8_t>& out, std::uint16_t type, std::optional<std::uint32_t> v) {
  if (!v) return;
  const std::uint8_t b[4] = {static_cast<std::uint8_t>(*v >> 24),
                             static_cast<std::uint8_t>(*v >> 16),
                             static_cast<std::uint8_t>(*v >> 8), static_cast<std::uint8_t>(*v)};
  put_tlv(out, type, b);
}

std::string_view as_string(std::span<const std::uint8_t> v) {
  std::size_t n = v.size();
  while (n > 0 && v[n - 1] == 0) --n;
  return {reinterpret_cast<const char*>(v.data()), n};
}

}  // namespace

void append_tags(const Tags& tags, std::vector<std::uint8_t>& out) {
  put_string(out, kDissectorName, tags.dissector);
  put_u32(out, kSourcePort, tags.source_port);
  put_u32(out, kDestinationPort, tags.destination_port);
  put_string(out, kProtocolColumn, tags.protocol_column);
  put_u32(out, kP2pDirection, tags.direction);
  put_string(out, kInfoColumn, tags.info_column);
  put16(out, kEndOfOptions);
  put16(out, 0);
}

std::optional<Parsed> parse_tags(std::span<const std::uint8_t> packet, std::string* error) {
  Cursor c(packet);
  Parsed p;
  // Each pass consumes at least the 4-byte TLV header, or returns.
  while (true) {
    const std::size_t at = c.offset();
    auto type = c.be16();
    auto length = c.be16();
    if (!type || !length) {
      *error = fmt::format("exported-PDU tag header truncated at packet offset {}", at);
      return std::nullopt;
    }
    if (*type == kEndOfOptions) break;
    auto value = c.take(*length);
    if (!value) {
      *error = fmt::format("exported-PDU tag {} at packet offset {} claims {} bytes, {} left",
                           *type, at, *length, c.remaining());
      return std::nullopt;
    }
    auto u32 = [&]() -> std::optional<std::uint32_t> {
      if (value->size() < 4) return std::nullopt;
      return (std::uint32_t{(*value)[0]} << 24) | (std::uint32_t{(*value)[1]} << 16) |
             (std::uint32_t{(*value)[2]} << 8) | (*value)[3];
    };
    switch (*type) {
      case kDissectorName:
        p.tags.dissector = as_string(*value);
        break;
      case kProtocolColumn:
        p.tags.protocol_column = as_string(*value);
        break;
      case kInfoColumn:
        p.tags.info_column = as_string(*value);
        break;
      case kP2pDirection:
        p.tags.direction = u32();
        break;
      case kSourcePort:
        p.tags.source_port = u32();
        break;
      case kDestinationPort:
        p.tags.destination_port = u32();
        break;
      default:
        break;  // tags we do not use
    }
  }
  p.payload_offset = c.offset();
  return p;
}

}  // namespace drivetap::upper_pdu
