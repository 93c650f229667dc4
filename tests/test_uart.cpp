// Unit tests: the UART decoder over logic levels and the line simulator that feeds it
// (docs/protocols.md §1 line settings, swapped A/B wires).
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "sources/logic/line_sim.hpp"
#include "sources/logic/uart_decoder.hpp"

using namespace drivetap;
using namespace drivetap::phy;

namespace {

constexpr std::uint64_t k1MHz = 1'000'000;

UartSettings format(double baud, std::uint8_t data_bits, UartParity parity, StopBits stop_bits) {
  UartSettings s;
  s.baud = baud;
  s.data_bits = data_bits;
  s.parity = parity;
  s.stop_bits = stop_bits;
  return s;
}

const UartSettings k9600_8N1 = format(9600, 8, UartParity::none, StopBits::one);

std::vector<std::uint8_t> random_bytes(std::size_t count, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::vector<std::uint8_t> bytes(count);
  for (std::uint8_t& b : bytes) b = static_cast<std::uint8_t>(rng() & 0xFF);
  return bytes;
}

LineSimSettings line(const UartSettings& uart, std::uint64_t sample_rate_hz = k1MHz) {
  LineSimSettings s;
  s.uart = uart;
  s.sample_rate_hz = sample_rate_hz;
  return s;
}

// A line of the given bytes: idle, the bytes with `gap` bit times between them, idle.
LineSimulator simulate(const LineSimSettings& settings, const std::vector<std::uint8_t>& bytes,
                       double gap = 0) {
  LineSimulator sim(settings);
  sim.idle(20);
  sim.send(bytes, gap);
  sim.idle(20);
  return sim;
}

std::vector<UartCharacter> decode(const std::vector<LevelRun>& runs, const UartSettings& settings,
                                  std::uint64_t sample_rate_hz = k1MHz) {
  return decode_runs(runs, settings, sample_rate_hz);
}

// Sent characters that did not come out as themselves, clean, in their place (plus any count
// difference): 0 for a perfect decode.
std::size_t wrong_characters(const std::vector<SimulatedCharacter>& sent,
                             const std::vector<UartCharacter>& got) {
  std::size_t wrong =
      sent.size() > got.size() ? sent.size() - got.size() : got.size() - sent.size();
  for (std::size_t i = 0; i < std::min(sent.size(), got.size()); ++i)
    wrong += got[i].value != sent[i].value || got[i].flags != 0;
  return wrong;
}

std::size_t count_flag(const std::vector<UartCharacter>& chars, std::uint8_t flag) {
  std::size_t n = 0;
  for (const UartCharacter& c : chars) n += (c.flags & flag) != 0;
  return n;
}

}  // namespace

// --- Round trips: simulator -> decoder --------------------------------------------------------

struct RoundTripFormat {
  const char* name;
  std::uint8_t data_bits;
  UartParity parity;
  StopBits stop_bits;
};

const RoundTripFormat kRoundTripFormats[] = {
    {"8N1", 8, UartParity::none, StopBits::one},
    {"8E1", 8, UartParity::even, StopBits::one},
    {"7O1", 7, UartParity::odd, StopBits::one},
    {"8N2", 8, UartParity::none, StopBits::two},
};

class UartRoundTrip
    : public ::testing::TestWithParam<std::tuple<RoundTripFormat, double, std::uint64_t>> {};

TEST_P(UartRoundTrip, RandomBytesDecodeExactlyWithSampleAccurateStarts) {
  const auto& [fmt, baud, rate] = GetParam();
  const UartSettings uart = format(baud, fmt.data_bits, fmt.parity, fmt.stop_bits);
  LineSimulator sim(line(uart, rate));
  // Gaps of 0 to 2.8 bit times: back-to-back characters re-synchronise on each start edge.
  std::mt19937 rng(1234);
  sim.idle(15);
  for (std::uint8_t b : random_bytes(300, 42)) {
    sim.idle((rng() % 5) * 0.7);
    sim.send(b);
  }
  sim.idle(15);

  UartDecoder decoder(uart, rate);
  std::vector<UartCharacter> got;
  decoder.push_runs(sim.runs(), got);
  decoder.finish(got);

  const auto& sent = sim.characters();
  ASSERT_EQ(got.size(), sent.size());
  for (std::size_t i = 0; i < sent.size(); ++i) {
    SCOPED_TRACE(i);
    EXPECT_EQ(got[i].value, sent[i].value);
    EXPECT_EQ(got[i].flags, 0);
    EXPECT_EQ(got[i].glitches, 0u);
    // The first low sample is the one at or after the true edge.
    EXPECT_GE(static_cast<double>(got[i].start_sample), sent[i].start_time);
    EXPECT_LT(static_cast<double>(got[i].start_sample), sent[i].start_time + 1.0);
    EXPECT_NEAR(static_cast<double>(got[i].end_sample), sent[i].end_time, 1.5);
  }
  EXPECT_EQ(decoder.stats().characters, sent.size());
  EXPECT_EQ(decoder.stats().false_starts, 0u);
  EXPECT_EQ(decoder.stats().glitches, 0u);
}

