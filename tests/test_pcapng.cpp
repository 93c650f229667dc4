// Unit tests: pcapng writer/reader, exported-PDU tags, link-layer unpacking, hostile files.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <unistd.h>

#include <cstdio>
#include <string>
#include <vector>

#include "formats/link_layer.hpp"
#include "formats/pcapng.hpp"
#include "formats/upper_pdu.hpp"
#include "sources/input_file.hpp"

using namespace drivetap;

namespace {

// Writes with pcapng::Writer into memory and returns the file bytes.
template <typename Fn>
std::vector<std::uint8_t> write_file(Fn fn) {
  char* buf = nullptr;
  std::size_t size = 0;
  std::FILE* f = open_memstream(&buf, &size);
  pcapng::Writer w(f);
  fn(w);
  std::fclose(f);
  std::vector<std::uint8_t> out(buf, buf + size);
  std::free(buf);
  return out;
}

// A packet read, its bytes copied out of the reader's buffer.
struct ReadPacket {
  std::uint32_t interface = 0;
  TimeNs timestamp = 0;
  bool has_timestamp = false;
  std::vector<std::uint8_t> data;
  std::optional<std::uint32_t> flags;
  std::string comment;
  std::vector<std::uint8_t> drivetap_option;
  std::uint64_t offset = 0;
};

struct ReadResult {
  std::vector<ReadPacket> packets;
  std::vector<pcapng::Interface> interfaces;
  std::string error;
  bool by_drivetap = false;
};

ReadResult read_file(std::vector<std::uint8_t> bytes) {
  ReadResult r;
  std::FILE* f = fmemopen(bytes.data(), bytes.size(), "rb");
  pcapng::Reader reader(f, "t.pcapng");
  pcapng::PacketRecord rec;
  while (reader.next(rec))
    r.packets.push_back(
        {rec.interface, rec.timestamp, rec.has_timestamp,
         std::vector<std::uint8_t>(rec.data.begin(), rec.data.end()), rec.flags, rec.comment,
         std::vector<std::uint8_t>(rec.drivetap_option.begin(), rec.drivetap_option.end()),
         rec.offset});
  r.error = reader.error();
  r.interfaces = reader.interfaces();
  r.by_drivetap = reader.written_by_drivetap();
  std::fclose(f);
  return r;
}

std::vector<std::uint8_t> sample_file() {
  return write_file([](pcapng::Writer& w) {
    w.section_header("drivetap 0.1.0");
    w.interface(252, "bus", "9600 8N1", "drivetap t15=1 t35=2 timeout=3 max_hold=4");
    const std::uint8_t data[] = {1, 3, 0, 0, 0, 1, 0x84, 0x0A};
    const std::uint8_t option[] = {'D', 'T', 1, 0, 1, 0, 0, 0};
    pcapng::Writer::Packet p;
    p.timestamp = 1'700'000'000'123'456'789;
    p.data = data;
    p.flags = pcapng::kFlagOutbound | pcapng::kFlagCrcError;
    p.comment = "a comment";
    p.drivetap_option = option;
    w.packet(p);
    p.timestamp += 1000;
    w.packet(p);
  });
}

}  // namespace

TEST(Pcapng, WriterOutputReadsBackWithEveryField) {
  const ReadResult r = read_file(sample_file());
  ASSERT_EQ(r.error, "");
  EXPECT_TRUE(r.by_drivetap);
  ASSERT_EQ(r.interfaces.size(), 1u);
  EXPECT_EQ(r.interfaces[0].link_type, 252);
  EXPECT_EQ(r.interfaces[0].name, "bus");
  EXPECT_EQ(r.interfaces[0].description, "9600 8N1");
  EXPECT_EQ(r.interfaces[0].drivetap_settings, "drivetap t15=1 t35=2 timeout=3 max_hold=4");
  ASSERT_EQ(r.packets.size(), 2u);
  EXPECT_EQ(r.packets[0].timestamp, 1'700'000'000'123'456'789);
  EXPECT_EQ(r.packets[1].timestamp, 1'700'000'000'123'457'789);
  EXPECT_EQ(r.packets[0].data, (std::vector<std::uint8_t>{1, 3, 0, 0, 0, 1, 0x84, 0x0A}));
  EXPECT_EQ(r.packets[0].flags, pcapng::kFlagOutbound | pcapng::kFlagCrcError);
  EXPECT_EQ(r.packets[0].comment, "a comment");
  EXPECT_EQ(r.packets[0].drivetap_option, (std::vector<std::uint8_t>{'D', 'T', 1, 0, 1, 0, 0, 0}));
}

