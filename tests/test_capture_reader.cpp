// Unit tests: reading captures of other tools — re-framing badly cut packets, RTU over UDP.
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <pcap/pcap.h>

#include <cstdio>
#include <memory>
#include <string>
#include <string_view>

#include "core/checksum.hpp"
#include "dissectors/modbus/modbus_protocol.hpp"
#include "formats/link_layer.hpp"
#include "formats/pcapng.hpp"
#include "formats/upper_pdu.hpp"
#include "sinks/capture_sink.hpp"
#include "sources/file/capture_reader.hpp"
#include "test_support.hpp"

using namespace drivetap;
using namespace drivetap::testing;

namespace {

struct Decoded {
  RecordingSink sink;
  ChannelTable channels;
  std::string error;
  std::vector<std::string> notes;
};

void decode_capture(const std::string& path, bool pcapng, Decoded& d) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  ASSERT_TRUE(f) << path;
  CaptureReader reader(f, path, pcapng, d.channels);
  ASSERT_TRUE(reader.read_header()) << reader.error();
  PipelineOptions p;
  p.serial = reader.settings().serial.value_or(SerialConfig{});
  p.timing = FramingTiming::from(p.serial);
  reader.set_character_time(p.timing.character_time);
  Pipeline pipeline(p, d.channels, d.sink);
  ByteEvent e;
  while (reader.next(e)) pipeline.push(e);
  pipeline.finish();
  d.error = reader.error();
  d.notes = reader.notes();
  if (pcapng) std::fclose(f);
}

// Writes a pcapng file under the test directory with pcapng::Writer: `fill` writes the blocks
// after the section header. Returns its path.
template <typename Fill>
std::string write_pcapng(const std::string& name, std::string_view application, Fill fill) {
  const std::string path = ::testing::TempDir() + name;
  std::FILE* f = std::fopen(path.c_str(), "wb");
  EXPECT_NE(f, nullptr) << path;
  if (!f) return path;
  pcapng::Writer w(f);
  w.section_header(application);
  fill(w);
  std::fclose(f);
  return path;
}

// A CaptureReader over a pcapng file, its header read, bytes spaced by `character`.
class OpenReader {
 public:
  OpenReader(const std::string& path, TimeNs character)
      : file_(std::fopen(path.c_str(), "rb"), &std::fclose) {
    if (!file_) return;
    reader_ = std::make_unique<CaptureReader>(file_.get(), path, true, channels_);
    header_read_ = reader_->read_header();
    reader_->set_character_time(character);
  }
  // The file opened and its header read; the tests ASSERT this before reading on.
  [[nodiscard]] ::testing::AssertionResult ok() const {
    if (!file_) return ::testing::AssertionFailure() << "cannot open the file";
    if (!header_read_) return ::testing::AssertionFailure() << reader_->error();
    return ::testing::AssertionSuccess();
  }
  CaptureReader* operator->() { return reader_.get(); }

 private:
  ChannelTable channels_;
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> file_;
  std::unique_ptr<CaptureReader> reader_;
  bool header_read_ = false;
};

}  // namespace

TEST(CaptureReader, Dlt147SplitAndMergedPacketsAreReframed) {
  Decoded d;
  decode_capture(std::string(DRIVETAP_SOURCE_DIR) + "/captures/dlt147-split-and-merged/input.pcap",
                 false, d);
  ASSERT_EQ(d.error, "");
  ASSERT_EQ(d.sink.frames.size(), 6u);
  EXPECT_EQ(hex_of(d.sink.frames[0].bytes), "010300000002C40B");  // from packets 1 and 2
  EXPECT_EQ(hex_of(d.sink.frames[2].bytes), "020400100001303C");  // packet 4, first frame
  EXPECT_EQ(hex_of(d.sink.frames[3].bytes), "0204021234F047");    // packet 4, second frame
  for (const Message& m : d.sink.frames) EXPECT_EQ(m.checksum.verdict, ChecksumVerdict::good);
  EXPECT_EQ(d.sink.count(Outcome::ok), 3u);
  ASSERT_EQ(d.sink.count(AnomalyKind::packet_split_frame), 1u);
  ASSERT_EQ(d.sink.count(AnomalyKind::packet_merged_frames), 1u);
  for (const Anomaly& a : d.sink.anomalies) {
    if (a.kind == AnomalyKind::packet_split_frame) {
      EXPECT_EQ(a.frame_number, 1u);
      EXPECT_NE(a.detail.find("packets 1..2"), std::string::npos) << a.detail;
    }
    if (a.kind == AnomalyKind::packet_merged_frames) {
      EXPECT_EQ(a.frame_number, 4u);
      EXPECT_NE(a.detail.find("packet 4"), std::string::npos) << a.detail;
    }
  }
}

