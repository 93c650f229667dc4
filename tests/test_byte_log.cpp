// Unit tests: the byte log reader (drivetap's plain-text capture format).
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cstdio>
#include <cstring>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "core/anomaly.hpp"
#include "core/byte_event.hpp"
#include "sources/file/byte_log.hpp"

using namespace drivetap;

namespace {

::testing::AssertionResult HasSub(const std::string& s, std::string_view sub) {
  if (s.find(sub) != std::string::npos) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << "'" << s << "' does not contain '" << sub << "'";
}

// A byte log held in memory, read through fmemopen().
class Log {
 public:
  explicit Log(std::string text, TimeNs character_time = 0)
      : text_(std::move(text)),
        file_(fmemopen(text_.data(), text_.size(), "r"), &std::fclose),
        reader_(file_.get(), "cap.log", channels_) {
    reader_.set_character_time(character_time);
  }

  ByteLogReader& reader() { return reader_; }
  ChannelTable& channels() { return channels_; }

  // All bytes up to the end or an error.
  std::vector<ByteEvent> read_all() {
    std::vector<ByteEvent> out;
    ByteEvent e;
    while (reader_.next(e)) out.push_back(e);
    return out;
  }

 private:
  std::string text_;
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> file_;
  ChannelTable channels_;
  ByteLogReader reader_;
};

}  // namespace

TEST(ByteLog, HeaderSetsSerialConfig) {
  Log log("# capture of the E-9 bus\n#! serial 19200 8E1\n\n0.000100 bus 01 03\n");
  ASSERT_TRUE(log.reader().read_header()) << log.reader().error();
  ASSERT_TRUE(log.reader().header_serial().has_value());
  const SerialConfig& s = *log.reader().header_serial();
  EXPECT_EQ(s.baud, 19200u);
  EXPECT_EQ(s.data_bits, 8);
  EXPECT_EQ(s.parity, Parity::even);
  EXPECT_EQ(s.stop_bits, 1);
  log.reader().set_character_time(s.character_time());
  const auto ev = log.read_all();
  EXPECT_TRUE(log.reader().error().empty()) << log.reader().error();
  ASSERT_EQ(ev.size(), 2u);
  EXPECT_EQ(ev[0].time, 100 * kNsPerUs);
  EXPECT_EQ(ev[0].byte, 0x01);
  EXPECT_EQ(ev[1].time, 100 * kNsPerUs + 572917);  // 11 bits at 19200 baud
  EXPECT_EQ(ev[1].byte, 0x03);
}

TEST(ByteLog, NoHeader) {
  Log log("0.5 bus 01\n");
  ASSERT_TRUE(log.reader().read_header());
  EXPECT_FALSE(log.reader().header_serial().has_value());
  const auto ev = log.read_all();
  ASSERT_EQ(ev.size(), 1u);
  EXPECT_EQ(ev[0].time, 500 * kNsPerMs);
}

TEST(ByteLog, EmptyInput) {
  Log log("");
  EXPECT_TRUE(log.reader().read_header());
  ByteEvent e;
  EXPECT_FALSE(log.reader().next(e));
  EXPECT_TRUE(log.reader().error().empty());
}

TEST(ByteLog, BadHeaderSerial) {
  Log log("#! serial 19200 9Q1\n0.0 bus 01\n");
  EXPECT_FALSE(log.reader().read_header());
  EXPECT_TRUE(HasSub(log.reader().error(), "cap.log:1:"));
  EXPECT_TRUE(HasSub(log.reader().error(), "9Q1"));
}

TEST(ByteLog, CommentsAreSkipped) {
  Log log(
      "# full-line comment\n"
      "   # indented comment\n"
      "0.001 bus 01 02 # trailing comment 03 04\n"
      "# another one between data lines\n"
      "\n"
      "0.002 bus 05\n",
      kNsPerUs);
  ASSERT_TRUE(log.reader().read_header());
  const auto ev = log.read_all();
  EXPECT_TRUE(log.reader().error().empty()) << log.reader().error();
  ASSERT_EQ(ev.size(), 3u);
  EXPECT_EQ(ev[0].byte, 0x01);
  EXPECT_EQ(ev[0].time, kNsPerMs);
  EXPECT_EQ(ev[1].byte, 0x02);
  EXPECT_EQ(ev[1].time, kNsPerMs + kNsPerUs);
  EXPECT_EQ(ev[2].byte, 0x05);
  EXPECT_EQ(ev[2].time, 2 * kNsPerMs);
}