INSTANTIATE_TEST_SUITE_P(FormatsBaudsSampleRates, UartRoundTrip,
                         ::testing::Combine(::testing::ValuesIn(kRoundTripFormats),
                                            ::testing::Values(9600.0, 115200.0),
                                            ::testing::Values(std::uint64_t{1'000'000},
                                                              std::uint64_t{2'000'000},
                                                              std::uint64_t{8'000'000})),
                         [](const auto& info) {
                           return std::string(std::get<0>(info.param).name) + "_" +
                                  std::to_string(static_cast<int>(std::get<1>(info.param))) + "_" +
                                  std::to_string(std::get<2>(info.param) / 1'000'000) + "MHz";
                         });

TEST(UartDecoder, UnusualFormatsRoundTrip) {
  const UartSettings formats[] = {
      format(9600, 5, UartParity::none, StopBits::one_and_half),
      format(9600, 9, UartParity::none, StopBits::one),
      format(19200, 8, UartParity::mark, StopBits::one),
      format(19200, 8, UartParity::space, StopBits::two),
      format(9600, 6, UartParity::even, StopBits::one_and_half),
  };
  for (const UartSettings& uart : formats) {
    SCOPED_TRACE(uart.data_bits);
    LineSimulator sim(line(uart));
    sim.idle(10);
    std::mt19937 rng(7);
    for (int i = 0; i < 200; ++i) sim.send(static_cast<std::uint16_t>(rng() & 0x1FF));
    sim.idle(10);
    const auto got = decode(sim.runs(), uart);
    EXPECT_EQ(wrong_characters(sim.characters(), got), 0u);
  }
}

// The simulator and the decoder share parity_bit(): checked here against the definition, the
// ones counted bit by bit, so that a wrong bit cannot hide behind a round trip.
TEST(UartParity, ParityBitMakesTheOnesEvenOrOddOrIsFixed) {
  for (unsigned value = 0; value < 512; ++value) {
    SCOPED_TRACE(value);
    unsigned ones = 0;
    for (unsigned bits = value; bits != 0; bits >>= 1) ones += bits & 1u;
    const auto v = static_cast<std::uint16_t>(value);
    EXPECT_EQ((ones + parity_bit(UartParity::even, v)) % 2, 0u);
    EXPECT_EQ((ones + parity_bit(UartParity::odd, v)) % 2, 1u);
    EXPECT_TRUE(parity_bit(UartParity::mark, v));
    EXPECT_FALSE(parity_bit(UartParity::space, v));
    EXPECT_FALSE(parity_bit(UartParity::none, v));
  }
  // 'A' (0x41) has two ones: even parity sends 0, odd parity 1.
  EXPECT_FALSE(parity_bit(UartParity::even, 0x41));
  EXPECT_TRUE(parity_bit(UartParity::odd, 0x41));
}

TEST(UartDecoder, MarkAndSpaceParityMistakenForEachOtherFailEveryCharacter) {
  for (auto [sent_parity, read_parity] : {std::pair{UartParity::mark, UartParity::space},
                                          std::pair{UartParity::space, UartParity::mark}}) {
    const auto sim =
        simulate(line(format(19200, 8, sent_parity, StopBits::one)), random_bytes(50, 3), 1);
    const auto got = decode(sim.runs(), format(19200, 8, read_parity, StopBits::one));
    ASSERT_EQ(got.size(), 50u);
    EXPECT_EQ(count_flag(got, kUartParityError), 50u);
    EXPECT_EQ(count_flag(got, kUartFramingError), 0u);
  }
}

TEST(UartDecoder, NonStandardBaud10700With8N2) {
  const UartSettings uart = format(10700, 8, UartParity::none, StopBits::two);
  const auto sim = simulate(line(uart), random_bytes(500, 10700));  // back to back: drift shows
  const auto got = decode(sim.runs(), uart);
  ASSERT_EQ(got.size(), 500u);
  EXPECT_EQ(wrong_characters(sim.characters(), got), 0u);
  // The same line read at the nearest standard rate falls apart.
  UartSettings standard = uart;
  standard.baud = 9600;
  EXPECT_GT(wrong_characters(sim.characters(), decode(sim.runs(), standard)), 250u);
}

// --- Wrong settings ---------------------------------------------------------------------------

TEST(UartDecoder, InvertedLineDecodesWithInversion) {
  UartSettings uart = k9600_8N1;
  uart.inverted = true;
  const auto sim = simulate(line(uart), random_bytes(200, 5), 3);
  // Idle low on the wire.
  const auto runs = sim.runs();
  ASSERT_FALSE(runs.front().level);
  const auto got = decode(runs, uart);
  EXPECT_EQ(wrong_characters(sim.characters(), got), 0u);
}

TEST(UartDecoder, InvertedLineWithoutInversionGivesFramingErrorsAndBreaks) {
  UartSettings wire = k9600_8N1;
  wire.inverted = true;
  const auto bytes = random_bytes(200, 5);
  const auto sim = simulate(line(wire), bytes, 3);
  const auto got = decode(sim.runs(), k9600_8N1);
  ASSERT_FALSE(got.empty());
  const std::size_t bad = count_flag(got, kUartFramingError | kUartBreak);
  // What docs/protocols.md §1 describes for swapped wires: mostly framing errors and breaks.
  EXPECT_GT(bad, got.size() / 2);
  EXPECT_GT(count_flag(got, kUartFramingError), 0u);
  EXPECT_GT(wrong_characters(sim.characters(), got), 150u);
}

