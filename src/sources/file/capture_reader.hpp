// Capture reader: pcapng (our reader) and classic pcap (libpcap) -> ByteEvents.
//
// Files drivetap wrote carry each byte's exact time and UART marks (pcapng.hpp, custom EPB
// option) and the run's settings: reading them back reproduces that run. Packets of other tools
// are unpacked by link type (link_layer.hpp) and their bytes laid out back to back, ending at
// the packet's timestamp (a capture tool stamps a packet when its last byte has arrived). All
// bytes are then re-framed by drivetap's framer, because other tools often cut frames badly;
// each byte keeps its packet number (ByteEvent::origin) so such packets can be reported.
#pragma once

#include <array>
#include <cstdio>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/byte_event.hpp"
#include "core/serial_config.hpp"
#include "formats/link_layer.hpp"
#include "formats/pcapng.hpp"
#include "sources/source.hpp"

// libpcap handles (pcap/pcap.h stays out of our headers).
struct pcap;
struct pcap_dumper;

namespace drivetap {

// Encodes/decodes the IDB settings string
// "drivetap t15=<ns> t35=<ns> timeout=<ns> max_hold=<ns> protocol=<id>".
std::string encode_settings(TimeNs t15, TimeNs t35, TimeNs timeout, TimeNs max_hold,
                            Protocol protocol);
RunSettings decode_settings(const std::string& description, const std::string& settings);

class CaptureReader final : public ByteSource {
 public:
  // Takes ownership of `in` for classic pcap (libpcap closes it); pcapng leaves it to the caller.
  CaptureReader(std::FILE* in, std::string name, bool pcapng, ChannelTable& channels);
  ~CaptureReader();
  CaptureReader(const CaptureReader&) = delete;
  CaptureReader& operator=(const CaptureReader&) = delete;

  // Reads up to the first packet, so that the settings are known. False on error.
  bool read_header() override;
  [[nodiscard]] RunSettings settings() const override { return settings_; }
  void set_character_time(TimeNs t) override { character_time_ = t; }

  bool next(ByteEvent& out) override;
  // The rest of the current packet (the next one when it is used up), at most kBatch bytes.
  bool next_batch(std::vector<ByteEvent>& out) override;
  static constexpr std::size_t kBatch = 4096;
  // The same as runs: a packet is one run (drivetap's per-byte option: one per stretch of evenly
  // spaced bytes), at most kBatch bytes a call.
  bool append_runs(RunBatch& out) override;
  [[nodiscard]] const std::string& error() const override { return error_; }
  // One line per kind of packet that carried no serial bytes, with a count and where first seen.
  [[nodiscard]] std::vector<std::string> notes() const override;
  [[nodiscard]] std::uint64_t packets() const { return packets_; }

 private:
  bool read_packet();  // next packet into held_; false at end or error
  // The fast lane of append_runs(): the pcapng packets that follow, while each is one that
  // load_pcapng_packet(), lay_out() and append_runs() would make one run of, the way another
  // tool's packet is laid out (an enhanced packet block without options, on an interface and
  // direction whose channel is known, its exported-PDU tags a block seen before), each appended to
  // `out` as that run straight from the reader's window, up to kPlainBytes bytes (from a pipe,
  // one packet: the next may be a while coming). How many packets were taken; 0 when the next is
  // any other (it takes the usual way).
  std::size_t append_plain_packets(RunBatch& out);
  static constexpr std::size_t kPlainBytes = 4096;
  bool load_pcapng_packet();
  bool load_pcap_packet();
  // Places the held packet's bytes in time: sets layout_ up (a byte event is made only when
  // next() takes it, so a large packet costs no per-byte memory).
  void lay_out();
  // One step of drivetap's per-byte option (time delta, UART marks, source packet delta) from
  // `pos`; false when the option is malformed or leaves the time range.
  static bool option_step(const std::vector<std::uint8_t>& option, std::size_t& pos, TimeNs& time,
                          std::int64_t& source_packet, std::uint8_t& flags);
  // Keeps a packet's bytes until lay_out (held_.option is left empty: the caller fills it).
  void hold(std::span<const std::uint8_t> bytes, TimeNs timestamp, ChannelId channel);
  void skip(const std::string& why, std::uint64_t where);
  // The channel of a packet's bytes; kNoChannel when it would be one too many.
  ChannelId channel_for(const std::string& base, const SerialPayload& payload);
  [[nodiscard]] std::string too_many_channels(long long offset) const;
  ChannelId pcapng_channel(std::uint32_t interface, const SerialPayload& payload);

