// Unit tests: line detection (src/sources/logic/detect.hpp) and diagnosis verdicts
// (src/diagnose/line_diagnosis.hpp) on simulated lines — every verdict present where its fault is
// simulated and absent on the clean line — and on byte-level evidence.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "core/checksum.hpp"
#include "diagnose/line_diagnosis.hpp"
#include "dissectors/modbus/modbus_protocol.hpp"
#include "sources/logic/detect.hpp"
#include "sources/logic/line_sim.hpp"
#include "sources/logic/logic_source.hpp"

using namespace drivetap;
using namespace drivetap::phy;

namespace {

// A logic capture held in memory: one block with every run.
class MemoryCapture final : public LogicCapture {
 public:
  MemoryCapture(std::vector<std::vector<LevelRun>> channels, std::uint64_t rate)
      : runs_(std::move(channels)), rate_(rate) {
    for (std::size_t i = 0; i < runs_.size(); ++i) names_.push_back(i == 0 ? "RX" : "TX");
  }
  [[nodiscard]] std::uint64_t sample_rate() const override { return rate_; }
  [[nodiscard]] const std::vector<std::string>& channels() const override { return names_; }
  bool select(const std::vector<std::size_t>& channels, std::string*) override {
    selected_ = channels;
    done_ = false;
    return true;
  }
  bool next_block(RunBlock& block, std::string*) override {
    if (done_) return false;
    done_ = true;
    block.runs.clear();
    std::uint64_t total = 0;
    for (std::size_t c : selected_) {
      block.runs.push_back(runs_[c]);
      total = 0;
      for (const LevelRun& r : runs_[c]) total += r.length;
    }
    block.begin = 0;
    block.end = total;
    return true;
  }