TEST(UartDecoder, ExtraStopBitReadAsEvenParityFailsOnAboutHalfOfRandomBytes) {
  // 8N2 read as 8E1: the first stop bit (always 1) is taken for the parity bit, which is right
  // for bytes with an odd number of ones only.
  const auto sim =
      simulate(line(format(9600, 8, UartParity::none, StopBits::two)), random_bytes(400, 9), 1);
  const auto got = decode(sim.runs(), format(9600, 8, UartParity::even, StopBits::one));
  ASSERT_EQ(got.size(), 400u);
  const std::size_t parity_errors = count_flag(got, kUartParityError);
  EXPECT_GT(parity_errors, 140u);
  EXPECT_LT(parity_errors, 260u);
  EXPECT_EQ(count_flag(got, kUartFramingError), 0u);
  for (std::size_t i = 0; i < got.size(); ++i) {
    EXPECT_EQ(got[i].value, sim.characters()[i].value);
    const bool odd_ones = std::popcount(got[i].value) % 2 == 1;
    EXPECT_EQ((got[i].flags & kUartParityError) != 0, !odd_ones) << i;
  }
}

TEST(UartDecoder, OddParityReadAsEvenIsAParityErrorOnEveryByte) {
  const auto sim =
      simulate(line(format(9600, 8, UartParity::odd, StopBits::one)), random_bytes(100, 11), 2);
  const auto got = decode(sim.runs(), format(9600, 8, UartParity::even, StopBits::one));
  ASSERT_EQ(got.size(), 100u);
  EXPECT_EQ(count_flag(got, kUartParityError), 100u);
}

TEST(UartDecoder, OnlyTheFirstStopBitDecidesAFramingErrorLaterOnesAreCounted) {
  // 8N1 back to back has no second stop bit: the next start bit is where it should be. Like a
  // 16550 (and sigrok), the decoder accepts it without error but counts the short stops; with a
  // gap of one bit time between characters the same traffic fits 8N2 (and 8N1.5).
  const auto bytes = random_bytes(100, 15);
  const auto back_to_back = simulate(line(k9600_8N1), bytes, 0);
  const auto spaced = simulate(line(k9600_8N1), bytes, 1);
  for (StopBits stop_bits : {StopBits::two, StopBits::one_and_half}) {
    const UartSettings read_as = format(9600, 8, UartParity::none, stop_bits);
    SCOPED_TRACE(read_as.frame_bits());
    UartDecoder decoder(read_as, k1MHz);
    std::vector<UartCharacter> got;
    decoder.push_runs(back_to_back.runs(), got);
    decoder.finish(got);
    ASSERT_EQ(got.size(), 100u);
    EXPECT_EQ(count_flag(got, kUartFramingError), 0u);
    EXPECT_EQ(decoder.stats().short_stop_bits, 99u);  // all but the last
    for (std::size_t i = 0; i < got.size(); ++i) {
      // The next start bit still re-synchronises the receiver, and ends the character.
      EXPECT_EQ(got[i].value, bytes[i]);
      if (i + 1 < got.size()) {
        EXPECT_EQ(got[i].end_sample, got[i + 1].start_sample);
      }
    }
    UartDecoder spaced_decoder(read_as, k1MHz);
    std::vector<UartCharacter> spaced_got;
    spaced_decoder.push_runs(spaced.runs(), spaced_got);
    spaced_decoder.finish(spaced_got);
    EXPECT_EQ(wrong_characters(spaced.characters(), spaced_got), 0u);
    EXPECT_EQ(spaced_decoder.stats().short_stop_bits, 0u);
  }
  // A low first stop bit is a framing error whatever the number of stop bits.
  const auto got = decode(back_to_back.runs(), format(9600, 8, UartParity::even, StopBits::two));
  EXPECT_GT(count_flag(got, kUartFramingError), 20u);
}

TEST(UartDecoder, DecodingAtTwiceTheBaudRateGivesFramingErrors) {
  const auto sim = simulate(line(k9600_8N1), random_bytes(200, 13));
  UartSettings twice = k9600_8N1;
  twice.baud = 19200;
  const auto got = decode(sim.runs(), twice);
  ASSERT_FALSE(got.empty());
  EXPECT_GT(count_flag(got, kUartFramingError), got.size() / 4);
  EXPECT_GT(wrong_characters(sim.characters(), got), 150u);
}

// --- Transmitter clock error ------------------------------------------------------------------

struct BaudErrorCase {
  double percent;
  UartSettings uart;
  std::uint64_t rate;
};

TEST(UartDecoder, TwoPercentBaudErrorStillDecodesCleanly) {
  for (const BaudErrorCase& c : {
           BaudErrorCase{+2, k9600_8N1, k1MHz},
           BaudErrorCase{-2, k9600_8N1, k1MHz},
           BaudErrorCase{+2, format(115200, 8, UartParity::even, StopBits::one), 8 * k1MHz},
           BaudErrorCase{-2, format(115200, 8, UartParity::even, StopBits::one), 8 * k1MHz},
           BaudErrorCase{+2, format(115200, 8, UartParity::none, StopBits::one), k1MHz},
           BaudErrorCase{-2, format(115200, 8, UartParity::none, StopBits::one), k1MHz},
       }) {
    SCOPED_TRACE(testing::Message() << c.percent << "% at " << c.uart.baud);
    LineSimSettings settings = line(c.uart, c.rate);
    settings.baud_error_percent = c.percent;
    const auto sim = simulate(settings, random_bytes(300, 17));  // back to back: the worst case
    EXPECT_EQ(wrong_characters(sim.characters(), decode(sim.runs(), c.uart, c.rate)), 0u);
  }
}

