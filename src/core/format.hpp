// Small formatting helpers shared by the sinks and the drive annotation.
#pragma once

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cstdint>
#include <cstring>
#include <iterator>
#include <span>
#include <string>
#include <string_view>

#include "core/byte_events.hpp"
#include "core/time.hpp"

namespace drivetap {

// The sinks build each output line by appending to one reused string: no temporary strings and
// no format-string parsing per frame on the paths taken for every frame. `Out` is std::string or
// core/line_buffer.hpp's LineBuffer (append(ptr, n), append(n, c), +=).

inline constexpr char kHexDigits[] = "0123456789ABCDEF";

// Two decimal digits per entry: "00", "01", .., "99" (a division by 100 gives two digits).
inline constexpr std::array<char, 200> kDigitPairs = [] {
  std::array<char, 200> pairs{};
  for (std::size_t i = 0; i < 100; ++i) {
    pairs[2 * i] = static_cast<char>('0' + i / 10);
    pairs[2 * i + 1] = static_cast<char>('0' + i % 10);
  }
  return pairs;
}();

// `n` more characters at the end of `out` for the caller to fill: LineBuffer's extend(), or a
// std::string grown by n.
template <class Out>
inline char* append_room(Out& out, std::size_t n) {
  if constexpr (requires { out.extend(n); }) {
    return out.extend(n);
  } else {
    const std::size_t at = out.size();
    out.resize(at + n);
    return out.data() + at;
  }
}

// Grows `out` by at most `most` characters that write(char* at) writes from `at` on, returning
// where it stopped: pieces of known greatest length written through a pointer, with no capacity
// check per piece (and no reload of the buffer's members after every character stored).
template <class Out, class Write>
inline void append_at_most(Out& out, std::size_t most, Write&& write) {
  char* const start = append_room(out, most);
  const char* const end = write(start);
  out.resize(static_cast<std::size_t>(end - out.data()));
}

// The lowest digits.size() decimal digits of v, zero-padded, into `digits`.
inline void write_decimal_digits(std::span<char> digits, std::uint64_t v) {
  std::size_t left = digits.size();
  // Every pass fills two places, right to left, with one two-byte copy (GCC -O3 splits a pass
  // that stores the two characters one by one into two loops, each dividing by 100 again).
  while (left >= 2) {
    const std::size_t pair = static_cast<std::size_t>(v % 100) * 2;
    v /= 100;
    left -= 2;
    std::memcpy(digits.subspan(left, 2).data(), &kDigitPairs[pair], 2);
  }
  if (left == 1) digits[0] = static_cast<char>('0' + v % 10);
}

// The number of decimal digits of v (1 for 0).
inline std::size_t decimal_digit_count(std::uint64_t v) {
  static constexpr std::array<std::uint64_t, 20> kPowersOfTen = [] {
    std::array<std::uint64_t, 20> powers{};
    std::uint64_t p = 1;
    for (std::uint64_t& power : powers) {
      power = p;
      p *= 10;  // (wraps after the last, unused)
    }
    return powers;
  }();
  // floor(log10(2^bits)) by 1233 / 4096 ~ log10(2): the count, or one more than it.
  // (v | 1: 0 has one digit; below 10^k, with k >= 1, exactly when v is.)
  const std::uint64_t w = v | 1u;
  const auto guess = static_cast<std::size_t>((std::bit_width(w) * 1233) >> 12);
  return guess + 1 - (w < kPowersOfTen[guess] ? 1 : 0);
}

// Digits are written where they belong, not formatted into a buffer and copied: a copy of 4 or 8
// bytes that reads characters just written 2 at a time stalls on store forwarding (fmt's
// format_int buffer copied into the line was an eighth of all the time JSON took, in perf).

// Numbers below 100 (addresses, function codes, counts, most register values) on a short path.
template <class Out>
inline void append_uint(Out& out, std::uint64_t v) {
  if (v < 10) {
    out += static_cast<char>('0' + v);
    return;
  }
  if (v < 100) {
    out.append(&kDigitPairs[2 * v], 2);
    return;
  }
  const std::size_t count = decimal_digit_count(v);
  write_decimal_digits(std::span<char>(append_room(out, count), count), v);
}

// `text` copied to `at`; returns the end. Short text (a channel's name) in two fixed-size moves
// that overlap, as LineBuffer::append() copies short pieces; longer text by memcpy. (The twin of
// that copy, not shared with it: moved into one function both call, it made GCC stop inlining
// append_uint into the Modbus info lines.)
inline char* write_chars(char* at, std::string_view text) {
  const std::size_t n = text.size();
  if (n >= 8 && n <= 16) {
    std::memcpy(at, text.data(), 8);
    std::memcpy(at + n - 8, text.data() + n - 8, 8);
  } else if (n >= 4 && n < 8) {
    std::memcpy(at, text.data(), 4);
    std::memcpy(at + n - 4, text.data() + n - 4, 4);
  } else {
    std::memcpy(at, text.data(), n);
  }
  return at + n;
}

template <class Out>
inline void append_int(Out& out, std::int64_t v) {
  if (v >= 0) return append_uint(out, static_cast<std::uint64_t>(v));
  const fmt::format_int digits(v);
  out.append(digits.data(), digits.size());
}

// '.' and the `decimals` (1..9) lowest decimal digits of `fraction`, zero-padded: ".050".
template <class Out>
inline void append_fraction(Out& out, std::uint64_t fraction, int decimals) {
  const auto count = static_cast<std::size_t>(decimals);
  const std::span<char> room(append_room(out, count + 1), count + 1);
  room[0] = '.';
  write_decimal_digits(room.subspan(1), fraction);
}

// |t| as whole seconds and the `decimals` (<= 9) leading digits of its fraction, truncated.
struct SecondsParts {
  bool negative;
  std::uint64_t whole;
  std::uint64_t fraction;
};
inline SecondsParts split_seconds(TimeNs t, int decimals) {
  const bool negative = t < 0;
  const std::uint64_t a =
      negative ? static_cast<std::uint64_t>(-(t + 1)) + 1u : static_cast<std::uint64_t>(t);
  std::uint64_t fraction = a % 1'000'000'000u;
  for (int i = decimals; i < 9; ++i) fraction /= 10;
  return {negative, a / 1'000'000'000u, fraction};
}

// Seconds with `decimals` (<= 9) digits, exact (no floating point): 1.500000.
template <class Out>
inline void append_seconds(Out& out, TimeNs t, int decimals) {
  const SecondsParts parts = split_seconds(t, decimals);
  if (parts.negative) out += '-';
  append_uint(out, parts.whole);
  if (decimals > 0) append_fraction(out, parts.fraction, decimals);
}

inline std::string format_seconds(TimeNs t, int decimals) {
  std::string s;
  append_seconds(s, t, decimals);
  return s;
}

// Milliseconds with 3 decimals, as "{:.3f}" of the double t / 1e6 prints them. Digits come from
// integers where that rounding is certain: t >= 0, not a tie (t % 1000 == 500, where the
// double's last bit decides) and below 2^50 ns (13 days; the double's error stays far below the
// 1 ns that separates t from a tie). Elsewhere the double is formatted.
template <class Out>
inline void append_ms(Out& out, TimeNs t) {
  if (t < 0 || t >= (TimeNs{1} << 50) || t % 1000 == 500) {
    fmt::format_to(std::back_inserter(out), "{:.3f}",
                   static_cast<double>(t) / static_cast<double>(kNsPerMs));
    return;
  }
  const auto us = static_cast<std::uint64_t>((t + 500) / 1000);
  append_uint(out, us / 1000);
  append_fraction(out, us % 1000, 3);
}

inline std::string format_ms(TimeNs t) {
  std::string s;
  append_ms(s, t);
  return s;
}

// "0x" and `raw` in upper-case hex, at least `width` digits ("0x000B" for 11, width 4): what
// "0x{:0NX}" prints with N = width, without the formatter (fmt::format_to grows and zero-fills
// a std::string per call).
template <class Out>
inline void append_hex(Out& out, std::uint32_t raw, int width) {
  int digits = width;
  while (digits < 8 && (raw >> (4 * digits)) != 0) ++digits;
  const auto count = static_cast<std::size_t>(digits);
  const std::span<char> room(append_room(out, count + 2), count + 2);  // one check, not one a digit
  room[0] = '0';
  room[1] = 'x';
  for (std::size_t i = 0; i < count; ++i)
    room[2 + i] = kHexDigits[(raw >> (4 * (count - 1 - i))) & 0xF];
}

template <class Out>
inline void append_hex_bytes(Out& out, std::span<const std::uint8_t> bytes,
                             std::string_view separator = " ") {
  for (std::size_t i = 0; i < bytes.size(); ++i) {
    if (i) out.append(separator);
    out += kHexDigits[bytes[i] >> 4];
    out += kHexDigits[bytes[i] & 0x0F];
  }
}

inline std::string hex_bytes(std::span<const std::uint8_t> bytes, const char* separator = " ") {
  std::string out;
  out.reserve(bytes.size() * 3);
  append_hex_bytes(out, bytes, separator);
  return out;
}

// The characters as sent, 3 hex digits each, where any carries a 9th data bit ("1A3 0F2");
// else empty (the bytes say it all).
inline std::string nine_bit_hex(const ByteEvents& events, const char* separator = " ") {
  if (!events.any_flags()) return {};
  bool any = false;
  for (std::size_t i = 0; i < events.size() && !any; ++i)
    any = (events.flags(i) & kUartNinthBit) != 0;
  if (!any) return {};
  std::string out;
  for (std::size_t i = 0; i < events.size(); ++i) {
    if (i) out += separator;
    out += (events.flags(i) & kUartNinthBit) ? '1' : '0';
    out += kHexDigits[events.byte(i) >> 4];
    out += kHexDigits[events.byte(i) & 0x0F];
  }
  return out;
}

}  // namespace drivetap
