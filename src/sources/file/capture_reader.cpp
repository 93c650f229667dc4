// Capture reader: pcapng (ours) and classic pcap (libpcap) into byte events (docs/formats.md "Other
// tools' pcap and pcapng").
#include "sources/file/capture_reader.hpp"

#include <fmt/format.h>
#include <pcap/pcap.h>

#include <algorithm>
#include <cstring>
#include <sstream>

#include "core/protocol.hpp"
#include "formats/link_layer.hpp"
#include "formats/shared_libraries.hpp"

namespace drivetap {

std::string encode_settings(TimeNs t15, TimeNs t35, TimeNs timeout, TimeNs max_hold,
                            Protocol protocol) {
  return fmt::format("drivetap t15={} t35={} timeout={} max_hold={} protocol={}", t15, t35, timeout,
                     max_hold, protocol_id(protocol));
}

RunSettings decode_settings(const std::string& description, const std::string& settings) {
  RunSettings r;
  std::string err;
  if (auto serial = SerialConfig::parse(description, &err)) r.serial = serial;
  std::istringstream in(settings);
  std::string word;
  in >> word;
  if (word != "drivetap") return r;
  while (in >> word) {
    const auto eq = word.find('=');
    if (eq == std::string::npos) continue;
    const std::string key = word.substr(0, eq);
    if (key == "protocol") {
      const Protocol p = protocol_from_option(word.substr(eq + 1));
      if (p != Protocol::unknown) r.protocol = p;
      continue;
    }
    TimeNs value = 0;
    try {
      value = std::stoll(word.substr(eq + 1));
    } catch (...) {
      continue;  // a value we cannot read is ignored: the command line still decides
    }
    if (value <= 0 || value > kMaxInterval) continue;  // not a usable interval: ignored
    if (key == "t15") r.t15 = value;
    if (key == "t35") r.t35 = value;
    if (key == "timeout") r.reply_timeout = value;
    if (key == "max_hold") r.max_hold = value;
  }
  return r;
}

CaptureReader::CaptureReader(std::FILE* in, std::string name, bool pcapng, ChannelTable& channels)
    : name_(std::move(name)), pcapng_(pcapng), channels_(channels) {
  if (pcapng_) {
    ng_ = std::make_unique<pcapng::Reader>(in, name_);
    ng_->keep_comments(false);
    return;
  }
  const PcapLibrary& lib = pcap_library();
  if (!lib.loaded) {
    error_ = fmt::format("{}: offset 0: a classic pcap file, but {}", name_, lib.error);
    std::fclose(in);
    return;
  }
  char errbuf[PCAP_ERRBUF_SIZE] = {0};
  pcap_ = lib.fopen_offline_with_tstamp_precision(in, PCAP_TSTAMP_PRECISION_NANO, errbuf);
  if (!pcap_) {
    error_ = fmt::format("{}: offset 0: {}", name_, errbuf);
    std::fclose(in);
    return;
  }
  pcap_link_type_ = static_cast<std::uint32_t>(lib.datalink(pcap_));
}

CaptureReader::~CaptureReader() {
  if (pcap_) pcap_library().close(pcap_);
}

void CaptureReader::skip(const std::string& why, std::uint64_t where) {
  Skipped& s = skipped_[why];
  if (s.count++ == 0) s.first = where;
}

std::vector<std::string> CaptureReader::notes() const {
  std::vector<std::string> out;
  for (const auto& [why, s] : skipped_)
    out.push_back(fmt::format("{}: skipped {} packet{} ({}), first: packet {}", name_, s.count,
                              s.count == 1 ? "" : "s", why, s.first));
  return out;
}

std::string CaptureReader::too_many_channels(long long offset) const {
  // Interfaces, directions and IP flows each make a channel.
  return fmt::format(
      "{}: offset {}: packet {}: more than {} channels (interfaces, directions "
      "and flows; the most drivetap keeps apart)",
      name_, offset, packets_, ChannelTable::kMaxChannels);
}

ChannelId CaptureReader::channel_for(const std::string& base, const SerialPayload& payload) {
  if (!payload.flow.empty())
    return channels_.intern(payload.flow, payload.flow_link, ChannelRole::bus, /*ip_flow=*/true);
  if (payload.outbound)
    return channels_.intern(base + (*payload.outbound ? ".tx" : ".rx"), base, ChannelRole::bus);
  return channels_.intern(base);
}

namespace {
// The slot of channel_cache_'s entry for a direction: none, outbound, inbound.
int direction_slot(std::optional<bool> outbound) {
  return outbound ? (*outbound ? 1 : 2) : 0;
}
}  // namespace

ChannelId CaptureReader::pcapng_channel(std::uint32_t interface, const SerialPayload& payload) {
  // Serial packets of one interface and direction always land on the same channel: remembered,
  // so that the name is built and looked up once per interface rather than once per packet.
  const int direction = direction_slot(payload.outbound);
  if (payload.flow.empty()) {
    if (cache_section_ != ng_->sections()) {
      channel_cache_.clear();
      cache_section_ = ng_->sections();
    }
    if (interface < channel_cache_.size() && channel_cache_[interface][direction] != kNoChannel)
      return channel_cache_[interface][direction];
  }
  const pcapng::Interface& itf = ng_->interfaces().at(interface);
  std::string base = itf.name;
  if (base.empty()) base = ng_->interfaces().size() == 1 ? "bus" : fmt::format("if{}", interface);
  const ChannelId ch = channel_for(base, payload);
  if (payload.flow.empty() && ch != kNoChannel) {
    if (channel_cache_.size() <= interface)
      channel_cache_.resize(interface + std::size_t{1}, {kNoChannel, kNoChannel, kNoChannel});
    channel_cache_[interface][direction] = ch;
  }
  return ch;
}

bool CaptureReader::option_step(const std::vector<std::uint8_t>& option, std::size_t& pos,
                                TimeNs& time, std::int64_t& source_packet, std::uint8_t& flags) {
  auto delta = pcapng::get_varint(option, &pos);
  if (!delta || pos >= option.size()) return false;
  flags = option[pos++];
  auto origin_delta = pcapng::get_varint(option, &pos);
  if (!origin_delta) return false;
  const std::int64_t step = pcapng::unzigzag(*delta);
  // |time| and |step| below 2^62: the sum cannot overflow; out of range = a bad option.
  if (step >= kTimeLimit || step <= -kTimeLimit || !time_in_range(time + step)) return false;
  time += step;
  // source_packet is in [0, 2^32) here: a step of 2^32 or more either way leaves that range (a
  // bad option), and a smaller one cannot overflow the sum.
  const std::int64_t origin_step = pcapng::unzigzag(*origin_delta);
  if (origin_step > std::int64_t{UINT32_MAX} || origin_step < -std::int64_t{UINT32_MAX})
    return false;
  source_packet += origin_step;
  return source_packet >= 0 && source_packet <= UINT32_MAX;
}

void CaptureReader::decode_chunk(std::size_t from) {
  decoded_.clear();
  layout_.chunk_start = from;
  const std::size_t end = std::min(layout_.count, from + kDecodedChunk);
  // lay_out() checked the whole option: every step succeeds again.
  for (std::size_t i = from; i < end; ++i) {
    std::uint8_t flags = 0;
    option_step(held_.option, layout_.option_pos, layout_.time, layout_.source_packet, flags);
    decoded_.push_back({layout_.time, flags, static_cast<std::uint32_t>(layout_.source_packet)});
  }
}

void CaptureReader::lay_out() {
  layout_ = Layout{};
  decoded_.clear();
  const std::vector<std::uint8_t>& option = held_.option;
  // drivetap's own option: exact per-byte times and UART marks, used only when the whole of it
  // is good. A packet of up to kDecodedChunk bytes is decoded and checked in one pass; a larger
  // one is checked whole first, then decoded a chunk at a time as next() takes its bytes.
  if (option.size() >= 4 && option[0] == 'D' && option[1] == 'T' && option[2] == 1) {
    std::size_t pos = 4;
    auto count = pcapng::get_varint(option, &pos);
    if (count && *count == held_.bytes.size()) {
      const std::size_t first = pos;
      TimeNs t = held_.timestamp;
      std::int64_t source_packet = 0;
      std::uint8_t flags = 0;
      const bool small = held_.bytes.size() <= kDecodedChunk;
      bool good = true;
      for (std::size_t i = 0; i < held_.bytes.size() && good; ++i) {
        good = option_step(option, pos, t, source_packet, flags);
        if (good && small)
          decoded_.push_back({t, flags, static_cast<std::uint32_t>(source_packet)});
      }
      if (good) {
        // Small: all decoded already (decode_chunk() is never called); large: from the start.
        layout_ = small ? Layout{true, 0, held_.bytes.size(), pos, t, source_packet, 0}
                        : Layout{true, 0, held_.bytes.size(), first, held_.timestamp, 0, 0};
        return;
      }
      decoded_.clear();
    }
  }
  // drivetap's compact form: evenly spaced bytes without UART marks, of one source packet.
  // n * step is checked against kTimeLimit before it is added to the timestamp: no overflow.
  if (option.size() >= 4 && option[0] == 'D' && option[1] == 'T' && option[2] == 2) {
    std::size_t pos = 4;
    const auto count = pcapng::get_varint(option, &pos);
    const auto step = pcapng::get_varint(option, &pos);
    const auto source_packet = pcapng::get_varint(option, &pos);
    const TimeNs n = static_cast<TimeNs>(held_.bytes.size());
    if (count && *count == held_.bytes.size() && step &&
        *step <= static_cast<std::uint64_t>(kMaxInterval) &&
        (n == 0 || static_cast<TimeNs>(*step) <= kTimeLimit / n) && source_packet &&
        *source_packet <= UINT32_MAX && pos == option.size() &&
        time_in_range(held_.timestamp + n * static_cast<TimeNs>(*step))) {
      layout_.even = true;
      layout_.count = held_.bytes.size();
      layout_.time = held_.timestamp;
      layout_.step = static_cast<TimeNs>(*step);
      layout_.source_packet = static_cast<std::int64_t>(*source_packet);
      return;
    }
  }
  // Other tools: the packet was stamped when its last byte had arrived. Times and the character
  // time are bounded (kTimeLimit, kMaxInterval) and a packet holds < 2^24 bytes: no overflow.
  const TimeNs n = static_cast<TimeNs>(held_.bytes.size());
  if (!time_in_range(held_.timestamp - n * character_time_)) {
    skip("timestamp out of range", held_.origin);
    return;
  }
  layout_.count = held_.bytes.size();
}

bool CaptureReader::load_pcapng_packet() {
  pcapng::PacketRecord& rec = record_;
  // Each pass consumes one packet block, or returns.
  while (ng_->next(rec)) {
    ++packets_;
    const pcapng::Interface& itf = ng_->interfaces().at(rec.interface);
    if (packets_ == 1 || settings_.serial == std::nullopt) {
      if (ng_->written_by_drivetap())
        settings_ = decode_settings(itf.description, itf.drivetap_settings);
    }
    if (!link_type_supported(itf.link_type)) {
      skip(fmt::format("link type {} carries no serial bytes drivetap reads", itf.link_type),
           packets_);
      continue;
    }
    std::optional<SerialPayload> payload;
    if (itf.link_type == kLinkTypeUpperPdu) {
      // A tag block seen before, byte for byte: the same parse.
      if (const KnownTags* known = known_tags_of(rec.data))
        payload =
            SerialPayload{std::span<const std::uint8_t>(rec.data).subspan(known->bytes.size()),
                          known->outbound,
                          {},
                          {}};
    }
    if (!payload) {
      std::string why;
      bool fatal = false;
      payload = extract_serial_payload(itf.link_type, rec.data, &why, &fatal);
      if (!payload) {
        skip(fatal ? fmt::format("malformed: {}", why) : why, packets_);
        continue;
      }
      if (itf.link_type == kLinkTypeUpperPdu) {  // the payload is what follows the tags
        KnownTags& known = known_tags_[known_tags_next_];
        known_tags_next_ = (known_tags_next_ + 1) % known_tags_.size();
        const std::size_t tags = rec.data.size() - payload->bytes.size();
        known.bytes.assign(rec.data.begin(), rec.data.begin() + static_cast<std::ptrdiff_t>(tags));
        known.outbound = payload->outbound;
      }
    }
    const bool ours = ng_->written_by_drivetap() && !rec.drivetap_option.empty();
    if (!ours && !payload->outbound && payload->flow.empty())
      payload->outbound = pcapng::outbound_of_flags(rec.flags);
    if (ours) payload->outbound.reset();  // our channel names already say everything
    // Our interfaces are our channels, declared in channel order: numbered in that order too
    // (records of one instant go in channel order), not in the order their first packets come.
    const bool first_of_interface = rec.interface >= channel_cache_.size() ||
                                    cache_section_ != ng_->sections() ||
                                    channel_cache_[rec.interface][0] == kNoChannel;
    if (ours && payload->flow.empty() && first_of_interface)
      for (std::uint32_t earlier = 0; earlier < rec.interface; ++earlier)
        if (pcapng_channel(earlier, *payload) == kNoChannel) break;
    const ChannelId ch = pcapng_channel(rec.interface, *payload);
    if (ch == kNoChannel) {
      error_ = too_many_channels(rec.offset);
      return false;
    }
    hold(payload->bytes, rec.timestamp, ch);
    held_.option.clear();
    if (ours) held_.option.assign(rec.drivetap_option.begin(), rec.drivetap_option.end());
    return true;
  }
  if (!ng_->error().empty()) error_ = ng_->error();
  return false;
}

bool CaptureReader::load_pcap_packet() {
  const PcapLibrary& lib = pcap_library();  // (loaded: pcap_ was opened with it)
  struct pcap_pkthdr* header = nullptr;
  const u_char* data = nullptr;
  // Each pass consumes one packet, or returns.
  while (true) {
    std::FILE* file = lib.file(pcap_);
    const long before = file ? std::ftell(file) : -1;
    const int rc = lib.next_ex(pcap_, &header, &data);
    if (rc == PCAP_ERROR_BREAK) return false;  // end of file
    if (rc != 1) {
      error_ = before >= 0
                   ? fmt::format("{}: offset {}: packet {}: {}", name_, before, packets_ + 1,
                                 lib.geterr(pcap_))
                   : fmt::format("{}: packet {}: {}", name_, packets_ + 1, lib.geterr(pcap_));
      return false;
    }
    ++packets_;
    if (!link_type_supported(pcap_link_type_)) {
      error_ = fmt::format(
          "{}: link type {} is not one drivetap reads (147-162, 250, 252, or "
          "serial telegrams over UDP/TCP)",
          name_, pcap_link_type_);
      return false;
    }
    std::string why;
    bool fatal = false;
    auto payload = extract_serial_payload(
        pcap_link_type_, std::span<const std::uint8_t>(data, header->caplen), &why, &fatal);
    if (!payload) {
      skip(fatal ? fmt::format("malformed: {}", why) : why, packets_);
      continue;
    }
    // libpcap gives 32-bit seconds and nanoseconds: always inside kTimeLimit.
    const TimeNs ts = static_cast<TimeNs>(header->ts.tv_sec) * kNsPerSecond +
                      static_cast<TimeNs>(header->ts.tv_usec);  // ns precision requested
    if (payload->bytes.empty()) continue;
    const ChannelId ch = channel_for("bus", *payload);
    if (ch == kNoChannel) {
      error_ = too_many_channels(before);
      return false;
    }
    hold(payload->bytes, ts, ch);
    return true;
  }
}

bool CaptureReader::read_packet() {
  if (!error_.empty()) return false;
  return pcapng_ ? load_pcapng_packet() : load_pcap_packet();
}

void CaptureReader::hold(std::span<const std::uint8_t> bytes, TimeNs timestamp, ChannelId channel) {
  held_.bytes.assign(bytes.begin(), bytes.end());
  held_.timestamp = timestamp;
  held_.channel = channel;
  held_.option.clear();
  held_.origin = static_cast<std::uint32_t>(packets_);
}

bool CaptureReader::read_header() {
  if (!error_.empty()) return false;
  pending_packet_ = read_packet();
  return error_.empty();
}

bool CaptureReader::hold_next() {
  // Each pass lays out one packet (its bytes are placed only now, once the character time that
  // spaces them is known), or returns.
  while (layout_.index >= layout_.count) {
    if (pending_packet_) {
      pending_packet_ = false;
    } else if (!read_packet()) {
      return false;
    }
    lay_out();
  }
  return true;
}

bool CaptureReader::next(ByteEvent& out) {
  if (!hold_next()) return false;
  const std::size_t i = layout_.index++;
  if (layout_.even) {
    out = even_event(i);
  } else if (layout_.exact) {
    if (i - layout_.chunk_start >= decoded_.size()) decode_chunk(i);
    const Decoded& d = decoded_[i - layout_.chunk_start];
    // The byte keeps the packet number of the capture it was first read from.
    out = {d.time, held_.bytes[i], d.flags, held_.channel, d.source_packet};
  } else {
    const TimeNs n = static_cast<TimeNs>(layout_.count);
    out = {held_.timestamp - (n - static_cast<TimeNs>(i)) * character_time_, held_.bytes[i], 0,
           held_.channel, held_.origin};
  }
  return true;
}

bool CaptureReader::next_batch(std::vector<ByteEvent>& out) {
  out.clear();
  ByteEvent e;
  if (!next(e)) return false;  // lays the next packet out when the held one is used up
  out.push_back(e);
  const std::size_t end = std::min(layout_.count, layout_.index + (kBatch - 1));
  if (layout_.even) {  // nearly every packet drivetap wrote: no per-byte decision
    for (std::size_t i = layout_.index; i < end; ++i) out.push_back(even_event(i));
    layout_.index = end;
    return true;
  }
  // Each pass takes one byte of the held packet.
  while (layout_.index < end && next(e)) out.push_back(e);
  return true;
}

inline const CaptureReader::KnownTags* CaptureReader::known_tags_of(
    std::span<const std::uint8_t> data) {
  // At most one entry can match: a tag block ends at its first end-of-options tag, so of two that
  // both began `data` one would end inside the other. The entry that matched the packet before
  // the last is tried first: requests and replies alternate.
  const auto matches = [&](const KnownTags& k) {
    const std::size_t tags = k.bytes.size();
    return tags != 0 && data.size() >= tags && std::memcmp(k.bytes.data(), data.data(), tags) == 0;
  };
  std::size_t match = matched_tags_[0];
  if (!matches(known_tags_[match])) {
    match = 0;
    while (match < known_tags_.size() && !matches(known_tags_[match])) ++match;
    if (match == known_tags_.size()) return nullptr;
  }
  matched_tags_[0] = matched_tags_[1];
  matched_tags_[1] = match;
  return &known_tags_[match];
}

std::size_t CaptureReader::append_plain_packets(RunBatch& out) {
  // Before the first packet the settings are not known; while a drivetap capture's are not, each
  // packet reads them again (load_pcapng_packet()).
  if (!ng_ || packets_ == 0 || (ng_->written_by_drivetap() && !settings_.serial) ||
      cache_section_ != ng_->sections())
    return 0;
  const std::size_t bytes_before = out.byte_count();
  std::size_t taken = 0;
  pcapng::PlainPacket packet;
  // Each pass takes one packet, or stops.
  while (out.byte_count() - bytes_before < kPlainBytes && ng_->peek_plain(packet)) {
    const pcapng::Interface& itf = ng_->interfaces()[packet.interface];
    if (itf.link_type != kLinkTypeUpperPdu || packet.interface >= channel_cache_.size()) break;
    // The tags of one of the last blocks, byte for byte.
    const KnownTags* known = known_tags_of(packet.data);
    if (!known) break;
    // The direction the tags give, else the one the flags give (as load_pcapng_packet()).
    const std::optional<bool> outbound =
        known->outbound ? known->outbound : pcapng::outbound_of_flags(packet.flags);
    const int direction = direction_slot(outbound);
    const ChannelId channel = channel_cache_[packet.interface][direction];
    if (channel == kNoChannel) break;
    const std::span<const std::uint8_t> bytes = packet.data.subspan(known->bytes.size());
    const TimeNs n = static_cast<TimeNs>(bytes.size());
    // Larger packets are cut into kBatch pieces, and a first byte out of range is skipped with a
    // note: both the usual way. (Bounded times and < 2^24 bytes: no overflow, as in lay_out().)
    if (bytes.size() > kBatch || !time_in_range(packet.timestamp - n * character_time_)) break;
    ng_->take_peeked();
    ++packets_;
    ++taken;
    out.add({bytes,
             packet.timestamp - n * character_time_,
             character_time_,
             channel,
             static_cast<std::uint32_t>(packets_),
             {}});
    // From a pipe, a packet as it arrives: the next may be a while coming (a live capture).
    if (!ng_->regular_file()) break;
  }
  return taken;
}

bool CaptureReader::append_runs(RunBatch& out) {
  // Once the held packet is used up, the packets that follow the plain way go in bulk.
  if (pcapng_ && !pending_packet_ && layout_.index >= layout_.count && error_.empty() &&
      append_plain_packets(out) > 0)
    return true;
  if (!hold_next()) return false;
  const std::size_t from = layout_.index;
  const std::size_t end = std::min(layout_.count, from + kBatch);
  const std::span<const std::uint8_t> bytes =
      std::span<const std::uint8_t>(held_.bytes).subspan(from, end - from);
  if (layout_.even) {  // nearly every packet drivetap wrote
    out.add({bytes,
             layout_.time + static_cast<TimeNs>(from) * layout_.step,
             layout_.step,
             held_.channel,
             static_cast<std::uint32_t>(layout_.source_packet),
             {}});
    layout_.index = end;
  } else if (!layout_.exact) {  // another tool's packet: back to back, ending at its timestamp
    const TimeNs n = static_cast<TimeNs>(layout_.count);
    out.add({bytes,
             held_.timestamp - (n - static_cast<TimeNs>(from)) * character_time_,
             character_time_,
             held_.channel,
             held_.origin,
             {}});
    layout_.index = end;
  } else {  // per-byte times: the events grouped into runs
    exact_events_.clear();
    ByteEvent e;
    while (layout_.index < end && next(e)) exact_events_.push_back(e);
    out.add_events(exact_events_);
  }
  return true;
}

}  // namespace drivetap