 private:
  std::vector<std::vector<LevelRun>> runs_;
  std::vector<std::string> names_;
  std::vector<std::size_t> selected_;
  std::uint64_t rate_;
  bool done_ = false;
};

UartSettings settings(double baud, std::uint8_t data_bits, UartParity parity, StopBits stop_bits,
                      bool inverted = false) {
  UartSettings s;
  s.baud = baud;
  s.data_bits = data_bits;
  s.parity = parity;
  s.stop_bits = stop_bits;
  s.inverted = inverted;
  return s;
}

// One channel, as detection takes channels.
std::vector<std::vector<LevelRun>> one(std::vector<LevelRun> runs) {
  std::vector<std::vector<LevelRun>> channels;
  channels.push_back(std::move(runs));
  return channels;
}

std::vector<std::uint8_t> with_crc(std::vector<std::uint8_t> pdu) {
  const std::uint16_t crc = crc16_modbus(pdu);
  pdu.push_back(static_cast<std::uint8_t>(crc & 0xFF));
  pdu.push_back(static_cast<std::uint8_t>(crc >> 8));
  return pdu;
}

struct Faults {
  double baud_error_percent = 0;
  bool release_artefact = false;       // the line floats low for ~9.7 bits after every reply
  double gap_inside_request_bits = 0;  // a pause in the middle of every 5th request
  double glitches_per_second = 0;
  std::uint64_t glitch_width = 0;
};

// A master polling drive 2 (read 2 holding registers) 40 times, 9600..115200 baud, 8 MHz samples.
std::vector<LevelRun> polling_line(const UartSettings& uart, const Faults& f = {},
                                   std::uint64_t rate = 8'000'000) {
  LineSimSettings ls;
  ls.uart = uart;
  ls.sample_rate_hz = rate;
  ls.baud_error_percent = f.baud_error_percent;
  ls.seed = 7;
  LineSimulator sim(ls);
  std::mt19937 rng(3);
  sim.idle(200);
  for (int i = 0; i < 40; ++i) {
    const auto reg = static_cast<std::uint8_t>(rng() & 0x3F);
    const auto request = with_crc({0x02, 0x03, 0x00, reg, 0x00, 0x02});
    if (f.gap_inside_request_bits > 0 && i % 5 == 0) {
      sim.send(std::span(request).first(3));
      sim.idle(f.gap_inside_request_bits);
      sim.send(std::span(request).subspan(3));
    } else {
      sim.send(request);
    }
    // The drive answers after 5 characters, or 2 ms above 19200 baud (t3.5 is 1.75 ms there).
    sim.idle(std::max(60.0, 0.002 * uart.baud));
    const auto reply = with_crc({0x02, 0x03, 0x04, static_cast<std::uint8_t>(rng() & 0xFF),
                                 static_cast<std::uint8_t>(rng() & 0xFF), 0x01,
                                 static_cast<std::uint8_t>(rng() & 0xFF)});
    sim.send(reply);
    if (f.release_artefact) sim.send_break(9.7);
    sim.idle(std::max(150.0, 0.005 * uart.baud));
  }
  if (f.glitches_per_second > 0) sim.add_random_glitches(f.glitches_per_second, f.glitch_width);
  return sim.runs();
}

// What `drivetap diagnose` does, on a simulated line (given: the settings as `-s` would give).
Diagnosis diagnose_line(std::vector<LevelRun> runs, std::optional<UartSettings> given = {},
                        std::uint64_t rate = 8'000'000) {
  ChannelTable channels;
  LogicSourceOptions so;
  so.uart = given;
  LogicSource source(std::make_unique<MemoryCapture>(one(std::move(runs)), rate), "sim", channels,
                     so);
  EXPECT_TRUE(source.read_header()) << source.error();
  PipelineOptions p;
  p.serial = *source.settings().serial;
  p.timing = FramingTiming::from(p.serial);
  p.protocol = protocols::modbus_rtu;
  return diagnose_capture(source, p, channels);
}

std::vector<std::string> ids(const Diagnosis& d) {
  std::vector<std::string> out;
  for (const Verdict& v : d.verdicts) out.push_back(v.id);
  return out;
}

const UartSettings k19200_8E1 = settings(19200, 8, UartParity::even, StopBits::one);

// The same polling on a pair with no fail-safe bias: each transmitter drives the line 1.5 bits
// before its first start bit and 1 bit after its last stop bit; in between it floats, read low.
std::vector<LevelRun> unbiased_polling_line(const UartSettings& uart) {
  LineSimSettings ls;
  ls.uart = uart;
  ls.sample_rate_hz = 8'000'000;
  LineSimulator sim(ls);
  std::mt19937 rng(5);
  auto transmit = [&](const std::vector<std::uint8_t>& bytes, double float_bits) {
    sim.idle(1.5);
    sim.send(bytes);
    sim.idle(1);
    sim.send_break(float_bits);
  };
  sim.send_break(100);
  for (int i = 0; i < 40; ++i) {
    const auto reg = static_cast<std::uint8_t>(rng() & 0x3F);
    transmit(with_crc({0x02, 0x03, 0x00, reg, 0x00, 0x02}), 60);
    transmit(with_crc({0x02, 0x03, 0x04, static_cast<std::uint8_t>(rng() & 0xFF), 0x00, 0x01,
                       static_cast<std::uint8_t>(rng() & 0xFF)}),
             300);
  }
  return sim.runs();
}

// Characters with `gap_bits` of idle after each (their values drawn below 2^data_bits).
std::vector<LevelRun> spaced_characters(const UartSettings& uart, double gap_bits,
                                        std::uint16_t lowest = 0, std::uint64_t rate = 8'000'000) {
  LineSimSettings ls;
  ls.uart = uart;
  ls.sample_rate_hz = rate;
  LineSimulator sim(ls);
  std::mt19937 rng(11);
  sim.idle(50);
  for (int i = 0; i < 300; ++i) {
    const auto span = static_cast<std::uint32_t>((1u << uart.data_bits) - lowest);
    sim.send(static_cast<std::uint16_t>(lowest + rng() % span));
    sim.idle(gap_bits);
  }
  sim.idle(50);
  return sim.runs();
}

}  // namespace

// ---- detection ----

