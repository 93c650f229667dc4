// Unit tests: SerialConfig parsing and Modbus timing (docs/protocols.md §1).
#include <gtest/gtest.h>

#include "core/serial_config.hpp"

using namespace drivetap;

TEST(SerialConfig, ParsesBaudAndFormat) {
  std::string err;
  auto c = SerialConfig::parse("19200 8E1", &err);
  ASSERT_TRUE(c) << err;
  EXPECT_EQ(c->baud, 19200u);
  EXPECT_EQ(c->parity, Parity::even);
  EXPECT_EQ(c->bits_per_character(), 11u);
  EXPECT_EQ(c->to_string(), "19200 8E1");
}