TEST(UartDecoder, SixPercentBaudErrorFails) {
  for (double percent : {+6.0, -6.0}) {
    SCOPED_TRACE(percent);
    LineSimSettings settings = line(k9600_8N1);
    settings.baud_error_percent = percent;
    const auto sim = simulate(settings, random_bytes(300, 17));
    const auto got = decode(sim.runs(), k9600_8N1);
    EXPECT_GT(wrong_characters(sim.characters(), got), 120u);
    EXPECT_GT(count_flag(got, kUartFramingError), 50u);
  }
}

// --- Noise ------------------------------------------------------------------------------------

namespace {

// A line of bytes with a glitch of `width` samples centred on each character's stop bit and on
// its data bit 3.
LineSimulator glitched_line(std::uint64_t width, const std::vector<std::uint8_t>& bytes) {
  LineSimulator sim = simulate(line(k9600_8N1), bytes, 2);
  const double bit = sim.samples_per_bit();
  const std::vector<SimulatedCharacter> sent = sim.characters();
  for (const SimulatedCharacter& c : sent) {
    for (double centre : {c.start_time + 9.5 * bit, c.start_time + 4.5 * bit})
      sim.add_glitch(static_cast<std::uint64_t>(std::llround(centre - width / 2.0)), width);
  }
  return sim;
}

}  // namespace

TEST(UartDecoder, GlitchesShorterThanTheFilterAreIgnoredAndCounted) {
  UartDecoder probe(k9600_8N1, k1MHz);
  ASSERT_EQ(probe.glitch_filter_samples(), 13u);  // 1/8 of 104.2 samples
  const auto bytes = random_bytes(100, 19);
  const auto sim = glitched_line(12, bytes);
  UartDecoder decoder(k9600_8N1, k1MHz);
  std::vector<UartCharacter> got;
  decoder.push_runs(sim.runs(), got);
  decoder.finish(got);
  EXPECT_EQ(wrong_characters(sim.characters(), got), 0u);
  for (const UartCharacter& c : got) EXPECT_EQ(c.glitches, 2u);
  EXPECT_EQ(decoder.stats().glitches, 200u);
}

TEST(UartDecoder, GlitchesLongerThanTheFilterCorruptBitsAndStopBits) {
  const auto bytes = random_bytes(100, 19);
  const auto sim = glitched_line(30, bytes);
  const auto got = decode(sim.runs(), k9600_8N1);
  ASSERT_EQ(got.size(), bytes.size());
  for (std::size_t i = 0; i < got.size(); ++i) {
    EXPECT_EQ(got[i].value, bytes[i] ^ 0x08) << i;  // data bit 3 flipped
    EXPECT_EQ(got[i].flags, kUartFramingError) << i;
    EXPECT_EQ(got[i].glitches, 0u);
  }
  // The same line with a filter longer than the glitches is clean. Not much longer: a 104-sample
  // bit with a 30-sample glitch in its middle is two 37-sample pulses, which a 40-sample filter
  // would remove as well.
  UartSettings filtered = k9600_8N1;
  filtered.glitch_filter_samples = 32;
  EXPECT_EQ(wrong_characters(sim.characters(), decode(sim.runs(), filtered)), 0u);
}

TEST(UartDecoder, SpikesOnTheIdleLine) {
  struct Case {
    std::uint64_t width;
    std::size_t characters, glitches, false_starts;
  };
  // Under the filter: noise. Under half a bit: a start bit gone at its centre (false start).
  // Longer: a phantom character, all ones after the start bit, as a UART would receive it.
  for (const Case& c : {Case{12, 0, 1, 0}, Case{30, 0, 0, 1}, Case{80, 1, 0, 0}}) {
    SCOPED_TRACE(c.width);
    LineSimulator sim(line(k9600_8N1));
    sim.idle(50);
    sim.add_glitch(2000, c.width);
    UartDecoder decoder(k9600_8N1, k1MHz);
    std::vector<UartCharacter> got;
    decoder.push_runs(sim.runs(), got);
    decoder.finish(got);
    ASSERT_EQ(got.size(), c.characters);
    EXPECT_EQ(decoder.stats().glitches, c.glitches);
    EXPECT_EQ(decoder.stats().false_starts, c.false_starts);
    if (!got.empty()) {
      EXPECT_EQ(got[0].value, 0xFF);
      EXPECT_EQ(got[0].start_sample, 2000u);
    }
  }
}

TEST(UartDecoder, RandomGlitchesUnderTheFilterLeaveTheDataIntact) {
  LineSimSettings settings = line(k9600_8N1);
  settings.seed = 99;
  LineSimulator sim = simulate(settings, random_bytes(300, 23), 1.5);
  sim.add_random_glitches(2000, 6);  // about 2000 per second of line: several per character
  UartDecoder decoder(k9600_8N1, k1MHz);
  std::vector<UartCharacter> got;
  decoder.push_runs(sim.runs(), got);
  decoder.finish(got);
  EXPECT_EQ(wrong_characters(sim.characters(), got), 0u);
  // A glitch landing on an edge only moves it; every other one is counted.
  EXPECT_GT(decoder.stats().glitches, 500u);
}

// --- Breaks -----------------------------------------------------------------------------------

