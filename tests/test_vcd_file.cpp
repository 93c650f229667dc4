// Unit tests: Value Change Dump reader (src/sources/logic/vcd_file.hpp) on hand-written VCDs and on
// sigrok-cli's exports of the .sr captures (captures/vcd/), which must give the same runs.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include <fmt/format.h>

#include "sources/logic/line_sim.hpp"
#include "sources/logic/uart_decoder.hpp"
#include "sources/logic/sigrok_file.hpp"
#include "sources/logic/vcd_file.hpp"

using namespace drivetap;
using phy::LevelRun;

namespace {

std::string capture(const std::string& rel) {
  return std::string(DRIVETAP_SOURCE_DIR) + "/captures/" + rel;
}

// Writes `text` to a file of its own (named after the running test) and returns its path.
std::string write_vcd(const std::string& text, const std::string& suffix = "") {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  const std::filesystem::path path =
      std::filesystem::path(::testing::TempDir()) /
      fmt::format("drivetap_{}_{}{}.vcd", info->test_suite_name(), info->name(), suffix);
  std::ofstream(path, std::ios::binary) << text;
  return path.string();
}

std::unique_ptr<VcdFile> open_text(const std::string& text) {
  std::string error;
  auto f = VcdFile::open(write_vcd(text), &error);
  EXPECT_TRUE(f) << error;
  return f;
}

// Why `text` is refused, from open() or, when the header is fine, from reading every channel.
std::string error_of(const std::string& text) {
  std::string error;
  auto f = VcdFile::open(write_vcd(text), &error);
  if (!f) return error;
  std::vector<std::size_t> all(f->channels().size());
  for (std::size_t i = 0; i < all.size(); ++i) all[i] = i;
  if (!f->select(all, &error)) return error;
  RunBlock block;
  while (f->next_block(block, &error)) {
  }
  return error;
}

void append_merged(std::vector<LevelRun>& to, const LevelRun& run) {
  if (!to.empty() && to.back().level == run.level)
    to.back().length += run.length;
  else
    to.push_back(run);
}

struct Read {
  std::vector<std::vector<LevelRun>> runs;  // per selected channel, adjacent levels merged
  std::uint64_t samples = 0;
  std::size_t blocks = 0;
  std::string error;
};

// Every block of the selected channels, checking the block contract on the way.
Read read_all(LogicCapture& f, const std::vector<std::size_t>& selected) {
  Read r;
  r.runs.assign(selected.size(), {});
  EXPECT_TRUE(f.select(selected, &r.error)) << r.error;
  RunBlock block;
  while (f.next_block(block, &r.error)) {
    ++r.blocks;
    EXPECT_EQ(block.begin, r.samples);
    EXPECT_GT(block.end, block.begin);
    r.samples = block.end;
    EXPECT_EQ(block.runs.size(), selected.size());
    for (std::size_t k = 0; k < block.runs.size(); ++k) {
      std::uint64_t covered = 0;
      for (const LevelRun& run : block.runs[k]) {
        EXPECT_GT(run.length, 0u);
        covered += run.length;
        append_merged(r.runs[k], run);
      }
      EXPECT_EQ(covered, block.end - block.begin) << "channel " << k;
    }
  }
  return r;
}

Read read_all(LogicCapture& f) {
  std::vector<std::size_t> all(f.channels().size());
  for (std::size_t i = 0; i < all.size(); ++i) all[i] = i;
  return read_all(f, all);
}

// "1x10 0x3": ten samples high, then three low.
std::string levels(const std::vector<LevelRun>& runs) {
  std::string out;
  for (const LevelRun& r : runs)
    out += fmt::format("{}{}x{}", out.empty() ? "" : " ", r.level ? 1 : 0, r.length);
  return out;
}

std::string header(const std::string& timescale, const std::string& vars) {
  return fmt::format(
      "$date today $end\n$version test $end\n$timescale {} $end\n$scope module top $end\n{}"
      "$upscope $end\n$enddefinitions $end\n",
      timescale, vars);
}

}  // namespace

