// Unit tests: plausibility rules of each protocol and detection on them
// (docs/protocols.md §2-§5, dissectors/common/plausibility.hpp).
#include <gtest/gtest.h>

#include <string>

#include "dissectors/danfoss_fc/fc_dissector.hpp"
#include "dissectors/easydrive/eds_dissector.hpp"
#include "dissectors/modbus/ascii_dissector.hpp"
#include "dissectors/modbus/modbus_protocol.hpp"
#include "dissectors/modbus/rtu_dissector.hpp"
#include "test_support.hpp"

using namespace drivetap;
using namespace drivetap::testing;

namespace {

// The id of the rule a check found broken, "none" for none.
std::string_view rule_id(const Plausibility& p) {
  return p.broken ? p.broken->id : "none";
}

std::vector<std::uint8_t> text(std::string_view s) {
  return {s.begin(), s.end()};
}

std::string_view rtu_rule(const std::vector<std::uint8_t>& b, Direction d = Direction::unknown) {
  return rule_id(modbus::rtu_plausibility(b, d, false));
}

std::string_view fc_rule(const std::vector<std::uint8_t>& b, Direction d = Direction::unknown) {
  return rule_id(danfoss_fc::fc_plausibility(b, d, false));
}

std::string_view ascii_rule(std::string_view s, Direction d = Direction::unknown) {
  const std::vector<std::uint8_t> b = text(s);
  return rule_id(modbus::ascii_plausibility(b, modbus::decode_ascii_hex(b), d, false));
}

std::string_view eds_rule(std::string_view s, Direction d = Direction::unknown) {
  return rule_id(easydrive::eds_plausibility(text(s), d, false));
}

Frame frame_of(const std::vector<std::uint8_t>& bytes) {
  Frame f;
  TimeNs t = 0;
  for (std::uint8_t b : bytes) f.events.push_back({t += 1000, b, 0, 0, 0});
  return f;
}

}  // namespace

TEST(Plausibility, ModbusRtuRules) {
  const auto read = with_crc({0x01, 0x03, 0x00, 0x00, 0x00, 0x01});
  EXPECT_EQ(rtu_rule(read), "none");
  EXPECT_EQ(rtu_rule(read, Direction::request), "none");
  EXPECT_EQ(rtu_rule(read, Direction::response), "modbus.length")
      << "6 PDU bytes are no FC 03 reply";
  // DMX: FF FF 00 00 00 has a good CRC; address 255 is reserved.
  const std::vector<std::uint8_t> dmx{0xFF, 0xFF, 0x00, 0x00, 0x00};
  EXPECT_EQ(check_rtu_crc(dmx).verdict, ChecksumVerdict::good);
  EXPECT_EQ(rtu_rule(dmx), "modbus.address");
  EXPECT_EQ(rtu_rule(with_crc({0xF7, 0x03, 0x02, 0x00, 0x01})), "none")
      << "247 is the highest slave address";
  EXPECT_EQ(rtu_rule(with_crc({0xF8, 0x03, 0x02, 0x00, 0x01})), "modbus.address");
  EXPECT_EQ(rtu_rule(with_crc({0x01, 0x41, 0x00})), "modbus.function");
  EXPECT_EQ(rtu_rule(with_crc({0x01, 0x83, 0x02})), "none");
  EXPECT_EQ(rtu_rule(with_crc({0x01, 0x83, 0x00})), "modbus.exception_code");
  EXPECT_EQ(rtu_rule(with_crc({0x01, 0x83, 0x0C})), "modbus.exception_code");
  EXPECT_EQ(rtu_rule(with_crc({0x01, 0x83, 0x02, 0x00})), "modbus.length");
  EXPECT_EQ(rtu_rule(with_crc({0x01, 0x03, 0x04, 0x00, 0x01})), "modbus.length")
      << "byte count 4 with 2 data bytes, and no request either";
  std::vector<std::uint8_t> huge(300, 0x01);
  EXPECT_EQ(rtu_rule(huge), "mbrtu.size");
  EXPECT_EQ(rtu_rule({0x01, 0x03, 0x00}), "mbrtu.size");
}

TEST(Plausibility, ModbusVendorExceptionCodeFromAProfile) {
  const auto e5 = with_crc({0x01, 0x83, 0x5E});
  EXPECT_EQ(rtu_rule(e5), "modbus.exception_code");
  allow_vendor_exception_code(0x5E);  // (no built-in profile uses 0x5E)
  EXPECT_EQ(rtu_rule(e5), "none");
}