TEST(LineDetection, FindsBaudFormatAndPolarityOfSimulatedPolling) {
  struct Case {
    UartSettings uart;
    const char* expected;
  };
  const Case cases[] = {
      {settings(9600, 8, UartParity::none, StopBits::one), "9600 8N1"},
      {k19200_8E1, "19200 8E1"},
      {settings(38400, 8, UartParity::odd, StopBits::one, true), "38400 8O1, inverted"},
      {settings(115200, 7, UartParity::odd, StopBits::one), "115200 7O1"},
      {settings(4800, 7, UartParity::even, StopBits::one, true), "4800 7E1, inverted"},
      {settings(57600, 8, UartParity::even, StopBits::one), "57600 8E1"},
  };
  for (const Case& c : cases) {
    const auto runs = polling_line(c.uart);
    const LineDetection d = detect_line(one(runs), 8'000'000);
    ASSERT_TRUE(d.found) << c.expected << ": " << d.why_not;
    EXPECT_EQ(settings_text(d.settings), c.expected) << d.format_reason;
    EXPECT_EQ(d.baud_confidence, Confidence::high) << c.expected;
    EXPECT_EQ(d.polarity_confidence, Confidence::high) << c.expected;
    EXPECT_EQ(d.format_confidence, Confidence::high) << c.expected << ": " << d.format_reason;
    EXPECT_NEAR(d.measured_baud, c.uart.baud, c.uart.baud * 0.01) << c.expected;
  }
}

TEST(LineDetection, SnapsAClockOffByTwoPercentButReportsWhatItMeasured) {
  Faults f;
  f.baud_error_percent = 2;
  const LineDetection d = detect_line(one(polling_line(k19200_8E1, f)), 8'000'000);
  ASSERT_TRUE(d.found);
  EXPECT_EQ(settings_text(d.settings), "19200 8E1");
  EXPECT_TRUE(d.baud_standard);
  EXPECT_NEAR(d.measured_baud, 19200 * 1.02, 19200 * 0.005);
}

TEST(LineDetection, NonStandardRateIsReportedAsMeasured) {
  const LineDetection d = detect_line(
      one(polling_line(settings(10700, 8, UartParity::none, StopBits::two))), 8'000'000);
  ASSERT_TRUE(d.found);
  EXPECT_FALSE(d.baud_standard);
  EXPECT_EQ(d.settings.baud, 10700);
  // Characters sent back to back 2 stop bits apart, never after 1: 2 stop bits.
  EXPECT_EQ(settings_text(d.settings), "10700 8N2");
  EXPECT_NE(d.format_reason.find("2 stop bits apart, none after 1"), std::string::npos)
      << d.format_reason;
}

// 7 data bits with idle between characters read as 8 without an error, every one with bit 7 set:
// the top data bit that is always 1 is the stop bit (on a 7-bit Modbus ASCII line, 0x3A ':'
// would read 0xBA and hide every frame).
TEST(LineDetection, SevenDataBitsAreNotEightWithTheTopBitSet) {
  const UartSettings seven = settings(19200, 7, UartParity::none, StopBits::one);
  const LineDetection d = detect_line(one(spaced_characters(seven, 3)), 8'000'000);
  ASSERT_TRUE(d.found) << d.why_not;
  EXPECT_EQ(settings_text(d.settings), "19200 7N1") << d.format_reason;
  EXPECT_NE(d.format_reason.find("the last data bit is 1 in all"), std::string::npos)
      << d.format_reason;
}

TEST(LineDetection, NineDataBitsAreFound) {
  const UartSettings nine = settings(19200, 9, UartParity::none, StopBits::one);
  const LineDetection d = detect_line(one(spaced_characters(nine, 3)), 8'000'000);
  ASSERT_TRUE(d.found) << d.why_not;
  EXPECT_EQ(settings_text(d.settings), "19200 9N1") << d.format_reason;
  // And the characters keep their 9th bit.
  const auto got = decode_runs(spaced_characters(nine, 3), d.settings, 8'000'000);
  EXPECT_TRUE(
      std::any_of(got.begin(), got.end(), [](const UartCharacter& c) { return c.value > 0xFF; }));
}

// 2 stop bits where characters follow exactly 2 stop bits apart; 1 where the sender's own gaps
// are no whole bit (a UART with 1 stop bit and software between characters).
TEST(LineDetection, StopBitsFromTheSpacingOfCharacters) {
  const UartSettings odd_two = settings(9600, 8, UartParity::odd, StopBits::two);
  const LineDetection two = detect_line(one(spaced_characters(odd_two, 0)), 8'000'000);
  EXPECT_EQ(settings_text(two.settings), "9600 8O2") << two.format_reason;
  const UartSettings odd_one = settings(9600, 8, UartParity::odd, StopBits::one);
  const LineDetection loose = detect_line(one(spaced_characters(odd_one, 1.4)), 8'000'000);
  EXPECT_EQ(settings_text(loose.settings), "9600 8O1") << loose.format_reason;
}

