// Wireshark agreement: the seed captures written as pcapng, read by tshark — protocol column,
// CRC status, direction and comment must match drivetap's decode; no malformed or unreassembled
// expert info except on frames drivetap itself reports as malformed. Needs tshark: skipped where
// it is missing, unless DRIVETAP_REQUIRE_TSHARK=1 (set by scripts/test.sh, as in CI).
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <sstream>

#include "sinks/capture_sink.hpp"
#include "sinks/text_sink.hpp"
#include "sources/file/capture_reader.hpp"
#include "test_support.hpp"

using namespace drivetap;
using namespace drivetap::testing;

namespace {

bool have_tshark() {
  if (std::system("tshark --version > /dev/null 2>&1") == 0) return true;
  const char* require = std::getenv("DRIVETAP_REQUIRE_TSHARK");
  if (require && std::string(require) == "1") ADD_FAILURE() << "tshark is required but missing";
  return false;
}

std::vector<std::vector<std::string>> run_tshark(const std::string& args) {
  const std::string cmd = "tshark " + args + " 2>/dev/null";
  std::FILE* p = popen(cmd.c_str(), "r");
  std::vector<std::vector<std::string>> rows;
  if (!p) return rows;
  char* line = nullptr;
  std::size_t cap = 0;
  while (getline(&line, &cap, p) > 0) {
    std::string s(line);
    if (!s.empty() && s.back() == '\n') s.pop_back();
    std::vector<std::string> cols;
    std::size_t start = 0;
    while (true) {
      const std::size_t tab = s.find('\t', start);
      cols.push_back(s.substr(start, tab == std::string::npos ? std::string::npos : tab - start));
      if (tab == std::string::npos) break;
      start = tab + 1;
    }
    rows.push_back(cols);
  }
  std::free(line);
  pclose(p);
  return rows;
}

// Decodes a capture in-process, writing pcapng to `path`; returns the decoded frames.
std::vector<Message> write_capture(const std::string& capture, const std::string& path,
                                   CaptureLinkType link, Protocol protocol = Protocol::unknown) {
  ChannelTable channels;
  RecordingSink record;
  std::FILE* in = std::fopen(
      (std::string(DRIVETAP_SOURCE_DIR) + "/captures/" + capture + "/input.log").c_str(), "rb");
  EXPECT_TRUE(in);
  ByteLogReader reader(in, capture, channels);
  EXPECT_TRUE(reader.read_header());
  PipelineOptions p;
  p.serial = reader.header_serial().value_or(SerialConfig{});
  p.timing = FramingTiming::from(p.serial);
  reader.set_character_time(p.timing.character_time);
  p.protocol = protocol;
  std::FILE* out = std::fopen(path.c_str(), "wb");
  {
    CaptureSinkOptions c;
    c.serial = p.serial;
    c.link_type = link;
    CaptureSink capture_sink(out, channels, c);
    TeeSink tee;
    tee.add(&record);
    tee.add(&capture_sink);
    Pipeline pipeline(p, channels, tee);
    ByteEvent e;
    while (reader.next(e)) pipeline.push(e);
    pipeline.finish();
    EXPECT_TRUE(tee.flush());
  }
  std::fclose(out);
  std::fclose(in);
  return record.frames;
}

bool has_malformed(const Message& m) {
  for (const Anomaly& a : m.anomalies)
    if (a.kind == AnomalyKind::malformed) return true;
  return false;
}

class TsharkAgreement : public ::testing::TestWithParam<const char*> {};

}  // namespace

