// CRC-16/MODBUS, table driven (PROTOCOLS.md §2).
#include "core/checksum.hpp"

#include <fmt/format.h>

#include <array>

namespace drivetap {
namespace {

constexpr std::array<std::uint16_t, 256> make_crc_table() {
  std::array<std::uint16_t, 256> table{};
  for (unsigned i = 0; i < 256; ++i) {
    std::uint16_t crc = static_cast<std::uint16_t>(i);
    for (int bit = 0; bit < 8; ++bit)
      crc = (crc & 1u) ? static_cast<std::uint16_t>((crc >> 1) ^ 0xA001u)
                       : static_cast<std::uint16_t>(crc >> 1);
    table[i] = crc;
  }
  return table;
}

constexpr auto kCrcTable = make_crc_table();

}  // namespace

std::uint16_t crc16_modbus_update(std::uint16_t crc, std::uint8_t byte) {
  return static_cast<std::uint16_t>((crc >> 8) ^ kCrcTable[(crc ^ byte) & 0xFFu]);
}

std::uint16_t crc16_modbus(std::span<const std::uint8_t> data, std::uint16_t crc) {
  for (const std::uint8_t b : data) crc = crc16_modbus_update(crc, b);
  return crc;
}

std::uint8_t lrc8(std::span<const std::uint8_t> data) {
  std::uint8_t sum = 0;
  for (const std::uint8_t b : data) sum = static_cast<std::uint8_t>(sum + b);
  return static_cast<std::uint8_t>(-sum);
}

ChecksumResult check_rtu_crc(std::span<const std::uint8_t> frame) {
  ChecksumResult r;
  if (frame.size() < 3) return r;
  const std::uint16_t crc = crc16_modbus(frame.first(frame.size() - 2));
  const std::uint8_t lo = frame[frame.size() - 2];
  const std::uint8_t hi = frame[frame.size() - 1];
  r.width = 2;
  r.stated_wire = static_cast<std::uint32_t>((lo << 8) | hi);
  r.computed_wire = static_cast<std::uint32_t>(((crc & 0xFFu) << 8) | (crc >> 8));
  if (r.stated_wire == r.computed_wire) {
    r.verdict = ChecksumVerdict::good;
  } else if (r.stated_wire == (((r.computed_wire & 0xFFu) << 8) | (r.computed_wire >> 8))) {
    r.verdict = ChecksumVerdict::swapped;
  } else {
    r.verdict = ChecksumVerdict::bad;
  }
  return r;
}

std::string wire_hex(std::uint32_t packed, std::uint8_t width, const char* separator) {
  std::string out;
  for (int i = width - 1; i >= 0; --i)
    out += fmt::format("{}{:02X}", i == width - 1 ? "" : separator, (packed >> (8 * i)) & 0xFF);
  return out;
}

const char* to_string(ChecksumVerdict v) {
  switch (v) {
    case ChecksumVerdict::none:
      return "none";
    case ChecksumVerdict::good:
      return "good";
    case ChecksumVerdict::bad:
      return "bad";
    case ChecksumVerdict::swapped:
      return "swapped";
  }
  return "none";
}

}  // namespace drivetap