TEST(Pcapng, TruncatedFileKeepsWhatCameBeforeAndNamesTheOffset) {
  std::vector<std::uint8_t> file = sample_file();
  file.resize(file.size() - 10);  // cut into the second packet
  const ReadResult r = read_file(file);
  EXPECT_EQ(r.packets.size(), 1u);
  EXPECT_NE(r.error.find("t.pcapng: offset "), std::string::npos) << r.error;
  EXPECT_NE(r.error.find("truncated block"), std::string::npos) << r.error;
}

TEST(Pcapng, AbsurdBlockLengthIsRejectedWithoutAllocating) {
  std::vector<std::uint8_t> file = sample_file();
  // First EPB header follows SHB and IDB: find it by type 6.
  std::size_t at = 0;
  while (at + 8 <= file.size()) {
    const std::uint32_t type =
        file[at] | (file[at + 1] << 8) | (file[at + 2] << 16) | (std::uint32_t{file[at + 3]} << 24);
    const std::uint32_t len = file[at + 4] | (file[at + 5] << 8) | (file[at + 6] << 16) |
                              (std::uint32_t{file[at + 7]} << 24);
    if (type == 6) break;
    at += len;
  }
  file[at + 4] = 0xF0;
  file[at + 5] = 0xFF;
  file[at + 6] = 0xFF;
  file[at + 7] = 0x7F;
  const ReadResult r = read_file(file);
  EXPECT_TRUE(r.packets.empty());
  EXPECT_NE(r.error.find(fmt::format("offset {}", at + 4)), std::string::npos) << r.error;
  EXPECT_NE(r.error.find("exceeds"), std::string::npos) << r.error;
}

TEST(Pcapng, WrongMagicAndGarbage) {
  std::vector<std::uint8_t> file = sample_file();
  file[8] = 0x55;  // byte-order magic
  EXPECT_NE(read_file(file).error.find("bad byte-order magic"), std::string::npos);
  const ReadResult garbage =
      read_file({'h', 'e', 'l', 'l', 'o', ' ', 'w', 'o', 'r', 'l', 'd', '!'});
  EXPECT_NE(garbage.error.find("not a pcapng file"), std::string::npos) << garbage.error;
  EXPECT_NE(read_file({}).error.find("empty file"), std::string::npos);
}

TEST(Pcapng, TrailerMismatchAndBadInterfaceAreErrors) {
  std::vector<std::uint8_t> file = sample_file();
  file[file.size() - 1] ^= 0x01;  // last block's trailing length
  EXPECT_NE(read_file(file).error.find("trailing block length"), std::string::npos);
  auto bad_itf = write_file([](pcapng::Writer& w) {
    w.section_header("x");
    const std::uint8_t d[] = {1};
    pcapng::Writer::Packet p;
    p.interface = 3;
    p.data = d;
    w.packet(p);
  });
  EXPECT_NE(read_file(bad_itf).error.find("names interface 3"), std::string::npos);
}

TEST(Pcapng, InterfacesOfOneSectionAreBounded) {
  // Interface blocks alone would otherwise grow memory with the file; a new section starts over.
  auto file = write_file([](pcapng::Writer& w) {
    w.section_header("x");
    for (std::size_t i = 0; i <= pcapng::kMaxInterfaces; ++i) w.interface(147, "", "", "");
  });
  const ReadResult r = read_file(file);
  EXPECT_NE(
      r.error.find(fmt::format("more than {} interfaces in one section", pcapng::kMaxInterfaces)),
      std::string::npos)
      << r.error;
  EXPECT_EQ(r.interfaces.size(), pcapng::kMaxInterfaces);
  auto two_sections = write_file([](pcapng::Writer& w) {
    for (int section = 0; section < 2; ++section) {
      w.section_header("x");
      for (std::size_t i = 0; i < pcapng::kMaxInterfaces; ++i) w.interface(147, "", "", "");
    }
  });
  EXPECT_EQ(read_file(two_sections).error, "");
}

