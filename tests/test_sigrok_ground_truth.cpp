// Golden check against other people's ground truth: sigrok's frame lists of real Modbus RTU
// captures (../shared/captures-external/sigrok/modbus_rtu, copied into captures/sigrok-*).
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <sstream>

#include "dissectors/modbus/modbus_protocol.hpp"
#include "sources/logic/logic_source.hpp"
#include "sources/logic/sigrok_file.hpp"
#include "test_support.hpp"

using namespace drivetap;
using namespace drivetap::testing;

namespace {

struct TruthFrame {
  TimeNs start;
  std::string hex;
};

// Reads a *.frames.csv (columns: label,idx,start_sample,...,hex) at `rate` samples/s.
std::vector<TruthFrame> read_truth(const std::string& path, std::int64_t rate) {
  std::ifstream in(path);
  EXPECT_TRUE(in) << path;
  std::string line;
  std::getline(in, line);  // header
  std::vector<TruthFrame> out;
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    std::vector<std::string> cols;
    std::stringstream ss(line);
    std::string col;
    while (std::getline(ss, col, ',')) cols.push_back(col);
    if (line.back() == ',') cols.emplace_back();
    EXPECT_EQ(cols.size(), 11u) << line;
    if (cols.size() != 11u) continue;
    std::string hex = cols[10];
    std::transform(hex.begin(), hex.end(), hex.begin(), ::toupper);
    out.push_back({std::stoll(cols[2]) * kNsPerSecond / rate, hex});
  }
  return out;
}

void expect_frame_for_frame(const std::string& capture, std::vector<TruthFrame> truth) {
  std::sort(truth.begin(), truth.end(),
            [](const TruthFrame& a, const TruthFrame& b) { return a.start < b.start; });
  RecordingSink sink;
  ChannelTable channels;
  std::string error;
  ASSERT_TRUE(run_byte_log(std::string(DRIVETAP_SOURCE_DIR) + "/captures/" + capture + "/input.log",
                           sink, channels, &error))
      << error;
  EXPECT_TRUE(sink.noise.empty());
  ASSERT_EQ(sink.frames.size(), truth.size());
  for (std::size_t i = 0; i < truth.size(); ++i) {
    EXPECT_EQ(hex_of(sink.frames[i].bytes), truth[i].hex) << "frame " << i + 1;
    EXPECT_EQ(sink.frames[i].frame.start(), truth[i].start) << "frame " << i + 1;
    EXPECT_EQ(sink.frames[i].checksum.verdict, ChecksumVerdict::good) << "frame " << i + 1;
  }
  // Every request answered: half as many transactions as frames, all ok.
  EXPECT_EQ(sink.count(Outcome::ok), truth.size() / 2);
  EXPECT_EQ(sink.transactions.size(), truth.size() / 2);
  EXPECT_TRUE(sink.anomalies.empty());
}

// The same ground truth from the logic samples themselves: the .sr through drivetap's own UART
// decoder. Bytes exact, start times within one bit of sigrok's.
// detect: no settings given; the source must find `serial` (and the polarity) itself.
void expect_sr_frame_for_frame(const std::string& sr_path, const std::string& serial, bool inverted,
                               std::vector<TruthFrame> truth, bool detect = false) {
  std::sort(truth.begin(), truth.end(),
            [](const TruthFrame& a, const TruthFrame& b) { return a.start < b.start; });
  std::string error;
  auto file = SigrokFile::open(sr_path, &error);
  ASSERT_TRUE(file) << error;
  const SerialConfig line = *SerialConfig::parse(serial, &error);
  LogicSourceOptions so;
  if (!detect) {
    so.uart = phy::UartSettings::from(line);
    so.uart->inverted = inverted;
  }
  ChannelTable channels;
  LogicSource source(std::move(file), sr_path, channels, so);
  ASSERT_TRUE(source.read_header()) << source.error();
  if (detect) {
    EXPECT_EQ(phy::settings_text(source.uart()), serial + (inverted ? ", inverted" : ""));
    ASSERT_TRUE(source.detection());
    EXPECT_EQ(source.detection()->format_confidence, phy::Confidence::high)
        << source.detection()->format_reason;
    EXPECT_EQ(source.detection()->polarity_confidence, phy::Confidence::high);
  }
  PipelineOptions p;
  p.serial = line;
  p.timing = FramingTiming::from(line);
  p.protocol = protocols::modbus_rtu;
  RecordingSink sink;
  Pipeline pipeline(p, channels, sink);
  ByteEvent e;
  while (source.next(e)) pipeline.push(e);
  pipeline.finish();
  EXPECT_TRUE(source.error().empty()) << source.error();
  EXPECT_TRUE(sink.noise.empty());
  ASSERT_EQ(sink.frames.size(), truth.size());
  const TimeNs bit = kNsPerSecond / line.baud;
  for (std::size_t i = 0; i < truth.size(); ++i) {
    EXPECT_EQ(hex_of(sink.frames[i].bytes), truth[i].hex) << "frame " << i + 1;
    // sigrok's start_sample is where its data annotation begins, the end of the start bit; ours
    // is the start bit's falling edge, one bit earlier. Within an eighth of a bit of that.
    EXPECT_LE(std::llabs(sink.frames[i].frame.start() + bit - truth[i].start), bit / 8)
        << "frame " << i + 1;
    EXPECT_EQ(sink.frames[i].checksum.verdict, ChecksumVerdict::good) << "frame " << i + 1;
  }
  EXPECT_EQ(sink.count(Outcome::ok), truth.size() / 2);
  EXPECT_TRUE(sink.anomalies.empty());
}

