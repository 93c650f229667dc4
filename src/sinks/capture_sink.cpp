// Capture sink: pcapng (our writer) or classic pcap (libpcap) output (docs/formats.md "The pcapng
// drivetap writes").
#include "sinks/capture_sink.hpp"

#include <stdio_ext.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cstring>
#include <iterator>
#include <optional>

#include <fmt/compile.h>
#include <fmt/format.h>
#include <pcap/pcap.h>

#include "drive/drive_fields.hpp"
#include "filter/record_fields.hpp"
#include "formats/link_layer.hpp"
#include "formats/shared_libraries.hpp"
#include "formats/upper_pdu.hpp"
#include "sinks/text_sink.hpp"

namespace drivetap {

struct CaptureSink::Pending {
  std::uint64_t number = 0;
  ChannelId channel = 0;
  FrameKind kind = FrameKind::telegram;
  ByteEvents events;
  std::vector<std::uint8_t> bytes;
  Direction direction = Direction::unknown;
  bool crc_error = false;
  bool broadcast = false;
  std::string protocol_column;
  std::string comment;
  std::string fields_line;  // the comment's second line (docs/formats.md "Packet comments")
  std::string_view wireshark_dissector;  // the dissector tag ("mbrtu", "danfoss_fc"), empty: none
  bool wireshark_builtin = false;        // stock Wireshark has that dissector
  // Findings of earlier packets, held with their drive's binding and handed on while this one
  // waited: described in its comment up to kEarlierDescribed, then counted.
  std::uint32_t earlier_findings = 0;
};

namespace {

// A value of the comment's second line: '%', the space, controls and DEL percent-escaped, so that
// items split at spaces and lines at line ends.
void append_escaped(std::string& out, std::string_view text) {
  for (const char c : text) {
    const auto u = static_cast<unsigned char>(c);
    if (u <= 0x20 || u == 0x7F || c == '%') {
      out += '%';
      out += kHexDigits[u >> 4];
      out += kHexDigits[u & 0x0F];
    } else {
      out += c;
    }
  }
}

// The finding's id as filters name it: the protocol's typed id, else the generic kind.
std::string_view finding_id_of(const Anomaly& a) {
  return a.finding ? std::string_view(a.finding->id) : std::string_view(anomaly_id(a.kind));
}

}  // namespace

std::string comment_fields_line(const Message& m) {
  std::string line(kCommentFieldsVersion);
  for (const FieldNode& node : m.fields) {
    line += ' ';
    line.append(node.depth, '>');  // one '>' per level under the top: the tree's shape
    fmt::format_to(std::back_inserter(line), FMT_COMPILE("{}@{}+{}"), node.desc->id, node.offset,
                   node.length);
    switch (node.desc->type) {
      case FieldType::group:
        break;
      case FieldType::text:
        line += '=';
        append_escaped(line, m.fields.text(node));
        break;
      case FieldType::bytes:
        line += '=';
        append_field_bytes_hex(line, node, m.bytes, m.text_encoded);
        break;
      default:
        line += '=';
        append_int(line, node.value);
        break;
    }
  }
  for (const Anomaly& a : m.anomalies) {
    line += " !";
    line += finding_id_of(a);
    line += '=';
    append_escaped(line, a.detail);
  }
  std::array<char, kDriveNumberChars> number;
  for (const DriveValue& v : m.drive_values) {
    line += " drive.";
    line += v.id;
    line += '=';
    append_escaped(line, drive_value_text(v, number));
  }
  if (!m.drive_info.empty()) {
    line += " drive=";
    append_escaped(line, m.drive_info);
  }
  return line;
}

CaptureSink::CaptureSink(std::FILE* out, const ChannelTable& channels, CaptureSinkOptions options)
    : out_(out), channels_(channels), options_(std::move(options)), ng_(out) {
  if (options_.format == CaptureFormat::pcapng) {
    ng_.section_header("drivetap 0.1.0");
    return;
  }
  const int dlt = options_.link_type == CaptureLinkType::user0 ? DLT_USER0 : kLinkTypeUpperPdu;
  // (The command line has made sure libpcap loads: `--pcap` says why it cannot.)
  const PcapLibrary& lib = pcap_library();
  if (lib.loaded) {
    pcap_ = lib.open_dead_with_tstamp_precision(dlt, 65535, PCAP_TSTAMP_PRECISION_NANO);
    if (pcap_) dumper_ = lib.dump_fopen(pcap_, out_);
  }
  if (!dumper_) status_.note_failure();
}

CaptureSink::~CaptureSink() {
  if (dumper_) pcap_library().dump_flush(dumper_);  // the FILE stays the caller's: no dump_close
  if (pcap_) pcap_library().close(pcap_);
}

// Interfaces are declared in channel order, those of the channels before this one first: a reader
// numbers channels by interface, and records at the same instant go in channel order, so the
// file reads back in the order it was written.
std::uint32_t CaptureSink::interface_for(ChannelId channel) {
  if (interface_of_channel_.size() <= channel) interface_of_channel_.resize(channel + 1u, -1);
  if (interface_of_channel_[channel] < 0) {
    const std::uint16_t link = options_.link_type == CaptureLinkType::user0
                                   ? static_cast<std::uint16_t>(kLinkTypeUser0)
                                   : static_cast<std::uint16_t>(kLinkTypeUpperPdu);
    for (ChannelId c = 0; c <= channel; ++c) {
      if (interface_of_channel_[c] >= 0) continue;
      ng_.interface(link, channels_.at(c).name, options_.serial.to_string(), options_.settings);
      interface_of_channel_[c] = interfaces_++;
    }
  }
  return static_cast<std::uint32_t>(interface_of_channel_[channel]);
}

// The one Pending is reused from packet to packet (its vectors and strings keep their storage);
// every member is set for each frame or noise record.
CaptureSink::Pending& CaptureSink::start_pending() {
  write_pending();
  if (!pending_) pending_ = std::make_unique<Pending>();
  has_pending_ = true;
  pending_->earlier_findings = 0;
  return *pending_;
}

void CaptureSink::on_frame(const Message& m) {
  if (!refusal_.empty()) return;
  if (options_.link_type == CaptureLinkType::user0 &&
      !(m.protocol.desc() && m.protocol.desc()->wireshark_builtin)) {
    // Link type 147 carries bare bytes that Wireshark maps to one dissector (Modbus RTU's): a
    // telegram of another protocol would be shown as Modbus RTU. Nothing more is written.
    write_pending();
    refusal_ = fmt::format(
        "--dlt user0: the bus speaks {}, which Wireshark has no dissector for at link type 147 "
        "(frame {}); write without --dlt (upper-PDU, drivetap's plugin decodes it)",
        protocol_label(m.protocol), m.frame.number);
    status_.note_failure();
    return;
  }
  Pending& p = start_pending();
  p.number = m.frame.number;
  p.channel = m.frame.channel;
  p.kind = FrameKind::telegram;
  p.events = m.frame.events;
  p.bytes = m.bytes;
  p.direction = m.direction;
  p.crc_error =
      m.checksum.verdict == ChecksumVerdict::bad || m.checksum.verdict == ChecksumVerdict::swapped;
  p.broadcast = m.address == 0;
  p.protocol_column = protocol_label(m.protocol);
  if (p.broadcast) p.protocol_column += " broadcast";
  p.comment.clear();
  append_frame_summary(p.comment, m, true);
  if (!m.drive_info.empty()) {
    p.comment += "; ";
    p.comment += m.drive_info;
  }
  p.fields_line.clear();
  if (!options_.plain) p.fields_line = comment_fields_line(m);
  p.wireshark_dissector = m.protocol.desc() ? m.protocol.desc()->wireshark_dissector : "";
  p.wireshark_builtin = m.protocol.desc() && m.protocol.desc()->wireshark_builtin;
}

void CaptureSink::on_noise(const Frame& f) {
  if (!refusal_.empty()) return;
  Pending& p = start_pending();
  p.number = f.number;
  p.channel = f.channel;
  p.kind = FrameKind::noise;
  p.events = f.events;
  p.bytes.assign(f.events.bytes().begin(), f.events.bytes().end());
  p.direction = Direction::unknown;
  p.crc_error = false;
  p.broadcast = false;
  p.protocol_column = "noise";
  p.comment.clear();
  fmt::format_to(std::back_inserter(p.comment), FMT_COMPILE("noise: {} byte{} outside any frame"),
                 p.bytes.size(), p.bytes.size() == 1 ? "" : "s");
  p.fields_line.assign(kCommentFieldsVersion);
  p.wireshark_dissector = {};
  p.wireshark_builtin = false;
}

void CaptureSink::on_anomaly(const Anomaly& a) {
  if (!has_pending_) return;
  if (a.address >= 0 && a.frame_number != 0 && a.frame_number < pending_->number) {
    // Held while its drive's family was not yet sure: its own packet is written already, so the
    // packet waiting now carries it, naming the frame it is about (pcapng has no later edit).
    Pending& p = *pending_;
    if (++p.earlier_findings <= kEarlierDescribed)
      fmt::format_to(std::back_inserter(p.comment),
                     FMT_COMPILE("; {} (#{}, held while drive {}'s family was not yet sure): {}"),
                     anomaly_label(a.kind), a.frame_number, a.address, a.detail);
    return;
  }
  if (a.frame_number != pending_->number) return;
  // A frame's own findings are in its fields line already (Message::anomalies); the others
  // (a noise record's, the conversation's) join it here.
  if (pending_->kind == FrameKind::noise || finding_known_after_frame(a.kind)) {
    pending_->fields_line += " !";
    pending_->fields_line += finding_id_of(a);
    pending_->fields_line += '=';
    append_escaped(pending_->fields_line, a.detail);
  }
  if (a.kind == AnomalyKind::checksum_bad || a.kind == AnomalyKind::checksum_swapped ||
      a.kind == AnomalyKind::noise)
    return;  // already in the comment's decode
  fmt::format_to(std::back_inserter(pending_->comment), FMT_COMPILE("; {}: {}"),
                 anomaly_label(a.kind), a.detail);
}

void CaptureSink::on_event(const BusEvent& e) {
  // A drive event read from the frame waiting to be written joins its fields line.
  if (!has_pending_ || e.frame == 0 || e.frame != pending_->number) return;
  pending_->fields_line += " *";
  append_escaped(pending_->fields_line, event_kind_id(e.kind));
  pending_->fields_line += '=';
  append_escaped(pending_->fields_line, e.detail);
}

void CaptureSink::write_pending() {
  if (!has_pending_ || status_.failed()) {
    has_pending_ = false;
    return;
  }
  Pending& p = *pending_;
  if (p.earlier_findings > kEarlierDescribed)
    fmt::format_to(std::back_inserter(p.comment),
                   FMT_COMPILE("; and {} more held findings of earlier frames"),
                   p.earlier_findings - kEarlierDescribed);
  std::vector<std::uint8_t>& data = data_;
  data.clear();
  if (options_.link_type == CaptureLinkType::upper_pdu) {
    // The fewest tags: the dissector, and what stock Wireshark needs beside it. The direction
    // is in the EPB flags (Wireshark's frame dissector sets the P2P direction from them), the
    // decode in the packet comment.
    upper_pdu::Tags tags;
    if (p.kind == FrameKind::telegram && !p.wireshark_dissector.empty()) {
      tags.dissector = p.wireshark_dissector;
      if (p.wireshark_builtin) {
        // Wireshark's Modbus RTU dissector tells queries from responses by port: destination 0
        // (its default RTU "port" range) marks a query, source 0 a response.
        if (p.direction == Direction::request) {
          tags.source_port = 1;
          tags.destination_port = 0;
        } else if (p.direction == Direction::response) {
          tags.source_port = 0;
          tags.destination_port = 1;
        }
      }
      // (drivetap's plugin's dissectors set their columns; Wireshark applies a protocol-column
      // tag only when it knows the dissector, so without the plugin the tag would be lost.)
    } else {
      tags.dissector = "data";  // noise
      if (!options_.plain) tags.protocol_column = p.protocol_column;
    }
    upper_pdu::append_tags(tags, data);
  }
  data.insert(data.end(), p.bytes.begin(), p.bytes.end());
  // pcap and pcapng store unsigned times: a byte time before 0 (a foreign capture's first packet
  // stamped at 0, its bytes laid out before it) is stamped at 0. pcapng's per-byte option keeps
  // the true times as deltas from the stamp, which may be negative.
  const TimeNs first = p.events.empty() ? 0 : p.events.front_time();
  const TimeNs timestamp = std::max<TimeNs>(first, 0);
  const TimeNs end =
      std::max<TimeNs>(p.events.empty() ? 0 : p.events.back_time() + options_.character_time, 0);

  if (options_.format == CaptureFormat::pcap) {
    struct pcap_pkthdr h {};
    h.ts.tv_sec = static_cast<time_t>(end / kNsPerSecond);
    h.ts.tv_usec = static_cast<suseconds_t>(end % kNsPerSecond);  // ns precision
    h.caplen = h.len = static_cast<bpf_u_int32>(data.size());
    pcap_library().dump(reinterpret_cast<u_char*>(dumper_), &h, data.data());
    // pcap_dump() says nothing of a failed write: its errno is kept here, on the writing thread.
    if (std::ferror(out_)) status_.note_failure();
  } else if (options_.plain) {
    pcapng::Writer::Packet pkt;
    pkt.interface = interface_for(p.channel);
    pkt.timestamp = end;
    pkt.data = data;
    ng_.packet(pkt);
    if (!ng_.ok()) status_.note_failure();
  } else {
    std::vector<std::uint8_t>& option = option_;
    const std::uint8_t kind = p.kind == FrameKind::noise ? 1 : 0;
    // Evenly spaced, unflagged bytes of one source packet (nearly every frame) need no entry
    // per byte: version 2 gives the spacing once.
    const TimeNs step =
        p.events.size() >= 2 ? p.events.time(1) - p.events.time(0) : options_.character_time;
    bool even = step >= 0 && first == timestamp;
    // One stretch without UART marks is even by construction; otherwise each byte is looked at.
    if (even && (p.events.stretches().size() > 1 || p.events.any_flags())) {
      const std::uint32_t origin = p.events.empty() ? 0 : p.events.origin(0);
      std::size_t i = 0;
      for (const ByteEvent& e : p.events) {
        even = e.flags == 0 && e.origin == origin &&
               e.time - timestamp == static_cast<TimeNs>(i) * step;
        if (!even) break;
        ++i;
      }
    }
    if (even) {
      option.assign({'D', 'T', 2, kind});
      pcapng::put_varint(option, p.events.size());
      pcapng::put_varint(option, static_cast<std::uint64_t>(step));
      pcapng::put_varint(option, p.events.empty() ? 0 : p.events.origin(0));
    } else {
      option.assign({'D', 'T', 1, kind});
      pcapng::put_varint(option, p.events.size());
      TimeNs previous = timestamp;
      std::int64_t previous_origin = 0;
      for (const ByteEvent& e : p.events) {
        pcapng::put_varint(option, pcapng::zigzag(e.time - previous));
        option.push_back(e.flags);
        pcapng::put_varint(option,
                           pcapng::zigzag(static_cast<std::int64_t>(e.origin) - previous_origin));
        previous = e.time;
        previous_origin = e.origin;
      }
    }
    pcapng::Writer::Packet pkt;
    pkt.interface = interface_for(p.channel);
    pkt.timestamp = timestamp;
    pkt.data = data;
    if (p.direction == Direction::request) pkt.flags |= pcapng::kFlagOutbound;
    if (p.direction == Direction::response) pkt.flags |= pcapng::kFlagInbound;
    if (p.crc_error) pkt.flags |= pcapng::kFlagCrcError;
    comment_.assign(p.comment);
    if (!p.fields_line.empty()) {
      comment_ += '\n';
      comment_ += p.fields_line;
    }
    pkt.comment = comment_;
    pkt.drivetap_option = option;
    ng_.packet(pkt);
    if (!ng_.ok()) status_.note_failure();
  }
  ++packets_;
  has_pending_ = false;
}

long whole_capture_prefix(int fd, long from, long size, CaptureFormat format) {
  auto read_u32 = [fd](long at, std::uint32_t* value) {
    std::uint8_t b[4];
    if (::pread(fd, b, 4, at) != 4) return false;
    std::memcpy(value, b, 4);  // host order: the order this process wrote it in
    return true;
  };
  long at = std::max(from, 0L);
  if (format == CaptureFormat::pcap) {
    constexpr long kFileHeader = 24, kRecordHeader = 16;
    if (at == 0) {
      if (size < kFileHeader) return 0;
      at = kFileHeader;
    }
    // Each pass steps over one whole record (at least its 16-byte header), or stops.
    while (at + kRecordHeader <= size) {
      std::uint32_t captured = 0;
      if (!read_u32(at + 8, &captured)) break;
      const long end = at + kRecordHeader + static_cast<long>(captured);
      if (end > size) break;
      at = end;
    }
    return at;
  }
  // pcapng: type(4) total length(4) ... total length(4); lengths >= 12 and multiples of 4.
  while (at + 12 <= size) {
    std::uint32_t total = 0;
    if (!read_u32(at + 4, &total) || total < 12 || total % 4 != 0) break;
    const long end = at + static_cast<long>(total);
    if (end > size) break;
    at = end;
  }
  return at;
}

std::FILE* open_output_file(const std::string& path) {
  struct stat st {};
  const bool special = ::stat(path.c_str(), &st) == 0 && !S_ISREG(st.st_mode);
  return std::fopen(path.c_str(), special ? "wb" : "w+b");
}

namespace {

// The one way outputs are cut back after a failed write: drop what stdio still buffers, and
// truncate a regular file to what `keep(fd, size)` says stays (nullopt: leave it as it is).
// Pipes and devices have nothing to cut.
template <typename Keep>
void cut_file_back(std::FILE* file, Keep keep) {
  __fpurge(file);
  const int fd = ::fileno(file);
  struct stat st {};
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) return;
  const std::optional<long> size = keep(fd, static_cast<long>(st.st_size));
  if (size && ::ftruncate(fd, *size) == 0) std::fseek(file, *size, SEEK_SET);
}

// The end of the last whole line of the `size` bytes of `fd` (0: none); nullopt when they cannot
// be read back.
std::optional<long> last_line_end(int fd, long size) {
  // Backwards from the end, a block at a time, to the last '\n'.
  char block[4096];
  for (long end = size; end > 0;) {
    const long start = std::max(0L, end - static_cast<long>(sizeof block));
    const ssize_t got = ::pread(fd, block, static_cast<std::size_t>(end - start), start);
    if (got != end - start) return std::nullopt;
    for (long i = got - 1; i >= 0; --i)
      if (block[i] == '\n') return start + i + 1;
    end = start;
  }
  return 0;
}

}  // namespace

void cut_back_to_last_line(std::FILE* file) {
  cut_file_back(file, last_line_end);
}

void cut_back_to(std::FILE* file, long known_good, CaptureFormat format) {
  cut_file_back(file, [&](int fd, long size) -> std::optional<long> {
    return whole_capture_prefix(fd, known_good, size, format);
  });
}

bool CaptureSink::flush() {
  write_pending();
  if (dumper_ && pcap_library().dump_flush(dumper_) != 0) status_.note_failure();
  return status_.flush(out_);
}

}  // namespace drivetap