TEST(Pcapng, MicrosecondDefaultResolutionAndOtherWriters) {
  // An IDB without if_tsresol: timestamps are microseconds.
  auto file = write_file([](pcapng::Writer& w) { w.section_header("someone else"); });
  const std::uint8_t idb[] = {1, 0, 0, 0, 20, 0, 0, 0, 147, 0, 0, 0, 0, 0, 0, 0, 20, 0, 0, 0};
  file.insert(file.end(), idb, idb + sizeof idb);
  const std::uint8_t epb[] = {6, 0, 0, 0, 36, 0, 0, 0, 0, 0, 0,    0,    0, 0, 0,  0, 0xE8, 3,
                              0, 0, 2, 0, 0,  0, 2, 0, 0, 0, 0xAB, 0xCD, 0, 0, 36, 0, 0,    0};
  file.insert(file.end(), epb, epb + sizeof epb);
  const ReadResult r = read_file(file);
  ASSERT_EQ(r.error, "");
  EXPECT_FALSE(r.by_drivetap);
  ASSERT_EQ(r.packets.size(), 1u);
  EXPECT_EQ(r.packets[0].timestamp, 1000 * 1000);  // 1000 us
  EXPECT_EQ(r.packets[0].data, (std::vector<std::uint8_t>{0xAB, 0xCD}));
}

TEST(Pcapng, VarintAndZigzagRoundTrip) {
  for (std::int64_t v : {0LL, 1LL, -1LL, 127LL, -128LL, 1'000'000'007LL, -9'000'000'000'000LL}) {
    std::vector<std::uint8_t> buf;
    pcapng::put_varint(buf, pcapng::zigzag(v));
    std::size_t pos = 0;
    auto back = pcapng::get_varint(buf, &pos);
    ASSERT_TRUE(back);
    EXPECT_EQ(pcapng::unzigzag(*back), v);
    EXPECT_EQ(pos, buf.size());
  }
  const std::vector<std::uint8_t> endless(20, 0xFF);
  std::size_t pos = 0;
  EXPECT_FALSE(pcapng::get_varint(endless, &pos));
}

TEST(UpperPdu, TagsRoundTripAndHostileLengths) {
  upper_pdu::Tags t;
  t.dissector = "mbrtu";
  t.protocol_column = "Modbus RTU";
  t.direction = upper_pdu::kDirectionReceived;
  t.source_port = 0;
  t.destination_port = 1;
  std::vector<std::uint8_t> pkt;
  upper_pdu::append_tags(t, pkt);
  EXPECT_EQ(pkt.size() % 4, 0u);
  pkt.push_back(0x42);
  std::string err;
  auto p = upper_pdu::parse_tags(pkt, &err);
  ASSERT_TRUE(p) << err;
  EXPECT_EQ(p->tags.dissector, "mbrtu");
  EXPECT_EQ(p->tags.protocol_column, "Modbus RTU");
  EXPECT_EQ(p->tags.direction, upper_pdu::kDirectionReceived);
  EXPECT_EQ(p->tags.destination_port, 1u);
  EXPECT_EQ(p->payload_offset, pkt.size() - 1);
  const std::vector<std::uint8_t> lying = {0, 12, 0xFF, 0xFF, 'm'};
  EXPECT_FALSE(upper_pdu::parse_tags(lying, &err));
  EXPECT_NE(err.find("claims 65535 bytes"), std::string::npos) << err;
}

TEST(LinkLayer, User0RtacUpperPduAndUdp) {
  std::string why;
  bool fatal = false;
  const std::vector<std::uint8_t> raw = {1, 3, 0, 0};
  auto u = extract_serial_payload(147, raw, &why, &fatal);
  ASSERT_TRUE(u);
  EXPECT_EQ(u->bytes.size(), 4u);

  std::vector<std::uint8_t> rtac = {0, 0, 0, 1, 0, 0, 0, 2, /*event RX*/ 2, 0, 0, 0, 0xAA};
  auto r = extract_serial_payload(250, rtac, &why, &fatal);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->bytes.size(), 1u);
  EXPECT_EQ(r->outbound, false);
  rtac[8] = 0;  // status change: no data
  EXPECT_FALSE(extract_serial_payload(250, rtac, &why, &fatal));
  EXPECT_FALSE(fatal);

  // Ethernet / IPv4 / UDP 10.0.0.1:4001 -> 10.0.0.2:502 carrying 3 RTU bytes.
  std::vector<std::uint8_t> eth(12, 0);
  eth.insert(eth.end(), {0x08, 0x00});
  const std::vector<std::uint8_t> ip = {0x45, 0, 0,  31, 0, 0, 0x40, 0, 64, 17,
                                        0,    0, 10, 0,  0, 1, 10,   0, 0,  2};
  const std::vector<std::uint8_t> udp = {0x0F, 0xA1, 0x01, 0xF6, 0, 11, 0, 0, 0x01, 0x03, 0x02};
  eth.insert(eth.end(), ip.begin(), ip.end());
  eth.insert(eth.end(), udp.begin(), udp.end());
  auto e = extract_serial_payload(1, eth, &why, &fatal);
  ASSERT_TRUE(e) << why;
  EXPECT_EQ(e->bytes.size(), 3u);
  EXPECT_EQ(e->flow, "udp 10.0.0.1:4001>10.0.0.2:502");
  EXPECT_EQ(e->flow_link, "udp 10.0.0.1:4001<>10.0.0.2:502");

  const std::vector<std::uint8_t> short_eth = {1, 2, 3};
  EXPECT_FALSE(extract_serial_payload(1, short_eth, &why, &fatal));
  EXPECT_TRUE(fatal);
  EXPECT_FALSE(extract_serial_payload(105, raw, &why, &fatal));
  EXPECT_NE(why.find("not supported"), std::string::npos);
}