TEST(UartDecoder, BreakIsReportedOnceThenDecodingResumes) {
  for (double break_bits : {12.0, 15.0, 19.0}) {
    SCOPED_TRACE(break_bits);
    LineSimulator sim(line(k9600_8N1));
    sim.idle(20);
    sim.send(0x01);
    sim.send(0x02);
    sim.idle(5);
    sim.send_break(break_bits);
    sim.idle(2);
    sim.send(0x55);
    sim.send(0xAA);
    sim.idle(20);
    UartDecoder decoder(k9600_8N1, k1MHz);
    std::vector<UartCharacter> got;
    decoder.push_runs(sim.runs(), got);
    decoder.finish(got);
    ASSERT_EQ(got.size(), 5u);
    EXPECT_EQ(got[0].value, 0x01);
    EXPECT_EQ(got[1].value, 0x02);
    EXPECT_EQ(got[2].flags, kUartBreak);
    EXPECT_EQ(got[2].value, 0);
    EXPECT_NEAR(static_cast<double>(got[2].start_sample), sim.breaks()[0].start_time, 1.0);
    EXPECT_EQ(got[3].value, 0x55);
    EXPECT_EQ(got[4].value, 0xAA);
    for (std::size_t i : {0u, 1u, 3u, 4u}) EXPECT_EQ(got[i].flags, 0) << i;
    EXPECT_EQ(decoder.stats().breaks, 1u);
    EXPECT_EQ(decoder.stats().rests_at_space, 0u);
  }
}

// Low for kRestCharacters character times or more: the line at rest (an unbiased pair between
// transmitters), not a character. Counted, not reported, and decoding resumes after it.
TEST(UartDecoder, LongLowIsTheLineAtRestNotABreak) {
  for (double low_bits : {20.0, 40.0, 1000.0}) {
    SCOPED_TRACE(low_bits);
    LineSimulator sim(line(k9600_8N1));
    sim.idle(20);
    sim.send(0x01);
    sim.send_break(low_bits);
    sim.idle(1.5);
    sim.send(0x55);
    sim.idle(20);
    UartDecoder decoder(k9600_8N1, k1MHz);
    std::vector<UartCharacter> got;
    decoder.push_runs(sim.runs(), got);
    decoder.finish(got);
    ASSERT_EQ(got.size(), 2u);
    EXPECT_EQ(got[0].value, 0x01);
    EXPECT_EQ(got[1].value, 0x55);
    EXPECT_EQ(got[1].flags, 0);
    EXPECT_EQ(decoder.stats().breaks, 0u);
    EXPECT_EQ(decoder.stats().rests_at_space, 1u);
    EXPECT_EQ(decoder.stats().characters, 2u);
  }
}

TEST(UartDecoder, RestIsKnownWithoutWaitingForTheLineToRise) {
  LineSimulator sim(line(k9600_8N1));
  sim.idle(20);
  sim.send_break(500);  // the capture ends while the line is still low
  const auto runs = sim.runs();
  ASSERT_FALSE(runs.back().level);
  UartDecoder decoder(k9600_8N1, k1MHz);
  std::vector<UartCharacter> got;
  decoder.push_runs(runs, got);
  EXPECT_EQ(decoder.stats().rests_at_space, 1u);  // before finish(): a live capture knows
  decoder.finish(got);
  EXPECT_TRUE(got.empty());
  EXPECT_EQ(decoder.stats().rests_at_space, 1u);
}

TEST(UartDecoder, BreakCutByTheEndOfTheCaptureIsReported) {
  LineSimulator sim(line(k9600_8N1));
  sim.idle(20);
  sim.send_break(15);  // the capture ends 1.5 characters into the low
  UartDecoder decoder(k9600_8N1, k1MHz);
  std::vector<UartCharacter> got;
  auto runs = sim.runs();
  ASSERT_FALSE(runs.back().level);
  decoder.push_runs(runs, got);
  EXPECT_TRUE(got.empty());  // a break or the line at rest: not known yet
  decoder.finish(got);
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0].flags, kUartBreak);
}

TEST(UartDecoder, ZeroByteIsNotABreak) {
  // 0x00 is low for 9 bits; the stop bit is high, so it is a character.
  const auto sim = simulate(line(k9600_8N1), {0x00, 0x00, 0x00});
  const auto got = decode(sim.runs(), k9600_8N1);
  ASSERT_EQ(got.size(), 3u);
  for (const UartCharacter& c : got) EXPECT_EQ(c.flags, 0);
}

// --- Streaming --------------------------------------------------------------------------------

TEST(UartDecoder, RunsSplitAnywhereDecodeTheSame) {
  LineSimulator sim = simulate(line(k9600_8N1), random_bytes(100, 29), 1);
  sim.add_random_glitches(1000, 9);
  sim.add_random_glitches(300, 25);
  const auto runs = sim.runs();
  UartDecoder whole_decoder(k9600_8N1, k1MHz);
  std::vector<UartCharacter> whole;
  whole_decoder.push_runs(runs, whole);
  whole_decoder.finish(whole);
  ASSERT_GT(whole.size(), 90u);

  // Each run cut into up to four pieces, as a reader's chunk boundaries would cut it.
  std::mt19937 rng(31);
  UartDecoder split_decoder(k9600_8N1, k1MHz);
  std::vector<UartCharacter> split;
  for (const LevelRun& r : runs) {
    std::uint64_t left = r.length;
    while (left > 0) {
      const std::uint64_t piece = std::min<std::uint64_t>(left, 1 + rng() % 60);
      split_decoder.push_run(r.level, piece, split);
      left -= piece;
    }
  }
  split_decoder.finish(split);
  EXPECT_EQ(split, whole);
  EXPECT_EQ(split_decoder.stats().glitches, whole_decoder.stats().glitches);

  // And sample by sample, through the bool expansion.
  EXPECT_EQ(runs_from_samples(expand_to_samples(runs)), runs);
  UartDecoder sample_decoder(k9600_8N1, k1MHz);
  std::vector<UartCharacter> by_sample;
  for (bool s : expand_to_samples(runs)) sample_decoder.push_run(s, 1, by_sample);
  sample_decoder.finish(by_sample);
  EXPECT_EQ(by_sample, whole);
}

