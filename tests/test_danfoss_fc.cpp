// Unit tests: Danfoss FC protocol — BCC, addresses, PKE/AK/PNU, CTW/STW, framing (docs/protocols.md
// §4).
#include <gtest/gtest.h>

#include "dissectors/danfoss_fc/fc_dissector.hpp"
#include "dissectors/danfoss_fc/fc_protocol.hpp"
#include "test_support.hpp"

using namespace drivetap;
using namespace drivetap::danfoss_fc;

namespace {

Frame frame_of(std::vector<std::uint8_t> bytes) {
  Frame f;
  TimeNs t = 0;
  for (std::uint8_t b : bytes) f.events.push_back({t += 1000, b, 0, 0, 0});
  return f;
}

std::string field_text(const Message& m, std::string_view id) {
  for (const FieldNode& n : m.fields)
    if (n.desc->id == id) return format_field_value(m.fields, n, m.bytes);
  return "(missing)";
}

}  // namespace

TEST(DanfossFc, AddressFormatsAndBroadcast) {
  EXPECT_EQ(decode_adr(0x04).number, 4);
  EXPECT_FALSE(decode_adr(0x04).broadcast);
  EXPECT_TRUE(decode_adr(0x24).broadcast);  // bit 5 in the 1..31 format
  EXPECT_EQ(decode_adr(0x81).number, 1);    // 1..126 format
  EXPECT_TRUE(decode_adr(0x80).broadcast);
  EXPECT_EQ(parameter_name(414), "4-14");
  EXPECT_EQ(parameter_name(1614), "16-14");
}

TEST(DanfossFc, WriteParameterTelegramOfTheIssue) {
  const Message m = dissected(dissect_fc,
                              frame_of({0x02, 0x0E, 0x81, 0xE1, 0x9E, 0, 0, 0, 0, 0x03, 0xE8, 0x04,
                                        0x7C, 0x20, 0x00, 0x41}),
                              Direction::request, {});
  EXPECT_EQ(m.protocol, protocols::danfoss_fc);
  EXPECT_EQ(m.address, 1);
  EXPECT_EQ(m.checksum.verdict, ChecksumVerdict::good);
  EXPECT_EQ(m.info,
            "write 4-14 = 1000 (RAM+EEPROM, word), CTW 0x047C [ramp, no coast, ramp, use ramp, "
            "start, data valid], REF 50.000 %");
  EXPECT_EQ(field_text(m, "danfoss_fc.param"), "4-14");
  EXPECT_EQ(field_text(m, "danfoss_fc.pwe"), "1000");
  EXPECT_TRUE(m.anomalies.empty());
}

TEST(DanfossFc, ErrorReplyAndStatusWord) {
  const Message m = dissected(
      dissect_fc,
      frame_of({0x02, 0x0E, 0x01, 0x71, 0x9E, 0, 0, 0, 0, 0, 0x02, 0x06, 0x07, 0x00, 0x00, 0xE1}),
      Direction::response, {});
  EXPECT_EQ(m.checksum.verdict, ChecksumVerdict::good);
  EXPECT_NE(m.info.find("4-14: cannot execute, error 2 (upper or lower limit exceeded)"),
            std::string::npos)
      << m.info;
  EXPECT_NE(m.info.find("STW 0x0607 [control ready, drive ready, enabled, speed != reference, "
                        "bus control, frequency within limits, not running]"),
            std::string::npos)
      << m.info;
}

TEST(DanfossFc, BadBccAndLengthMismatchAreNamed) {
  const Message bad =
      dissected(dissect_fc, frame_of({0x02, 0x06, 0x04, 0x04, 0x7C, 0x20, 0x00, 0x59}),
                Direction::request, {});
  EXPECT_EQ(bad.checksum.verdict, ChecksumVerdict::bad);
  EXPECT_EQ(bad.checksum.stated_wire, 0x59u);
  EXPECT_EQ(bad.checksum.computed_wire, 0x58u);
  const Message cut =
      dissected(dissect_fc, frame_of({0x02, 0x0E, 0x04, 0x04, 0x7C, 0x20, 0x00, 0x58}),
                Direction::request, {});
  bool named = false;
  for (const Anomaly& a : cut.anomalies) {
    if (a.detail.find("LGE 14 announces 16") != 0) continue;
    named = true;
    // Raised by its typed finding, counted under the generic kind.
    ASSERT_NE(a.finding, nullptr);
    EXPECT_STREQ(a.finding->id, "danfoss_fc.lge_mismatch");
    EXPECT_EQ(a.kind, AnomalyKind::malformed);
  }
  EXPECT_TRUE(named);
}

TEST(DanfossFc, NegativeReferenceIsSignedPercent) {
  const Message m =
      dissected(dissect_fc, frame_of({0x02, 0x06, 0x04, 0x04, 0x7C, 0xE0, 0x00, 0x00}),
                Direction::request, {});
  EXPECT_NE(m.info.find("REF -50.000 %"), std::string::npos) << m.info;
}

TEST(DanfossFc, FramesBackToBackWithNoiseThroughThePipeline) {
  drivetap::testing::RecordingSink sink;
  ChannelTable channels;
  std::string error;
  ASSERT_TRUE(drivetap::testing::run_byte_log(
      std::string(DRIVETAP_SOURCE_DIR) + "/captures/fc-noise-back-to-back/input.log", sink,
      channels, &error, protocols::danfoss_fc))
      << error;
  EXPECT_EQ(sink.frames.size(), 8u);
  EXPECT_EQ(sink.noise.size(), 4u);
  for (const Message& m : sink.frames) EXPECT_EQ(m.checksum.verdict, ChecksumVerdict::good);
  EXPECT_EQ(sink.count(Outcome::ok), 4u);
}
