// Formatting of generic field values for the text and JSON sinks.
#include "core/field.hpp"

#include <fmt/compile.h>
#include <fmt/format.h>

namespace drivetap {

std::string field_bytes_hex(const FieldNode& node, std::span<const std::uint8_t> frame,
                            bool text_encoded) {
  std::string out;
  append_field_bytes_hex(out, node, frame, text_encoded);
  return out;
}

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
      out = fmt::format(FMT_COMPILE("{}"), node.value);
      break;
    case FieldType::hex:
      out = fmt::format(FMT_COMPILE("0x{:0{}X} ({})"), node.value, d.hex_digits, node.value);
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

}  // namespace drivetap
