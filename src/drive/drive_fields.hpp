// The drive layer's record fields (`drive.*`): each frame's drive values under stable names, for
// display filters, `-T fields` and the JSON record's `drive` object (docs/reference.md "Display
// filters", docs/formats.md; the profiles of dissectors/profiles/README.md).
#pragma once

#include <cstddef>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "core/drive_values.hpp"
#include "drive/annotate.hpp"
#include "drive/profile.hpp"

namespace drivetap {

// The drive values of a frame of `station` (its address, -1 when none) that `profile` read into
// `observed` (read_for_drive_into() with the observation), unspelt, in a fixed order: station,
// family, the shared quantities, then the profile's registers in telegram order. The pipeline
// hands them with the frame (Message::drive_values): no sink reads the frame again. `out` is
// appended to.
void collect_drive_values(const DriveProfile& profile, int station,
                          const DriveObservation& observed, std::vector<DriveValue>& out);

// complete_drive_info() of a message whose drive values are still to collect: the reading that
// writes the annotation, with its observation, also gives them (collect_drive_values() of the
// message's station), as the pipeline's reading would have. Nothing for a message without
// drive_profile.
void complete_drive_info_and_values(Message& message, DriveReading& scratch);

// Whether `id` is one of the names every family shares ("setpoint", "status_word"; the order
// collect_drive_values() gives them in).
bool is_shared_drive_field_id(std::string_view id);

// The shared id a role's value goes under, by its unit: drive.setpoint in Hz, drive.setpoint_pct in
// % (of the reference); drive.output_current in A, drive.output_voltage in V. Empty for a role of
// no quantity.
std::string_view role_value_id(RegisterRole role, std::string_view unit);
// Why a role's register cannot be in `unit` ("role setpoint is in Hz (drive.setpoint) or %
// (drive.setpoint_pct), not 'rpm'"); empty when it can (or the role is of no quantity).
std::string role_unit_rule(RegisterRole role, std::string_view unit);
// The one unit of a `drive.*` id (without `drive.`), as `drivetap fields` and
// `-e drive.<id>.unit` give it: a shared id's, or a register's in the first profile that has it;
// empty for none (a code, a word, a text).
std::string_view drive_field_unit(std::span<const DriveProfile* const> profiles,
                                  std::string_view id);

// The most characters drive_value_text() writes of a number.
inline constexpr std::size_t kDriveNumberChars = 400;

// A value's text as the JSON record and the fields show it: a number's digits (a register's value
// in the profile's unit, with the decimals its scale shows) or the text itself. A number's text
// is written into `buffer`.
std::string_view drive_value_text(const DriveValue& value,
                                  std::span<char, kDriveNumberChars> buffer);

// The `drive.*` ids (without `drive.`) the given profiles can produce: the shared ones they have
// registers for, then their registers' own ids.
std::vector<std::string> drive_field_ids(std::span<const DriveProfile* const> profiles);
// What drive_field_values() gives under `id`: an integer, a number in a unit, or a text.
enum class DriveFieldKind : std::uint8_t { integer, number, text };
DriveFieldKind drive_field_kind(std::string_view id);

// A `drive.*` id as `drivetap fields` and the Wireshark plugin list it (without `drive.`).
struct DriveFieldListing {
  std::string id;
  std::string name;  // "Output frequency", or the register's name in its profile
  DriveFieldKind kind = DriveFieldKind::number;
  std::string blurb;  // where the value comes from
  std::string unit;   // its one unit (drive_field_unit), empty for none
  // As `tshark -G fields` types it: FT_STRING, FT_UINT32 (a raw word in BASE_HEX, other
  // integers BASE_DEC) or FT_DOUBLE; base "" for none.
  std::string_view wireshark_type;
  std::string_view wireshark_base;
};
// Its name with its unit, as `drivetap fields` and Wireshark show it: "Output frequency [Hz]" (the
// name alone when it has no unit or already ends with it).
std::string drive_field_label(const DriveFieldListing& f);
// drive_field_ids() with a name and a description each, in the same order.
std::vector<DriveFieldListing> drive_field_listing(std::span<const DriveProfile* const> profiles);

// Adds the `drive.*` source to the record fields (add_record_field_source), resolving the names
// the given profiles can produce. Once per process; the profiles must outlive it.
void add_drive_field_source(std::span<const DriveProfile* const> profiles);

}  // namespace drivetap