TEST(ByteLog, HashInsideATokenIsNotAComment) {
  // '#' starts a comment only as the start of a token: "05#x" is a bad byte.
  Log log("0.0 bus 01\n0.002 bus 05#x\n");
  ASSERT_TRUE(log.reader().read_header());
  const auto ev = log.read_all();
  EXPECT_EQ(ev.size(), 1u);
  EXPECT_TRUE(HasSub(log.reader().error(), "cap.log:2:")) << log.reader().error();
  EXPECT_TRUE(HasSub(log.reader().error(), "bad hex digit in '05#x'"));
}

TEST(ByteLog, TrailingCommentAfterBytes) {
  Log log("0.001 bus 01 02 # 03 04\n0.002 bus 05 #\n", kNsPerUs);
  ASSERT_TRUE(log.reader().read_header());
  const auto ev = log.read_all();
  EXPECT_TRUE(log.reader().error().empty()) << log.reader().error();
  ASSERT_EQ(ev.size(), 3u);
  EXPECT_EQ(ev[0].byte, 0x01);
  EXPECT_EQ(ev[1].byte, 0x02);
  EXPECT_EQ(ev[2].byte, 0x05);
  EXPECT_EQ(ev[2].time, 2 * kNsPerMs);
}

TEST(ByteLog, BytesOfALineAreSpacedByTheCharacterTime) {
  Log log("1.0 bus 01 03 00 00\n2.0 bus AA\n", 1'145'833);
  ASSERT_TRUE(log.reader().read_header());
  const auto ev = log.read_all();
  ASSERT_EQ(ev.size(), 5u);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(ev[i].time, kNsPerSecond + i * 1'145'833) << i;
  EXPECT_EQ(ev[4].time, 2 * kNsPerSecond);  // each line restarts at its own time
  EXPECT_EQ(ev[4].byte, 0xAA);
}

TEST(ByteLog, SetCharacterTimeAfterHeader) {
  Log log("#! serial 9600 8N1\n0.0 bus 01 02 03\n");
  ASSERT_TRUE(log.reader().read_header());
  log.reader().set_character_time(log.reader().header_serial()->character_time());
  const auto ev = log.read_all();
  ASSERT_EQ(ev.size(), 3u);
  EXPECT_EQ(ev[1].time - ev[0].time, 1'041'667);
  EXPECT_EQ(ev[2].time - ev[1].time, 1'041'667);
}

TEST(ByteLog, RunsOfHexDigits) {
  Log log("0.0 bus 020300 0a Ff 0000000401\n", 100);
  ASSERT_TRUE(log.reader().read_header());
  const auto ev = log.read_all();
  EXPECT_TRUE(log.reader().error().empty()) << log.reader().error();
  const std::vector<std::uint8_t> want = {0x02, 0x03, 0x00, 0x0A, 0xFF,
                                          0x00, 0x00, 0x00, 0x04, 0x01};
  ASSERT_EQ(ev.size(), want.size());
  for (std::size_t i = 0; i < want.size(); ++i) {
    EXPECT_EQ(ev[i].byte, want[i]) << i;
    EXPECT_EQ(ev[i].time, static_cast<TimeNs>(i) * 100) << i;
    EXPECT_EQ(ev[i].flags, 0) << i;
  }
}

TEST(ByteLog, UartMarks) {
  Log log("0.0 bus 00!f 00!pb 01 FF!o 00!fpbo 00!\n", 10);
  ASSERT_TRUE(log.reader().read_header());
  const auto ev = log.read_all();
  EXPECT_TRUE(log.reader().error().empty()) << log.reader().error();
  ASSERT_EQ(ev.size(), 6u);
  EXPECT_EQ(ev[0].byte, 0x00);
  EXPECT_EQ(ev[0].flags, kUartFramingError);
  EXPECT_EQ(ev[1].flags, kUartParityError | kUartBreak);
  EXPECT_EQ(ev[2].byte, 0x01);
  EXPECT_EQ(ev[2].flags, 0);
  EXPECT_EQ(ev[3].byte, 0xFF);
  EXPECT_EQ(ev[3].flags, kUartOverrun);
  EXPECT_EQ(ev[4].flags, kUartFramingError | kUartParityError | kUartBreak | kUartOverrun);
  EXPECT_EQ(ev[5].flags, 0);
  EXPECT_EQ(ev[5].time, 50);
}