TEST_P(TsharkAgreement, ProtocolCrcDirectionCommentAndNoMalformed) {
  if (!have_tshark()) GTEST_SKIP() << "tshark not installed";
  const std::string path = ::testing::TempDir() + GetParam() + ".pcapng";
  const std::vector<Message> frames = write_capture(GetParam(), path, CaptureLinkType::upper_pdu);
  const auto rows = run_tshark(
      "-r " + path +
      " -o mbrtu.crc_verification:TRUE -T fields -e _ws.col.Protocol -e mbrtu.crc16.status"
      " -e frame.p2p_dir -e frame.comment -e _ws.malformed -e _ws.expert.message");
  ASSERT_EQ(rows.size(), frames.size());
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const Message& m = frames[i];
    const auto& r = rows[i];
    ASSERT_GE(r.size(), 6u) << "frame " << i + 1;
    EXPECT_EQ(r[0], "Modbus RTU") << "frame " << i + 1;
    // Wireshark stops before the CRC on a frame whose length fields lie (it waits for a
    // reassembly that never comes); drivetap reports those frames as malformed.
    if (!(has_malformed(m) && r[1].empty())) {
      EXPECT_EQ(r[1], m.checksum.verdict == ChecksumVerdict::good ? "1" : "0")
          << "frame " << i + 1 << ": Wireshark's CRC status disagrees with drivetap's verdict";
    }
    EXPECT_EQ(r[2], m.direction == Direction::request ? "0" : "1") << "frame " << i + 1;
    EXPECT_EQ(r[3].rfind(frame_summary(m, true), 0), 0u) << "frame " << i + 1 << ": " << r[3];
    if (!has_malformed(m)) {
      EXPECT_EQ(r[4], "") << "frame " << i + 1 << " malformed in Wireshark";
      EXPECT_EQ(r[5].find("Unreassembled"), std::string::npos) << "frame " << i + 1 << ": " << r[5];
      EXPECT_EQ(r[5].find("Malformed"), std::string::npos) << "frame " << i + 1 << ": " << r[5];
    }
  }
}

INSTANTIATE_TEST_SUITE_P(SeedCaptures, TsharkAgreement,
                         ::testing::Values("seed-erman-e9", "seed-erman-erg", "seed-e5-8200",
                                           "seed-danfoss-modbus", "sigrok-flowmeter-graph-tool"),
                         [](const auto& info) {
                           std::string n = info.param;
                           for (char& c : n)
                             if (c == '-') c = '_';
                           return n;
                         });

TEST(TsharkUser0, DecodesWithTheDocumentedUserDltEntry) {
  if (!have_tshark()) GTEST_SKIP() << "tshark not installed";
  const std::string path = ::testing::TempDir() + "user0.pcapng";
  const auto frames = write_capture("seed-erman-erg", path, CaptureLinkType::user0);
  // The user DLT line of docs/formats.md ("In Wireshark"): User 0 (DLT=147) -> payload protocol
  // mbrtu.
  const auto rows =
      run_tshark("-o 'uat:user_dlts:\"User 0 (DLT=147)\",\"mbrtu\",\"0\",\"\",\"0\",\"\"' -r " +
                 path + " -T fields -e _ws.col.Protocol -e mbrtu.unit_id");
  ASSERT_EQ(rows.size(), frames.size());
  for (std::size_t i = 0; i < rows.size(); ++i) {
    EXPECT_EQ(rows[i][0], "Modbus RTU") << "frame " << i + 1;
    EXPECT_EQ(rows[i].at(1), std::to_string(frames[i].address)) << "frame " << i + 1;
  }
}

TEST(TsharkOtherProtocols, LabelledWithDirectionAndDrivetapsDecodeAsComment) {
  if (!have_tshark()) GTEST_SKIP() << "tshark not installed";
  for (const char* capture : {"seed-e5-8200-ascii", "seed-danfoss-fc", "seed-easydrive"}) {
    const std::string path = ::testing::TempDir() + capture + ".pcapng";
    const std::vector<Message> frames = write_capture(capture, path, CaptureLinkType::upper_pdu);
    const auto rows = run_tshark("-r " + path +
                                 " -T fields -e _ws.col.Protocol -e frame.p2p_dir -e frame.comment"
                                 " -e _ws.malformed -e exported_pdu.prot_name");
    ASSERT_EQ(rows.size(), frames.size()) << capture;
    for (std::size_t i = 0; i < frames.size(); ++i) {
      const Message& m = frames[i];
      ASSERT_GE(rows[i].size(), 5u);
      // Named for drivetap's plugin (tests/wireshark_plugin.py shows the protocol column with
      // it); stock Wireshark knows no such dissector and labels the packet an exported PDU.
      ASSERT_NE(m.protocol.desc(), nullptr);
      EXPECT_EQ(rows[i][4], m.protocol.desc()->wireshark_dissector) << capture;
      EXPECT_EQ(rows[i][0], "Exported PDU") << capture << " frame " << i + 1;
      if (m.direction != Direction::unknown) {
        EXPECT_EQ(rows[i][1], m.direction == Direction::request ? "0" : "1") << capture;
      }
      EXPECT_EQ(rows[i][2].rfind(frame_summary(m, true), 0), 0u) << rows[i][2];
      EXPECT_EQ(rows[i][3], "") << capture << " frame " << i + 1;
    }
  }
}
