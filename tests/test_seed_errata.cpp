// The manuals' worked examples (docs/protocols.md §2, §6): every checksum verdict, with the stated
// and computed CRCs of each erratum, checked independently of the golden files.
#include <gtest/gtest.h>

#include <map>

#include "dissectors/easydrive/eds_protocol.hpp"
#include "dissectors/modbus/modbus_protocol.hpp"
#include "test_support.hpp"

using namespace drivetap;
using namespace drivetap::testing;

namespace {

struct Expect {
  ChecksumVerdict verdict;
  std::uint32_t stated = 0;  // wire order, e.g. 0x8048 for "80 48"
  std::uint32_t computed = 0;
};

constexpr auto G = ChecksumVerdict::good;
constexpr auto B = ChecksumVerdict::bad;
constexpr auto S = ChecksumVerdict::swapped;

void check_capture(const std::string& name, const std::vector<Expect>& expected) {
  RecordingSink sink;
  ChannelTable channels;
  std::string error;
  ASSERT_TRUE(run_byte_log(std::string(DRIVETAP_SOURCE_DIR) + "/captures/" + name + "/input.log",
                           sink, channels, &error))
      << error;
  ASSERT_EQ(sink.frames.size(), expected.size()) << name;
  EXPECT_TRUE(sink.noise.empty()) << name;
  for (std::size_t i = 0; i < expected.size(); ++i) {
    const ChecksumResult& c = sink.frames[i].checksum;
    EXPECT_EQ(c.verdict, expected[i].verdict) << name << " frame " << i + 1;
    if (expected[i].verdict != G) {
      EXPECT_EQ(c.stated_wire, expected[i].stated) << name << " frame " << i + 1;
      EXPECT_EQ(c.computed_wire, expected[i].computed) << name << " frame " << i + 1;
    }
  }
}

}  // namespace

TEST(SeedErrata, ErmanE9) {
  // 000 §6: example 1 request sent high byte first; every other example-1/2 CRC is wrong.
  check_capture("seed-erman-e9", {{S, 0x3A44, 0x443A},
                                  {B, 0x8048, 0xCFF0},
                                  {S, 0x3A44, 0x443A},
                                  {G},
                                  {B, 0xEBFC, 0xA171},
                                  {B, 0xF1E1, 0x403E},
                                  {B, 0xEBFC, 0xA171},
                                  {B, 0xCDC1, 0x3DC1},
                                  {G},
                                  {G},
                                  {G},
                                  {G}});
}

TEST(SeedErrata, ErmanErg) {
  // 003: only the FC 04 request is wrong (the FC 03 CRC reused).
  std::vector<Expect> e(32, Expect{G});
  e[8] = {B, 0x15C9, 0x61C9};
  e[10] = {B, 0x15C9, 0x61C9};
  check_capture("seed-erman-erg", e);
}

TEST(SeedErrata, E5With02AddressErrorExample) {
  std::vector<Expect> e(17, Expect{G});
  e[0] = {B, 0xC0CD, 0x30CD};  // 02 83 52 C0 CD: the address-01 CRC reused
  check_capture("seed-e5-8200", e);
}

TEST(SeedErrata, DanfossModbusExamplesAllGood) {
  check_capture("seed-danfoss-modbus", std::vector<Expect>(12, Expect{G}));
}

TEST(SeedErrata, ContentDefectsBeyondChecksumsAreNamed) {
  RecordingSink sink;
  ChannelTable channels;
  std::string error;
  ASSERT_TRUE(run_byte_log(std::string(DRIVETAP_SOURCE_DIR) + "/captures/seed-erman-erg/input.log",
                           sink, channels, &error));
  // FC 04 reply: byte count 0x10 with 10 data bytes — framed by silence, decoded, flagged.
  const Message& fc04 = sink.frames.at(9);
  EXPECT_EQ(fc04.bytes.size(), 15u);
  EXPECT_EQ(fc04.direction, Direction::response);
  ASSERT_FALSE(fc04.anomalies.empty());
  EXPECT_EQ(fc04.anomalies[0].kind, AnomalyKind::malformed);
  EXPECT_NE(fc04.anomalies[0].detail.find("byte count says 16"), std::string::npos);
  // 01 89 01 86 50 answers an FC 08 request with FC 0x89: not a reply to it.
  EXPECT_EQ(sink.count(Outcome::unsolicited), 1u);
}

