// Unit tests: ring of capture files (src/sinks/ring_capture_sink.hpp), dumpcap's -b for `capture`.
#include <gtest/gtest.h>

#include <filesystem>

#include "dissectors/modbus/modbus_protocol.hpp"
#include "pipeline/pipeline.hpp"
#include "sinks/ring_capture_sink.hpp"
#include "sources/file/capture_reader.hpp"
#include "test_support.hpp"

using namespace drivetap;
using namespace drivetap::testing;
namespace fs = std::filesystem;

namespace {

struct TempDir {
  fs::path path;
  TempDir() {
    path = fs::temp_directory_path() / fs::path("drivetap-ring-" + std::to_string(::getpid()) +
                                                "-" + std::to_string(counter++));
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~TempDir() { fs::remove_all(path); }
  static inline int counter = 0;
};

// `frames` Modbus requests 100 ms apart through a pipeline into the ring.
std::uint64_t write_frames(RingCaptureSink& ring, ChannelTable& channels, int frames) {
  PipelineOptions p;
  p.serial = *SerialConfig::parse("19200 8E1", nullptr);
  p.timing = FramingTiming::from(p.serial);
  p.protocol = protocols::modbus_rtu;
  Pipeline pipeline(p, channels, ring);
  const ChannelId bus = channels.intern("bus");
  TimeNs t = 1'700'000'000LL * kNsPerSecond;
  for (int i = 0; i < frames; ++i) {
    for (std::uint8_t b : with_crc({0x02, 0x03, 0x00, static_cast<std::uint8_t>(i), 0x00, 0x02})) {
      pipeline.push(ByteEvent{t, b, 0, bus});
      t += p.timing.character_time;
    }
    t += 100 * kNsPerMs;
  }
  pipeline.finish();
  return pipeline.stats().frames;
}

std::vector<fs::path> files_in(const fs::path& dir) {
  std::vector<fs::path> out;
  for (const auto& e : fs::directory_iterator(dir)) out.push_back(e.path());
  std::sort(out.begin(), out.end());
  return out;
}

// Frames in one pcapng file read back through the pipeline; the reader must reach its end clean.
std::uint64_t packets_in(const fs::path& file) {
  std::FILE* f = std::fopen(file.c_str(), "rb");
  EXPECT_TRUE(f) << file;
  if (!f) return 0;
  ChannelTable channels;
  CaptureReader reader(f, file.string(), true, channels);
  EXPECT_TRUE(reader.read_header()) << reader.error();
  PipelineOptions p;
  p.serial = *SerialConfig::parse("19200 8E1", nullptr);
  p.timing = FramingTiming::from(p.serial);
  p.protocol = protocols::modbus_rtu;
  RecordingSink sink;
  Pipeline pipeline(p, channels, sink);
  ByteEvent e;
  while (reader.next(e)) pipeline.push(e);
  pipeline.finish();
  EXPECT_TRUE(reader.error().empty()) << file << ": " << reader.error();
  std::fclose(f);
  return sink.frames.size();
}

}  // namespace

TEST(RingCaptureSink, ParsesDumpcapStyleOptions) {
  RingOptions r;
  EXPECT_EQ(parse_ring_option("filesize:100", r), "");
  EXPECT_EQ(r.max_bytes, 100'000'000u);
  EXPECT_EQ(parse_ring_option("duration:60", r), "");
  EXPECT_EQ(r.max_duration, 60 * kNsPerSecond);
  EXPECT_EQ(parse_ring_option("files:5", r), "");
  EXPECT_EQ(r.max_files, 5u);
  EXPECT_NE(parse_ring_option("files:0", r), "");
  EXPECT_NE(parse_ring_option("files:-1", r), "");
  EXPECT_NE(parse_ring_option("size:10", r).find("unknown key 'size'"), std::string::npos);
  EXPECT_NE(parse_ring_option("duration:1x", r), "");
}

TEST(RingCaptureSink, RotatesByCaptureTimeAndKeepsTheNewestFiles) {
  TempDir dir;
  ChannelTable channels;
  RingOptions ring;
  ring.max_duration = kNsPerSecond;  // 10 frames (100 ms apart) per file
  ring.max_files = 3;
  CaptureSinkOptions c;
  c.serial = *SerialConfig::parse("19200 8E1", nullptr);
  RingCaptureSink sink((dir.path / "bus.pcapng").string(), channels, c, ring);
  std::string error;
  ASSERT_TRUE(sink.open(&error)) << error;
  EXPECT_EQ(write_frames(sink, channels, 45), 45u);
  ASSERT_TRUE(sink.close()) << sink.error();
  const auto files = files_in(dir.path);
  ASSERT_EQ(files.size(), 3u);  // 5 written (10+10+10+10+5), the 2 oldest removed
  EXPECT_NE(files[0].filename().string().find("bus_00003_"), std::string::npos) << files[0];
  EXPECT_EQ(files[2].extension(), ".pcapng");
  std::uint64_t total = 0;
  for (const auto& f : files) total += packets_in(f);
  EXPECT_EQ(total, 25u);  // files 3, 4, 5: every one valid to its end
}

TEST(RingCaptureSink, RotatesBySize) {
  TempDir dir;
  ChannelTable channels;
  RingOptions ring;
  ring.max_bytes = 1'000'000;
  CaptureSinkOptions c;
  c.serial = *SerialConfig::parse("19200 8E1", nullptr);
  RingCaptureSink sink((dir.path / "big").string(), channels, c, ring);
  std::string error;
  ASSERT_TRUE(sink.open(&error)) << error;
  write_frames(sink, channels, 6000);
  ASSERT_TRUE(sink.close());
  const auto files = files_in(dir.path);
  ASSERT_GE(files.size(), 2u);
  std::uint64_t total = 0;
  for (const auto& f : files) {
    EXPECT_LE(fs::file_size(f), 1'000'000u + 4096u) << f;
    total += packets_in(f);
  }
  EXPECT_EQ(total, 6000u);
}

TEST(RingCaptureSink, UncreatableFileIsAnError) {
  ChannelTable channels;
  RingCaptureSink sink("/nonexistent-dir/bus.pcapng", channels, CaptureSinkOptions{},
                       RingOptions{});
  std::string error;
  EXPECT_FALSE(sink.open(&error));
  EXPECT_NE(error.find("-w /nonexistent-dir/bus_00001_"), std::string::npos) << error;
  EXPECT_NE(error.find("cannot create"), std::string::npos) << error;
}