  std::string name_;
  bool pcapng_;
  ChannelTable& channels_;
  std::unique_ptr<pcapng::Reader> ng_;
  pcapng::PacketRecord record_;  // reused for every packet
  // The exported-PDU tag blocks of the last upper-PDU packets and their parse: drivetap writes
  // a few kinds over and over (requests and replies alternate), so a packet that starts with
  // the bytes of one of them is not parsed again.
  struct KnownTags {
    std::vector<std::uint8_t> bytes;
    std::optional<bool> outbound;
  };
  std::array<KnownTags, 4> known_tags_;
  std::size_t known_tags_next_ = 0;  // the entry the next new tag block replaces
  // known_tags_of(): the entries the last two packets matched, the older first.
  std::array<std::size_t, 2> matched_tags_{};
  // The entry of known_tags_ whose block begins `data`, or nullptr. (Once a packet: inlined, as a
  // profile-guided build has it; defined inline in capture_reader.cpp, its only user.)
  [[gnu::always_inline]] const KnownTags* known_tags_of(std::span<const std::uint8_t> data);
  // Channel of each interface of the current section, by direction (none stated, outbound,
  // inbound); kNoChannel until its first packet. Indexed, so a file with many interfaces or
  // sections costs no search per packet.
  std::vector<std::array<ChannelId, 3>> channel_cache_;
  std::uint64_t cache_section_ = 0;
  ::pcap* pcap_ = nullptr;
  std::uint32_t pcap_link_type_ = 0;
  RunSettings settings_;
  TimeNs character_time_ = 0;
  struct Held {  // the packet read but not yet laid out as byte events
    std::vector<std::uint8_t> bytes;
    TimeNs timestamp = 0;
    ChannelId channel = 0;
    std::vector<std::uint8_t> option;
    std::uint32_t origin = 0;
  } held_;
  struct Layout {        // where next() is in the held packet
    bool exact = false;  // per-byte times from drivetap's option (version 1)
    std::size_t index = 0, count = 0;
    std::size_t option_pos = 0;  // exact: the entry after the decoded ones in held_.option
    TimeNs time = 0;  // exact: the last decoded byte's time (first: the packet's); even: first's
    std::int64_t source_packet = 0;  // exact: the last decoded byte's; even: every byte's
    std::size_t chunk_start = 0;     // exact: packet index of decoded_[0]
    bool even = false;  // drivetap's compact option (version 2): byte i at time + i*step
    TimeNs step = 0;
    // Neither: another tool's packet, its bytes back to back ending at the packet's timestamp.
  } layout_;
  // exact: the option's entries decoded ahead, at most kDecodedChunk at a time (a packet that
  // fits, nearly all, is decoded and checked in one pass; a larger one is checked whole first).
  struct Decoded {
    TimeNs time;
    std::uint8_t flags;
    std::uint32_t source_packet;
  };
  static constexpr std::size_t kDecodedChunk = 4096;
  std::vector<Decoded> decoded_;
  // Byte i of a held packet laid out by drivetap's compact option (layout_.even).
  [[nodiscard]] ByteEvent even_event(std::size_t i) const {
    return {layout_.time + static_cast<TimeNs>(i) * layout_.step, held_.bytes[i], 0, held_.channel,
            static_cast<std::uint32_t>(layout_.source_packet)};
  }
  // Entries `from`.. (at most kDecodedChunk, in order after the last decoded) into decoded_.
  void decode_chunk(std::size_t from);
  // Lays out the next packet when the held one is used up; false at the end or on error.
  bool hold_next();
  std::vector<ByteEvent> exact_events_;  // append_runs(): a packet with per-byte times
  bool pending_packet_ = false;          // read_header() loaded the first packet already
  std::uint64_t packets_ = 0;
  std::string error_;
  struct Skipped {
    std::uint64_t count = 0;
    std::uint64_t first = 0;
  };
  std::map<std::string, Skipped> skipped_;
};

}  // namespace drivetap
