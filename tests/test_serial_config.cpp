// Unit tests: SerialConfig parsing and Modbus timing (docs/protocols.md §1).
#include <gtest/gtest.h>

#include "core/serial_config.hpp"
#include "pipeline/options.hpp"

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

// Where the settings in force came from, part by part, and -s against the capture's own.
TEST(SettingsProvenance, EachPartSaysWhereItCameFrom) {
  RunSettings none, said;
  std::string err;
  said.serial = *SerialConfig::parse("4800 8N1", &err);
  EXPECT_EQ(settings_provenance(none, "").text(), "default");
  EXPECT_EQ(settings_provenance(said, "").text(), "from the capture");
  EXPECT_EQ(settings_provenance(none, "19200 8E1").text(), "as given");
  EXPECT_EQ(settings_provenance(none, "19200").text(), "baud as given, format default");
  EXPECT_EQ(settings_provenance(said, "8E1").text(),
            "baud from the capture, format as given; the capture says 4800 8N1");
  const SettingsProvenance against = settings_provenance(said, "19200 8E1");
  EXPECT_EQ(against.text(), "as given; the capture says 4800 8N1");
  EXPECT_EQ(against.contradiction, "-s 19200 8E1: the capture says 4800 8N1; decoding as 19200 8E1");
  // -s that agrees with the capture contradicts nothing.
  EXPECT_EQ(settings_provenance(said, "4800 8N1").contradiction, "");
  EXPECT_EQ(settings_provenance(said, "4800").text(), "baud as given, format from the capture");
}
