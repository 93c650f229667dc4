// CRC-16/MODBUS (docs/protocols.md §2.3): the sliced crc16_modbus() against the byte-at-a-time
// definition, at every length a frame can have and every alignment.
#include <gtest/gtest.h>

#include <cstdint>
#include <random>
#include <span>
#include <vector>

#include "core/checksum.hpp"

using namespace drivetap;

namespace {

std::uint16_t crc16_bytewise(std::span<const std::uint8_t> data, std::uint16_t crc = 0xFFFF) {
  for (const std::uint8_t b : data) crc = crc16_modbus_update(crc, b);
  return crc;
}

std::vector<std::uint8_t> random_bytes(std::size_t n) {
  std::mt19937 rng(7);
  std::vector<std::uint8_t> v(n);
  for (std::uint8_t& b : v) b = static_cast<std::uint8_t>(rng());
  return v;
}

}  // namespace

TEST(Crc16, KnownValues) {
  const std::uint8_t read_one[] = {0x01, 0x03, 0x00, 0x00, 0x00, 0x01};  // CRC 84 0A on the wire
  EXPECT_EQ(crc16_modbus(read_one), 0x0A84);
  const std::uint8_t check[] = {'1', '2', '3', '4', '5', '6', '7', '8', '9'};
  EXPECT_EQ(crc16_modbus(check), 0x4B37);  // the catalogue's check value of CRC-16/MODBUS
  EXPECT_EQ(crc16_modbus({}), 0xFFFF);
}

// Every length 0..300 (the longest RTU frame is 256 bytes) at every offset 0..15, from the
// initial register and from another one (a chained call).
TEST(Crc16, SlicedEqualsBytewiseAtEveryLengthAndAlignment) {
  const std::vector<std::uint8_t> data = random_bytes(300 + 16);
  for (std::size_t offset = 0; offset < 16; ++offset)
    for (std::size_t len = 0; len <= 300; ++len) {
      const auto s = std::span(data).subspan(offset, len);
      ASSERT_EQ(crc16_modbus(s), crc16_bytewise(s)) << "offset " << offset << " length " << len;
      ASSERT_EQ(crc16_modbus(s, 0x1D0F), crc16_bytewise(s, 0x1D0F))
          << "offset " << offset << " length " << len;
    }
  const auto whole = std::span(data);
  EXPECT_EQ(crc16_modbus(whole.subspan(37), crc16_modbus(whole.first(37))), crc16_bytewise(whole));
}
