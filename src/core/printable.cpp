// Untrusted text made safe to print (src/core/printable.hpp).
#include "core/printable.hpp"

#include <fmt/format.h>

#include <cstdint>

namespace drivetap {

std::size_t utf8_length(std::string_view text, std::size_t i, bool allow_c1) {
  const auto b = [&](std::size_t k) { return static_cast<unsigned char>(text[k]); };
  const unsigned char c = b(i);
  if (c < 0x80) return 1;
  std::size_t n = 0;
  std::uint32_t cp = 0;
  if (c >= 0xC2 && c <= 0xDF) {
    n = 2;
    cp = c & 0x1F;
  } else if (c >= 0xE0 && c <= 0xEF) {
    n = 3;
    cp = c & 0x0F;
  } else if (c >= 0xF0 && c <= 0xF4) {
    n = 4;
    cp = c & 0x07;
  } else {
    return 0;
  }
  if (i + n > text.size()) return 0;
  for (std::size_t k = 1; k < n; ++k) {
    if ((b(i + k) & 0xC0) != 0x80) return 0;
    cp = cp << 6 | (b(i + k) & 0x3F);
  }
  if ((n == 3 && cp < 0x800) || (n == 4 && (cp < 0x10000 || cp > 0x10FFFF))) return 0;
  if (cp >= 0xD800 && cp <= 0xDFFF) return 0;
  if (!allow_c1 && cp <= 0x9F) return 0;  // C1 controls (CSI 0x9B drives some terminals)
  return n;
}

namespace {

// Length of the printable character at text[i], or 0 when the byte there must be escaped.
std::size_t printable_length(std::string_view text, std::size_t i) {
  const auto c = static_cast<unsigned char>(text[i]);
  if (c < 0x80) return c >= 0x20 && c != 0x7F && c != '\\' ? 1 : 0;
  return utf8_length(text, i, /*allow_c1=*/false);
}

}  // namespace

std::string printable(std::string_view text, bool escape_backslash) {
  std::string out;
  out.reserve(text.size());
  for (std::size_t i = 0; i < text.size();) {
    const std::size_t n = printable_length(text, i);
    if (n > 0) {
      out.append(text.substr(i, n));
      i += n;
    } else if (text[i] == '\\') {
      out += escape_backslash ? "\\\\" : "\\";
      ++i;
    } else {
      fmt::format_to(std::back_inserter(out), "\\x{:02X}", static_cast<unsigned char>(text[i]));
      ++i;
    }
  }
  return out;
}

std::string printable_bounded(std::string_view text, std::size_t max_bytes) {
  std::string out = printable(text);
  if (out.size() <= max_bytes) return out;
  // FNV-1a of the original bytes: names that share their first bytes keep distinct texts.
  std::uint32_t hash = 2166136261u;
  for (const char c : text) hash = (hash ^ static_cast<unsigned char>(c)) * 16777619u;
  const std::string tail = fmt::format("…#{:08x}", hash);
  std::size_t keep = max_bytes > tail.size() ? max_bytes - tail.size() : 0;
  // Back to the start of a character (and not inside a \xNN or \\ escape).
  while (keep > 0 && (static_cast<unsigned char>(out[keep]) & 0xC0) == 0x80) --keep;
  for (std::size_t k = keep >= 3 ? keep - 3 : 0; k < keep; ++k)
    if (out[k] == '\\') {
      keep = k;
      break;
    }
  out.resize(keep);
  out += tail;
  return out;
}

}  // namespace drivetap
