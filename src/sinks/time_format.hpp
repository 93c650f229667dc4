// The time column of the text output and of `-T fields` (-t, as tshark's; docs/reference.md
// "Time formats"): one function formats a record's time in any of the formats.
#pragma once

#include <optional>
#include <string>
#include <string_view>

#include "core/byte_event.hpp"

namespace drivetap {

// tshark's -t formats.
enum class TimeFormat {
  relative,         // r: seconds since the capture's start (the default)
  absolute,         // a: local time of day, HH:MM:SS.ffffff
  absolute_date,    // ad: local date and time, YYYY-MM-DD HH:MM:SS.ffffff
  delta,            // d: seconds since the previous record captured
  delta_displayed,  // dd: seconds since the previous record displayed
  epoch,            // e: seconds since 1970-01-01 00:00:00 UTC
  utc,              // u: UTC time of day
  utc_date,         // ud: UTC date and time
};

// "r", "ad", ... as -t takes them; nullopt for anything else.
std::optional<TimeFormat> time_format_from_option(std::string_view option);
// The -t choices, for help texts and errors: "ad, a, r, d, dd, e, u, ud".
const char* time_format_choices();
// Whether the format needs the wall-clock time of the capture (a, ad, e, u, ud).
bool time_format_is_wall_clock(TimeFormat format);

// What a record's time is measured against. Times in the pipeline are the capture's own clock:
// nanoseconds since the Unix epoch for pcap, pcapng and live captures (`wall_clock`), seconds
// since its start for a byte log or a logic capture.
struct TimeReference {
  bool wall_clock = false;
  // The capture's start on its own clock: relative times count from it (0 for a capture whose
  // clock starts at its start; the first byte's time for a wall-clock one).
  TimeNs origin = 0;
  // The previous record captured and displayed (d, dd); -1: none yet.
  TimeNs previous_captured = -1;
  TimeNs previous_displayed = -1;
};

// The most characters format_time() writes ("-2562047788015215-..": a date of 26, a sign and
// twenty digits with 6 decimals).
inline constexpr std::size_t kMaxTimeChars = 40;

// `t` in `format` (6 decimals), written to `out` (room for kMaxTimeChars); returns the count
// written. A wall-clock format of a capture without a wall clock is written relative (the caller
// says so once). Local time honours TZ, as tshark's.
// t - since, held at the ends of TimeNs's range.
TimeNs time_since(TimeNs t, TimeNs since);
// The time a seconds format (r, d, dd, e) shows of `t`, in ns; nullopt for a calendar format.
std::optional<TimeNs> shown_seconds(TimeNs t, TimeFormat format, const TimeReference& reference);

std::size_t format_time(char* out, TimeNs t, TimeFormat format, const TimeReference& reference);
std::string format_time(TimeNs t, TimeFormat format, const TimeReference& reference);

}  // namespace drivetap