TEST(Plausibility, DanfossFcRules) {
  EXPECT_EQ(fc_rule({0x02, 0x06, 0x04, 0x04, 0x7C, 0x20, 0x00, 0x58}), "none");
  EXPECT_EQ(
      fc_rule({0x02, 0x0E, 0x81, 0xE1, 0x9E, 0, 0, 0, 0, 0x03, 0xE8, 0x04, 0x7C, 0x20, 0x00, 0x41},
              Direction::request),
      "none");
  // "Hello world": no STX.
  EXPECT_EQ(fc_rule(text("Hello world!\r\n")), "danfoss_fc.stx");
  // Constant bytes: FF FF FF FF and 00 00 00 00 have a good BCC.
  EXPECT_EQ(fc_rule({0xFF, 0xFF, 0xFF, 0xFF}), "danfoss_fc.stx");
  EXPECT_EQ(fc_rule({0x02, 0x02, 0x02, 0x02}), "danfoss_fc.lge_allowed");
  EXPECT_EQ(fc_rule({0x02, 0x0E, 0x04, 0x04, 0x7C, 0x20, 0x00, 0x58}), "danfoss_fc.lge_count");
  EXPECT_EQ(fc_rule(fc_telegram(0x00, {0x04, 0x7C, 0x20, 0x00})), "danfoss_fc.adr");
  EXPECT_EQ(fc_rule(fc_telegram(0xFF, {0x04, 0x7C, 0x20, 0x00})), "danfoss_fc.adr");
  EXPECT_EQ(fc_rule(fc_telegram(0x20, {0x04, 0x7C, 0x20, 0x00})), "none") << "broadcast";
  // AK 7 (cannot execute) only in a reply; AK 0xD (write RAM+EEPROM) only in a request; AK 5 none.
  const auto ak7 = fc_telegram(0x01, {0x71, 0x9E, 0, 0, 0, 0x02, 0x06, 0x07, 0, 0, 0, 0});
  EXPECT_EQ(fc_rule(ak7, Direction::response), "none");
  EXPECT_EQ(fc_rule(ak7, Direction::request), "danfoss_fc.ak");
  const auto ak5 = fc_telegram(0x01, {0x51, 0x9E, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0});
  EXPECT_EQ(fc_rule(ak5), "danfoss_fc.ak");
  // Text blocks: LGE 10 + n only with AK 0xF.
  EXPECT_EQ(fc_rule(fc_telegram(0x01, {0xF1, 0x9E, 0x04, 0, 'a', 'b', 'c', 0, 0, 0, 0})), "none");
  EXPECT_EQ(fc_rule(fc_telegram(0x01, {0x11, 0x9E, 0x04, 0, 'a', 'b', 'c', 0, 0, 0, 0})),
            "danfoss_fc.lge_allowed");
}

TEST(Plausibility, ModbusAsciiRules) {
  EXPECT_EQ(ascii_rule(":010325230001B3\r\n"), "none");
  EXPECT_EQ(ascii_rule(":010325230001b3\r\n"), "none")
      << "lower case is a malformed finding, not another protocol";
  EXPECT_EQ(ascii_rule(":010325230001B3"), "mbascii.terminator");
  EXPECT_EQ(ascii_rule(":Hello world\r\n"), "mbascii.charset");
  EXPECT_EQ(ascii_rule(":0103\r\n"), "mbascii.length");
  EXPECT_EQ(ascii_rule(":010325230001B\r\n"), "mbascii.length");
  EXPECT_EQ(ascii_rule(":FF0325230001B3\r\n"), "modbus.address")
      << "the Modbus rules apply to the bytes the hex spells";
}

TEST(Plausibility, EasydriveRules) {
  EXPECT_EQ(eds_rule("~010C00010FA0027C\r"), "none");
  EXPECT_EQ(eds_rule("~010C00010FA0027C"), "easydrive.terminator");
  EXPECT_EQ(eds_rule("~010c00010fa0027c\r"), "easydrive.charset");
  EXPECT_EQ(eds_rule("~010C00010FA002\r"), "easydrive.length");
  EXPECT_EQ(eds_rule("~01FF00010FA0027C\r"), "easydrive.command");
  EXPECT_EQ(eds_rule("~010C00010FA0027C\r", Direction::response), "easydrive.command")
      << "0C is a command, not a response code";
}

TEST(Plausibility, ImplausibleTelegramIsNamedAndIsNoGoodTelegram) {
  const Message m = dissected(danfoss_fc::dissect_fc, frame_of({0xFF, 0xFF, 0xFF, 0xFF}),
                              Direction::unknown, FramingTiming{});
  EXPECT_EQ(m.checksum.verdict, ChecksumVerdict::good) << "the checksum is what it is";
  EXPECT_TRUE(is_implausible(m));
  EXPECT_FALSE(good_telegram(head_of(m)));
  bool named = false;
  for (const Anomaly& a : m.anomalies)
    if (a.kind == AnomalyKind::implausible)
      named = a.detail == "starts with 0xFF, not STX [danfoss_fc.stx, PROTOCOLS.md §4]";
  EXPECT_TRUE(named);
  EXPECT_EQ(anomaly_severity(AnomalyKind::implausible), Severity::error);
}

