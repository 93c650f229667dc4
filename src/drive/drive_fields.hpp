// The drive layer's record fields (`drive.*`): each frame's drive values under stable names, for
// display filters, `-T fields` and the JSON record's `drive` object (docs/reference.md "Display
// filters", docs/formats.md; the profiles of dissectors/profiles/README.md).
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "core/message.hpp"
#include "drive/profile.hpp"

namespace drivetap {

// One drive value of a frame: `id` without the `drive.` prefix ("output_frequency"); a number
// (`value` in the profile's unit, `text` its JSON spelling, `raw` as the wire carries it when it
// has a register) or a string (`is_number` false, `text`).
struct DriveFieldValue {
  std::string id;
  bool is_number = true;
  double value = 0;
  std::string text;
  std::string unit;
  bool has_raw = false;
  std::uint32_t raw = 0;
};

// The drive values of `m` (read with Message::drive_read_with and Message::request), in a fixed
// order: station, family, the shared quantities, then the profile's registers in telegram order.
// Nothing when no profile read the frame. `out`'s storage is reused.
void drive_field_values(const Message& m, std::vector<DriveFieldValue>& out);

// The `drive.*` ids (without `drive.`) the given profiles can produce: the shared ones they have
// registers for, then their registers' own ids.
std::vector<std::string> drive_field_ids(std::span<const DriveProfile* const> profiles);
// What drive_field_values() gives under `id`: an integer, a number in a unit, or a text.
enum class DriveFieldKind : std::uint8_t { integer, number, text };
DriveFieldKind drive_field_kind(std::string_view id);

// Adds the `drive.*` source to the record fields (add_record_field_source), resolving the names
// the given profiles can produce. Once per process; the profiles must outlive it.
void add_drive_field_source(std::span<const DriveProfile* const> profiles);

}  // namespace drivetap
