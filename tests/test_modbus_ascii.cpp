// Unit tests: Modbus ASCII — LRC, hex-text decoding, framing by ':' ... CR LF (docs/protocols.md
// §3).
#include <gtest/gtest.h>

#include "core/checksum.hpp"
#include "dissectors/common/delimited_framer.hpp"
#include "dissectors/modbus/ascii_dissector.hpp"
#include "dissectors/modbus/modbus_protocol.hpp"
#include "test_support.hpp"

using namespace drivetap;
using namespace drivetap::modbus;

namespace {

std::vector<std::uint8_t> text(std::string_view s) {
  return {s.begin(), s.end()};
}

Frame frame_of(std::string_view s) {
  Frame f;
  TimeNs t = 0;
  for (char c : s) f.events.push_back({t += 1000, static_cast<std::uint8_t>(c), 0, 0, 0});
  return f;
}

}  // namespace

TEST(ModbusAscii, LrcOfTheManualsExample) {
  const std::uint8_t bytes[] = {0x01, 0x03, 0x01, 0x00, 0x0A};  // sum 0x0F
  EXPECT_EQ(lrc8(bytes), 0xF1);
}

TEST(ModbusAscii, DecodesTheSpecRequest) {
  const Message m =
      dissected(dissect_ascii, frame_of(":010325230001B3\r\n"), Direction::request, {});
  EXPECT_EQ(m.protocol, protocols::modbus_ascii);
  EXPECT_EQ(m.address, 1);
  EXPECT_EQ(m.function, 3);
  EXPECT_EQ(m.checksum.verdict, ChecksumVerdict::good);
  EXPECT_EQ(m.checksum.stated_wire, 0xB3u);
  EXPECT_EQ(m.info, "Read Holding Registers 0x2523");
  EXPECT_TRUE(m.anomalies.empty());
  // Field spans point at the hex characters: start address "2523" is at 5..8.
  bool found = false;
  for (const FieldNode& n : m.fields)
    if (n.desc->id == "modbus.reference_num") {
      found = true;
      EXPECT_EQ(n.offset, 5u);
      EXPECT_EQ(n.length, 4u);
      EXPECT_EQ(n.value, 0x2523);
    }
  EXPECT_TRUE(found);
}

TEST(ModbusAscii, BadLrcShowsStatedAndComputed) {
  const Message m =
      dissected(dissect_ascii, frame_of(":010325230001B4\r\n"), Direction::request, {});
  EXPECT_EQ(m.checksum.verdict, ChecksumVerdict::bad);
  EXPECT_EQ(m.checksum.stated_wire, 0xB4u);
  EXPECT_EQ(m.checksum.computed_wire, 0xB3u);
  ASSERT_FALSE(m.anomalies.empty());
  EXPECT_EQ(m.anomalies[0].kind, AnomalyKind::checksum_bad);
  EXPECT_EQ(m.anomalies[0].detail, "LRC on wire B4, computed B3");
}

TEST(ModbusAscii, TextDefectsAreNamed) {
  const AsciiHex lower = decode_ascii_hex(text(":010325230001b3\r\n"));
  EXPECT_TRUE(lower.lower_case);
  EXPECT_EQ(lower.binary.size(), 7u);
  const AsciiHex junk = decode_ascii_hex(text(":0103G5\r\n"));
  ASSERT_FALSE(junk.problems.empty());
  EXPECT_NE(junk.problems[0].detail.find("0x47 at 5 is not a hex digit"), std::string::npos);
  const AsciiHex cut = decode_ascii_hex(text(":010325"));
  EXPECT_FALSE(cut.terminated);
  EXPECT_NE(cut.problems[0].detail.find("frame cut"), std::string::npos);
  const AsciiHex odd = decode_ascii_hex(text(":0103252\r\n"));
  EXPECT_NE(odd.problems[0].detail.find("odd number"), std::string::npos);
}

TEST(DelimitedFramer, ResyncsOnStartAndKeepsNoise) {
  DelimitedFramerOptions o;
  o.character_time = 1000;
  DelimitedFramer f(0, o);
  FrameBatch out;
  TimeNs t = 0;
  for (char c : std::string("xx:0103\r\n:01") + ":010325230001B3\r\n")
    f.push({t += 1000, static_cast<std::uint8_t>(c), 0, 0, 0}, out);
  f.finish(out);
  ASSERT_EQ(out.size(), 4u);
  EXPECT_EQ(out[0].kind, FrameKind::noise);  // "xx"
  EXPECT_EQ(out[1].size(), 7u);              // ":0103\r\n"
  EXPECT_EQ(out[2].size(), 3u);              // ":01" cut by the next ':'
  EXPECT_EQ(out[2].kind, FrameKind::telegram);
  EXPECT_EQ(out[3].size(), 17u);
}

TEST(DelimitedFramer, SilenceLongerThanTheTimeoutCutsAFrame) {
  DelimitedFramerOptions o;
  o.character_time = 1000;
  o.inter_character_timeout = 1'000'000;
  DelimitedFramer f(0, o);
  FrameBatch out;
  f.push({0, ':', 0, 0, 0}, out);
  f.push({1000, '0', 0, 0, 0}, out);
  f.advance(5'000'000, out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].close, FrameClose::silence);
}

TEST(ModbusAscii, PipelinePairsAsciiRequestAndReply) {
  ChannelTable channels;
  channels.intern("bus");
  drivetap::testing::RecordingSink sink;
  PipelineOptions p;
  p.protocol = protocols::modbus_ascii;
  p.timing = FramingTiming::from(p.serial);
  Pipeline pipeline(p, channels, sink);
  TimeNs t = 0;
  for (std::string_view s : {":010325230001B3\r\n", ":01030207D023\r\n"}) {
    for (char c : s)
      pipeline.push({t += p.timing.character_time, static_cast<std::uint8_t>(c), 0, 0, 0});
    t += 20 * kNsPerMs;
  }
  pipeline.finish();
  ASSERT_EQ(sink.frames.size(), 2u);
  EXPECT_EQ(sink.frames[1].direction, Direction::response);
  EXPECT_EQ(sink.frames[1].info, "Read Holding Registers reply: 1 register = 2000");
  EXPECT_EQ(sink.count(Outcome::ok), 1u);
}
