// The time column in tshark's -t formats (src/sinks/time_format.hpp).
#include "sinks/time_format.hpp"

#include <ctime>
#include <iterator>
#include <limits>

#include <fmt/format.h>

#include "core/format.hpp"

namespace drivetap {
namespace {

struct FormatName {
  std::string_view option;
  TimeFormat format;
};
// In tshark's order (`tshark -h`).
constexpr FormatName kFormatNames[] = {
    {"ad", TimeFormat::absolute_date},
    {"a", TimeFormat::absolute},
    {"r", TimeFormat::relative},
    {"d", TimeFormat::delta},
    {"dd", TimeFormat::delta_displayed},
    {"e", TimeFormat::epoch},
    {"u", TimeFormat::utc},
    {"ud", TimeFormat::utc_date},
};

// Seconds with 6 decimals ("-0.000123", "12.345678").
std::size_t write_seconds(char* out, TimeNs t) {
  const SecondsParts parts = split_seconds(t, 6);
  const auto end =
      fmt::format_to(out, "{}{}.{:06}", parts.negative ? "-" : "", parts.whole, parts.fraction);
  return static_cast<std::size_t>(end - out);
}

// A calendar time, local or UTC, with or without the date. Microseconds are truncated as tshark
// does; a time before the epoch borrows a second.
std::size_t write_calendar(char* out, TimeNs t, bool utc, bool date) {
  std::int64_t seconds = t / kNsPerSecond;
  std::int64_t micros = (t % kNsPerSecond) / 1000;
  if (micros < 0) {
    micros += 1'000'000;
    --seconds;
  }
  const auto when = static_cast<std::time_t>(seconds);
  std::tm tm{};
  const bool ok = utc ? gmtime_r(&when, &tm) != nullptr : localtime_r(&when, &tm) != nullptr;
  if (!ok) return write_seconds(out, t);  // beyond what a calendar year holds
  char* end = out;
  if (date)
    end = fmt::format_to(end, "{:04}-{:02}-{:02} ", tm.tm_year + 1900, tm.tm_mon + 1, tm.tm_mday);
  end = fmt::format_to(end, "{:02}:{:02}:{:02}.{:06}", tm.tm_hour, tm.tm_min, tm.tm_sec, micros);
  return static_cast<std::size_t>(end - out);
}

// a - b, held at the ends of the range (times of a damaged capture may be anywhere in it).
TimeNs difference(TimeNs a, TimeNs b) {
  TimeNs d = 0;
  if (!__builtin_sub_overflow(a, b, &d)) return d;
  return a < b ? std::numeric_limits<TimeNs>::min() : std::numeric_limits<TimeNs>::max();
}

}  // namespace

TimeNs time_since(TimeNs t, TimeNs since) {
  return difference(t, since);
}

std::optional<TimeFormat> time_format_from_option(std::string_view option) {
  for (const FormatName& n : kFormatNames)
    if (n.option == option) return n.format;
  return std::nullopt;
}

const char* time_format_choices() {
  return "ad, a, r, d, dd, e, u, ud";
}

bool time_format_is_wall_clock(TimeFormat format) {
  return format == TimeFormat::absolute || format == TimeFormat::absolute_date ||
         format == TimeFormat::epoch || format == TimeFormat::utc || format == TimeFormat::utc_date;
}

std::optional<TimeNs> shown_seconds(TimeNs t, TimeFormat format, const TimeReference& reference) {
  if (time_format_is_wall_clock(format) && !reference.wall_clock) format = TimeFormat::relative;
  switch (format) {
    case TimeFormat::relative:
      return difference(t, reference.origin);
    case TimeFormat::delta:
      return reference.previous_captured < 0 ? 0 : difference(t, reference.previous_captured);
    case TimeFormat::delta_displayed:
      return reference.previous_displayed < 0 ? 0 : difference(t, reference.previous_displayed);
    case TimeFormat::epoch:
      return t;
    case TimeFormat::absolute:
    case TimeFormat::absolute_date:
    case TimeFormat::utc:
    case TimeFormat::utc_date:
      break;
  }
  return std::nullopt;
}

std::size_t format_time(char* out, TimeNs t, TimeFormat format, const TimeReference& reference) {
  if (const std::optional<TimeNs> seconds = shown_seconds(t, format, reference))
    return write_seconds(out, *seconds);
  const bool utc = format == TimeFormat::utc || format == TimeFormat::utc_date;
  const bool date = format == TimeFormat::absolute_date || format == TimeFormat::utc_date;
  return write_calendar(out, t, utc, date);
}

std::string format_time(TimeNs t, TimeFormat format, const TimeReference& reference) {
  char buffer[kMaxTimeChars];
  return std::string(buffer, format_time(buffer, t, format, reference));
}

}  // namespace drivetap
