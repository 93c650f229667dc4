// A frame's drive values as the drive level read them, handed with the frame to the sinks, which
// spell them (src/drive/drive_fields.hpp): the `drive.*` record fields and the JSON `drive`
// object (docs/formats.md; the profiles of dissectors/profiles/README.md).
#pragma once

#include <cstdint>
#include <string_view>

namespace drivetap {

struct RegisterDef;  // drive/profile.hpp

// One value under its `drive.*` id (without the prefix): a register's raw value, a whole number
// or a text. It points into its drive profile (or static storage), which outlives the records.
struct DriveValue {
  enum class Kind : std::uint8_t { reg, integer, text };
  Kind kind = Kind::integer;
  bool double_word = false;          // reg: two registers' worth
  std::uint32_t raw = 0;             // reg: as the wire carries it
  std::int64_t integer = 0;          // integer
  std::string_view id;               // "output_frequency"
  const RegisterDef* reg = nullptr;  // reg
  std::string_view text;             // text
};

}  // namespace drivetap