TEST(ByteLog, ExactNanosecondTimes) {
  Log log(
      "1.000000001 bus 01\n"
      "2.5 bus 02\n"
      "3 bus 03\n"
      "4.123456789999 bus 04\n"  // digits beyond 9 are dropped
      "0.000001 s 05\n");
  ASSERT_TRUE(log.reader().read_header());
  const auto ev = log.read_all();
  EXPECT_TRUE(log.reader().error().empty()) << log.reader().error();
  ASSERT_EQ(ev.size(), 5u);
  EXPECT_EQ(ev[0].time, 1'000'000'001);
  EXPECT_EQ(ev[1].time, 2'500'000'000);
  EXPECT_EQ(ev[2].time, 3'000'000'000);
  EXPECT_EQ(ev[3].time, 4'123'456'789);
  EXPECT_EQ(ev[4].time, 1'000);
}

TEST(ByteLog, SeveralChannels) {
  Log log(
      "0.001 m 01 03\n"
      "0.002 s 01 03 02\n"
      "0.003 bus AA\n"
      "0.004 port1.m 02\n"
      "0.005 port1.s 03\n"
      "0.006 m 04\n");
  ASSERT_TRUE(log.reader().read_header());
  const auto ev = log.read_all();
  EXPECT_TRUE(log.reader().error().empty()) << log.reader().error();
  ASSERT_EQ(ev.size(), 9u);
  const ChannelTable& ch = log.channels();
  ASSERT_EQ(ch.size(), 5u);
  // Ids in order of first use.
  EXPECT_EQ(ev[0].channel, 0);
  EXPECT_EQ(ev[1].channel, 0);
  EXPECT_EQ(ev[2].channel, 1);
  EXPECT_EQ(ev[5].channel, 2);
  EXPECT_EQ(ev[6].channel, 3);
  EXPECT_EQ(ev[7].channel, 4);
  EXPECT_EQ(ev[8].channel, 0);
  EXPECT_EQ(ch.at(0).name, "m");
  EXPECT_EQ(ch.at(0).role, ChannelRole::master);
  EXPECT_EQ(ch.at(0).link, "");
  EXPECT_EQ(ch.at(1).name, "s");
  EXPECT_EQ(ch.at(1).role, ChannelRole::slave);
  EXPECT_EQ(ch.at(1).link, "");
  EXPECT_EQ(ch.at(2).name, "bus");
  EXPECT_EQ(ch.at(2).role, ChannelRole::bus);
  EXPECT_EQ(ch.at(2).link, "");
  EXPECT_EQ(ch.at(3).name, "port1.m");
  EXPECT_EQ(ch.at(3).role, ChannelRole::master);
  EXPECT_EQ(ch.at(3).link, "port1");
  EXPECT_EQ(ch.at(4).name, "port1.s");
  EXPECT_EQ(ch.at(4).role, ChannelRole::slave);
  EXPECT_EQ(ch.at(4).link, "port1");
  // m, s and bus share the default link; port1.m and port1.s share "port1".
  EXPECT_EQ(ch.link_count(), 2u);
  EXPECT_EQ(ch.link_index(0), ch.link_index(1));
  EXPECT_EQ(ch.link_index(0), ch.link_index(2));
  EXPECT_EQ(ch.link_index(3), ch.link_index(4));
  EXPECT_NE(ch.link_index(0), ch.link_index(3));
}

TEST(ChannelTable, NamesRolesAndLinks) {
  ChannelTable t;
  EXPECT_EQ(t.intern("port2"), 0);
  EXPECT_EQ(t.intern("port2.s"), 1);
  EXPECT_EQ(t.intern("/dev/ttyUSB0"), 2);
  EXPECT_EQ(t.intern("port2"), 0);  // interned once
  EXPECT_EQ(t.size(), 3u);
  EXPECT_EQ(t.at(0).role, ChannelRole::bus);
  EXPECT_EQ(t.at(0).link, "port2");
  EXPECT_EQ(t.at(1).role, ChannelRole::slave);
  EXPECT_EQ(t.link_index(0), t.link_index(1));
  EXPECT_EQ(t.at(2).role, ChannelRole::bus);
  EXPECT_EQ(t.at(2).link, "/dev/ttyUSB0");
  EXPECT_NE(t.link_index(2), t.link_index(0));
  EXPECT_EQ(t.link_count(), 2u);
}

TEST(ChannelTable, StopsAtItsLimit) {
  ChannelTable t;
  for (std::size_t i = 0; i < ChannelTable::kMaxChannels; ++i) {
    std::string name = "c";
    name += std::to_string(i);
    ASSERT_EQ(t.intern(name), i);
  }
  EXPECT_EQ(t.intern("one-more"), kNoChannel);
  EXPECT_EQ(t.intern("one-more", "", ChannelRole::bus), kNoChannel);
  EXPECT_EQ(t.intern("c7"), 7);  // names already known still resolve
  EXPECT_EQ(t.size(), ChannelTable::kMaxChannels);
}

TEST(ByteLog, ErrorTooManyChannels) {
  std::string text;
  for (std::size_t i = 0; i <= ChannelTable::kMaxChannels; ++i)
    text += "0." + std::to_string(i) + " ch" + std::to_string(i) + " 01\n";
  Log log(text);
  ASSERT_TRUE(log.reader().read_header());
  const auto ev = log.read_all();
  EXPECT_EQ(ev.size(), ChannelTable::kMaxChannels);  // everything before the bad line
  EXPECT_TRUE(
      HasSub(log.reader().error(), fmt::format("cap.log:{}:", ChannelTable::kMaxChannels + 1)))
      << log.reader().error();
  EXPECT_TRUE(HasSub(log.reader().error(), "more than 256 channels"));
}

TEST(ByteLog, LinesAcrossReadBlocksAndLongLines) {
  // The reader cuts lines from 64 KiB reads: lines straddle the seams, and one line is longer
  // than a read.
  std::string text = "#! serial 9600 8N1\n";
  std::vector<std::uint8_t> expected;
  for (int i = 0; i < 20000; ++i) {
    text += fmt::format("{}.{:06} bus {:02x} {:02x}\r\n", i / 1000, (i % 1000) * 1000, i & 0xFF,
                        (i >> 8) & 0xFF);
    expected.push_back(static_cast<std::uint8_t>(i & 0xFF));
    expected.push_back(static_cast<std::uint8_t>((i >> 8) & 0xFF));
  }
  text += "30.0 bus";
  for (int i = 0; i < 50000; ++i) {
    text += fmt::format(" {:02x}", i % 251);
    expected.push_back(static_cast<std::uint8_t>(i % 251));
  }
  text += "\n31.0 bus 7e";  // last line without its newline
  expected.push_back(0x7E);
  Log log(text);
  ASSERT_TRUE(log.reader().read_header());
  const auto ev = log.read_all();
  ASSERT_EQ(log.reader().error(), "");
  ASSERT_EQ(ev.size(), expected.size());
  for (std::size_t i = 0; i < ev.size(); ++i) ASSERT_EQ(ev[i].byte, expected[i]) << i;
  EXPECT_EQ(ev.back().time, 31 * kNsPerSecond);
}

namespace {
// An endless stream of one character, counting what was read from it.
struct Endless {
  char fill;
  std::size_t served = 0;
};
ssize_t endless_read(void* cookie, char* buf, size_t n) {
  auto* e = static_cast<Endless*>(cookie);
  std::memset(buf, e->fill, n);
  e->served += n;
  return static_cast<ssize_t>(n);
}
}  // namespace

TEST(ByteLog, EndlessLineIsRefusedAtTheLimitNotRead) {
  // A file that never ends its line: refused after the line length limit, having read (and
  // held) little more than that (getline() would have read on until memory ran out).
  Endless source{'0'};
  std::FILE* f = fopencookie(&source, "r", {endless_read, nullptr, nullptr, nullptr});
  ASSERT_NE(f, nullptr);
  ChannelTable channels;
  {
    ByteLogReader reader(f, "endless.log", channels);
    EXPECT_FALSE(reader.read_header());
    EXPECT_TRUE(HasSub(reader.error(), "endless.log:1:")) << reader.error();
    EXPECT_TRUE(HasSub(reader.error(), "line longer than")) << reader.error();
  }
  EXPECT_LT(source.served, (16u << 20) + (1u << 20));
  std::fclose(f);
}

TEST(ByteLog, ErrorBadHexDigit) {
  Log log("# header comment\n0.0 bus 01 G2\n");
  ASSERT_TRUE(log.reader().read_header());
  const auto ev = log.read_all();
  EXPECT_TRUE(HasSub(log.reader().error(), "cap.log:2:12:")) << log.reader().error();
  EXPECT_TRUE(HasSub(log.reader().error(), "bad hex digit in 'G2'"));
}

TEST(ByteLog, ErrorBadHexDigitInARun) {
  Log log("0.0 bus 0102zz\n");
  ASSERT_TRUE(log.reader().read_header());
  log.read_all();
  // Column of the bad pair inside the run (1-based): token at 9, "zz" at 13.
  EXPECT_TRUE(HasSub(log.reader().error(), "cap.log:1:13:")) << log.reader().error();
}

TEST(ByteLog, ErrorOddLengthToken) {
  Log log("0.0 bus 01\n0.1   bus 010\n");
  ASSERT_TRUE(log.reader().read_header());
  const auto ev = log.read_all();
  EXPECT_EQ(ev.size(), 1u);
  EXPECT_TRUE(HasSub(log.reader().error(), "cap.log:2:11:")) << log.reader().error();
  EXPECT_TRUE(HasSub(log.reader().error(), "'010'"));
  EXPECT_TRUE(HasSub(log.reader().error(), "pairs of hex digits"));
}

TEST(ByteLog, ErrorUnknownMark) {
  Log log("0.0 bus 00!fx\n");
  ASSERT_TRUE(log.reader().read_header());
  log.read_all();
  EXPECT_TRUE(HasSub(log.reader().error(), "cap.log:1:9:")) << log.reader().error();
  EXPECT_TRUE(HasSub(log.reader().error(), "unknown UART mark 'x'"));
}

TEST(ByteLog, ErrorMarksOnARun) {
  Log log("0.0 bus 0102!f\n");
  ASSERT_TRUE(log.reader().read_header());
  log.read_all();
  EXPECT_TRUE(HasSub(log.reader().error(), "cap.log:1:9:")) << log.reader().error();
  EXPECT_TRUE(HasSub(log.reader().error(), "belong to one byte"));
}

TEST(ByteLog, ErrorMissingChannel) {
  Log log("0.0 bus 01\n0.25\n");
  ASSERT_TRUE(log.reader().read_header());
  log.read_all();
  EXPECT_TRUE(HasSub(log.reader().error(), "cap.log:2:5:")) << log.reader().error();
  EXPECT_TRUE(HasSub(log.reader().error(), "expected a channel name"));

  Log comment("0.25 # no channel\n");
  ASSERT_TRUE(comment.reader().read_header());
  comment.read_all();
  EXPECT_TRUE(HasSub(comment.reader().error(), "cap.log:1:6:")) << comment.reader().error();
  EXPECT_TRUE(HasSub(comment.reader().error(), "expected a channel name"));
}

TEST(ByteLog, ErrorBadTime) {
  Log log("0.0x bus 01\n");
  ASSERT_TRUE(log.reader().read_header());
  log.read_all();
  EXPECT_TRUE(HasSub(log.reader().error(), "cap.log:1:1:")) << log.reader().error();
  EXPECT_TRUE(HasSub(log.reader().error(), "expected a time"));

  Log word("bus 01\n");
  ASSERT_TRUE(word.reader().read_header());
  word.read_all();
  EXPECT_TRUE(HasSub(word.reader().error(), "cap.log:1:1:")) << word.reader().error();
}

TEST(ByteLog, ErrorTimeTooLarge) {
  // 9223372039 s does not fit in int64 nanoseconds (max ~9223372036.85 s): an error, not a wrap.
  Log log("9223372039 bus 01\n");
  ASSERT_TRUE(log.reader().read_header());
  const auto ev = log.read_all();
  EXPECT_TRUE(ev.empty()) << "first time " << (ev.empty() ? 0 : ev[0].time);
  EXPECT_TRUE(HasSub(log.reader().error(), "time too large")) << log.reader().error();

  Log fraction("9223372036.9 bus 01\n");
  ASSERT_TRUE(fraction.reader().read_header());
  const auto ev2 = fraction.read_all();
  EXPECT_TRUE(ev2.empty()) << "first time " << (ev2.empty() ? 0 : ev2[0].time);
  EXPECT_TRUE(HasSub(fraction.reader().error(), "time too large")) << fraction.reader().error();

  Log huge("99999999999999999999 bus 01\n");
  ASSERT_TRUE(huge.reader().read_header());
  EXPECT_TRUE(huge.read_all().empty());
  EXPECT_TRUE(HasSub(huge.reader().error(), "time too large")) << huge.reader().error();
}

TEST(ByteLog, ErrorSerialHeaderAfterData) {
  Log log("#! serial 9600 8N1\n0.0 bus 01\n#! serial 19200 8E1\n0.1 bus 02\n");
  ASSERT_TRUE(log.reader().read_header());
  const auto ev = log.read_all();
  ASSERT_EQ(ev.size(), 1u);
  EXPECT_EQ(ev[0].byte, 0x01);
  EXPECT_TRUE(HasSub(log.reader().error(), "cap.log:3:1:")) << log.reader().error();
  EXPECT_TRUE(HasSub(log.reader().error(), "'#! serial' after the first byte"));
  // The header settings stay those of the first header.
  EXPECT_EQ(log.reader().header_serial()->baud, 9600u);
}

TEST(ByteLog, UnknownDirectivesAreIgnored) {
  Log log("#! tool sniffer 2.1\n#! serial 4800\n0.0 bus 01\n#! note after data\n0.1 bus 02\n");
  ASSERT_TRUE(log.reader().read_header());
  EXPECT_EQ(log.reader().header_serial()->baud, 4800u);
  const auto ev = log.read_all();
  EXPECT_TRUE(log.reader().error().empty()) << log.reader().error();
  EXPECT_EQ(ev.size(), 2u);
}

TEST(ByteLog, TimeReversedFinding) {
  Log log(
      "0.010 m 01 03\n"
      "0.020 s 01 83 02\n"
      "0.005 m 01\n"      // earlier than m's previous line: reversed
      "0.015 s 02\n"      // earlier than s's previous line: reversed
      "0.015 bus 03\n");  // first line on bus: fine
  ASSERT_TRUE(log.reader().read_header());
  ByteEvent e;
  for (int i = 0; i < 5; ++i) ASSERT_TRUE(log.reader().next(e));
  EXPECT_TRUE(log.reader().take_findings().empty());
  ASSERT_TRUE(log.reader().next(e));  // the reversed m line
  EXPECT_EQ(e.time, 5 * kNsPerMs);
  auto findings = log.reader().take_findings();
  ASSERT_EQ(findings.size(), 1u);
  EXPECT_EQ(findings[0].kind, AnomalyKind::time_reversed);
  EXPECT_EQ(findings[0].time, 5 * kNsPerMs);
  EXPECT_EQ(findings[0].channel, 0);
  EXPECT_EQ(findings[0].frame_number, 0u);
  EXPECT_TRUE(HasSub(findings[0].detail, "cap.log:3"));
  EXPECT_TRUE(HasSub(findings[0].detail, "channel m"));
  EXPECT_TRUE(log.reader().take_findings().empty());  // taken once

  const auto rest = log.read_all();
  EXPECT_EQ(rest.size(), 2u);
  findings = log.reader().take_findings();
  ASSERT_EQ(findings.size(), 1u);
  EXPECT_EQ(findings[0].channel, 1);
  EXPECT_TRUE(HasSub(findings[0].detail, "cap.log:4"));
}

TEST(ByteLog, EqualTimesAreNotReversed) {
  Log log("0.010 bus 01\n0.010 bus 02\n");
  ASSERT_TRUE(log.reader().read_header());
  EXPECT_EQ(log.read_all().size(), 2u);
  EXPECT_TRUE(log.reader().take_findings().empty());
}

TEST(ByteLog, ErrorIsSticky) {
  Log log("0.0 bus 01 zz\n0.1 bus 02\n");
  ASSERT_TRUE(log.reader().read_header());
  ByteEvent e;
  EXPECT_FALSE(log.reader().next(e));
  const std::string err = log.reader().error();
  EXPECT_FALSE(err.empty());
  // After an error the reader stays stopped.
  EXPECT_FALSE(log.reader().next(e)) << "returned byte " << int(e.byte);
  EXPECT_EQ(log.reader().error(), err);
}

TEST(ByteLog, Sniff) {
  EXPECT_TRUE(ByteLogReader::sniff("0.000 bus 01 03\n"));
  EXPECT_TRUE(ByteLogReader::sniff("# comment\n#! serial 9600 8N1\n\n  12.5 m 01\n"));
  EXPECT_TRUE(ByteLogReader::sniff("# only a comment"));
  EXPECT_FALSE(ByteLogReader::sniff("bus 01 03\n"));
  EXPECT_FALSE(ByteLogReader::sniff(":010300000001FB\r\n"));  // Modbus ASCII
  EXPECT_FALSE(ByteLogReader::sniff("# comment\n  PK"));
  // pcapng section header block: 0A 0D 0D 0A then the block length.
  EXPECT_FALSE(ByteLogReader::sniff(std::string_view("\x0a\x0d\x0d\x0a\x1c\x00\x00\x00", 8)));
}