TEST(UartDecoder, FinishDropsACharacterTheCaptureCutAndCountsIt) {
  LineSimulator sim(line(k9600_8N1));
  sim.idle(20);
  sim.send(0x0F);
  // Keep the samples up to 6.6 bit times after the start edge: data bits 0..5 seen, 6 and 7 not.
  // The recording ended, the line did not fail: sigrok shows nothing there either.
  const auto start = static_cast<std::uint64_t>(std::ceil(sim.characters()[0].start_time));
  const auto cut = start + static_cast<std::uint64_t>(6.6 * sim.samples_per_bit());
  auto samples = expand_to_samples(sim.runs());
  samples.resize(cut);
  UartDecoder decoder(k9600_8N1, k1MHz);
  std::vector<UartCharacter> got;
  decoder.push_runs(runs_from_samples(samples), got);
  EXPECT_TRUE(got.empty());
  decoder.finish(got);
  EXPECT_TRUE(got.empty());
  EXPECT_EQ(decoder.stats().cut_by_end, 1u);
  EXPECT_EQ(decoder.stats().framing_errors, 0u);
}

TEST(UartDecoder, FinishDropsAnEdgeWhoseStartBitWasNeverSampled) {
  UartDecoder decoder(k9600_8N1, k1MHz);
  std::vector<UartCharacter> got;
  decoder.push_run(true, 1000, got);
  decoder.push_run(false, 30, got);  // less than half a bit before the capture ends
  decoder.finish(got);
  EXPECT_TRUE(got.empty());
}

TEST(UartDecoder, FinishCountsAPulseCutByTheEndAsAGlitch) {
  UartDecoder decoder(k9600_8N1, k1MHz);
  std::vector<UartCharacter> got;
  decoder.push_run(true, 1000, got);
  decoder.push_run(false, 5, got);  // shorter than the 13-sample filter when the capture ends
  EXPECT_EQ(decoder.stats().glitches, 0u);
  decoder.finish(got);
  EXPECT_TRUE(got.empty());
  EXPECT_EQ(decoder.stats().glitches, 1u);
  EXPECT_EQ(decoder.stats().false_starts, 0u);
}

TEST(UartDecoder, CaptureStartingLowDoesNotStartACharacter) {
  // The analyser started in the middle of a character: the first low stretch ends, and only the
  // next real start edge counts.
  const auto sim = simulate(line(k9600_8N1), {0x41});
  std::vector<LevelRun> runs = {{false, 300}, {true, 700}};
  for (const LevelRun& r : sim.runs()) runs.push_back(r);
  const auto got = decode(runs, k9600_8N1);
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0].value, 0x41);
  EXPECT_EQ(got[0].flags, 0);
}

// --- Line simulator ---------------------------------------------------------------------------

TEST(LineSim, JitteredEdgesStillDecodeWithStartsOnTheJitteredEdge) {
  LineSimSettings settings = line(format(115200, 8, UartParity::even, StopBits::one), 8 * k1MHz);
  settings.edge_jitter_bits = 0.15;
  settings.seed = 2024;
  const auto sim = simulate(settings, random_bytes(300, 37), 1);
  const auto got = decode(sim.runs(), settings.uart, settings.sample_rate_hz);
  ASSERT_EQ(wrong_characters(sim.characters(), got), 0u);
  double largest_shift = 0;
  for (std::size_t i = 0; i < got.size(); ++i) {
    const double start = sim.characters()[i].start_time;
    EXPECT_NEAR(static_cast<double>(got[i].start_sample), start, 1.0) << i;
    const double nominal = std::round(start / sim.samples_per_bit()) * sim.samples_per_bit();
    largest_shift = std::max(largest_shift, std::abs(start - nominal));
  }
  EXPECT_GT(largest_shift, 0.05 * sim.samples_per_bit());  // the jitter did move edges
}

TEST(LineSim, SameSeedSameLineOtherSeedOtherLine) {
  LineSimSettings settings = line(k9600_8N1);
  settings.edge_jitter_bits = 0.2;
  settings.seed = 5;
  auto make = [&] {
    LineSimulator sim = simulate(settings, random_bytes(20, 1));
    sim.add_random_glitches(500, 4);
    return sim.runs();
  };
  const auto first = make();
  EXPECT_EQ(make(), first);
  settings.seed = 6;
  EXPECT_NE(make(), first);
}

