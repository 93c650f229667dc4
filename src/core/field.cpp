// Formatting of generic field values for the text and JSON sinks.
#include "core/field.hpp"

#include <fmt/compile.h>
#include <fmt/format.h>

#include <algorithm>
#include <iterator>

#include "core/enum_text.hpp"

namespace drivetap {

std::string field_bytes_hex(const FieldNode& node, std::span<const std::uint8_t> frame,
                            bool text_encoded) {
  std::string out;
  append_field_bytes_hex(out, node, frame, text_encoded);
  return out;
}

// GCC 12 warns of an overlapping copy in the assignment of a short literal to `out` below, which
// cannot overlap (GCC bug 105329): the warning is quietened, the code left as it is.
#pragma GCC diagnostic push
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Wrestrict"
#endif
std::string format_field_value(const FieldTree& tree, const FieldNode& node,
                               std::span<const std::uint8_t> frame, bool text_encoded) {
  const FieldDesc& d = *node.desc;
  const std::string_view text = tree.text(node);
  std::string out;
  switch (d.type) {
    case FieldType::group:
      out = text;
      return out;
    case FieldType::uint:
    case FieldType::real:  // never in a tree: a record's number, held as an integer here
      out = fmt::format(FMT_COMPILE("{}"), node.value);
      break;
    case FieldType::hex:
      out = fmt::format(FMT_COMPILE("0x{:0{}X} ({})"), node.value, std::max(d.bits / 4, 1),
                        node.value);
      break;
    case FieldType::boolean:
      out = node.value ? "1" : "0";
      break;
    case FieldType::enumerated: {
      const std::string_view name = d.name_of(static_cast<std::uint32_t>(node.value));
      out = name.empty() ? fmt::format(FMT_COMPILE("{} (0x{:02X})"), node.value, node.value)
                         : fmt::format(FMT_COMPILE("{} ({})"), node.value, name);
      break;
    }
    case FieldType::bytes: {
      const std::string hex = field_bytes_hex(node, frame, text_encoded);
      for (std::size_t i = 0; i < hex.size(); i += 2)
        out += fmt::format(FMT_COMPILE("{}{}"), i ? " " : "", hex.substr(i, 2));
      if (node.length == 0) out = "(none)";
      break;
    }
    case FieldType::text:
      return std::string(text);
  }
  if (!text.empty()) out += fmt::format(FMT_COMPILE(" [{}]"), text);
  return out;
}
#pragma GCC diagnostic pop

namespace {

// Wireshark's name and display base of each FieldType, in FieldType order, as `tshark -G fields`
// prints them. A type named "" is an unsigned number whose name comes from its width
// (FT_UINT8/16/32); a base of "" is one Wireshark prints none for, "0" a flag's (the width of
// the bits it is a flag of: none).
struct WiresharkType {
  std::string_view type;
  std::string_view base;
};
constexpr WiresharkType kWiresharkTypes[] = {
    {"FT_NONE", ""},      // group
    {"", "BASE_DEC"},     // uint
    {"", "BASE_HEX"},     // hex
    {"FT_BOOLEAN", "0"},  // boolean
    {"", "BASE_DEC"},     // enumerated
    {"FT_BYTES", ""},     // bytes
    {"FT_STRING", ""},    // text
    {"FT_DOUBLE", ""},    // real
};
static_assert(std::size(kWiresharkTypes) == static_cast<std::size_t>(FieldType::real) + 1);

WiresharkType wireshark_type_of(FieldType t) {
  return enum_text(t, kWiresharkTypes, kWiresharkTypes[0]);
}

}  // namespace

std::string_view wireshark_field_type(const FieldDesc& d) {
  const std::string_view named = wireshark_type_of(d.type).type;
  if (!named.empty()) return named;
  return d.bits <= 8 ? "FT_UINT8" : d.bits <= 16 ? "FT_UINT16" : "FT_UINT32";
}

std::string_view wireshark_field_base(const FieldDesc& d) {
  return wireshark_type_of(d.type).base;
}

}  // namespace drivetap
