// Small formatting helpers shared by the sinks.
#pragma once

#include <fmt/format.h>

#include <cstdint>
#include <span>
#include <string>

#include "core/time.hpp"

namespace drivetap {

// Seconds with `decimals` (<= 9) digits, exact (no floating point): 1.500000.
inline std::string format_seconds(TimeNs t, int decimals) {
  const bool negative = t < 0;
  const std::uint64_t a =
      negative ? static_cast<std::uint64_t>(-(t + 1)) + 1u : static_cast<std::uint64_t>(t);
  std::uint64_t frac = a % 1'000'000'000u;
  for (int i = decimals; i < 9; ++i) frac /= 10;
  if (decimals <= 0) return fmt::format("{}{}", negative ? "-" : "", a / 1'000'000'000u);
  return fmt::format("{}{}.{:0{}}", negative ? "-" : "", a / 1'000'000'000u, frac, decimals);
}

inline std::string format_ms(TimeNs t) {
  return fmt::format("{:.3f}", static_cast<double>(t) / static_cast<double>(kNsPerMs));
}

inline std::string hex_bytes(std::span<const std::uint8_t> bytes, const char* separator = " ") {
  std::string out;
  out.reserve(bytes.size() * 3);
  for (std::size_t i = 0; i < bytes.size(); ++i)
    fmt::format_to(std::back_inserter(out), "{}{:02X}", i ? separator : "", bytes[i]);
  return out;
}

}  // namespace drivetap