TEST(CaptureReader, ModbusRtuOverUdpPairsAcrossBothDirections) {
  const std::string path = ::testing::TempDir() + "rtu_over_udp.pcap";
  pcap_t* dead =
      pcap_open_dead_with_tstamp_precision(DLT_EN10MB, 65535, PCAP_TSTAMP_PRECISION_NANO);
  pcap_dumper_t* dump = pcap_dump_open(dead, path.c_str());
  ASSERT_TRUE(dump);
  auto packet = [&](bool from_client, const std::vector<std::uint8_t>& rtu, std::int64_t ns) {
    std::vector<std::uint8_t> p(12, 0);
    p.insert(p.end(), {0x08, 0x00});
    const std::uint16_t total = static_cast<std::uint16_t>(20 + 8 + rtu.size());
    std::vector<std::uint8_t> ip = {0x45,
                                    0,
                                    static_cast<std::uint8_t>(total >> 8),
                                    static_cast<std::uint8_t>(total),
                                    0,
                                    0,
                                    0x40,
                                    0,
                                    64,
                                    17,
                                    0,
                                    0};
    const std::vector<std::uint8_t> a = {192, 168, 0, 10}, b = {192, 168, 0, 20};
    ip.insert(ip.end(), (from_client ? a : b).begin(), (from_client ? a : b).end());
    ip.insert(ip.end(), (from_client ? b : a).begin(), (from_client ? b : a).end());
    const std::uint16_t cport = 40000, sport = 4001;
    const std::uint16_t src = from_client ? cport : sport, dst = from_client ? sport : cport;
    std::vector<std::uint8_t> udp = {static_cast<std::uint8_t>(src >> 8),
                                     static_cast<std::uint8_t>(src),
                                     static_cast<std::uint8_t>(dst >> 8),
                                     static_cast<std::uint8_t>(dst),
                                     0,
                                     static_cast<std::uint8_t>(8 + rtu.size()),
                                     0,
                                     0};
    p.insert(p.end(), ip.begin(), ip.end());
    p.insert(p.end(), udp.begin(), udp.end());
    p.insert(p.end(), rtu.begin(), rtu.end());
    pcap_pkthdr h{};
    h.ts.tv_sec = static_cast<time_t>(ns / 1'000'000'000);
    h.ts.tv_usec = static_cast<suseconds_t>(ns % 1'000'000'000);
    h.caplen = h.len = static_cast<bpf_u_int32>(p.size());
    pcap_dump(reinterpret_cast<u_char*>(dump), &h, p.data());
  };
  const auto req = with_crc({0x05, 0x03, 0x00, 0x10, 0x00, 0x01});
  const auto rsp = with_crc({0x05, 0x03, 0x02, 0x00, 0x64});
  packet(true, req, 1'000'000'000);
  packet(false, rsp, 1'030'000'000);
  packet(true, req, 2'000'000'000);
  packet(false, rsp, 2'030'000'000);
  pcap_dump_close(dump);
  pcap_close(dead);

  Decoded d;
  decode_capture(path, false, d);
  ASSERT_EQ(d.error, "");
  ASSERT_EQ(d.sink.frames.size(), 4u);
  EXPECT_EQ(d.channels.at(d.sink.frames[0].frame.channel).name,
            "udp 192.168.0.10:40000>192.168.0.20:4001");
  EXPECT_EQ(d.channels.at(d.sink.frames[1].frame.channel).name,
            "udp 192.168.0.20:4001>192.168.0.10:40000");
  EXPECT_EQ(d.sink.frames[1].direction, Direction::response);
  EXPECT_EQ(d.sink.count(Outcome::ok), 2u) << "replies on the other flow pair with the requests";
  EXPECT_TRUE(d.notes.empty());
}

TEST(CaptureReader, PacketsWithoutSerialBytesAreCountedNotFatal) {
  const std::string path = ::testing::TempDir() + "arp.pcap";
  pcap_t* dead = pcap_open_dead(DLT_EN10MB, 65535);
  pcap_dumper_t* dump = pcap_dump_open(dead, path.c_str());
  std::vector<std::uint8_t> arp(42, 0);
  arp[12] = 0x08;
  arp[13] = 0x06;
  for (int i = 0; i < 3; ++i) {
    pcap_pkthdr h{};
    h.caplen = h.len = static_cast<bpf_u_int32>(arp.size());
    pcap_dump(reinterpret_cast<u_char*>(dump), &h, arp.data());
  }
  pcap_dump_close(dump);
  pcap_close(dead);
  Decoded d;
  decode_capture(path, false, d);
  EXPECT_EQ(d.error, "");
  EXPECT_TRUE(d.sink.frames.empty());
  ASSERT_EQ(d.notes.size(), 1u);
  EXPECT_NE(d.notes[0].find("skipped 3 packets (ethertype 0x0806 is not IP), first: packet 1"),
            std::string::npos)
      << d.notes[0];
}

TEST(CaptureReader, ChannelsAreBoundedAndTheExcessNamed) {
  // Each named interface is a channel: one more than ChannelTable::kMaxChannels ends the read at
  // that packet, everything before it decoded.
  const std::size_t interfaces = ChannelTable::kMaxChannels + 1;
  const std::string path = write_pcapng("many-interfaces.pcapng", "test", [&](pcapng::Writer& w) {
    for (std::size_t i = 0; i < interfaces; ++i) w.interface(147, fmt::format("port{}", i), "", "");
    const std::uint8_t request[] = {1, 3, 0, 0, 0, 1, 0x84, 0x0A};
    for (std::size_t i = 0; i < interfaces; ++i) {
      pcapng::Writer::Packet p;
      p.interface = static_cast<std::uint32_t>(i);
      p.timestamp = static_cast<TimeNs>(i + 1) * kNsPerSecond;
      p.data = request;
      w.packet(p);
    }
  });
  Decoded d;
  decode_capture(path, true, d);
  EXPECT_NE(d.error.find(fmt::format("{}: offset ", path)), std::string::npos) << d.error;
  EXPECT_NE(d.error.find(fmt::format("packet {}: more than {} channels", interfaces,
                                     ChannelTable::kMaxChannels)),
            std::string::npos)
      << d.error;
  EXPECT_EQ(d.channels.size(), ChannelTable::kMaxChannels);
  // One record a channel (one telegram is too little for detection: shown as data).
  EXPECT_EQ(d.sink.frames.size() + d.sink.noise.size(), ChannelTable::kMaxChannels);
}

TEST(CaptureReader, LargePacketIsLaidOutByteByByteWithItsTimes) {
  // One 256 KiB packet of another tool (no per-byte option): its bytes are placed as next()
  // takes them, evenly spaced so that the last ends at the packet's time stamp.
  const std::uint8_t request[] = {1, 3, 0, 0, 0, 1, 0x84, 0x0A};
  std::vector<std::uint8_t> data;
  for (int i = 0; i < 32768; ++i) data.insert(data.end(), std::begin(request), std::end(request));
  pcapng::Writer::Packet p;
  p.timestamp = 100 * kNsPerSecond;
  p.data = data;
  const std::string path = write_pcapng("large-packet.pcapng", "test", [&](pcapng::Writer& w) {
    w.interface(147, "", "", "");
    w.packet(p);
  });
  const TimeNs character = 1'000'000;
  OpenReader reader(path, character);
  ASSERT_TRUE(reader.ok());
  ByteEvent e;
  std::size_t n = 0;
  while (reader->next(e)) {
    ASSERT_LT(n, data.size());
    EXPECT_EQ(e.byte, data[n]);
    EXPECT_EQ(e.time, p.timestamp - static_cast<TimeNs>(data.size() - n) * character);
    EXPECT_EQ(e.origin, 1u);
    ++n;
  }
  EXPECT_EQ(reader->error(), "");
  EXPECT_EQ(n, data.size());
}

TEST(CaptureReader, LargePacketWithExactTimesIsDecodedInChunks) {
  // drivetap's per-byte option on a packet larger than one decoded chunk (4096 entries): exact
  // times, UART marks and source packets come out byte for byte across the chunk seams; a packet
  // whose option breaks near its end falls back to even spacing as a whole.
  const std::size_t n = 10000;
  std::vector<std::uint8_t> data(n), option = {'D', 'T', 1, 0};
  std::vector<TimeNs> times(n);
  std::vector<std::uint32_t> sources(n);
  pcapng::put_varint(option, n);
  const TimeNs stamp = 50 * kNsPerSecond;
  TimeNs t = stamp;
  std::int64_t source = 0;
  for (std::size_t i = 0; i < n; ++i) {
    data[i] = static_cast<std::uint8_t>(i * 7);
    const TimeNs delta = 1000 + static_cast<TimeNs>(i % 13) * 100;
    const std::int64_t source_delta = i % 1000 == 0 ? 1 : 0;
    t += delta;
    source += source_delta;
    times[i] = t;
    sources[i] = static_cast<std::uint32_t>(source);
    pcapng::put_varint(option, pcapng::zigzag(delta));
    option.push_back(static_cast<std::uint8_t>(i % 3 == 0 ? kUartParityError : 0));
    pcapng::put_varint(option, pcapng::zigzag(source_delta));
  }
  std::vector<std::uint8_t> broken = option;
  broken.resize(broken.size() - 2);  // the last entry cut: the whole option is unusable
  const TimeNs broken_stamp = 100 * kNsPerSecond;
  const std::string path =
      write_pcapng("large-exact.pcapng", "drivetap test", [&](pcapng::Writer& w) {
        w.interface(147, "bus", "", "");
        pcapng::Writer::Packet p;
        p.timestamp = stamp;
        p.data = data;
        p.drivetap_option = option;
        w.packet(p);
        p.timestamp = broken_stamp;
        p.drivetap_option = broken;
        w.packet(p);
      });
  const TimeNs character = 500'000;
  OpenReader reader(path, character);
  ASSERT_TRUE(reader.ok());
  ByteEvent e;
  for (std::size_t i = 0; i < n; ++i) {
    ASSERT_TRUE(reader->next(e)) << i << ": " << reader->error();
    ASSERT_EQ(e.byte, data[i]) << i;
    ASSERT_EQ(e.time, times[i]) << i;
    ASSERT_EQ(e.flags, i % 3 == 0 ? kUartParityError : 0) << i;
    ASSERT_EQ(e.origin, sources[i]) << i;
  }
  for (std::size_t i = 0; i < n; ++i) {
    ASSERT_TRUE(reader->next(e)) << i << ": " << reader->error();
    ASSERT_EQ(e.byte, data[i]) << i;
    ASSERT_EQ(e.time, broken_stamp - static_cast<TimeNs>(n - i) * character) << i;
    ASSERT_EQ(e.flags, 0) << i;
    ASSERT_EQ(e.origin, 2u) << i;
  }
  EXPECT_FALSE(reader->next(e));
  EXPECT_EQ(reader->error(), "");
}

TEST(CaptureReader, EvenlySpacedFramesAreWrittenCompactlyAndReadBackExactly) {
  // drivetap's pcapng gives the bytes of a frame that are evenly spaced, unflagged and of one
  // source packet as one step (option version 2); others byte by byte (version 1). Either way
  // reading the file back gives every byte's time, marks and packet as written.
  const SerialConfig serial;
  const TimeNs ct = serial.character_time();
  const std::string path = ::testing::TempDir() + "even-and-exact.pcapng";
  std::vector<ByteEvent> written;
  {
    std::FILE* f = std::fopen(path.c_str(), "wb");
    ASSERT_NE(f, nullptr);
    ChannelTable channels;
    channels.intern("bus");
    CaptureSinkOptions o;
    o.serial = serial;
    o.character_time = ct;
    o.settings = encode_settings(ct * 3 / 2, ct * 7 / 2, kNsPerSecond, 100 * kNsPerMs,
                                 protocols::modbus_rtu);
    CaptureSink sink(f, channels, o);
    PipelineOptions p;
    p.serial = serial;
    p.timing = FramingTiming::from(serial);
    p.protocol = protocols::modbus_rtu;
    Pipeline pipeline(p, channels, sink);
    TimeNs t = kNsPerSecond;
    auto send = [&](const std::vector<std::uint8_t>& bytes, TimeNs spacing, std::size_t flag_at) {
      for (std::size_t i = 0; i < bytes.size(); ++i) {
        const ByteEvent e{t, bytes[i], std::uint8_t(i == flag_at ? kUartParityError : 0), 0, 0};
        written.push_back(e);
        pipeline.push(e);
        t += spacing;
      }
      t += 20 * kNsPerMs;
    };
    const auto frame = with_crc({0x01, 0x03, 0x00, 0x10, 0x00, 0x02});
    send(frame, ct, 99);            // back to back: compact
    send(frame, ct + 1000, 99);     // evenly spaced, slower: compact with its own step
    send(frame, ct, 3);             // a parity mark: byte by byte
    send({0x01, 0x03}, ct, 99);     // a fragment
    send(frame, ct * 11 / 10, 99);  // compact again
    pipeline.finish();
    ASSERT_TRUE(sink.flush());
    std::fclose(f);
  }
  // The options as written.
  std::vector<int> versions;
  {
    std::FILE* f = std::fopen(path.c_str(), "rb");
    ASSERT_NE(f, nullptr);
    pcapng::Reader r(f, path);
    pcapng::PacketRecord rec;
    while (r.next(rec))
      versions.push_back(rec.drivetap_option.size() > 2 ? rec.drivetap_option[2] : 0);
    EXPECT_EQ(r.error(), "");
    std::fclose(f);
  }
  EXPECT_EQ(versions, (std::vector<int>{2, 2, 1, 2, 2}));
  OpenReader reader(path, ct * 5);  // the character time plays no part for drivetap's packets
  ASSERT_TRUE(reader.ok());
  ByteEvent e;
  for (std::size_t i = 0; i < written.size(); ++i) {
    ASSERT_TRUE(reader->next(e)) << i << ": " << reader->error();
    EXPECT_EQ(e.time, written[i].time) << i;
    EXPECT_EQ(e.byte, written[i].byte) << i;
    EXPECT_EQ(e.flags, written[i].flags) << i;
  }
  EXPECT_FALSE(reader->next(e));
  EXPECT_EQ(reader->error(), "");
}

TEST(CaptureReader, BrokenCompactOptionFallsBackToEvenSpacingBeforeTheTimestamp) {
  const std::vector<std::uint8_t> data = {1, 2, 3};
  auto compact = [](std::uint64_t count, std::uint64_t step, std::uint64_t source) {
    std::vector<std::uint8_t> o = {'D', 'T', 2, 0};
    pcapng::put_varint(o, count);
    pcapng::put_varint(o, step);
    pcapng::put_varint(o, source);
    return o;
  };
  std::vector<std::vector<std::uint8_t>> options = {
      compact(3, 1000, 0),                       // good
      compact(4, 1000, 0),                       // count differs from the packet's
      compact(3, std::uint64_t{1} << 61, 0),     // step beyond any interval
      compact(3, 1000, std::uint64_t{1} << 33),  // source packet beyond 32 bits
  };
  options.push_back(compact(3, 1000, 0));
  options.back().push_back(0);             // trailing byte
  options.push_back({'D', 'T', 2, 0, 3});  // cut short
  const TimeNs stamp = 10 * kNsPerSecond;
  const std::string path = write_pcapng("compact.pcapng", "drivetap test", [&](pcapng::Writer& w) {
    w.interface(147, "bus", "", "");
    for (const auto& option : options) {
      pcapng::Writer::Packet p;
      p.timestamp = stamp;
      p.data = data;
      p.drivetap_option = option;
      w.packet(p);
    }
  });
  const TimeNs character = 500'000;
  OpenReader reader(path, character);
  ASSERT_TRUE(reader.ok());
  ByteEvent e;
  for (std::size_t packet = 0; packet < options.size(); ++packet) {
    for (std::size_t i = 0; i < data.size(); ++i) {
      ASSERT_TRUE(reader->next(e)) << packet << ": " << reader->error();
      const TimeNs expected = packet == 0 ? stamp + static_cast<TimeNs>(i) * 1000
                                          : stamp - static_cast<TimeNs>(3 - i) * character;
      EXPECT_EQ(e.time, expected) << "packet " << packet << " byte " << i;
      EXPECT_EQ(e.origin, packet == 0 ? 0u : packet + 1) << "packet " << packet;
    }
  }
  EXPECT_FALSE(reader->next(e));
}

TEST(CaptureReader, RepeatedExportedPduTagsGiveTheSameDirectionAsParsing) {
  // Another tool's upper-PDU packets: six kinds of tag block (more than the reader remembers)
  // in a repeating order; each packet's direction tag must decide its channel every time.
  std::vector<upper_pdu::Tags> kinds(6);
  for (std::size_t k = 0; k < kinds.size(); ++k) {
    kinds[k].dissector = k % 3 == 2 ? "data" : "mbrtu";
    kinds[k].protocol_column = fmt::format("kind {}", k);
    if (k % 3 != 1)
      kinds[k].direction = k % 2 == 0 ? upper_pdu::kDirectionSent : upper_pdu::kDirectionReceived;
  }
  const std::vector<std::size_t> order = {0, 1, 0, 1, 2, 3, 4, 5, 0, 5, 4, 3, 2, 1, 0, 0, 1};
  const std::string path = write_pcapng("upper-pdu-tags.pcapng", "test", [&](pcapng::Writer& w) {
    w.interface(kLinkTypeUpperPdu, "eth0", "", "");
    for (std::size_t i = 0; i < order.size(); ++i) {
      std::vector<std::uint8_t> data;
      upper_pdu::append_tags(kinds[order[i]], data);
      data.push_back(static_cast<std::uint8_t>(i));
      pcapng::Writer::Packet p;
      p.timestamp = static_cast<TimeNs>(i + 1) * kNsPerSecond;
      p.data = data;
      w.packet(p);
    }
  });
  ChannelTable channels;
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> file(std::fopen(path.c_str(), "rb"),
                                                       &std::fclose);
  ASSERT_TRUE(file);
  CaptureReader reader(file.get(), path, true, channels);
  ASSERT_TRUE(reader.read_header()) << reader.error();
  reader.set_character_time(1000);
  ByteEvent e;
  for (std::size_t i = 0; i < order.size(); ++i) {
    ASSERT_TRUE(reader.next(e)) << i << ": " << reader.error();
    EXPECT_EQ(e.byte, i);
    const upper_pdu::Tags& tags = kinds[order[i]];
    const std::string expected = !tags.direction                                ? "eth0"
                                 : *tags.direction == upper_pdu::kDirectionSent ? "eth0.tx"
                                                                                : "eth0.rx";
    EXPECT_EQ(channels.at(e.channel).name, expected) << "packet " << i;
  }
  EXPECT_FALSE(reader.next(e));
  EXPECT_EQ(reader.error(), "");
}

TEST(CaptureReader, PacketsTakenInBulkGiveTheEventsOfOneByOne) {
  // Another tool's upper-PDU packets, which append_runs() takes in bulk once their tag block is
  // known (append_plain_packets), among packets it leaves to the usual way: tag blocks it does not
  // remember (six kinds, four remembered), a packet larger than a batch, empty ones, a comment,
  // a second interface, the direction in the flags of some. The events of the runs must be those
  // next() gives one by one.
  std::vector<upper_pdu::Tags> kinds(6);
  for (std::size_t k = 0; k < kinds.size(); ++k) {
    kinds[k].dissector = "mbrtu";
    kinds[k].protocol_column = fmt::format("kind {}", k);
    if (k % 3 != 1)
      kinds[k].direction = k % 2 == 0 ? upper_pdu::kDirectionSent : upper_pdu::kDirectionReceived;
  }
  const std::string path = write_pcapng("bulk.pcapng", "test", [&](pcapng::Writer& w) {
    w.interface(kLinkTypeUpperPdu, "a", "", "");
    w.interface(kLinkTypeUpperPdu, "b", "", "");
    for (std::size_t i = 0; i < 600; ++i) {
      std::vector<std::uint8_t> data;
      upper_pdu::append_tags(kinds[i < 300 ? i % 2 : (i * 7) % kinds.size()], data);
      const std::size_t n = i == 250 ? CaptureReader::kBatch + 100 : i % 23 == 0 ? 0 : i % 13 + 1;
      for (std::size_t b = 0; b < n; ++b) data.push_back(static_cast<std::uint8_t>(i + b));
      pcapng::Writer::Packet p;
      p.interface = i % 5 == 4 ? 1 : 0;
      p.timestamp = static_cast<TimeNs>(i + 1) * 10 * kNsPerMs;
      p.data = data;
      if (i % 97 == 5) p.comment = "a comment";
      // The direction in the packet's flags (of tags that give none: kinds 1 and 4), or none.
      if (i % 3 == 0) p.flags = i % 2 == 0 ? pcapng::kFlagOutbound : pcapng::kFlagInbound;
      w.packet(p);
    }
  });
  std::vector<ByteEvent> one_by_one;
  std::vector<std::string> names;
  {
    OpenReader reader(path, 520 * kNsPerUs);
    ASSERT_TRUE(reader.ok());
    ByteEvent e;
    while (reader->next(e)) one_by_one.push_back(e);
    EXPECT_EQ(reader->error(), "");
  }
  std::vector<ByteEvent> bulk;
  OpenReader reader(path, 520 * kNsPerUs);
  ASSERT_TRUE(reader.ok());
  RunBatch batch;
  while (reader->append_runs(batch)) {
  }
  for (std::size_t k = 0; k < batch.size(); ++k)
    for (std::size_t i = 0; i < batch[k].size(); ++i) bulk.push_back(batch[k].event(i));
  EXPECT_EQ(reader->error(), "");
  ASSERT_EQ(bulk.size(), one_by_one.size());
  for (std::size_t i = 0; i < bulk.size(); ++i) {
    EXPECT_EQ(bulk[i].time, one_by_one[i].time) << i;
    EXPECT_EQ(bulk[i].byte, one_by_one[i].byte) << i;
    EXPECT_EQ(bulk[i].channel, one_by_one[i].channel) << i;
    EXPECT_EQ(bulk[i].origin, one_by_one[i].origin) << i;
    EXPECT_EQ(bulk[i].flags, one_by_one[i].flags) << i;
  }
}