// DMX-like slots whose pulses are all 2 bits or longer (0xCC, 0x0C, 0x00: no lone bit): the bit is
// the greatest width the pulses are multiples of, 250000, not the shortest pulse (125000, which
// snaps to 128000), however long the marks between slots.
TEST(LineDetection, WholeBitIsTheGreatestCommonWidthNotTheShortestPulse) {
  for (double gap : {0.0, 3.7}) {
    LineSimSettings ls;
    ls.uart = settings(250000, 8, UartParity::none, StopBits::two);
    ls.sample_rate_hz = 4'000'000;
    LineSimulator sim(ls);
    std::mt19937 rng(3);
    sim.idle(40);
    for (int packet = 0; packet < 4; ++packet) {
      sim.send_break(25);
      sim.idle(3);
      for (int slot = 0; slot < 60; ++slot) {
        static constexpr std::uint8_t kNoLoneBit[] = {0xCC, 0x0C, 0x00};
        sim.send(kNoLoneBit[rng() % 3]);
        sim.idle(gap);
      }
      sim.idle(30);
    }
    const LineDetection d = detect_line(one(sim.runs()), 4'000'000);
    ASSERT_TRUE(d.found) << d.why_not;
    EXPECT_EQ(d.settings.baud, 250000) << gap << ": " << settings_text(d.settings);
    EXPECT_EQ(d.single_bit_pulses, 0u);
    EXPECT_EQ(d.baud_confidence, Confidence::low) << "no one-bit pulse: the width is inferred";
    EXPECT_EQ(d.best().errors(), 0u);
  }
}

// The only long stretch is a DMX break; the slots are 0x00 but for a few 0x55 (dimmers at 85), each
// with a long mark after it: both polarities decode without an error (the inverted one as other
// bytes). The break is no rest level: upright, and no unbiased bus.
TEST(LineDetection, BreakIsNotTheRestLevel) {
  LineSimSettings ls;
  ls.uart = settings(250000, 8, UartParity::none, StopBits::two);
  ls.sample_rate_hz = 3'000'000;
  LineSimulator sim(ls);
  sim.idle(3);
  sim.send_break(25);
  sim.idle(3);
  for (int slot = 0; slot < 200; ++slot) {
    sim.send(slot % 20 == 1 ? 0x55 : 0x00);
    sim.idle(3.7);
  }
  const LineDetection d = detect_line(one(sim.runs()), 3'000'000);
  ASSERT_TRUE(d.found) << d.why_not;
  EXPECT_EQ(settings_text(d.settings), "250000 8N1") << d.format_reason;
  EXPECT_FALSE(d.settings.inverted) << d.polarity_reason;
  EXPECT_FALSE(d.floats_when_idle);
  EXPECT_EQ(d.breaks_not_rest, 1u);
  EXPECT_NE(d.polarity_reason.find("taken as a break"), std::string::npos) << d.polarity_reason;
}

// LIN: a 13-bit break before every frame, then 0x55 and bytes whose top bit is their even parity
// (0xA3, 0x5C, 0x00): breaks are no damage, and 4 values repeated prove no parity bit.
TEST(LineDetection, LinBreaksAreNoErrorsAndRepeatedValuesProveNoParity) {
  LineSimSettings ls;
  ls.uart = settings(19200, 8, UartParity::none, StopBits::one);
  ls.sample_rate_hz = 1'000'000;
  LineSimulator sim(ls);
  sim.idle(50);
  for (int frame = 0; frame < 12; ++frame) {
    sim.send_break(13);
    sim.idle(1);
    const std::vector<std::uint8_t> bytes = {0x55, 0xA3, 0x5C, 0x00};
    sim.send(bytes, 0.5);
    sim.idle(40);
  }
  const LineDetection d = detect_line(one(sim.runs()), 1'000'000);
  ASSERT_TRUE(d.found) << d.why_not;
  EXPECT_EQ(settings_text(d.settings), "19200 8N1") << d.format_reason;
  EXPECT_EQ(d.best().errors(), 0u);
  EXPECT_EQ(d.best().stats.breaks, 12u);
  EXPECT_EQ(d.polarity_confidence, Confidence::high) << d.polarity_reason;
  EXPECT_NE(d.format_reason.find("7E1 decodes the same"), std::string::npos) << d.format_reason;
}

