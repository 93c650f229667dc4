// SerialConfig parsing and formatting (docs/protocols.md §1 line settings).
#include "core/serial_config.hpp"

#include <fmt/format.h>

#include <cctype>
#include <charconv>
#include <cmath>

namespace drivetap {
namespace {

bool is_space_or_comma(char c) {
  return c == ' ' || c == '\t' || c == ',';
}

std::string_view trim(std::string_view s) {
  while (!s.empty() && is_space_or_comma(s.front())) s.remove_prefix(1);
  while (!s.empty() && is_space_or_comma(s.back())) s.remove_suffix(1);
  return s;
}

bool parse_uint(std::string_view s, std::uint32_t* out) {
  if (s.empty()) return false;
  auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), *out);
  return ec == std::errc{} && ptr == s.data() + s.size();
}

bool parse_format(std::string_view s, SerialConfig* cfg) {
  if (s.size() != 3) return false;
  if (s[0] < '5' || s[0] > '9') return false;  // 9: logic captures only (a tty has no 9th bit)
  cfg->data_bits = static_cast<std::uint8_t>(s[0] - '0');
  switch (s[1]) {
    case 'N':
    case 'n':
      cfg->parity = Parity::none;
      break;
    case 'E':
    case 'e':
      cfg->parity = Parity::even;
      break;
    case 'O':
    case 'o':
      cfg->parity = Parity::odd;
      break;
    default:
      return false;
  }
  if (s[2] != '1' && s[2] != '2') return false;
  cfg->stop_bits = static_cast<std::uint8_t>(s[2] - '0');
  return true;
}

}  // namespace

std::string SerialConfig::to_string() const {
  const char parity_letter = parity == Parity::none ? 'N' : parity == Parity::even ? 'E' : 'O';
  return fmt::format("{} {}{}{}", baud, data_bits, parity_letter, stop_bits);
}

std::optional<SerialConfig> SerialConfig::parse(std::string_view text, std::string* error,
                                                const SerialConfig& base) {
  SerialConfig cfg = base;
  std::string_view rest = trim(text);
  if (rest.empty()) {
    *error = "empty serial settings (expected e.g. \"19200 8E1\")";
    return std::nullopt;
  }
  bool saw_baud = false;
  bool saw_format = false;
  while (!rest.empty()) {
    std::size_t end = 0;
    while (end < rest.size() && !is_space_or_comma(rest[end])) ++end;
    const std::string_view token = rest.substr(0, end);
    rest = trim(rest.substr(end));
    std::uint32_t baud = 0;
    if (!saw_baud && parse_uint(token, &baud)) {
      if (baud < 50 || baud > 4'000'000) {
        *error = fmt::format("baud rate {} out of range (50..4000000)", baud);
        return std::nullopt;
      }
      cfg.baud = baud;
      saw_baud = true;
    } else if (!saw_format && parse_format(token, &cfg)) {
      saw_format = true;
    } else {
      *error = fmt::format("bad serial setting '{}' in \"{}\" (expected e.g. \"19200 8E1\")", token,
                           text);
      return std::nullopt;
    }
  }
  return cfg;
}

std::optional<SerialConfig> SerialConfig::parse(std::string_view text, std::string* error) {
  return parse(text, error, SerialConfig{});
}

std::optional<TimeNs> parse_interval(std::string_view text, TimeNs character_time,
                                     std::string* error) {
  std::string_view s = trim(text);
  std::size_t digits = 0;
  while (digits < s.size() &&
         (std::isdigit(static_cast<unsigned char>(s[digits])) || s[digits] == '.'))
    ++digits;
  const std::string number(s.substr(0, digits));
  const std::string_view unit = s.substr(digits);
  double value = 0;
  auto [ptr, ec] = std::from_chars(number.data(), number.data() + number.size(), value);
  if (number.empty() || ec != std::errc{} || ptr != number.data() + number.size() || value < 0) {
    *error = fmt::format("bad interval '{}' (expected e.g. 3.5c, 1750us, 2ms)", text);
    return std::nullopt;
  }
  double ns = 0;
  if (unit.empty() || unit == "c" || unit == "chars" || unit == "char") {
    ns = value * static_cast<double>(character_time);
  } else if (unit == "us") {
    ns = value * kNsPerUs;
  } else if (unit == "ms") {
    ns = value * kNsPerMs;
  } else if (unit == "s") {
    ns = value * kNsPerSecond;
  } else {
    *error = fmt::format("bad unit '{}' in interval '{}' (use c, us, ms or s)", unit, text);
    return std::nullopt;
  }
  if (ns > static_cast<double>(kMaxInterval)) {
    *error = fmt::format("interval '{}' is longer than the 1 h limit", text);
    return std::nullopt;
  }
  return static_cast<TimeNs>(std::llround(ns));
}

}  // namespace drivetap
