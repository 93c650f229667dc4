// Unit tests: Easydrive '~' protocol — SUM, replies read in the light of their request (§5).
#include <fmt/format.h>
#include <gtest/gtest.h>

#include "dissectors/easydrive/eds_dissector.hpp"
#include "dissectors/easydrive/eds_protocol.hpp"
#include "test_support.hpp"

using namespace drivetap;

namespace {

std::string frame_text(const std::string& body) {
  const std::vector<std::uint8_t> b(body.begin(), body.end());
  return fmt::format("~{}{:04X}\r", body, easydrive::ascii_sum(b));
}

std::vector<Message> run(const std::vector<std::string>& frames) {
  ChannelTable channels;
  channels.intern("bus");
  drivetap::testing::RecordingSink sink;
  PipelineOptions p;
  p.protocol = protocols::easydrive;
  p.timing = FramingTiming::from(p.serial);
  Pipeline pipeline(p, channels, sink);
  TimeNs t = 0;
  for (const std::string& f : frames) {
    for (char c : f)
      pipeline.push({t += p.timing.character_time, static_cast<std::uint8_t>(c), 0, 0, 0});
    t += 20 * kNsPerMs;
  }
  pipeline.finish();
  return sink.frames;
}

}  // namespace

TEST(Easydrive, SumOfTheManualsStatusQuery) {
  const std::string s = "010A0000";
  EXPECT_EQ(easydrive::ascii_sum(std::vector<std::uint8_t>(s.begin(), s.end())), 0x0192);
}

TEST(Easydrive, RepliesAreReadWithTheirRequest) {
  const auto m =
      run({frame_text("010B000F"), frame_text("0100030F0015"), frame_text("010B0001"),
           frame_text("010000010FA0"), frame_text("010C00010FA0"), frame_text("01000001")});
  ASSERT_EQ(m.size(), 6u);
  EXPECT_EQ(m[1].direction, Direction::response);
  EXPECT_EQ(m[1].info, "OK, status word, 0x0015 [run, reverse, normal run], drive fault code 3");
  EXPECT_EQ(m[3].info, "OK, output frequency, 40.00 Hz");
  EXPECT_EQ(m[4].info, "run control, set running frequency, 40.00 Hz");
  EXPECT_EQ(m[5].info, "OK, set running frequency");
  for (const Message& x : m) EXPECT_EQ(x.checksum.verdict, ChecksumVerdict::good);
}

TEST(Easydrive, InvalidCharactersAndLengthAreNamed) {
  const auto m = run({"~010b00000193\r"});
  ASSERT_EQ(m.size(), 1u);
  bool invalid = false;
  for (const Anomaly& a : m[0].anomalies) invalid |= a.detail.find("invalid character 0x62") == 0;
  EXPECT_TRUE(invalid);
}
