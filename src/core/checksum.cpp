// CRC-16/MODBUS, table driven (docs/protocols.md §2): slicing-by-16 for whole buffers, by-4 for
// short tails, one table step per byte for the incremental update and the last bytes.
#include "core/checksum.hpp"

#include <fmt/format.h>

#include <array>
#include <cstddef>
#include <iterator>

#include "core/enum_text.hpp"

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

// Slicing-by-16: kSlices[k][b] is the CRC register after byte b followed by k zero bytes (from a
// zero register), so 16 bytes are folded in with 16 independent lookups instead of a chain of 16
// dependent ones. 16 tables of 256 entries, 8 KiB: they stay in L1.
constexpr std::size_t kSlicing = 16;
using SliceTables = std::array<std::array<std::uint16_t, 256>, kSlicing>;

constexpr SliceTables make_slice_tables() {
  SliceTables t{};
  t[0] = make_crc_table();
  for (std::size_t k = 1; k < kSlicing; ++k)
    for (unsigned i = 0; i < 256; ++i)
      t[k][i] = static_cast<std::uint16_t>((t[k - 1][i] >> 8) ^ t[0][t[k - 1][i] & 0xFFu]);
  return t;
}

constexpr SliceTables kSlices = make_slice_tables();

}  // namespace

std::uint16_t crc16_modbus_update(std::uint16_t crc, std::uint8_t byte) {
  return static_cast<std::uint16_t>((crc >> 8) ^ kCrcTable[(crc ^ byte) & 0xFFu]);
}

namespace {

// The register after a block of `k` bytes (2 <= k <= kSlicing) at once: the 16-bit register only
// meets the block's first two bytes, and byte j of the block is followed by k - 1 - j more, hence
// table k - 1 - j.
template <std::size_t k>
[[gnu::always_inline]] inline std::uint16_t crc16_block(std::span<const std::uint8_t, k> block,
                                                        std::uint16_t crc) {
  static_assert(k >= 2 && k <= kSlicing);
  std::uint32_t acc =
      kSlices[k - 1][(block[0] ^ crc) & 0xFFu] ^ kSlices[k - 2][(block[1] ^ (crc >> 8)) & 0xFFu];
  for (std::size_t j = 2; j < k; ++j) acc ^= kSlices[k - 1 - j][block[j]];
  return static_cast<std::uint16_t>(acc);
}

}  // namespace

std::uint16_t crc16_modbus(std::span<const std::uint8_t> data, std::uint16_t crc) {
  // Sixteen bytes a step; then what is left (most RTU frames are 6 to 37 bytes before the CRC) in
  // at most four steps of 8, 4, 2 and 1 bytes rather than byte by byte.
  while (data.size() >= kSlicing) {
    crc = crc16_block(data.first<kSlicing>(), crc);
    data = data.subspan(kSlicing);
  }
  if (data.size() >= 8) {
    crc = crc16_block(data.first<8>(), crc);
    data = data.subspan(8);
  }
  if (data.size() >= 4) {
    crc = crc16_block(data.first<4>(), crc);
    data = data.subspan(4);
  }
  if (data.size() >= 2) {
    crc = crc16_block(data.first<2>(), crc);
    data = data.subspan(2);
  }
  if (!data.empty()) crc = crc16_modbus_update(crc, data[0]);
  return crc;
}

std::uint8_t lrc8(std::span<const std::uint8_t> data) {
  std::uint8_t sum = 0;
  for (const std::uint8_t b : data) sum = static_cast<std::uint8_t>(sum + b);
  return static_cast<std::uint8_t>(-sum);
}

ChecksumResult check_rtu_crc(std::span<const std::uint8_t> frame) {
  if (frame.size() < 3) return {};
  return check_rtu_crc(frame, crc16_modbus(frame.first(frame.size() - 2)));
}

std::string wire_hex(std::uint32_t packed, std::uint8_t width, std::string_view separator) {
  std::string out;
  append_wire_hex(out, packed, width, separator);
  return out;
}

std::string_view to_string(ChecksumVerdict v) {
  static constexpr std::string_view kToStrings[] = {"none", "good", "bad", "swapped"};
  static_assert(std::size(kToStrings) == static_cast<std::size_t>(ChecksumVerdict::swapped) + 1);
  return enum_text(v, kToStrings, std::string_view{"none"});
}

}  // namespace drivetap