TEST(Plausibility, HelloWorldIsNoDriveProtocol) {
  // Issue 37 §4: 56 characters of text once made one "Danfoss FC bcc ok" telegram.
  AutoRun r;
  r.send(text("Hello world! This is a UART test line, 56 characters!!\r\n"));
  r.pipeline->finish();
  ASSERT_EQ(r.sink.events.size(), 1u);
  EXPECT_EQ(r.sink.events[0].protocol, Protocol::unknown);
  EXPECT_EQ(r.sink.events[0].confidence, "none");
  EXPECT_NE(r.sink.events[0].detail.find("no drive protocol: 56 bytes of printable ASCII text"),
            std::string::npos)
      << r.sink.events[0].detail;
  EXPECT_EQ(r.sink.summary.good_telegrams, 0u);
}

TEST(Plausibility, ConstantBytesAreNamed) {
  AutoRun r;
  for (int i = 0; i < 10; ++i) r.send(std::vector<std::uint8_t>(16, 0xFF));
  r.pipeline->finish();
  ASSERT_FALSE(r.sink.events.empty());
  EXPECT_EQ(r.sink.events[0].protocol, Protocol::unknown);
  EXPECT_NE(r.sink.events[0].detail.find("160 bytes of constant 0xFF"), std::string::npos)
      << r.sink.events[0].detail;
  EXPECT_EQ(r.sink.summary.good_telegrams, 0u);
  EXPECT_TRUE(r.sink.summary.drives.empty());
}

TEST(Plausibility, DetectionNeedsSeveralGoodTelegramsAndPairsForHigh) {
  {
    AutoRun r;  // one good telegram on a bus: never enough
    r.send(fc_telegram(0x04, {0x04, 0x7C, 0x20, 0x00}));
    r.pipeline->finish();
    ASSERT_EQ(r.sink.events.size(), 1u);
    EXPECT_EQ(r.sink.events[0].protocol, Protocol::unknown);
  }
  {
    AutoRun r;  // requests alone, never answered: the protocol, but not with high confidence
    for (int i = 0; i < 6; ++i) r.send(with_crc({0x01, 0x03, 0x00, 0x00, 0x00, 0x01}));
    r.pipeline->finish();
    ASSERT_FALSE(r.sink.events.empty());
    EXPECT_EQ(r.sink.events[0].protocol, protocols::modbus_rtu);
    EXPECT_EQ(r.sink.events[0].confidence, "medium");
  }
  {
    AutoRun r;  // requests and their replies
    for (int i = 0; i < 3; ++i) {
      r.send(with_crc({0x01, 0x03, 0x00, 0x00, 0x00, 0x01}));
      r.send(with_crc({0x01, 0x03, 0x02, 0x00, 0x2A}));
    }
    r.pipeline->finish();
    ASSERT_FALSE(r.sink.events.empty());
    EXPECT_EQ(r.sink.events[0].protocol, protocols::modbus_rtu);
    EXPECT_EQ(r.sink.events[0].confidence, "high");
  }
}

TEST(Plausibility, ImplausibleGoodChecksumsDoNotDecide) {
  // FF FF 00 00 00 (DMX) has a good CRC: three of them once made Modbus RTU at medium confidence.
  AutoRun r;
  for (int i = 0; i < 5; ++i) r.send({0xFF, 0xFF, 0x00, 0x00, 0x00});
  r.pipeline->finish();
  ASSERT_FALSE(r.sink.events.empty());
  EXPECT_EQ(r.sink.events[0].protocol, Protocol::unknown);
  // No drive protocol: the line's bytes are data (noise records), no telegram of any protocol.
  EXPECT_EQ(r.sink.summary.frames, 0u);
  EXPECT_EQ(r.sink.summary.noise_records, 5u);
  EXPECT_EQ(r.sink.summary.good_telegrams, 0u);
}

TEST(Plausibility, IpFlowWithNoDriveProtocolIsLeftOut) {
  AutoRun r(/*ip_flow=*/true);
  r.send(text("GET / HTTP/1.1\r\nHost: example.com\r\n\r\n"));
  r.pipeline->finish();
  ASSERT_EQ(r.sink.events.size(), 1u);
  EXPECT_EQ(r.sink.events[0].protocol, Protocol::unknown);
  EXPECT_TRUE(r.sink.frames.frames.empty()) << "no frame of a flow that failed detection";
  EXPECT_TRUE(r.sink.frames.noise.empty());
  ASSERT_EQ(r.sink.summary.source_notes.size(), 1u);
  EXPECT_NE(r.sink.summary.source_notes[0].find("left out of the decode"), std::string::npos);
}

TEST(Plausibility, IpFlowWithADriveProtocolJoins) {
  AutoRun r(/*ip_flow=*/true);
  for (int i = 0; i < 4; ++i) {
    r.send(with_crc({0x01, 0x03, 0x00, 0x00, 0x00, 0x01}));
    r.send(with_crc({0x01, 0x03, 0x02, 0x00, 0x2A}));
  }
  r.pipeline->finish();
  ASSERT_FALSE(r.sink.events.empty());
  EXPECT_EQ(r.sink.events[0].protocol, protocols::modbus_rtu);
  EXPECT_EQ(r.sink.frames.frames.size(), 8u);
  EXPECT_EQ(r.sink.summary.good_telegrams, 8u);
}
