// Unit tests: hex text input for `drivetap decode`.
#include <gtest/gtest.h>

#include <cstdint>
#include <string>
#include <vector>

#include "core/byte_event.hpp"
#include "sources/file/hex_text.hpp"

using namespace drivetap;

using Frames = std::vector<std::vector<std::uint8_t>>;

namespace {

::testing::AssertionResult HasSub(const std::string& s, std::string_view sub) {
  if (s.find(sub) != std::string::npos) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << "'" << s << "' does not contain '" << sub << "'";
}

}  // namespace

TEST(HexText, OneFrameWithSpaces) {
  std::string err;
  auto f = parse_hex_frames("02 03 00 00 00 04 44 3A", &err);
  ASSERT_TRUE(f) << err;
  EXPECT_EQ(*f, (Frames{{0x02, 0x03, 0x00, 0x00, 0x00, 0x04, 0x44, 0x3A}}));
}

TEST(HexText, SpacesOptional) {
  std::string err;
  auto f = parse_hex_frames("0103000000018 40A", &err);
  // Digits pair up across spaces: 01 03 00 00 00 01 84 0A.
  ASSERT_TRUE(f) << err;
  EXPECT_EQ(*f, (Frames{{0x01, 0x03, 0x00, 0x00, 0x00, 0x01, 0x84, 0x0A}}));

  auto g = parse_hex_frames("010300000001840a", &err);
  ASSERT_TRUE(g) << err;
  EXPECT_EQ(*g, *f);

  auto tabs = parse_hex_frames("\t01\t03 \r", &err);
  ASSERT_TRUE(tabs) << err;
  EXPECT_EQ(*tabs, (Frames{{0x01, 0x03}}));
}

TEST(HexText, MixedCaseAndDashes) {
  std::string err;
  auto f = parse_hex_frames("aB-cD-eF", &err);
  ASSERT_TRUE(f) << err;
  EXPECT_EQ(*f, (Frames{{0xAB, 0xCD, 0xEF}}));
}

TEST(HexText, ZeroXPrefixes) {
  std::string err;
  auto f = parse_hex_frames("0x01 0x03 0X00 0x0A", &err);
  ASSERT_TRUE(f) << err;
  EXPECT_EQ(*f, (Frames{{0x01, 0x03, 0x00, 0x0A}}));

  auto mixed = parse_hex_frames("0x01 03 0x00", &err);
  ASSERT_TRUE(mixed) << err;
  EXPECT_EQ(*mixed, (Frames{{0x01, 0x03, 0x00}}));

  // A prefix on every byte, written together.
  auto joined = parse_hex_frames("0x010x030x00", &err);
  ASSERT_TRUE(joined) << err;
  EXPECT_EQ(*joined, (Frames{{0x01, 0x03, 0x00}}));
}

TEST(HexText, Separators) {
  std::string err;
  auto f = parse_hex_frames("01 03 | 02 04, 05;06\n07 08\r\n09", &err);
  ASSERT_TRUE(f) << err;
  ASSERT_EQ(f->size(), 6u);
  EXPECT_EQ((*f)[0], (std::vector<std::uint8_t>{0x01, 0x03}));
  EXPECT_EQ((*f)[1], (std::vector<std::uint8_t>{0x02, 0x04}));
  EXPECT_EQ((*f)[2], (std::vector<std::uint8_t>{0x05}));
  EXPECT_EQ((*f)[3], (std::vector<std::uint8_t>{0x06}));
  EXPECT_EQ((*f)[4], (std::vector<std::uint8_t>{0x07, 0x08}));
  EXPECT_EQ((*f)[5], (std::vector<std::uint8_t>{0x09}));
}

TEST(HexText, EmptyFramesBetweenSeparatorsAreDropped) {
  std::string err;
  auto f = parse_hex_frames("|| 01 ;;\n\n 02 ,", &err);
  ASSERT_TRUE(f) << err;
  EXPECT_EQ(*f, (Frames{{0x01}, {0x02}}));
}

TEST(HexText, OddDigitCount) {
  std::string err;
  EXPECT_FALSE(parse_hex_frames("01 03 0", &err));
  EXPECT_TRUE(HasSub(err, "odd number of hex digits")) << err;
  EXPECT_TRUE(HasSub(err, "position 7")) << err;

  // An odd count inside one frame is reported at the separator, naming the lone digit.
  err.clear();
  EXPECT_FALSE(parse_hex_frames("01 0A3 | 02 03", &err));
  EXPECT_TRUE(HasSub(err, "odd number of hex digits")) << err;
  EXPECT_TRUE(HasSub(err, "'3' at position 6")) << err;
}