TEST(LinkLayer, ModbusTcpIsNotMistakenForRtu) {
  std::vector<std::uint8_t> pkt = {0x45, 0, 0,  52, 0, 0, 0x40, 0, 64, 6,
                                   0,    0, 10, 0,  0, 1, 10,   0, 0,  2};
  std::vector<std::uint8_t> tcp(20, 0);
  tcp[0] = 0xC0;
  tcp[1] = 0x00;
  tcp[2] = 0x01;
  tcp[3] = 0xF6;
  tcp[12] = 0x50;
  pkt.insert(pkt.end(), tcp.begin(), tcp.end());
  const std::vector<std::uint8_t> mbap = {0, 1, 0, 0, 0, 6, 1, 3, 0, 0, 0, 1};
  pkt.insert(pkt.end(), mbap.begin(), mbap.end());
  std::string why;
  bool fatal = false;
  EXPECT_FALSE(extract_serial_payload(101, pkt, &why, &fatal));
  EXPECT_NE(why.find("MBAP"), std::string::npos) << why;
}

TEST(Pcapng, PeekPlainGivesWhatNextGivesAndLeavesTheRestToIt) {
  // Packets without options or with flags alone (peek_plain's), with a comment (next()'s), on
  // interfaces of nanosecond and microsecond resolution; then, in two more files, a block whose
  // trailer is wrong and a microsecond timestamp out of range. Read taking every block peek_plain()
  // gives and the rest with next(), and read with next() alone, the packets and the error must be
  // the same.
  std::vector<std::uint8_t> file = write_file([](pcapng::Writer& w) {
    w.section_header("test");
    w.interface(252, "ns", "", "drivetap t15=1 t35=2 timeout=3 max_hold=4");
    w.interface(147, "ns too", "", "");
  });
  // Interface 2: no if_tsresol, microseconds.
  const std::uint8_t idb[] = {1, 0, 0, 0, 20, 0, 0, 0, 147, 0, 0, 0, 0, 0, 0, 0, 20, 0, 0, 0};
  file.insert(file.end(), idb, idb + sizeof idb);
  const std::vector<std::uint8_t> packets = write_file([](pcapng::Writer& w) {
    for (std::uint8_t i = 0; i < 30; ++i) {
      std::vector<std::uint8_t> data(i % 7, i);
      pcapng::Writer::Packet p;
      p.interface = i % 3;
      p.timestamp = 1'000'000'000 + i * 1'234'567;
      p.data = data;
      if (i % 5 == 3) p.comment = "with a comment";
      if (i % 8 == 6) p.flags = pcapng::kFlagInbound;
      if (i % 8 == 7) p.flags = 0;  // a flags option saying nothing: still one
      w.packet(p);
    }
  });
  file.insert(file.end(), packets.begin(), packets.end());
  // The last packet: 1 byte, and the end of options (pcapng::Writer writes it always).
  const std::vector<std::uint8_t> last_block(file.end() - 40, file.end());
  ASSERT_EQ(last_block[0], pcapng::kEnhancedPacket);
  std::vector<std::uint8_t> broken = file;
  broken.insert(broken.end(), last_block.begin(), last_block.end());
  broken.back() ^= 0x04;  // the copy's trailing length differs from its leading one
  std::vector<std::uint8_t> late = file;
  late.insert(late.end(), last_block.begin(), last_block.end());
  late[late.size() - 40 + 8] = 2;      // interface 2: microseconds
  late[late.size() - 40 + 15] = 0x7F;  // high word 0x7F000000: times 1000 is past the range
  for (const std::vector<std::uint8_t>* bytes : {&file, &broken, &late}) {
    const ReadResult expected = read_file(*bytes);
    std::vector<std::uint8_t> copy = *bytes;
    std::FILE* f = fmemopen(copy.data(), copy.size(), "rb");
    pcapng::Reader reader(f, "t.pcapng");
    std::vector<ReadPacket> read;
    std::size_t peeked = 0;
    pcapng::PacketRecord rec;
    pcapng::PlainPacket plain;
    // Each pass takes one packet, or ends.
    while (true) {
      if (reader.peek_plain(plain)) {
        read.push_back({plain.interface,
                        plain.timestamp,
                        true,
                        std::vector<std::uint8_t>(plain.data.begin(), plain.data.end()),
                        plain.flags,
                        "",
                        {},
                        0});
        reader.take_peeked();
        ++peeked;
        continue;
      }
      if (!reader.next(rec)) break;
      read.push_back({rec.interface,
                      rec.timestamp,
                      rec.has_timestamp,
                      std::vector<std::uint8_t>(rec.data.begin(), rec.data.end()),
                      rec.flags,
                      rec.comment,
                      {},
                      0});
    }
    std::fclose(f);
    EXPECT_EQ(reader.error(), expected.error);
    // 30 packets less 6 with a comment and the first, read by next() with the headers before it
    // (those with flags alone are peeked).
    EXPECT_EQ(peeked, 23u);
    ASSERT_EQ(read.size(), expected.packets.size());
    for (std::size_t i = 0; i < read.size(); ++i) {
      EXPECT_EQ(read[i].interface, expected.packets[i].interface) << i;
      EXPECT_EQ(read[i].timestamp, expected.packets[i].timestamp) << i;
      EXPECT_EQ(read[i].data, expected.packets[i].data) << i;
      EXPECT_EQ(read[i].flags, expected.packets[i].flags) << i;
      EXPECT_EQ(read[i].comment, expected.packets[i].comment) << i;
    }
  }
}