// Most characters 1 idle bit apart, as 2 stop bits space them, but every fourth followed by the
// next after 1 stop bit: that one leaves no room for a second, so one stop bit is named.
TEST(LineDetection, TwoStopBitsOnlyWhereEveryCharacterLeavesRoomForTwo) {
  for (const bool some_back_to_back : {false, true}) {
    LineSimSettings ls;
    ls.uart = settings(9600, 8, UartParity::none, StopBits::one);
    ls.sample_rate_hz = 8'000'000;
    LineSimulator sim(ls);
    std::mt19937 rng(7);
    sim.idle(50);
    for (int i = 0; i < 300; ++i) {
      sim.send(static_cast<std::uint16_t>(rng() & 0xFF));
      if (!(some_back_to_back && i % 4 == 0)) sim.idle(1);
    }
    sim.idle(50);
    const LineDetection d = detect_line(one(sim.runs()), 8'000'000);
    ASSERT_TRUE(d.found) << d.why_not;
    EXPECT_EQ(settings_text(d.settings), some_back_to_back ? "9600 8N1" : "9600 8N2")
        << d.format_reason;
  }
}

// Two samples a bit decode (sigrok decodes them too), with low confidence in the rate.
TEST(LineDetection, TwoSamplesPerBitDecodeWithLowConfidence) {
  const UartSettings uart = settings(9600, 8, UartParity::none, StopBits::one);
  const LineDetection d = detect_line(one(spaced_characters(uart, 2, 0, 19'200)), 19'200);
  ASSERT_TRUE(d.found) << d.why_not;
  EXPECT_EQ(settings_text(d.settings), "9600 8N1");
  EXPECT_EQ(d.baud_confidence, Confidence::low);
  EXPECT_EQ(d.best().errors(), 0u);
}

// A clock or strobe beside the data (every pulse one width) is no UART line.
TEST(LineDetection, PulsesAllOneWidthAreNoUart) {
  std::vector<LevelRun> strobe;
  for (int i = 0; i < 100; ++i) {
    strobe.push_back({true, 10000});  // idle between strobes: no data pulse
    strobe.push_back({false, 500});
  }
  const LineDetection d = detect_line(one(strobe), 1'000'000);
  EXPECT_FALSE(d.found);
  EXPECT_NE(d.why_not.find("clock or strobe"), std::string::npos) << d.why_not;
}

TEST(LineDetection, TooFewEdgesIsNoGuess) {
  const LineDetection d = detect_line(one({{true, 1000}, {false, 50}, {true, 1000}}), 1'000'000);
  EXPECT_FALSE(d.found);
  EXPECT_NE(d.why_not.find("too few edges"), std::string::npos);
}

// ---- verdicts on simulated lines: each present where its fault is, absent on the clean line ----

TEST(Diagnosis, CleanLineHasNoVerdict) {
  for (const UartSettings& uart : {k19200_8E1, settings(9600, 8, UartParity::none, StopBits::one),
                                   settings(115200, 8, UartParity::odd, StopBits::one)}) {
    const Diagnosis d = diagnose_line(polling_line(uart));
    EXPECT_TRUE(d.verdicts.empty()) << settings_text(uart) << ": " << ids(d).front();
    EXPECT_EQ(d.evidence.frames, 80u);
    EXPECT_EQ(d.evidence.frames_checksum_ok, 80u);
    EXPECT_EQ(d.stats.transactions, 40u);
    // Also with the right settings given.
    EXPECT_TRUE(diagnose_line(polling_line(uart), uart).verdicts.empty());
  }
}

// An unbiased pair rests low between transmissions although every character on it is upright:
// upright, with the unbiased-bus verdict; never "A and B swapped".
TEST(Diagnosis, UnbiasedPairIsUprightAndFloatsNotSwapped) {
  const Diagnosis d = diagnose_line(unbiased_polling_line(k19200_8E1));
  ASSERT_EQ(d.evidence.channels.size(), 1u);
  const LineDetection& line = *d.evidence.channels.front().detection;
  EXPECT_FALSE(line.settings.inverted) << line.polarity_reason;
  EXPECT_TRUE(line.floats_when_idle);
  EXPECT_EQ(ids(d), std::vector<std::string>{"unbiased-bus"});
  EXPECT_EQ(d.evidence.frames_checksum_ok, 80u);
  EXPECT_EQ(d.evidence.breaks, 0u);  // the floating line is no character
  // The same with the settings given.
  EXPECT_EQ(ids(diagnose_line(unbiased_polling_line(k19200_8E1), k19200_8E1)),
            std::vector<std::string>{"unbiased-bus"});
}

TEST(Diagnosis, SwappedWiresAreAnInvertedLine) {
  UartSettings swapped = k19200_8E1;
  swapped.inverted = true;
  const Diagnosis d = diagnose_line(polling_line(swapped));
  EXPECT_EQ(ids(d), std::vector<std::string>{"inverted-line"});
  EXPECT_EQ(d.evidence.frames_checksum_ok, 80u);  // decoded inverted all the same
  const Verdict& v = d.verdicts.front();
  // Decided by how each polarity decodes, and the fix names both causes of an inversion.
  EXPECT_NE(v.evidence.find("decodes clearly better"), std::string::npos) << v.evidence;
  EXPECT_NE(v.evidence.find("inverted: 0 errors"), std::string::npos) << v.evidence;
  EXPECT_NE(v.fix.find("swap the A and B"), std::string::npos);
  EXPECT_NE(v.fix.find("RS-232 side of a converter"), std::string::npos);
  // Given the right polarity, no verdict.
  EXPECT_TRUE(diagnose_line(polling_line(swapped), swapped).verdicts.empty());
}

TEST(Diagnosis, WrongBaudGivenIsABaudMismatchNamingTheRateThatWorks) {
  UartSettings wrong = k19200_8E1;
  wrong.baud = 9600;
  const Diagnosis d = diagnose_line(polling_line(k19200_8E1), wrong);
  EXPECT_EQ(ids(d), std::vector<std::string>{"baud-mismatch"});
  EXPECT_NE(d.verdicts.front().fix.find("-s \"19200 8E1\""), std::string::npos)
      << d.verdicts.front().fix;
}

TEST(Diagnosis, WrongParityGivenIsAParityMismatchNamingTheFormatThatWorks) {
  for (UartParity wrong_parity : {UartParity::none, UartParity::odd}) {
    UartSettings wrong = k19200_8E1;
    wrong.parity = wrong_parity;
    const Diagnosis d = diagnose_line(polling_line(k19200_8E1), wrong);
    EXPECT_EQ(ids(d), std::vector<std::string>{"parity-mismatch"});
    EXPECT_NE(d.verdicts.front().fix.find("8E1"), std::string::npos);
  }
}

TEST(Diagnosis, GlitchesOverTheFilterAreNoise) {
  Faults f;
  f.glitches_per_second = 20;
  f.glitch_width = 8'000'000 / 19200 / 2;  // half a bit: corrupts what it hits
  const Diagnosis d = diagnose_line(polling_line(k19200_8E1, f));
  EXPECT_EQ(ids(d), std::vector<std::string>{"noise"});
  EXPECT_GT(d.evidence.framing_errors + d.evidence.parity_errors + d.evidence.false_starts, 0u);
}

TEST(Diagnosis, UnbiasedBusLeavesAStrayByteAfterEveryReply) {
  Faults f;
  f.release_artefact = true;
  const Diagnosis d = diagnose_line(polling_line(k19200_8E1, f));
  EXPECT_EQ(ids(d), std::vector<std::string>{"unbiased-bus"});
  EXPECT_EQ(d.evidence.release_artefacts, 40u);
}

TEST(Diagnosis, PauseInsideFramesBreaksT15) {
  Faults f;
  f.gap_inside_request_bits = 2.5 * 11;  // 2.5 characters
  const Diagnosis d = diagnose_line(polling_line(k19200_8E1, f));
  EXPECT_EQ(ids(d), std::vector<std::string>{"timing-t15"});
  EXPECT_EQ(d.evidence.intra_frame_gaps, 8u);
}

TEST(Diagnosis, NonStandardRateIsReported) {
  const Diagnosis d =
      diagnose_line(polling_line(settings(10700, 8, UartParity::even, StopBits::one)));
  EXPECT_EQ(ids(d), std::vector<std::string>{"non-standard-baud"});
}

// ---- the same logic on byte-level evidence ----

TEST(Diagnosis, ByteLevelEvidence) {
  LineEvidence clean;
  clean.settings = "19200 8E1";
  clean.characters = 1000;
  clean.frames = 100;
  clean.frames_checksum_ok = 100;
  EXPECT_TRUE(diagnose(clean).empty());

  LineEvidence parity = clean;
  parity.parity_errors = 480;  // about half: even read as none, or none read as even
  EXPECT_EQ(diagnose(parity).front().id, "parity-mismatch");

  LineEvidence framing = clean;
  framing.framing_errors = 600;
  EXPECT_EQ(diagnose(framing).front().id, "settings-mismatch");

  // 8N1 on an 8E1 bus: the parity bit read as the stop bit fails on every byte with an even
  // number of ones, on none of the others; odd parity the other way round. Framing errors spread
  // over both kinds of byte are no parity bit.
  for (const bool even : {true, false}) {
    LineEvidence stop = clean;
    stop.settings = "19200 8N1";
    stop.by_ones = {520, 480};
    stop.framed_badly_by_ones = even ? std::array<std::uint64_t, 2>{520, 0}
                                     : std::array<std::uint64_t, 2>{0, 480};
    stop.framing_errors = even ? 520 : 480;
    const std::vector<Verdict> v = diagnose(stop);
    ASSERT_EQ(v.size(), 1u);
    EXPECT_EQ(v[0].id, "parity-mismatch");
    EXPECT_EQ(v[0].title, even ? "The line carries a parity bit: use 19200 8E1"
                               : "The line carries a parity bit: use 19200 8O1");
    EXPECT_EQ(v[0].fix, even ? "capture with -s \"19200 8E1\"" : "capture with -s \"19200 8O1\"");
  }
  LineEvidence spread = clean;
  spread.settings = "19200 8N1";
  spread.by_ones = {520, 480};
  spread.framed_badly_by_ones = {300, 300};
  spread.framing_errors = 600;
  EXPECT_EQ(diagnose(spread).front().id, "settings-mismatch");

  LineEvidence noisy = clean;
  noisy.framing_errors = 6;
  noisy.parity_errors = 3;
  noisy.frames_checksum_ok = 95;
  noisy.frames_checksum_bad = 5;
  ASSERT_EQ(diagnose(noisy).size(), 1u);
  EXPECT_EQ(diagnose(noisy).front().id, "noise");

  LineEvidence floating = clean;
  floating.framing_errors = 50;
  floating.release_artefacts = 50;
  floating.frames_checksum_ok = 50;
  floating.frames_checksum_bad = 50;
  ASSERT_EQ(diagnose(floating).size(), 1u);
  EXPECT_EQ(diagnose(floating).front().id, "unbiased-bus");
}

// ---- every finding leads to a verdict or a benign note ----

namespace {

// The evidence a run with findings of `kind` (three of them, at station 2) gathers.
LineEvidence evidence_with(AnomalyKind kind) {
  LineEvidence e;
  e.characters = 1000;
  e.frames = 100;
  e.frames_checksum_ok = 90;
  e.findings[static_cast<std::size_t>(kind)] = 3;
  LineEvidence::Station& s = e.stations[2];
  s.frames = 50;
  s.requests = 25;
  switch (kind) {
    case AnomalyKind::checksum_bad:
      s.bad_checksum = 3;
      break;
    case AnomalyKind::checksum_swapped:
      s.swapped_checksum = 3;
      break;
    case AnomalyKind::intra_frame_gap:
      e.intra_frame_gaps = 3;
      break;
    case AnomalyKind::short_interframe_gap:
      e.short_interframe_gaps = 3;
      break;
    case AnomalyKind::noise:
      e.noise_records = 3;
      e.noise_bytes = 5;
      break;
    case AnomalyKind::malformed:
    case AnomalyKind::implausible:
      s.malformed = 3;
      break;
    case AnomalyKind::unanswered_request:
      s.timeouts = 3;
      break;
    case AnomalyKind::unsolicited_response:
      s.unsolicited = 3;
      break;
    case AnomalyKind::uart_framing:
      e.framing_errors = 3;
      break;
    case AnomalyKind::uart_parity:
      e.parity_errors = 3;
      break;
    case AnomalyKind::uart_break:
      e.breaks = 3;
      break;
    case AnomalyKind::timing_rule:
      e.timing_rules["the drive needs 200 ms (ERMAN E-9P/9G, 000 §4)"] = {
          TimingRule::request_after_reply,
          {{2,
            {3, 7,
             "frame 7: request 171.0 ms after the drive's last reply; the drive needs 200 ms"}}}};
      break;
    default:  // overrun, clock, packets: the count is all
      break;
  }
  return e;
}

}  // namespace

TEST(Diagnosis, EveryKindOfFindingLeadsToAVerdictOrABenignNote) {
  for (std::size_t k = 0; k < kAnomalyKindCount; ++k) {
    const auto kind = static_cast<AnomalyKind>(k);
    SCOPED_TRACE(anomaly_id(kind));
    ASSERT_EQ(kFindingCoverage[k].kind, kind);  // the table follows the enum
    const std::vector<Verdict> verdicts = diagnose(evidence_with(kind));
    const std::string covering = std::string(" ") + kFindingCoverage[k].verdict + " ";
    const bool covered = std::any_of(verdicts.begin(), verdicts.end(), [&](const Verdict& v) {
      return covering.find(" " + v.id + " ") != std::string::npos;
    });
    EXPECT_TRUE(covered) << "verdicts: " << verdicts.size();
    for (const Verdict& v : verdicts) EXPECT_EQ(v.fix.empty(), v.benign) << v.id;
  }
  // And nothing at all is a healthy line.
  EXPECT_TRUE(diagnose(LineEvidence{}).empty());
}

TEST(Diagnosis, EachTimingRuleIsItsOwnVerdictWithItsOwnFix) {
  LineEvidence e;
  FramingTiming timing;
  DiagnosisSink sink(e, timing);
  // Typed as the pipeline makes them; no text: diagnosis reads the rule, not the words.
  const TimingBreak breaks[] = {
      {TimingRule::reply_too_late, 27.0, 20, "Danfoss VLT AQUA", "002"},
      {TimingRule::reply_too_soon, 7.7, 10, "E5-8200", "004"},
      {TimingRule::request_after_reply, 171.0, 200, "ERMAN E-9P/9G", "000"},
      {TimingRule::reply_too_late, 25.0, 20, "Danfoss VLT AQUA", "002"}};
  std::uint64_t number = 0;
  for (const TimingBreak& b : breaks) {
    Message m;
    m.frame.number = ++number;
    m.address = static_cast<int>(number);
    sink.on_frame(m);
    Anomaly a{AnomalyKind::timing_rule, 0, 0, number, {}};
    a.timing = b;
    sink.on_anomaly(a);
  }
  std::vector<const Verdict*> rules;
  const std::vector<Verdict> verdicts = diagnose(e);
  for (const Verdict& v : verdicts)
    if (v.id == "timing-rule") rules.push_back(&v);
  ASSERT_EQ(rules.size(), 3u);
  EXPECT_NE(rules[0]->fix, rules[1]->fix);
  EXPECT_NE(rules[1]->fix, rules[2]->fix);
  EXPECT_NE(rules[0]->fix, rules[2]->fix);
  // The VLT's two late replies, at stations 1 and 4, are one verdict.
  const auto vlt = std::find_if(rules.begin(), rules.end(), [](const Verdict* v) {
    return v->title.find("VLT") != std::string::npos;
  });
  ASSERT_NE(vlt, rules.end());
  EXPECT_NE((*vlt)->evidence.find("2 times (station 1: 1, station 4: 1"), std::string::npos)
      << (*vlt)->evidence;
  EXPECT_NE((*vlt)->fix.find("later than its manual"), std::string::npos);
  EXPECT_EQ((*vlt)->title,
            "A drive's timing rule is broken: the drive answers within 20 ms (Danfoss VLT AQUA, "
            "002)");
  EXPECT_NE((*vlt)->evidence.find("first: frame 1: reply 27.0 ms after the request; the drive "
                                  "answers within 20 ms"),
            std::string::npos)
      << (*vlt)->evidence;
}
