// ANSI colours of the text output and of `diagnose` (--color): findings by severity, bad
// checksums, noise, events and verdicts. Only ever written to a terminal unless --color=always.
#pragma once

#include <string_view>

#include "core/anomaly.hpp"

namespace drivetap::color {

inline constexpr std::string_view kRed = "\x1b[31m";
inline constexpr std::string_view kYellow = "\x1b[33m";
inline constexpr std::string_view kGreen = "\x1b[32m";
inline constexpr std::string_view kCyan = "\x1b[36m";
inline constexpr std::string_view kReset = "\x1b[0m";

// A finding's colour: errors red, warnings yellow, notes cyan.
inline std::string_view of(Severity severity) {
  switch (severity) {
    case Severity::error:
      return kRed;
    case Severity::warning:
      return kYellow;
    case Severity::note:
      break;
  }
  return kCyan;
}

}  // namespace drivetap::color
