// Capture sink: every frame and noise record as one packet of a pcapng (default) or classic pcap
// file that Wireshark opens (docs/formats.md "The pcapng drivetap writes").
//
// Link type 252 (Wireshark upper PDU): each packet starts with exported-PDU tags naming the
// dissector ("mbrtu" for Modbus RTU, "data" for noise), the protocol column text and the
// direction (P2P sent = master -> slave), then the frame bytes. `--dlt user0` writes the bare
// bytes with link type 147 instead (Wireshark then needs a user DLT entry: docs/formats.md, "In
// Wireshark"). pcapng only: one interface per channel (name, line settings as description), EPB
// direction flags (outbound = master -> slave), the CRC-error flag bit, drivetap's annotation as
// the packet comment, and per-byte times and UART marks in a custom option, so that reading the
// file back reproduces the run exactly (`--plain` leaves all of that out but the interfaces).
// Classic pcap has no room for per-byte times: its packets are stamped when their last byte ended,
// as capture tools stamp them, so reading one back lays the bytes out where they were.
#pragma once

#include <cstdio>
#include <memory>
#include <vector>

#include "core/byte_event.hpp"
#include "core/serial_config.hpp"
#include "formats/pcapng.hpp"
#include "sinks/sink.hpp"

// libpcap handles (pcap/pcap.h stays out of our headers).
struct pcap;
struct pcap_dumper;

namespace drivetap {

enum class CaptureFormat { pcapng, pcap };
enum class CaptureLinkType { upper_pdu, user0 };

struct CaptureSinkOptions {
  CaptureFormat format = CaptureFormat::pcapng;
  CaptureLinkType link_type = CaptureLinkType::upper_pdu;
  SerialConfig serial;
  TimeNs character_time = 0;  // classic pcap stamps a packet at the end of its last byte
  std::string settings;       // encode_settings(...) of the run, stored per interface
  // pcapng with the frames only (`-w --plain`): per packet the dissector tag (and Modbus RTU's
  // query/response ports) and the bytes, stamped at the end of the last byte as capture tools
  // stamp; no comment, flags, direction tags or per-byte times. Read back like another tool's
  // capture (bytes back to back before the timestamp), without UART marks.
  bool plain = false;
};

// After a failed write (disk full, file size limit): drops what stdio still buffers and cuts the
// file back to the end of the last block (pcapng) or record (classic pcap) that reached the disk
// whole, so it stays readable with every packet that fitted. `known_good` is an offset already
// known to end a whole block (the last successful flush, or 0): the walk over the blocks on disk
// starts there.
void cut_back_to(std::FILE* file, long known_good, CaptureFormat format);

// The end of the last whole pcapng block / pcap record of the file `fd` holds, walking from
// `from` (a block boundary, or 0) to `size` bytes. Lengths are read as this host wrote them.
// Capture files are opened with open_output_file() so that the walk can read them back; where
// it cannot, the result is `from`.
long whole_capture_prefix(int fd, long from, long size, CaptureFormat format);

// Creates an output file (capture, text or JSON) for writing: a regular file is opened for
// reading too ("w+b"), so that cut_back_to() / cut_back_to_last_line() can read it back; a FIFO
// or device only for writing ("wb": a FIFO opened read-write would never report its reader gone).
std::FILE* open_output_file(const std::string& path);

// After a failed write of a text or JSON Lines output: drops what stdio still buffers and cuts
// the file back after its last whole line, so that no reader meets half a record.
void cut_back_to_last_line(std::FILE* file);

// The packet comment's second line, machine-readable for drivetap's Wireshark plugin
// (docs/formats.md "Packet comments"): "drivetap/2", then space-separated items, each field of the
// tree as `id@offset+length=value` after one '>' per level, each finding as `!id=detail`, each
// drive value as `drive.id=value`, the drive annotation as `drive=text`, each drive event read from
// the frame as
// `*kind=detail`; values percent-escaped.
inline constexpr std::string_view kCommentFieldsVersion = "drivetap/2";
std::string comment_fields_line(const Message& m);

// What the capture sinks (one file, or a ring of them) share: they write packets, and neither
// transactions nor the summary.
class PacketSink : public Sink {
 public:
  // Packets carry the bytes and the info line as a comment, not the field tree.
  [[nodiscard]] SinkNeeds needs() const override {
    SinkNeeds n;
    n.fields = n.transactions = n.drive_values = false;
    return n;
  }
};

class CaptureSink final : public PacketSink {
 public:
  CaptureSink(std::FILE* out, const ChannelTable& channels, CaptureSinkOptions options);
  ~CaptureSink() override;
  void on_frame(const Message& message) override;
  void on_noise(const Frame& noise) override;
  void on_anomaly(const Anomaly& anomaly) override;
  void on_event(const BusEvent& event) override;
  bool flush() override;
  [[nodiscard]] std::uint64_t packets() const { return packets_; }
  // The comment's fields line needs the field tree and the drive values (not with --plain: no
  // comments).
  [[nodiscard]] SinkNeeds needs() const override {
    SinkNeeds n = PacketSink::needs();
    n.fields = n.drive_values = !options_.plain;
    return n;
  }
  // `--dlt user0` and a telegram Wireshark has no dissector for at link type 147: the one line
  // that refuses the run (nothing of it written); empty while none came.
  [[nodiscard]] const std::string& refusal() const { return refusal_; }

 private:
  struct Pending;
  static constexpr std::uint32_t kEarlierDescribed = 16;
  Pending& start_pending();  // writes the pending packet, then gives its storage for the next
  void write_pending();
  std::uint32_t interface_for(ChannelId channel);

  std::FILE* out_;
  const ChannelTable& channels_;
  CaptureSinkOptions options_;
  pcapng::Writer ng_;
  ::pcap* pcap_ = nullptr;
  ::pcap_dumper* dumper_ = nullptr;
  std::vector<std::int64_t> interface_of_channel_;  // -1: no IDB yet
  std::uint32_t interfaces_ = 0;
  std::uint64_t packets_ = 0;
  // A frame waits for its anomalies (they go in the comment); the storage stays for the next.
  std::unique_ptr<Pending> pending_;
  bool has_pending_ = false;
  std::vector<std::uint8_t> option_;  // drivetap's EPB option, reused from packet to packet
  std::vector<std::uint8_t> data_;    // the packet's data (upper-PDU tags and bytes), reused
  std::string comment_;               // the packet's comment, both lines, reused
  WriteStatus status_;
  std::string refusal_;
};

}  // namespace drivetap
