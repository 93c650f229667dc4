// Wireshark exported-PDU TLVs (LINKTYPE_WIRESHARK_UPPER_PDU), hand-written: see docs/design.md
// "Decisions worth knowing".
#include "formats/upper_pdu.hpp"

#include <fmt/format.h>

#include "core/cursor.hpp"

namespace drivetap::upper_pdu {
namespace {

// The TLV types drivetap writes and reads (EXP_PDU_TAG_*); any other is skipped when reading.
enum class TagType : std::uint16_t {
  end_of_options = 0,
  dissector_name = 12,
  source_port = 25,
  destination_port = 26,
  protocol_column = 33,
  p2p_direction = 35,
  info_column = 36,
};

void put16(std::vector<std::uint8_t>& out, std::uint16_t v) {
  out.push_back(static_cast<std::uint8_t>(v >> 8));
  out.push_back(static_cast<std::uint8_t>(v));
}

void put_tlv(std::vector<std::uint8_t>& out, TagType type, std::span<const std::uint8_t> value) {
  const std::size_t padded = (value.size() + 3) & ~std::size_t{3};
  put16(out, static_cast<std::uint16_t>(type));
  put16(out, static_cast<std::uint16_t>(padded));
  out.insert(out.end(), value.begin(), value.end());
  out.insert(out.end(), padded - value.size(), 0);
}

void put_string(std::vector<std::uint8_t>& out, TagType type, const std::string& s) {
  if (s.empty()) return;
  const std::size_t n = std::min<std::size_t>(s.size(), 0xFFF0);
  put_tlv(out, type, std::span(reinterpret_cast<const std::uint8_t*>(s.data()), n));
}

void put_u32(std::vector<std::uint8_t>& out, TagType type, std::optional<std::uint32_t> v) {
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
  put_string(out, TagType::dissector_name, tags.dissector);
  put_u32(out, TagType::source_port, tags.source_port);
  put_u32(out, TagType::destination_port, tags.destination_port);
  put_string(out, TagType::protocol_column, tags.protocol_column);
  put_u32(out, TagType::p2p_direction, tags.direction);
  put_string(out, TagType::info_column, tags.info_column);
  put_tlv(out, TagType::end_of_options, {});
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
    if (static_cast<TagType>(*type) == TagType::end_of_options) break;
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
    switch (static_cast<TagType>(*type)) {
      case TagType::dissector_name:
        p.tags.dissector = as_string(*value);
        break;
      case TagType::protocol_column:
        p.tags.protocol_column = as_string(*value);
        break;
      case TagType::info_column:
        p.tags.info_column = as_string(*value);
        break;
      case TagType::p2p_direction:
        p.tags.direction = u32();
        break;
      case TagType::source_port:
        p.tags.source_port = u32();
        break;
      case TagType::destination_port:
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