TEST(HexText, NonHexCharacter) {
  std::string err;
  EXPECT_FALSE(parse_hex_frames("01 03 0G 00", &err));
  EXPECT_TRUE(HasSub(err, "'G' at position 8 is not a hex digit")) << err;

  err.clear();
  EXPECT_FALSE(parse_hex_frames("z1", &err));
  EXPECT_TRUE(HasSub(err, "'z' at position 1")) << err;

  err.clear();
  EXPECT_FALSE(parse_hex_frames("01 x3", &err));  // 'x' without its leading 0
  EXPECT_TRUE(HasSub(err, "'x' at position 4")) << err;
}

TEST(HexText, EmptyInput) {
  std::string err;
  EXPECT_FALSE(parse_hex_frames("", &err));
  EXPECT_EQ(err, "no hex bytes given");

  err.clear();
  EXPECT_FALSE(parse_hex_frames("  | , ;\n ", &err));
  EXPECT_EQ(err, "no hex bytes given");
}

TEST(HexText, SynthesizeEventsSpacing) {
  const Frames frames = {{0x01, 0x03, 0x00}, {0x01, 0x83}};
  std::vector<ByteEvent> out;
  TimeNs clock = 0;
  synthesize_events(frames, 2, 1000, 5000, &clock, out);
  ASSERT_EQ(out.size(), 5u);
  const TimeNs want_time[] = {0, 1000, 2000, 8000, 9000};
  const std::uint8_t want_byte[] = {0x01, 0x03, 0x00, 0x01, 0x83};
  for (std::size_t i = 0; i < out.size(); ++i) {
    EXPECT_EQ(out[i].time, want_time[i]) << i;
    EXPECT_EQ(out[i].byte, want_byte[i]) << i;
    EXPECT_EQ(out[i].channel, 2) << i;
    EXPECT_EQ(out[i].flags, 0) << i;
  }
  // The clock ends after the last frame and its gap, ready for the next call.
  EXPECT_EQ(clock, 15000);
}

TEST(HexText, SynthesizeEventsAppendsFromTheClock) {
  std::vector<ByteEvent> out(1);
  TimeNs clock = 100;
  synthesize_events({{0xAA}}, 0, 10, 40, &clock, out);
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[1].time, 100);
  EXPECT_EQ(out[1].byte, 0xAA);
  EXPECT_EQ(clock, 150);

  synthesize_events({}, 0, 10, 40, &clock, out);
  EXPECT_EQ(out.size(), 2u);
  EXPECT_EQ(clock, 150);
}

// The forms people paste a telegram in: a C array (commas between bytes), braces, Intel's `h`.
// Commas between frames of several bytes still separate frames.
TEST(HexText, PastedArraysAndSuffixes) {
  const Frames one = {{0x02, 0x03, 0x00, 0x00, 0x00, 0x04, 0x44, 0x3A}};
  for (const char* text :
       {"0x02,0x03,0x00,0x00,0x00,0x04,0x44,0x3A", "0x02, 0x03, 0x00, 0x00, 0x00, 0x04, 0x44, 0x3A",
        "{0x02, 0x03, 0x00, 0x00, 0x00, 0x04, 0x44, 0x3A}", "[02,03,00,00,00,04,44,3A]",
        "02h 03h 00h 00h 00h 04h 44h 3Ah", "02H,03H,00H,00H,00H,04H,44H,3AH"}) {
    std::string err;
    const auto f = parse_hex_frames(text, &err);
    ASSERT_TRUE(f) << text << ": " << err;
    EXPECT_EQ(*f, one) << text;
  }
  std::string err;
  const auto two = parse_hex_frames("{0x01, 0x03}, {0x02, 0x04}", &err);
  ASSERT_TRUE(two) << err;
  EXPECT_EQ(*two, (Frames{{0x01, 0x03}, {0x02, 0x04}}));
  const auto frames = parse_hex_frames("01 03 00 00 00 01 84 0A, 01 03 02 00 2A 38 4B", &err);
  ASSERT_TRUE(frames) << err;
  EXPECT_EQ(frames->size(), 2u);
  // An `h` that ends no byte is no suffix.
  EXPECT_FALSE(parse_hex_frames("0h2", &err));
}
