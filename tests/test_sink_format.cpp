// Unit tests: the sinks' hand-written number and string formatting (src/core/format.hpp,
// json_sink) against what fmt prints.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "core/format.hpp"
#include "core/line_buffer.hpp"
#include "sinks/json_sink.hpp"
#include "sinks/text_sink.hpp"

using namespace drivetap;

namespace {

std::string ms_of(TimeNs t) {
  std::string s;
  append_ms(s, t);
  return s;
}

std::string fmt_ms(TimeNs t) {
  return fmt::format("{:.3f}", static_cast<double>(t) / static_cast<double>(kNsPerMs));
}

}  // namespace

TEST(SinkFormat, MillisecondsAreWhatFmtPrints) {
  // Edges: zero, rounding up into the next millisecond and second, ties (formatted as the
  // double has them), negatives, the integer path's limit and beyond.
  for (const TimeNs t :
       {TimeNs{0}, TimeNs{1}, TimeNs{499}, TimeNs{500}, TimeNs{501}, TimeNs{999'499},
        TimeNs{999'500}, TimeNs{999'501}, TimeNs{1'500}, TimeNs{2'500}, TimeNs{15'940'123},
        TimeNs{-1}, TimeNs{-500}, TimeNs{-1'500'000}, (TimeNs{1} << 50) - 1, TimeNs{1} << 50,
        (TimeNs{1} << 50) + 1, TimeNs{1} << 61})
    EXPECT_EQ(ms_of(t), fmt_ms(t)) << t;
  std::mt19937_64 random(42);
  for (int i = 0; i < 200000; ++i) {
    const int bits = static_cast<int>(random() % 51);
    const TimeNs t = static_cast<TimeNs>(random() >> (64 - std::max(bits, 1)));
    ASSERT_EQ(ms_of(t), fmt_ms(t)) << t;
  }
}

TEST(SinkFormat, JsonStringsEscapeQuotesBackslashesAndControls) {
  EXPECT_EQ(json_quote("plain text 123"), "\"plain text 123\"");
  EXPECT_EQ(json_quote("say \"hi\" \\ there"), "\"say \\\"hi\\\" \\\\ there\"");
  EXPECT_EQ(json_quote("a\nb\rc\td"), "\"a\\nb\\rc\\td\"");
  EXPECT_EQ(json_quote(std::string("x\x01y\x1f", 4)), "\"x\\u0001y\\u001f\"");
  EXPECT_EQ(json_quote(std::string("nul\0end", 7)), "\"nul\\u0000end\"");
  EXPECT_EQ(json_quote("\xC2\xB0"
                       "C"),
            "\"\xC2\xB0"
            "C\"");  // UTF-8 passes as it is
  EXPECT_EQ(json_quote(""), "\"\"");
}

// Long strings go through the sixteen- and eight-character scans before any escaping: a
// character that needs escaping is found at every place of them, and none is found where there
// is none (ASCII; bytes from 0x80 are checked as UTF-8, below).
TEST(SinkFormat, JsonEscapingOfLongStringsFindsEveryPlace) {
  auto reference = [](std::string_view s) {
    std::string out = "\"";
    for (const char c : s) {
      const auto u = static_cast<unsigned char>(c);
      if (c == '"')
        out += "\\\"";
      else if (c == '\\')
        out += "\\\\";
      else if (c == '\n')
        out += "\\n";
      else if (c == '\r')
        out += "\\r";
      else if (c == '\t')
        out += "\\t";
      else if (u < 0x20)
        out += fmt::format("\\u{:04x}", u);
      else
        out += c;
    }
    return out + "\"";
  };
  for (const std::size_t length : {16u, 17u, 31u, 40u, 48u, 300u}) {
    std::string plain;
    for (std::size_t i = 0; i < length; ++i) plain += static_cast<char>(0x20 + (i * 37) % 0x60);
    for (char& c : plain)
      if (c == '"' || c == '\\') c = 'x';
    EXPECT_EQ(json_quote(plain), reference(plain)) << length;
    const std::size_t step = length > 48 ? 13 : 1;  // every place of the short ones
    for (std::size_t at = 0; at < length; at += step)
      for (const char special : {'"', '\\', '\n', '\x01', '\x1f', '\0'}) {
        std::string s = plain;
        s[at] = special;
        EXPECT_EQ(json_quote(s), reference(s)) << length << " " << at << " " << int{special};
      }
  }
}

// Names from hostile files reach JSON: well-formed UTF-8 passes, a malformed byte
// becomes U+FFFD and a C1 control is escaped, at every place of a long string (the scans).
TEST(SinkFormat, JsonOfMalformedUtf8IsValidUtf8) {
  EXPECT_EQ(json_quote("a\xFF"
                       "b"),
            "\"a\\ufffdb\"");                                          // not a lead byte
  EXPECT_EQ(json_quote("\xC3"), "\"\\ufffd\"");                        // cut sequence
  EXPECT_EQ(json_quote("\xC0\xAF"), "\"\\ufffd\\ufffd\"");             // overlong '/'
  EXPECT_EQ(json_quote("\xED\xA0\x80"), "\"\\ufffd\\ufffd\\ufffd\"");  // surrogate
  EXPECT_EQ(json_quote("\xC2\x9B"
                       "2J"),
            "\"\\u009b2J\"");  // C1 CSI
  EXPECT_EQ(json_quote("\xE2\x82\xAC\xF0\x9F\x98\x80"), "\"\xE2\x82\xAC\xF0\x9F\x98\x80\"");
  const std::string plain(48, 'a');
  for (std::size_t at = 0; at < plain.size(); ++at) {
    std::string s = plain;
    s[at] = '\xFE';
    EXPECT_EQ(json_quote(s),
              fmt::format("\"{}\\ufffd{}\"", plain.substr(0, at), plain.substr(at + 1)))
        << at;
  }
}

TEST(SinkFormat, LineBufferHoldsWhatAStringWouldHold) {
  // The same appends into a LineBuffer and a std::string, past several growths of the buffer.
  LineBuffer line;
  std::string expected;
  for (int i = 0; i < 300; ++i) {
    line += "k\":";
    expected += "k\":";
    append_uint(line, static_cast<std::uint64_t>(i) * 7919u);
    append_uint(expected, static_cast<std::uint64_t>(i) * 7919u);
    // Odd i: a tie (t % 1000 == 500), which append_ms formats through fmt; even i: integers.
    const TimeNs t = i % 2 ? i * 1000 + 500 : i * 1234567;
    append_ms(line, t);
    append_ms(expected, t);
    line.append(static_cast<std::size_t>(i % 3), ' ');
    expected.append(static_cast<std::size_t>(i % 3), ' ');
    line += std::string("x\n");
    expected += std::string("x\n");
    line += ',';
    expected += ',';
  }
  EXPECT_EQ(line.view(), expected);
  line.resize(5);
  EXPECT_EQ(line.view(), expected.substr(0, 5));
  line.resize(7);  // grows as std::string::resize does: with NULs
  EXPECT_EQ(line.view(), expected.substr(0, 5) + std::string(2, '\0'));
  line.clear();
  EXPECT_TRUE(line.empty());
  append_json_quoted(line, "a\"b");
  EXPECT_EQ(line.view(), "\"a\\\"b\"");
  // A view of the buffer appended to it, across a growth (the old storage must outlive the copy).
  LineBuffer twice;
  twice.append(std::string(200, 'x') + "y");
  for (int k = 0; k < 4; ++k) twice.append(twice.view());
  EXPECT_EQ(twice.size(), 16u * 201u);
  EXPECT_EQ(twice.view().substr(twice.size() - 201), std::string(200, 'x') + "y");
}

TEST(SinkFormat, JsonTailEscapedInPlaceAsQuotingWouldEscapeIt) {
  // The JSON sink writes a frame's summary straight into its line and escapes it there.
  const std::string head = "{\"summary\":\"";
  for (const std::string& tail : {std::string("Read Holding Registers reply: 2 registers = 0, 0"),
                                  std::string("id 0x00=\"ACME\", 0x01=\"E-9\\x\"\n"),
                                  std::string("x\x01y", 3), std::string()}) {
    const std::string escaped = head + json_quote(tail).substr(1, json_quote(tail).size() - 2);
    std::string line = head + tail;
    escape_json_tail(line, head.size());
    EXPECT_EQ(line, escaped) << tail;
    LineBuffer buffer;
    buffer += head + tail;
    escape_json_tail(buffer, head.size());
    EXPECT_EQ(buffer.view(), escaped) << tail;
  }
}

TEST(SinkFormat, JsonTailFindsEveryCharacterToEscapeAtEveryPosition) {
  // The tail is scanned sixteen characters at a time (SSE2), then eight: every byte value at
  // every place of a block, of a word and of the rest after them (41 = 16 + 16 + 8 + 1) must be
  // found exactly when it needs escaping.
  for (int value = 0; value < 256; ++value) {
    for (std::size_t at = 0; at < 41; ++at) {
      std::string tail(41, 'a');
      tail[at] = static_cast<char>(value);
      if (at > 0) tail[at - 1] = static_cast<char>(0x80 | value);  // a high byte just before
      const std::string quoted = json_quote(tail);
      LineBuffer buffer;
      buffer += "{\"s\":\"";
      buffer += tail;
      escape_json_tail(buffer, 6);
      ASSERT_EQ(buffer.view().substr(6), quoted.substr(1, quoted.size() - 2))
          << "byte " << value << " at " << at;
    }
  }
}

namespace {

template <class Out>
std::string uint_of(std::uint64_t v) {
  Out out;
  out += 'x';  // appended after something, as in a line
  append_uint(out, v);
  return std::string(out.data() + 1, out.size() - 1);
}

template <class Out>
std::string int_of(std::int64_t v) {
  Out out;
  append_int(out, v);
  return std::string(out.data(), out.size());
}

// Values of every decimal length: each power of ten and its neighbours, the limits, a range
// counted through and random values of every bit width.
std::vector<std::uint64_t> uint_cases() {
  std::vector<std::uint64_t> cases;
  for (std::uint64_t v = 0; v <= 120'000; ++v) cases.push_back(v);
  std::uint64_t power = 1;
  for (int i = 0; i < 20; ++i) {
    cases.insert(cases.end(), {power - 1, power, power + 1});
    if (i < 19) power *= 10;
  }
  cases.push_back(UINT64_MAX);
  cases.push_back(UINT64_MAX - 1);
  std::mt19937_64 random(7);
  for (int bits = 1; bits <= 64; ++bits)
    for (int k = 0; k < 2000; ++k)
      cases.push_back(bits == 64 ? random() : random() & ((std::uint64_t{1} << bits) - 1));
  return cases;
}

}  // namespace

TEST(SinkFormat, UnsignedNumbersAreWhatFmtPrints) {
  for (const std::uint64_t v : uint_cases()) {
    const std::string expected = fmt::format("{}", v);
    ASSERT_EQ(uint_of<std::string>(v), expected) << v;
    ASSERT_EQ(uint_of<LineBuffer>(v), expected) << v;
  }
}

TEST(SinkFormat, SignedNumbersAreWhatFmtPrints) {
  for (const std::uint64_t u : uint_cases()) {
    for (const std::int64_t v :
         {static_cast<std::int64_t>(u), -static_cast<std::int64_t>(u >> 1)}) {
      const std::string expected = fmt::format("{}", v);
      ASSERT_EQ(int_of<std::string>(v), expected) << v;
      ASSERT_EQ(int_of<LineBuffer>(v), expected) << v;
    }
  }
  EXPECT_EQ(int_of<LineBuffer>(INT64_MIN), "-9223372036854775808");
  EXPECT_EQ(int_of<std::string>(INT64_MIN), "-9223372036854775808");
  EXPECT_EQ(int_of<LineBuffer>(INT64_MAX), "9223372036854775807");
}

TEST(SinkFormat, FractionsAreTheLowestDigitsZeroPadded) {
  std::mt19937_64 random(11);
  for (int decimals = 1; decimals <= 9; ++decimals) {
    std::uint64_t modulus = 1;
    for (int i = 0; i < decimals; ++i) modulus *= 10;
    for (int k = 0; k < 20000; ++k) {
      // Small values (leading zeros), values near the modulus and beyond it (digits dropped).
      const std::uint64_t fraction =
          k < 1000   ? static_cast<std::uint64_t>(k)
          : k < 2000 ? modulus - 1 - static_cast<std::uint64_t>(k - 1000) % modulus
                     : random() % 4'000'000'000u;
      const std::string expected = fmt::format(".{:0{}}", fraction % modulus, decimals);
      std::string s = "t=";
      append_fraction(s, fraction, decimals);
      ASSERT_EQ(s, "t=" + expected) << fraction << " " << decimals;
      LineBuffer line;
      append_fraction(line, fraction, decimals);
      ASSERT_EQ(std::string(line.view()), expected) << fraction << " " << decimals;
    }
  }
}

TEST(SinkFormat, TextPrefixIsTheAlignedColumns) {
  // Every record's number (or "-"), time and channel, as fmt pads them: the prefix writes its
  // pieces into room for the most they take, so long numbers, times and names are the edges.
  std::mt19937_64 random(13);
  std::vector<TimeNs> times = {0,         1,        999'999'999, 1'000'000'000, -1, -1'500'000'000,
                               INT64_MAX, INT64_MIN};
  for (int k = 0; k < 2000; ++k)
    times.push_back(static_cast<TimeNs>(random() >> static_cast<unsigned>(k % 64)));
  const std::vector<std::uint64_t> numbers = uint_cases();
  const std::vector<std::string> channels = {
      "", "a", "rtu", "bus1", "ttyUSB0=rtu", "ab", "12345", std::string(40, 'c')};
  // Every number, each with a time and a channel of the lists in turn (every time meets many).
  for (std::size_t k = 0; k < numbers.size(); ++k) {
    const TimeNs t = times[k % times.size()];
    const std::uint64_t number = k % 7 == 0 ? 0 : numbers[k];
    const std::string& channel = channels[k % channels.size()];
    for (const bool show_time : {true, false}) {
      const std::string time_column =
          show_time ? fmt::format("{:>14} ", format_seconds(t, 6)) : std::string();
      const std::string expected = std::string("|") +
                                   (number ? fmt::format("{:>5}", number) : std::string("    -")) +
                                   " " + time_column + fmt::format("{:<3} ", channel);
      std::string s = "|";
      append_text_prefix(s, number, t, show_time, channel);
      ASSERT_EQ(s, expected) << number << " " << t << " " << channel;
      LineBuffer line;
      line += '|';
      append_text_prefix(line, number, t, show_time, channel);
      ASSERT_EQ(std::string(line.view()), expected) << number << " " << t << " " << channel;
    }
  }
}