TEST(SeedErrata, E5AsciiExamples) {
  RecordingSink sink;
  ChannelTable channels;
  std::string error;
  ASSERT_TRUE(
      run_byte_log(std::string(DRIVETAP_SOURCE_DIR) + "/captures/seed-e5-8200-ascii/input.log",
                   sink, channels, &error, protocols::modbus_ascii))
      << error;
  ASSERT_EQ(sink.frames.size(), 18u);
  for (std::size_t i = 0; i < sink.frames.size(); ++i) {
    const ChecksumResult& c = sink.frames[i].checksum;
    EXPECT_EQ(sink.frames[i].protocol, protocols::modbus_ascii);
    if (i == 8) {  // :01882075 — the manual's LRC has its digits swapped
      EXPECT_EQ(c.verdict, ChecksumVerdict::bad);
      EXPECT_EQ(c.stated_wire, 0x75u);
      EXPECT_EQ(c.computed_wire, 0x57u);
    } else {
      EXPECT_EQ(c.verdict, ChecksumVerdict::good) << "frame " << i + 1;
    }
  }
  EXPECT_EQ(sink.count(AnomalyKind::malformed), 2u);  // the FC 03 count '2501', twice
}

TEST(SeedErrata, EasydriveExamples) {
  RecordingSink sink;
  ChannelTable channels;
  std::string error;
  ASSERT_TRUE(run_byte_log(std::string(DRIVETAP_SOURCE_DIR) + "/captures/seed-easydrive/input.log",
                           sink, channels, &error, protocols::easydrive))
      << error;
  ASSERT_EQ(sink.frames.size(), 40u);
  // 0-based frame indices of docs/protocols.md §6's Easydrive errata, with the stated SUM.
  const std::map<std::size_t, std::uint32_t> off_by_one = {{11, 0x01A3}, {12, 0x01A6}, {13, 0x01A7},
                                                           {14, 0x01A8}, {15, 0x01A9}, {16, 0x01AA},
                                                           {30, 0x01A8}};
  const std::map<std::size_t, std::uint32_t> cr_in_sum = {{37, 0x028B}, {38, 0x028C}};
  for (std::size_t i = 0; i < sink.frames.size(); ++i) {
    const ChecksumResult& c = sink.frames[i].checksum;
    if (i == 35 || i == 36) {  // ~010EB, ~010EA: truncated in the manual
      EXPECT_EQ(c.verdict, ChecksumVerdict::none) << "frame " << i + 1;
    } else if (off_by_one.count(i)) {
      EXPECT_EQ(c.verdict, ChecksumVerdict::bad) << "frame " << i + 1;
      EXPECT_EQ(c.stated_wire, off_by_one.at(i));
      EXPECT_EQ(std::max(c.stated_wire, c.computed_wire) - std::min(c.stated_wire, c.computed_wire),
                1u);
    } else if (cr_in_sum.count(i)) {
      EXPECT_EQ(c.verdict, ChecksumVerdict::bad) << "frame " << i + 1;
      EXPECT_EQ(c.stated_wire, cr_in_sum.at(i));
      EXPECT_EQ(c.stated_wire - c.computed_wire, 0x0Du);
    } else {
      EXPECT_EQ(c.verdict, ChecksumVerdict::good) << "frame " << i + 1;
    }
  }
  EXPECT_EQ(sink.frames[18].info, "run control, set running frequency, 40.00 Hz");
}
