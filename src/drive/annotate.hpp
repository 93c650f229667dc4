// Drive-level meaning of a decoded frame from the drive's profile (dissectors/profiles/README.md):
// the annotation line ("drive 2 (E-9): setpoint 50.00 Hz; output frequency 49.87 Hz") and what
// the frame says about the drive's state, for the timeline. The frame is read through its
// protocol's drive records (core/drive_records.hpp): registers, coils and parameters (under the
// profile's addressing rule), vendor exception codes, process data words, run commands, fault
// reports. A reply is read with the request it answers.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "core/format.hpp"
#include "core/line_buffer.hpp"
#include "core/message.hpp"
#include "drive/profile.hpp"
#include "drive/records.hpp"

namespace drivetap {

// A value as the drive's profile shows it: "50.00 Hz", "4 (overcurrent)". The text is made when
// asked for, from the register and its raw value: the timeline keeps a drive's telemetry from
// every poll but shows it only in the summary (made at every poll, the texts would dominate
// `read --stats` with drive profiles). A value that no register describes carries
// its text made (`written`: Easydrive's fault code). It points into its profile, which must
// outlive it and not change meanwhile (the pipeline's profiles outlive the pipeline).
struct Quantity {
  double value = 0;
  std::string written;
  const DriveProfile* profile = nullptr;  // with `reg`: what the text is made from
  const RegisterDef* reg = nullptr;
  std::uint32_t raw = 0;
  bool double_word = false;

  // The register's value (raw as the wire carries it; `double_word`: two registers' worth).
  static Quantity of(const DriveProfile& profile, const RegisterDef& reg, std::uint32_t raw,
                     bool double_word);
  // Back to a value of nothing, `written` keeping its storage. Member by member, the defaults
  // above: making it from Quantity{} and moving the string round it cost the hot path.
  void clear() {
    value = 0;
    written.clear();
    profile = nullptr;
    reg = nullptr;
    raw = 0;
    double_word = false;
  }
  void append_text(std::string& out) const;
  [[nodiscard]] std::string text() const;
  // Whether the two read the same: without making the texts when they are one register's same
  // raw value, or two plain numbers of one scale and unit (of a power of ten, or with the same
  // value).
  [[nodiscard]] bool same_text(const Quantity& other) const;
  bool operator==(const Quantity& other) const { return value == other.value && same_text(other); }
};

// A register's value as a frame carried it (raw as on the wire; `double_word`: two registers'
// worth).
struct RegisterValue {
  const RegisterDef* reg = nullptr;
  std::uint32_t raw = 0;
  bool double_word = false;
  bool operator==(const RegisterValue&) const = default;
};

// What one frame showed about its drive. Status fields come from the drive's replies; command
// fields from what the master wrote.
struct DriveObservation {
  std::optional<bool> running, reverse, fault_active, warning;
  std::optional<Quantity> setpoint, output_frequency, current, voltage;
  std::optional<std::uint32_t> fault_code;  // 0 = no fault
  Quantity fault;                           // with fault_code: "4 (overcurrent)"
  std::optional<bool> run_command, reverse_command;
  bool reset_command = false;
  std::optional<Quantity> setpoint_command;
  // Every register, coil and parameter value the frame carried that the profile names, written
  // or reported, in telegram order: the `drive.*` fields (drive/drive_fields.hpp).
  std::vector<RegisterValue> registers;