TEST(VcdFile, TimescaleForms) {
  struct Case {
    const char* timescale;
    std::uint64_t rate;
    std::uint64_t timescale_rate;
  };
  // Finer than 1 ns: divided down to 1 GHz.
  for (const Case& c :
       {Case{"1 us", 1'000'000, 1'000'000}, Case{"1us", 1'000'000, 1'000'000},
        Case{"10 ns", 100'000'000, 100'000'000}, Case{"100ns", 10'000'000, 10'000'000},
        Case{"1 ns", 1'000'000'000, 1'000'000'000},
        Case{"\n  1ps\n", 1'000'000'000, 1'000'000'000'000},
        Case{"100 ps", 1'000'000'000, 10'000'000'000},
        Case{"1 fs", 1'000'000'000, 1'000'000'000'000'000}, Case{"1 s", 1, 1},
        Case{"100 ms", 10, 10}}) {
    auto f = open_text(header(c.timescale, "$var wire 1 ! a $end\n") + "#0 1!\n#10\n");
    ASSERT_TRUE(f) << c.timescale;
    EXPECT_EQ(f->sample_rate(), c.rate) << c.timescale;
    EXPECT_EQ(f->timescale_rate(), c.timescale_rate) << c.timescale;
  }
}

TEST(VcdFile, BadTimescalesAreRefusedWithTheirLine) {
  const std::string var = "$var wire 1 ! a $end\n";
  for (const char* bad : {"1 parsec", "3 ns", "1000 ns", "ns", "10 s", "100 s", "1.5 us"}) {
    const std::string e = error_of(header(bad, var));
    EXPECT_NE(e.find(": line 3: $timescale"), std::string::npos) << bad << ": " << e;
  }
  const std::string none =
      error_of("$scope module top $end\n" + var + "$upscope $end\n$enddefinitions $end\n#0 1!\n");
  EXPECT_NE(none.find(": line 4: no $timescale in the header"), std::string::npos) << none;
}

TEST(VcdFile, SigrokStyleLinesAndTheEndOfTheCapture) {
  // sigrok-cli's layout: values on the time stamp's line; the last time stamp alone is the end.
  auto f = open_text(
      "$timescale 1 us $end\n$scope module libsigrok $end\n$var wire 1 ! TX $end\n"
      "$var wire 1 \" RX $end\n$upscope $end\n$enddefinitions $end\n"
      "#0 1! 0\"\n#10 0!\n#12 1! 1\"\n#30\n");
  ASSERT_TRUE(f);
  EXPECT_EQ(f->sample_rate(), 1'000'000u);
  ASSERT_EQ(f->channels(), (std::vector<std::string>{"TX", "RX"}));
  const Read r = read_all(*f);
  EXPECT_TRUE(r.error.empty()) << r.error;
  EXPECT_EQ(r.samples, 30u);
  EXPECT_EQ(levels(r.runs[0]), "1x10 0x2 1x18");
  EXPECT_EQ(levels(r.runs[1]), "0x12 1x18");
}

TEST(VcdFile, SimulatorStyleDumpvarsCommentsAndEqualTimes) {
  auto f = open_text(header("1ns",
                            "$var reg 1 ! clk $end\n$var wire 1 # tx $end\n"
                            "$var wire 8 $ data [7:0] $end\n$var real 1 % volts $end\n"
                            "$var string 1 & state $end\n") +
                     "$comment all values at 0 $end\n"
                     "$dumpvars\n0!\n1#\nbxxxxxxxx $\nr0.5 %\n$end\n"
                     "#5\n1!\nb10100101 $\n$comment a comment\n  over lines $end\n"
                     "#5\n0#\n"  // equal time stamps are one moment
                     "#7\nr1.25 %\nsIDLE &\n$dumpoff\nx!\nx#\n$end\n"
                     "#9\n$dumpon\n0!\n1#\n$end\n"
                     "#9\n$dumpall 0! 1# $end\n"
                     "#12\n0#\n");  // a value at the last time stamp lasts no sample
  ASSERT_TRUE(f);
  ASSERT_EQ(f->channels(), (std::vector<std::string>{"clk", "tx"}));
  EXPECT_EQ(f->skipped_variables(), 3u);  // the vector, the real and the string
  const Read r = read_all(*f);
  EXPECT_TRUE(r.error.empty()) << r.error;
  EXPECT_EQ(r.samples, 12u);
  // $dumpoff's x keeps each level; $dumpon gives them back.
  EXPECT_EQ(levels(r.runs[0]), "0x5 1x4 0x3");
  EXPECT_EQ(levels(r.runs[1]), "1x5 0x4 1x3");
}

TEST(VcdFile, UnknownLevelsAndFirstValues) {
  auto f = open_text(header("1 us",
                            "$var wire 1 a x_then_1 $end\n$var wire 1 b late_0 $end\n"
                            "$var wire 1 c never $end\n$var wire 1 d z_between $end\n"
                            "$var wire 1 e weak $end\n") +
                     "#0\nxa\nzc\n1d\nHe\n"
                     "#4\n1a\nzd\nLe\n"
                     "#6\n0b\n1d\nUc\n"
                     "#8\nxa\n-d\n0d\nhe\n"
                     "#10\n");
  ASSERT_TRUE(f);
  const Read r = read_all(*f);
  EXPECT_TRUE(r.error.empty()) << r.error;
  EXPECT_EQ(levels(r.runs[0]), "1x10");     // x, then 1 at #4: 1 from sample 0; x again keeps it
  EXPECT_EQ(levels(r.runs[1]), "0x10");     // first dumped at #6
  EXPECT_EQ(levels(r.runs[2]), "1x10");     // never a level: idle high
  EXPECT_EQ(levels(r.runs[3]), "1x8 0x2");  // z keeps 1; "-" then 0 at #8
  EXPECT_EQ(levels(r.runs[4]), "1x4 0x4 1x2");  // H, L, h
}

TEST(VcdFile, MultiByteIdentifiersScopesAndAliases) {
  auto f = open_text(
      "$timescale 10 ns $end\n"
      "$scope module top $end\n$scope module tb $end\n"
      "$var wire 1 !# tx $end\n"
      "$var wire 1 aaaaa clk $end\n"
      "$scope module dut $end\n$var wire 1 s10 rx $end\n$var wire 1 !# tx_in $end\n"
      "$var wire 1 # bit [3] $end\n$upscope $end\n"
      "$upscope $end\n$upscope $end\n$enddefinitions $end\n"
      "#0\n1!#\n0aaaaa\n0s10\n1#\n#3\n0!#\n1aaaaa\n#4\n1s10\nb0 #\n#7\n1!#\n#9\n");
  ASSERT_TRUE(f);
  EXPECT_EQ(f->sample_rate(), 100'000'000u);
  // Below the shared scopes top.tb; a bit-select joins the name; "!#" is declared twice.
  ASSERT_EQ(f->channels(),
            (std::vector<std::string>{"tx", "clk", "dut.rx", "dut.tx_in", "dut.bit[3]"}));
  const Read r = read_all(*f);
  EXPECT_TRUE(r.error.empty()) << r.error;
  EXPECT_EQ(levels(r.runs[0]), "1x3 0x4 1x2");
  EXPECT_EQ(levels(r.runs[1]), "0x3 1x6");
  EXPECT_EQ(levels(r.runs[2]), "0x4 1x5");
  EXPECT_EQ(levels(r.runs[3]), levels(r.runs[0]));  // alias of tx
  EXPECT_EQ(levels(r.runs[4]), "1x4 0x5");          // a 1-bit "b0" value
  // A subset, in another order, one channel twice.
  const Read two = read_all(*f, {2, 0, 2});
  EXPECT_EQ(levels(two.runs[0]), levels(r.runs[2]));
  EXPECT_EQ(levels(two.runs[1]), levels(r.runs[0]));
  EXPECT_EQ(levels(two.runs[2]), levels(r.runs[2]));
}

TEST(VcdFile, NamesWithSpacesAndNoSharedScope) {
  auto f = open_text(
      "$timescale 1 ns $end\n$scope module a $end\n$var wire 1 ! Channel 0 $end\n$upscope $end\n"
      "$scope module b $end\n$var wire 1 \" Channel 1 $end\n$upscope $end\n"
      "$var wire 1 # top_level $end\n$enddefinitions $end\n#0 0! 0\" 0#\n#1\n");
  ASSERT_TRUE(f);
  EXPECT_EQ(f->channels(), (std::vector<std::string>{"a.Channel 0", "b.Channel 1", "top_level"}));
}

TEST(VcdFile, TimesFinerThanANanosecondAreDividedDown) {
  // 1 ps: 1 GHz, every time divided by 1000 and rounded down; the 400 ps pulse at #2100 vanishes.
  auto f = open_text(header("1ps", "$var wire 1 ! a $end\n") +
                     "#0\n1!\n#1500\n0!\n#2100\n1!\n#2500\n0!\n#4999\n1!\n#7000\n");
  ASSERT_TRUE(f);
  EXPECT_EQ(f->sample_rate(), 1'000'000'000u);
  const Read r = read_all(*f);
  EXPECT_TRUE(r.error.empty()) << r.error;
  EXPECT_EQ(r.samples, 7u);
  EXPECT_EQ(levels(r.runs[0]), "1x1 0x3 1x3");
}

TEST(VcdFile, SigrokStatedRate) {
  const std::string vars = "$var wire 1 ! TX $end\n";
  const std::string body = "#0 1!\n#2055 0!\n#4140 1!\n#191245\n";
  auto two_mhz = open_text("$comment\n  Acquisition with 8/8 channels at 2 MHz\n$end\n" +
                           header("100 ns", vars) + body);
  ASSERT_TRUE(two_mhz);
  EXPECT_EQ(two_mhz->sample_rate(), 2'000'000u);
  EXPECT_EQ(two_mhz->timescale_rate(), 10'000'000u);
  const Read r = read_all(*two_mhz);
  EXPECT_EQ(r.samples, 38249u);
  EXPECT_EQ(levels(r.runs[0]), "1x411 0x417 1x37421");
  // 24 MHz on 100 ps: sigrok rounded each time to a tick; rounding back gives its samples.
  auto fx2 = open_text("$comment\n  Acquisition with 2/8 channels at 24 MHz\n$end\n" +
                       header("100 ps", vars) + "#0 1!\n#4167 0!\n#8333 1!\n#12500\n");
  ASSERT_TRUE(fx2);
  EXPECT_EQ(fx2->sample_rate(), 24'000'000u);
  EXPECT_EQ(levels(read_all(*fx2).runs[0]), "1x10 0x10 1x10");
  // A rate above the timescale's cannot be: the timescale's own rate stays.
  auto too_fast = open_text("$comment\n  Acquisition with 1/8 channels at 20 MHz\n$end\n" +
                            header("100 ns", vars) + body);
  ASSERT_TRUE(too_fast);
  EXPECT_EQ(too_fast->sample_rate(), 10'000'000u);
  // Not sigrok's comment: ignored.
  auto other = open_text("$comment\n  sampled at 2 MHz\n$end\n" + header("100 ns", vars) + body);
  ASSERT_TRUE(other);
  EXPECT_EQ(other->sample_rate(), 10'000'000u);
}

TEST(VcdFile, ManyBlocksGiveTheSameRunsAsOne) {
  // 300000 edges: several blocks; run boundaries do not depend on where blocks end.
  std::string text = header("1 us", "$var wire 1 ! a $end\n$var wire 1 \" quiet $end\n");
  text += "#0 0! 1\"\n";
  std::vector<LevelRun> expected;
  std::uint64_t t = 0;
  bool level = false;
  for (int i = 0; i < 300000; ++i) {
    const std::uint64_t length = 1 + static_cast<std::uint64_t>(i % 7);
    expected.push_back({level, length});
    t += length;
    level = !level;
    text += fmt::format("#{} {}!\n", t, level ? 1 : 0);
  }
  t += 5;
  expected.push_back({level, 5});
  text += fmt::format("#{}\n", t);
  auto f = open_text(text);
  ASSERT_TRUE(f);
  const Read r = read_all(*f);
  EXPECT_TRUE(r.error.empty()) << r.error;
  EXPECT_GT(r.blocks, 3u);
  EXPECT_EQ(r.samples, t);
  EXPECT_TRUE(r.runs[0] == expected);  // 300001 runs: no printout
  EXPECT_EQ(levels(r.runs[1]), fmt::format("1x{}", t));
  // select() starts over.
  const Read again = read_all(*f);
  EXPECT_TRUE(again.runs == r.runs);
}

TEST(VcdFile, BlockEndsAnywhereChangeNothing) {
  // Blocks of 1..9 tokens end between every kind of token: at equal times, inside $dumpvars,
  // between a vector value and its identifier's next change.
  auto f = open_text(header("1ps",
                            "$var wire 1 ! a $end\n$var wire 1 \" b $end\n"
                            "$var wire 4 # v $end\n") +
                     "$dumpvars 1! x\" b0000 # $end\n#1000 0!\n#1000 1\"\n#1500 b1 #\n1!\n"
                     "#2000\n#2200 0! 0\" 1!\n#3000 $comment c $end 0\"\n#3000 1\"\n#4000 0!\n"
                     "#5999 1!\n#6000\n");
  ASSERT_TRUE(f);
  const Read whole = read_all(*f);
  EXPECT_EQ(whole.samples, 6u);
  // Two values of one channel in one sample (1.0 and 1.5 ns; 2.2 ns): the last one counts.
  EXPECT_EQ(levels(whole.runs[0]), "1x4 0x1 1x1");
  EXPECT_EQ(levels(whole.runs[1]), "1x2 0x1 1x3");
  for (std::size_t tokens = 1; tokens < 10; ++tokens) {
    f->set_block_tokens(tokens);
    const Read r = read_all(*f);
    EXPECT_EQ(levels(r.runs[0]), levels(whole.runs[0])) << tokens;
    EXPECT_EQ(levels(r.runs[1]), levels(whole.runs[1])) << tokens;
    EXPECT_EQ(r.samples, whole.samples);
    EXPECT_GT(r.blocks, 1u);
  }
}

TEST(VcdFile, TimeGoingBackIsAnErrorWithItsLine) {
  const std::string e =
      error_of(header("1 us", "$var wire 1 ! a $end\n") + "#0\n1!\n#10\n0!\n#5\n1!\n#20\n");
  EXPECT_NE(e.find(".vcd: line 12: time #5 goes back (after #10)"), std::string::npos) << e;
}

TEST(VcdFile, BlocksBeforeAnErrorStand) {
  std::string text = header("1 us", "$var wire 1 ! a $end\n") + "#0 0!\n";
  for (int i = 1; i <= 200000; ++i) text += fmt::format("#{} {}!\n", i, i % 2);
  text += "#3 0!\n";
  std::string error;
  auto f = VcdFile::open(write_vcd(text), &error);
  ASSERT_TRUE(f) << error;
  ASSERT_TRUE(f->select({0}, &error)) << error;
  RunBlock block;
  std::uint64_t samples = 0;
  while (f->next_block(block, &error)) samples = block.end;
  EXPECT_GT(samples, 0u);
  EXPECT_NE(error.find(fmt::format(": line {}: time #3 goes back", 9 + 200000)), std::string::npos)
      << error;
  EXPECT_FALSE(f->next_block(block, &error));  // and stays at the end
}

TEST(VcdFile, TruncatedHeaders) {
  const std::string start = "$timescale 1 us $end\n$scope module top $end\n";
  std::string e = error_of(start + "$var wire 1 ! a\n");
  EXPECT_NE(e.find(": line 3: $var is not closed by $end"), std::string::npos) << e;
  e = error_of(start + "$var wire 1 ! a $end\n$upscope $end\n");
  EXPECT_NE(e.find(": line 5: the file ends inside the header (no $enddefinitions)"),
            std::string::npos)
      << e;
  e = error_of("");
  EXPECT_NE(e.find(": line 1: the file ends inside the header"), std::string::npos) << e;
  e = error_of(start + "$comment never closed\n");
  EXPECT_NE(e.find(": line 3: $comment is not closed by $end"), std::string::npos) << e;
}

TEST(VcdFile, MalformedDeclarationsAndValues) {
  const std::string ts = "$timescale 1 us $end\n";
  const std::string var = "$var wire 1 ! a $end\n$enddefinitions $end\n";
  struct Case {
    std::string text;
    std::string error;
  };
  for (const Case& c : std::vector<Case>{
           {"garbage\n", ": line 1: 'garbage' outside a header section"},
           {ts + "$var wire 1 ! $end\n", ": line 2: $var needs a type, a size"},
           {ts + "$var wire one ! a $end\n", ": line 2: $var size 'one' is not a bit count"},
           {ts + "$var wire 8 ! a $end\n$enddefinitions $end\n",
            ": line 3: no 1-bit variable to read (1 declared"},
           {ts + var + "#0 1!\n1?\n", ": line 5: value for '?', which no $var declares"},
           {ts + var + "#0 1!\nq!\n", ": line 5: 'q!' is not a value change"},
           {ts + var + "#0 1!\n1\n", ": line 5: value '1' without an identifier"},
           {ts + var + "#0 1!\nb101\n", "the file ends between a value and its"},
           {ts + var + "#0 1!\n#x\n", ": line 5: '#x' is not a time"},
           {ts + var + "#0 1!\n#18446744073709551616\n", "does not fit 64 bits"},
           {ts + var + "#0 1!\n$var\n", ": line 5: '$var' among the value changes"},
           // 2^62 ns is the pipeline's limit: 4611686018 s at 1 us.
           {ts + var + "#0 1!\n#4611686018000000\n", "is beyond the 4611686018 s a capture"},
       }) {
    const std::string e = error_of(c.text);
    EXPECT_NE(e.find(c.error), std::string::npos) << c.text << "\n-> " << e;
  }
  // Just inside the limit, and a 64-bit time at 1 fs (divided to 1 GHz), are fine.
  EXPECT_EQ(error_of(ts + var + "#0 1!\n#4611686017999999\n"), "");
  EXPECT_EQ(error_of("$timescale 1 fs $end\n" + var + "#0 1!\n#18446744073709551615\n"), "");
}

TEST(VcdFile, HostileSizesAreBounded) {
  const std::string ts = "$timescale 1 us $end\n";
  std::string many = ts;
  for (int i = 0; i <= 4096; ++i) many += fmt::format("$var wire 1 v{} n{} $end\n", i, i);
  EXPECT_NE(error_of(many).find(": line 4098: more than 4096 variables"), std::string::npos);
  const std::string long_id(257, 'i');
  EXPECT_NE(error_of(ts + "$var wire 1 " + long_id + " a $end\n")
                .find(": line 2: identifier longer than 256 bytes"),
            std::string::npos);
  EXPECT_NE(error_of(ts + "$var wire 1 ! " + std::string(1025, 'n') + " $end\n")
                .find(": line 2: variable name longer than 1024 bytes"),
            std::string::npos);
  std::string deep = ts;
  for (int i = 0; i < 33; ++i) deep += "$scope module m $end\n";
  EXPECT_NE(error_of(deep).find(": line 34: scopes nested deeper than 32"), std::string::npos);
  // A word of 64 KiB + 1 (a vector value, say) is refused; one of 64 KiB is read and skipped,
  // also when it runs across reads.
  const std::string var = "$var wire 1 ! a $end\n$var wire 65536 \" v $end\n$enddefinitions $end\n";
  const std::string too_long = ts + var + "#0 1!\nb" + std::string(65536, '1') + " \"\n";
  EXPECT_NE(error_of(too_long).find(": line 6: a word longer than 65536 bytes"), std::string::npos);
  const std::string longest =
      ts + var + "#0 1!\nb" + std::string(65535, '1') + " \"\n#10 0!\n#12\n";
  EXPECT_EQ(error_of(longest), "");
  std::string error;
  for (const std::size_t read_bytes : {1000, 4096, 65536}) {
    auto f = VcdFile::open(write_vcd(too_long, "_too_long"), &error, read_bytes);
    ASSERT_TRUE(f) << error;
    EXPECT_NE(read_all(*f).error.find(": line 6: a word longer than 65536 bytes"),
              std::string::npos);
    f = VcdFile::open(write_vcd(longest, "_longest"), &error, read_bytes);
    ASSERT_TRUE(f) << error;
    const Read r = read_all(*f);
    EXPECT_EQ(r.error, "");
    EXPECT_EQ(levels(r.runs[0]), "1x10 0x2");
  }
}

TEST(VcdFile, MissingFile) {
  std::string error;
  EXPECT_FALSE(VcdFile::open("/nonexistent.vcd", &error));
  EXPECT_NE(error.find("/nonexistent.vcd: cannot open: "), std::string::npos) << error;
}

// sigrok-cli's VCD export of each .sr (captures/vcd/README.md) gives the runs of the .sr itself.
class VcdFromSigrok : public ::testing::TestWithParam<std::pair<const char*, const char*>> {};

TEST_P(VcdFromSigrok, SameRunsAndRateAsTheSessionFile) {
  const auto [vcd_name, sr_name] = GetParam();
  std::string error;
  auto vcd = VcdFile::open(capture(vcd_name), &error);
  ASSERT_TRUE(vcd) << error;
  auto sr = SigrokFile::open(capture(sr_name), &error);
  ASSERT_TRUE(sr) << error;
  EXPECT_EQ(vcd->sample_rate(), sr->sample_rate());
  std::vector<std::size_t> in_vcd, in_sr;
  for (std::size_t i = 0; i < vcd->channels().size(); ++i) {
    const auto& names = sr->channels();
    const auto at = std::find(names.begin(), names.end(), vcd->channels()[i]);
    ASSERT_NE(at, names.end()) << vcd->channels()[i];
    in_vcd.push_back(i);
    in_sr.push_back(static_cast<std::size_t>(at - names.begin()));
  }
  const Read a = read_all(*vcd, in_vcd);
  const Read b = read_all(*sr, in_sr);
  EXPECT_TRUE(a.error.empty()) << a.error;
  EXPECT_TRUE(b.error.empty()) << b.error;
  EXPECT_EQ(a.samples, b.samples);
  std::size_t moving = 0;
  for (std::size_t k = 0; k < in_vcd.size(); ++k) {
    EXPECT_EQ(levels(a.runs[k]), levels(b.runs[k])) << vcd->channels()[k];
    moving += b.runs[k].size() > 1;
  }
  EXPECT_GT(moving, 0u);
}

INSTANTIATE_TEST_SUITE_P(
    Captures, VcdFromSigrok,
    ::testing::Values(std::make_pair("vcd/hello_world_7o1_115200.vcd",
                                     "uart-phy/hello_world_7o1_hello_world_7o1_115200.sr"),
                      std::make_pair("vcd/errors_ampel64_4800_8n1_ok.vcd",
                                     "uart-phy/errors_ampel64_4800_8n1_ok.sr"),
                      std::make_pair("vcd/brainchild-io-16do.vcd",
                                     "sigrok-brainchild-io-16do/brainchild-io-16do.sr")));

// Read a few bytes at a time (words running across reads, the header too) and in blocks of a
// few tokens: the same channels and levels.
TEST_P(VcdFromSigrok, SameRunsInSmallReadsAndBlocks) {
  const char* vcd_name = GetParam().first;
  std::string error;
  auto whole = VcdFile::open(capture(vcd_name), &error);
  ASSERT_TRUE(whole) << error;
  const Read expected = read_all(*whole);
  for (const std::size_t read_bytes : {1, 2, 3, 7, 64}) {
    auto f = VcdFile::open(capture(vcd_name), &error, read_bytes);
    ASSERT_TRUE(f) << error;
    EXPECT_EQ(f->channels(), whole->channels());
    EXPECT_EQ(f->sample_rate(), whole->sample_rate());
    f->set_block_tokens(read_bytes);
    const Read r = read_all(*f);
    EXPECT_TRUE(r.error.empty()) << r.error;
    EXPECT_EQ(r.samples, expected.samples);
    EXPECT_TRUE(r.runs == expected.runs) << read_bytes;
  }
}

TEST(VcdFile, HelloWorldDecodesAt115200_7O1) {
  std::string error;
  auto f = VcdFile::open(capture("vcd/hello_world_7o1_115200.vcd"), &error);
  ASSERT_TRUE(f) << error;
  ASSERT_EQ(f->channels(), std::vector<std::string>{"TX"});
  const Read r = read_all(*f, {0});
  ASSERT_TRUE(r.error.empty()) << r.error;
  const auto serial = SerialConfig::parse("115200 7O1", &error);
  ASSERT_TRUE(serial) << error;
  const auto characters =
      phy::decode_runs(r.runs[0], phy::UartSettings::from(*serial), f->sample_rate());
  std::string text;
  for (const phy::UartCharacter& c : characters) {
    EXPECT_EQ(c.flags, 0) << text;
    text += static_cast<char>(c.value);
  }
  EXPECT_EQ(text, "Hello World!\r\nHello World!\r\nHello World!\r\nHello World!\r\n");
}

// The line simulator's VCD (sigrok's layout, src/sources/logic/line_sim.hpp) reads back as the very runs
// it was written from, also at 3 and 24 MHz, whose sample times it rounds to 1 ns and 100 ps.
TEST(VcdFile, LineSimulatorVcdRoundTrip) {
  const std::vector<std::uint8_t> bytes = {0x01, 0x03, 0x00, 0x00, 0x00, 0x0A, 0xC5, 0xCD, 0x55};
  for (const std::uint64_t rate :
       {250'000ull, 1'000'000ull, 2'000'000ull, 8'000'000ull, 24'000'000ull, 3'000'000ull}) {
    SCOPED_TRACE(rate);
    phy::LineSimSettings settings;
    settings.sample_rate_hz = rate;
    settings.uart.baud = 19200;
    settings.uart.parity = phy::UartParity::even;
    const std::vector<LevelRun> line = phy::simulate_uart(bytes, settings, 1.5);
    std::ostringstream text;
    phy::write_vcd(text, line, rate, "RX");
    auto f = open_text(text.str());
    ASSERT_TRUE(f);
    const Read r = read_all(*f, {0});
    ASSERT_TRUE(r.error.empty()) << r.error;
    EXPECT_EQ(f->sample_rate(), rate);
    EXPECT_EQ(levels(r.runs[0]), levels(line));
    std::vector<std::uint8_t> decoded;
    for (const phy::UartCharacter& c :
         phy::decode_runs(r.runs[0], settings.uart, f->sample_rate())) {
      EXPECT_EQ(c.flags, 0);
      decoded.push_back(static_cast<std::uint8_t>(c.value));
    }
    EXPECT_EQ(decoded, bytes);
  }
}