TEST(LineSim, CharacterWaveformIsExact) {
  // 0x35 = 0b00110101 at 100 kbaud sampled at 1 MHz: 10 samples per bit, LSB first.
  LineSimulator sim(line(format(100'000, 8, UartParity::even, StopBits::one)));
  sim.idle(1);
  sim.send(0x35);  // four ones: even parity bit 0
  const std::vector<LevelRun> expected = {
      {true, 10},  {false, 10},                                       // idle, start
      {true, 10},  {false, 10}, {true, 10}, {false, 10}, {true, 20},  // 1 0 1 0 1 1
      {false, 30},                                                    // bits 6, 7, parity
      {true, 10},                                                     // stop
  };
  EXPECT_EQ(sim.runs(), expected);
  ASSERT_EQ(sim.characters().size(), 1u);
  EXPECT_DOUBLE_EQ(sim.characters()[0].start_time, 10.0);
  EXPECT_DOUBLE_EQ(sim.characters()[0].end_time, 120.0);
}

TEST(LineSim, GlitchFlipsTheLineWhereverItIs) {
  LineSimulator sim(line(format(100'000, 8, UartParity::none, StopBits::one)));
  sim.idle(1);
  sim.send(0x00);         // low from 10 to 100
  sim.add_glitch(3, 2);   // low spike on idle
  sim.add_glitch(50, 4);  // high spike in the data
  sim.add_glitch(98, 2);  // ends on the rising edge at 100: the edge moves to 98
  const std::vector<LevelRun> expected = {{true, 3}, {false, 2},  {true, 5}, {false, 40},
                                          {true, 4}, {false, 44}, {true, 12}};
  EXPECT_EQ(sim.runs(), expected);
}

TEST(LineSim, PositiveBaudErrorSendsFaster) {
  LineSimSettings settings = line(k9600_8N1);
  settings.baud_error_percent = +2;
  LineSimulator fast(settings);
  EXPECT_DOUBLE_EQ(fast.samples_per_bit(), 1e6 / (9600 * 1.02));
  fast.send(0x55);
  EXPECT_LT(fast.characters()[0].end_time, 10 * 1e6 / 9600);
}

TEST(LineSim, RejectsSettingsItCannotSimulate) {
  LineSimSettings settings = line(k9600_8N1);
  settings.edge_jitter_bits = 0.5;
  EXPECT_THROW(LineSimulator{settings}, std::invalid_argument);
  settings = line(k9600_8N1, 15'000);  // about 1.6 samples per bit
  EXPECT_THROW(LineSimulator{settings}, std::invalid_argument);
  settings = line(k9600_8N1, 20'000);  // about 2 samples per bit: decodable, as sigrok does
  EXPECT_NO_THROW(LineSimulator{settings});
}

TEST(LineSim, VcdAsSigrokWritesIt) {
  const std::vector<LevelRun> runs = {{true, 100}, {false, 50}, {true, 25}};
  std::ostringstream one_mhz;
  write_vcd(one_mhz, runs, k1MHz);
  EXPECT_EQ(one_mhz.str(),
            "$version drivetap line simulator $end\n"
            "$comment\n  Acquisition with 1/1 channels at 1 MHz\n$end\n"
            "$timescale 1 us $end\n"
            "$scope module drivetap $end\n"
            "$var wire 1 ! RX $end\n"
            "$upscope $end\n"
            "$enddefinitions $end\n"
            "#0 1!\n"
            "#100 0!\n"
            "#150 1!\n"
            "#175\n");

  struct Case {
    std::uint64_t rate;
    const char* timescale;
    const char* changes;
  };
  for (const Case& c : {Case{2'000'000, "100 ns", "#0 1!\n#500 0!\n#750 1!\n#875\n"},
                        Case{8'000'000, "1 ns", "#0 1!\n#12500 0!\n#18750 1!\n#21875\n"},
                        Case{3'000'000, "1 ns", "#0 1!\n#33333 0!\n#50000 1!\n#58333\n"},
                        Case{250'000, "1 us", "#0 1!\n#400 0!\n#600 1!\n#700\n"}}) {
    SCOPED_TRACE(c.rate);
    std::ostringstream out;
    write_vcd(out, runs, c.rate, "A B");
    const std::string text = out.str();
    EXPECT_NE(text.find(std::string("$timescale ") + c.timescale + " $end\n"), std::string::npos);
    EXPECT_NE(text.find("$var wire 1 ! A_B $end\n"), std::string::npos);
    EXPECT_EQ(text.substr(text.find("$enddefinitions $end\n") + 21), c.changes);
  }
}

// --- Settings, time conversion ----------------------------------------------------------------

TEST(UartSettings, ValidateNamesTheProblem) {
  EXPECT_EQ(k9600_8N1.validate(k1MHz), "");
  UartSettings s = k9600_8N1;
  s.data_bits = 4;
  EXPECT_NE(s.validate(k1MHz).find("data bits"), std::string::npos);
  s.data_bits = 10;
  EXPECT_NE(s.validate(k1MHz).find("data bits"), std::string::npos);
  s = k9600_8N1;
  EXPECT_NE(s.validate(15'000).find("samples per bit"), std::string::npos);
  EXPECT_EQ(s.validate(20'000), "");
  s.glitch_filter_samples = 60;  // over half of 104 samples
  EXPECT_NE(s.validate(k1MHz).find("glitch filter"), std::string::npos);
  s.glitch_filter_samples = 50;
  EXPECT_EQ(s.validate(k1MHz), "");
  s.baud = 0;
  EXPECT_NE(s.validate(k1MHz).find("baud"), std::string::npos);
  EXPECT_THROW(UartDecoder(s, k1MHz), std::invalid_argument);
}

TEST(UartSettings, FromSerialConfig) {
  const UartSettings s = UartSettings::from(SerialConfig{19200, 7, Parity::odd, 2});
  EXPECT_EQ(s.baud, 19200);
  EXPECT_EQ(s.data_bits, 7);
  EXPECT_EQ(s.parity, UartParity::odd);
  EXPECT_EQ(s.stop_bits, StopBits::two);
  EXPECT_FALSE(s.inverted);
  EXPECT_DOUBLE_EQ(s.frame_bits(), 11.0);
  EXPECT_DOUBLE_EQ(format(9600, 8, UartParity::none, StopBits::one_and_half).frame_bits(), 10.5);
}

TEST(SampleClock, ConvertsSamplesToNanoseconds) {
  const SampleClock one_mhz{k1MHz, 0};
  EXPECT_EQ(one_mhz.to_ns(0), 0);
  EXPECT_EQ(one_mhz.to_ns(1), 1'000);
  EXPECT_EQ(one_mhz.to_ns(60'000'000), 60 * kNsPerSecond);
  const SampleClock three_mhz{3'000'000, 5 * kNsPerSecond};
  EXPECT_EQ(three_mhz.to_ns(1), 5 * kNsPerSecond + 333);
  EXPECT_EQ(three_mhz.to_ns(2), 5 * kNsPerSecond + 667);
  EXPECT_EQ(three_mhz.to_ns(3), 5 * kNsPerSecond + 1'000);
  // A day at 10 GHz: no overflow on the way.
  const SampleClock ten_ghz{10'000'000'000, 0};
  EXPECT_EQ(ten_ghz.to_ns(864'000'000'000'001), 86'400 * kNsPerSecond);
  EXPECT_EQ(ten_ghz.to_ns(864'000'000'000'005), 86'400 * kNsPerSecond + 1);
}

TEST(SampleClock, ByteEventCarriesTimeLowByteAndFlags) {
  UartCharacter c;
  c.start_sample = 2'500;
  c.value = 0x1A5;  // 9 data bits: the byte is the low 8, the ninth rides as a flag
  c.flags = kUartParityError | kUartFramingError;
  const ByteEvent e = to_byte_event(c, SampleClock{2'000'000, 100}, 3);
  EXPECT_EQ(e.time, 100 + 1'250'000);
  EXPECT_EQ(e.byte, 0xA5);
  EXPECT_EQ(e.flags, kUartParityError | kUartFramingError | kUartNinthBit);
  EXPECT_EQ(e.channel, 3);
  c.value = 0x0A5;
  EXPECT_EQ(to_byte_event(c, SampleClock{2'000'000, 100}, 3).flags,
            kUartParityError | kUartFramingError);
}

// --- Throughput sanity (prints a rate, asserts only correctness) -------------------------------

TEST(UartThroughput, SixtySecondsAtOneMegahertzDecodesCompletely) {
  // 60 s of 115200 8N1 at 1 MHz: frames of 32 bytes with 40 bit times between them.
  const UartSettings uart = format(115200, 8, UartParity::none, StopBits::one);
  LineSimulator sim(line(uart));
  std::mt19937 rng(60);
  std::vector<std::uint8_t> frame(32);
  sim.idle(40);
  while (sim.now() < 60.0 * k1MHz) {
    for (std::uint8_t& b : frame) b = static_cast<std::uint8_t>(rng());
    sim.send(frame);
    sim.idle(40);
  }
  const auto runs = sim.runs();
  std::uint64_t samples = 0;
  for (const LevelRun& r : runs) samples += r.length;

  UartDecoder decoder(uart, k1MHz);
  std::vector<UartCharacter> got;
  got.reserve(sim.characters().size());
  const auto began = std::chrono::steady_clock::now();
  decoder.push_runs(runs, got);
  decoder.finish(got);
  const std::chrono::duration<double> took = std::chrono::steady_clock::now() - began;

  EXPECT_GE(samples, 60'000'000u);
  ASSERT_EQ(got.size(), sim.characters().size());
  EXPECT_EQ(wrong_characters(sim.characters(), got), 0u);
  std::printf("[ info     ] %llu samples in %zu runs, %zu characters: %.0f M samples/s\n",
              static_cast<unsigned long long>(samples), runs.size(), got.size(),
              static_cast<double>(samples) / took.count() / 1e6);
}

TEST(UartThroughput, NoiseOnEverySampleIsFilteredWithoutCharacters) {
  // The decoder's worst case: a run per sample. 10 M samples of 1-sample spikes on an idle line.
  UartDecoder decoder(k9600_8N1, k1MHz);
  std::vector<UartCharacter> got;
  const auto began = std::chrono::steady_clock::now();
  decoder.push_run(true, 1000, got);
  for (int i = 0; i < 5'000'000; ++i) {
    decoder.push_run(false, 1, got);
    decoder.push_run(true, 1, got);
  }
  decoder.finish(got);
  const std::chrono::duration<double> took = std::chrono::steady_clock::now() - began;
  EXPECT_TRUE(got.empty());
  EXPECT_EQ(decoder.stats().glitches, 5'000'000u);
  std::printf("[ info     ] 10 M one-sample runs: %.0f M runs/s\n", 1e7 / took.count() / 1e6);
}