TEST(Pcapng, WholeBlockReadsOfARegularFileGiveWhatSmallReadsGive) {
  // From a regular file opened as every input is (open_input: a stdio buffer of one read block)
  // the reader asks for whole read blocks where they hold what it needs, and otherwise for what
  // is left of its window. Blocks of 1 to 2000 bytes straddle the block and window boundaries;
  // packets of 70 KiB and 300 KiB need more than a block and more than the window. Read that way
  // and from memory (no file: only the bytes each block needs), the packets must be the same.
  const std::vector<std::uint8_t> file = write_file([](pcapng::Writer& w) {
    w.section_header("test");
    w.interface(147, "bus", "", "");
    for (std::uint32_t i = 0; i < 3000; ++i) {
      const std::size_t size = i == 700 ? 70 * 1024 : i == 1900 ? 300 * 1024 : 1 + (i * 37) % 2000;
      std::vector<std::uint8_t> data(size);
      for (std::size_t k = 0; k < size; ++k) data[k] = static_cast<std::uint8_t>(i + k);
      pcapng::Writer::Packet p;
      p.timestamp = 1'000'000'000 + i;
      p.data = data;
      w.packet(p);
    }
  });
  ASSERT_GT(file.size(), 3u * 1024 * 1024);  // a dozen windows
  const ReadResult expected = read_file(file);
  ASSERT_EQ(expected.error, "");
  ASSERT_EQ(expected.packets.size(), 3000u);

  char path[] = "/tmp/drivetap-pcapng-XXXXXX";
  const int fd = mkstemp(path);
  ASSERT_GE(fd, 0);
  ASSERT_EQ(write(fd, file.data(), file.size()), static_cast<ssize_t>(file.size()));
  close(fd);
  InputFile in;
  std::string error;
  ASSERT_TRUE(open_input(path, &in, &error)) << error;
  pcapng::Reader reader(in.file, path);
  pcapng::PacketRecord rec;
  std::size_t n = 0;
  // Each pass reads one packet, or ends.
  while (reader.next(rec)) {
    ASSERT_LT(n, expected.packets.size());
    EXPECT_EQ(std::vector<std::uint8_t>(rec.data.begin(), rec.data.end()), expected.packets[n].data)
        << n;
    EXPECT_EQ(rec.timestamp, expected.packets[n].timestamp) << n;
    ++n;
  }
  EXPECT_EQ(reader.error(), "");
  EXPECT_EQ(n, expected.packets.size());
  close_input(in);
  std::remove(path);
}
