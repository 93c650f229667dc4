// Unit tests: sigrok session file (.sr) reader on the real captures copied from sigrok-dumps.
#include <gtest/gtest.h>

#include <fstream>

#include "sources/sigrok_file.hpp"

using namespace drivetap;

namespace {

std::string capture(const std::string& rel) {
  return std::string(DRIVETAP_SOURCE_DIR) + "/captures/" + rel;
}

struct Read {
  std::uint64_t samples = 0;
  std::vector<std::uint64_t> edges;  // per bit 0..15
  std::uint64_t first = 0;
};

Read read_all(SigrokFile& f) {
  Read r;
  r.edges.assign(16, 0);
  bool have = false;
  std::uint64_t prev = 0;
  std::string error;
  EXPECT_TRUE(f.read(
      [&](std::span<const std::uint64_t> chunk) {
        for (std::uint64_t s : chunk) {
          if (!have) {
            r.first = s;
            prev = s;
            have = true;
          }
          const std::uint64_t changed = s ^ prev;
          for (int b = 0; b < 16; ++b) r.edges[b] += (changed >> b) & 1;
          prev = s;
          ++r.samples;
        }
      },
      &error))
      << error;
  return r;
}

}  // namespace

TEST(SigrokFile, SampleRatesParse) {
  EXPECT_EQ(parse_sample_rate("1 MHz"), 1e6);
  EXPECT_EQ(parse_sample_rate("500 kHz"), 5e5);
  EXPECT_EQ(parse_sample_rate("8000000"), 8e6);
  EXPECT_EQ(parse_sample_rate("fast"), 0);
  EXPECT_EQ(parse_sample_rate("2 parsecs"), 0);
}

TEST(SigrokFile, BrainchildTwoByteSamplesOverThirtyChunks) {
  std::string error;
  auto f = SigrokFile::open(capture("sigrok-brainchild-io-16do/brainchild-io-16do.sr"), &error);
  ASSERT_TRUE(f) << error;
  EXPECT_EQ(f->sample_rate(), 1e6);
  ASSERT_EQ(f->channels().size(), 16u);
  EXPECT_EQ(f->channels()[0], "0");
  EXPECT_EQ(f->channels()[1], "1");
  const Read r = read_all(*f);
  EXPECT_EQ(r.samples, (29u * 20480u + 6080u) / 2u);  // unitsize 2
  // Inverted RS-232 side: both lines idle low; both carry traffic; the other 14 never move.
  EXPECT_EQ(r.first & 3, 0u);
  EXPECT_GT(r.edges[0], 100u);
  EXPECT_GT(r.edges[1], 100u);
  for (int b = 2; b < 16; ++b) EXPECT_EQ(r.edges[b], 0u) << b;
}

TEST(SigrokFile, NamedChannelsAndOneByteSamples) {
  std::string error;
  auto f = SigrokFile::open(capture("uart-phy/errors_ampel64_4800_8n1_ok.sr"), &error);
  ASSERT_TRUE(f) << error;
  EXPECT_EQ(f->sample_rate(), 2e6);
  ASSERT_EQ(f->channels().size(), 8u);
  EXPECT_EQ(f->channels()[3], "RX");
  EXPECT_EQ(f->channels()[4], "TX");
  const Read r = read_all(*f);
  // The traffic is on bit 4, named "TX" — as `sigrok-cli -O bits` shows it too (MANIFEST.md
  // calls it RX because sigrok's UART decoder was run with rx=RX and still found the bytes).
  EXPECT_EQ(r.first >> 4 & 1, 1u);  // idles high (normal polarity)
  EXPECT_GT(r.edges[4], 10u);
  EXPECT_EQ(r.edges[3], 0u);
}

TEST(SigrokFile, AnalogTraceIsThresholded) {
  std::string error;
  auto f = SigrokFile::open(capture("uart-phy/from_analog_uart_analog_10700_8n2.sr"), &error);
  ASSERT_TRUE(f) << error;
  EXPECT_TRUE(f->analog());
  EXPECT_EQ(f->sample_rate(), 8e6);
  ASSERT_EQ(f->channels().size(), 1u);
  EXPECT_EQ(f->channels()[0], "CH1");
  const Read r = read_all(*f);
  EXPECT_GT(r.samples, 100000u);
  EXPECT_GT(r.edges[0], 20u);  // bytes 0x1A..0x20 and 0x00 separators: many edges
}

TEST(SigrokFile, NotASessionFile) {
  std::string error;
  EXPECT_FALSE(SigrokFile::open(capture("session-e9/input.log"), &error));
  EXPECT_NE(error.find("session-e9/input.log: not a readable zip"), std::string::npos) << error;
  EXPECT_FALSE(SigrokFile::open("/nonexistent.sr", &error));
  EXPECT_NE(error.find("/nonexistent.sr: "), std::string::npos) << error;
}