  // Back to nothing observed (every member as a new observation has it); the strings keep their
  // storage. Member by member: assigning a new observation cost the hot path. A member added above
  // must be reset here too (test_drive_level.cpp's ReadingIntoOneReadingIsReadingAfresh sets every
  // member, then clears).
  void clear() {
    running.reset();
    reverse.reset();
    fault_active.reset();
    warning.reset();
    setpoint.reset();
    output_frequency.reset();
    current.reset();
    voltage.reset();
    fault_code.reset();
    fault.clear();
    run_command.reset();
    reverse_command.reset();
    reset_command = false;
    setpoint_command.reset();
    registers.clear();
  }
  bool operator==(const DriveObservation&) const = default;
};

struct DriveReading {
  std::string text;  // "drive 2 (ERMAN E-9P/9G): ..." or empty when the profile says nothing
  DriveObservation observed;
  DriveRecordReader records;  // what the telegram said, as its decoder read it
  // Where the text is built, piece by piece with appends that stay inline (a reply's annotation
  // is some fifty pieces), before it is copied into `text` at once.
  LineBuffer line;
};

// `request`: for a reply, the bytes of its request (as on the wire), empty when unknown.
// `want_text` false: the observation only, no text (no sink shows it: `read --stats`; or the
// sink writes it on its own thread: complete_drive_info()). An exception reply the profile
// names still gets its "error 0x.." text.
DriveReading read_for_drive(const DriveProfile& profile, const Message& message,
                            std::span<const std::uint8_t> request, bool want_text = true);

// What read_for_drive_into() makes.
enum class DriveReadingWants : std::uint8_t {
  observation,           // as read_for_drive() with want_text false
  text_and_observation,  // as read_for_drive()
  // The text alone, for a sink writing the annotation of a frame whose observation the pipeline
  // made already (complete_drive_info()): the register roles are not applied, so `observed` is
  // not the frame's observation (it holds at most what the text needed of it) and must not be
  // read.
  text,
};
// read_for_drive() into `out`, whose strings keep their storage from one frame to the next (the
// pipeline reads every frame into one DriveReading).
void read_for_drive_into(const DriveProfile& profile, const TelegramHead& telegram,
                         std::span<const std::uint8_t> request, DriveReadingWants wants,
                         DriveReading& out);
// The same from the telegram's records read already (`records`, read with its request; then
// `out.records` is left as it is): the pipeline reads a telegram's records once for the binder
// and the annotation.
void read_for_drive_into(const DriveProfile& profile, const TelegramHead& telegram,
                         const DriveRecords& records, DriveReadingWants wants, DriveReading& out);
inline void read_for_drive_into(const DriveProfile& profile, const Message& message,
                                std::span<const std::uint8_t> request, DriveReadingWants wants,
                                DriveReading& out) {
  read_for_drive_into(profile, head_of(message), request, wants, out);
}

// Writes the annotation a pipeline left to its sink (Message::drive_profile): drive_info as
// read_for_drive() gives its text, from the message and its request's bytes; drive_profile is
// cleared. `scratch` lends its storage (the caller keeps one for every message). Nothing for a
// message without drive_profile.
void complete_drive_info(Message& message, DriveReading& scratch);

// One value as the profile describes it: "50.00 Hz", "0x0003 [running, forward]", "4
// (overcurrent)". `raw` holds 16 bits, or 32 for a two-word register or a double-word PWE.
std::string describe_value(const DriveProfile& profile, const RegisterDef& reg, std::uint32_t raw,
                           bool double_word = false);
// describe_value() appended to `out`.
void append_value(std::string& out, const DriveProfile& profile, const RegisterDef& reg,
                  std::uint32_t raw, bool double_word = false);

// The raw value as the register holds it: signed registers read as 16- or 32-bit two's
// complement.
inline std::int64_t register_raw_value(const RegisterDef& reg, std::uint32_t raw,
                                       bool double_word) {
  if (!reg.is_signed) return raw;
  return double_word ? static_cast<std::int32_t>(raw) : static_cast<std::int16_t>(raw & 0xFFFF);
}
// The number of decimals of `scale` when it is 1, 0.1, 0.01 ... 0.00001 (a scaled value is then
// an exact decimal, spelt from integers); -1 otherwise.
int decimal_scale_index(double scale);
// Decimals a value under `scale` is shown with, in the `=` line and every drive.* value: an exact
// decimal scale's (0.01 -> 2, 0.5 -> 1), else its resolution's, the fewest in which one step of
// the raw value shows (Danfoss's 100/16384 % -> 3).
int scale_decimals(double scale);
// `value` (a register's raw value, |value| < 2^32) under the scale 10^-decimals, decimals being
// decimal_scale_index() of the scale (0 to 5), into `at`: "-12.05"; returns the end. Exact, from
// integers: the text "{:.Nf}" prints of the double value * scale.
inline constexpr std::size_t kDecimalScaledChars = 17;  // '-', 10 digits, '.', 5 decimals
inline char* write_decimal_scaled(char* at, std::int64_t value, int decimals) {
  static constexpr std::uint64_t kPowersOfTen[] = {1, 10, 100, 1000, 10000, 100000};
  const std::uint64_t unit = kPowersOfTen[decimals];
  const auto magnitude = static_cast<std::uint64_t>(value < 0 ? -value : value);
  if (value < 0) *at++ = '-';
  const std::uint64_t whole = magnitude / unit;
  const std::size_t count = decimal_digit_count(whole);
  write_decimal_digits(std::span<char>(at, count), whole);
  at += count;
  if (decimals > 0) {
    *at++ = '.';
    const auto places = static_cast<std::size_t>(decimals);
    write_decimal_digits(std::span<char>(at, places), magnitude % unit);
    at += places;
  }
  return at;
}

// "16-13 frequency" for a parameter, the register's name otherwise.
std::string display_name(const RegisterDef& reg);

}  // namespace drivetap