std::string dir(const std::string& capture) {
  return std::string(DRIVETAP_SOURCE_DIR) + "/captures/" + capture + "/";
}

}  // namespace

TEST(SigrokGroundTruth, FlowmeterGraphTool) {
  expect_frame_for_frame("sigrok-flowmeter-graph-tool",
                         read_truth(dir("sigrok-flowmeter-graph-tool") + "frames.csv", 4'000'000));
}

TEST(SigrokGroundTruth, FlowmeterTarget15LiterPerMin) {
  expect_frame_for_frame(
      "sigrok-flowmeter-target-15liter-per-min",
      read_truth(dir("sigrok-flowmeter-target-15liter-per-min") + "frames.csv", 4'000'000));
}

TEST(SigrokGroundTruth, BrainchildTwoChannels) {
  auto truth = read_truth(dir("sigrok-brainchild-io-16do") + "frames_tx.csv", 1'000'000);
  auto rx = read_truth(dir("sigrok-brainchild-io-16do") + "frames_rx.csv", 1'000'000);
  truth.insert(truth.end(), rx.begin(), rx.end());
  expect_frame_for_frame("sigrok-brainchild-io-16do", truth);
}

TEST(SigrokGroundTruth, FlowmeterGraphToolFromSamples) {
  expect_sr_frame_for_frame(
      dir("sigrok-flowmeter-graph-tool") + "flowmeter_graph_tool.sr", "9600 8N1", false,
      read_truth(dir("sigrok-flowmeter-graph-tool") + "frames.csv", 4'000'000));
}

TEST(SigrokGroundTruth, FlowmeterTarget15LiterPerMinFromSamples) {
  expect_sr_frame_for_frame(
      dir("sigrok-flowmeter-target-15liter-per-min") + "flowmeter_target_15liter_per_min.sr",
      "9600 8N1", false,
      read_truth(dir("sigrok-flowmeter-target-15liter-per-min") + "frames.csv", 4'000'000));
}

TEST(SigrokGroundTruth, BrainchildTwoChannelsFromSamples) {
  auto truth = read_truth(dir("sigrok-brainchild-io-16do") + "frames_tx.csv", 1'000'000);
  auto rx = read_truth(dir("sigrok-brainchild-io-16do") + "frames_rx.csv", 1'000'000);
  truth.insert(truth.end(), rx.begin(), rx.end());
  expect_sr_frame_for_frame(dir("sigrok-brainchild-io-16do") + "brainchild-io-16do.sr", "19200 8E1",
                            true, truth);
}

// No option at all: channels, polarity, baud and format found from the samples.
TEST(SigrokGroundTruth, BrainchildDetectedWithNoOption) {
  auto truth = read_truth(dir("sigrok-brainchild-io-16do") + "frames_tx.csv", 1'000'000);
  auto rx = read_truth(dir("sigrok-brainchild-io-16do") + "frames_rx.csv", 1'000'000);
  truth.insert(truth.end(), rx.begin(), rx.end());
  expect_sr_frame_for_frame(dir("sigrok-brainchild-io-16do") + "brainchild-io-16do.sr", "19200 8E1",
                            true, truth, /*detect=*/true);
}

// Characters inside a frame start 11 bit times apart: 8N2, or 8N1 and a bit of idle line. Both
// read without error; detection says 8N1 (and that 8N2 fits), whose t3.5 the flowmeter keeps.
TEST(SigrokGroundTruth, FlowmetersDetectedWithNoOption) {
  expect_sr_frame_for_frame(
      dir("sigrok-flowmeter-graph-tool") + "flowmeter_graph_tool.sr", "9600 8N1", false,
      read_truth(dir("sigrok-flowmeter-graph-tool") + "frames.csv", 4'000'000), true);
  expect_sr_frame_for_frame(
      dir("sigrok-flowmeter-target-15liter-per-min") + "flowmeter_target_15liter_per_min.sr",
      "9600 8N1", false,
      read_truth(dir("sigrok-flowmeter-target-15liter-per-min") + "frames.csv", 4'000'000), true);
}
