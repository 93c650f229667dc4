// pcapng reader and writer, hand-written (pcapng spec, draft-ietf-opsawg-pcapng; see docs/design.md
// "Decisions worth knowing"). Only the blocks drivetap needs are interpreted: SHB, IDB, EPB, SPB;
// others are skipped by their length.
//
//   block:  +------------+--------------+---------------- ... ----+--------------+
//           | type (4)   | total len (4)| body (padded to 4)       | total len (4)|
//           +------------+--------------+---------------- ... ----+--------------+
//   option: | code (2) | length (2) | value (padded to 4) |   ...   | 0 | 0 |
//
// drivetap's own data rides in custom options (code 2988 string / 2989 binary) under Private
// Enterprise Number 32473 (RFC 5612's documentation number), written in the section's byte
// order as the spec requires:
//   IDB, 2988: "drivetap t15=<ns> t35=<ns> timeout=<ns> max_hold=<ns>"  (settings of the run)
//   EPB, 2989: "DT" version(1)=1 kind(1: 0 telegram, 1 noise) count(varint)
//              then per byte: time delta (zigzag varint, ns from the previous byte's start;
//              the first from the packet timestamp), UART flags (1 byte), and source packet
//              delta (zigzag varint from the previous byte's; the first from 0): the packet of
//              the original capture the byte came from, 0 when it had none
//         or:  "DT" version(1)=2 kind(1) count(varint) step(varint, ns) source packet(varint)
//              when the bytes are evenly spaced (byte i starts at timestamp + i * step, nearly
//              always back to back at the character time), carry no UART flags and share one
//              source packet: 5 to 12 bytes instead of 3 or more per byte
#pragma once

#include <cstdint>
#include <cstdio>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "core/time.hpp"

namespace drivetap::pcapng {

inline constexpr std::uint32_t kSectionHeader = 0x0A0D0D0A;
inline constexpr std::uint32_t kInterfaceDescription = 1;
inline constexpr std::uint32_t kSimplePacket = 3;
inline constexpr std::uint32_t kEnhancedPacket = 6;
inline constexpr std::uint32_t kByteOrderMagic = 0x1A2B3C4D;

inline constexpr std::uint16_t kOptEnd = 0;
inline constexpr std::uint16_t kOptComment = 1;
inline constexpr std::uint16_t kOptShbUserApplication = 4;
inline constexpr std::uint16_t kOptIfName = 2;
inline constexpr std::uint16_t kOptIfDescription = 3;
inline constexpr std::uint16_t kOptIfTsResolution = 9;
inline constexpr std::uint16_t kOptIfTsOffset = 14;
inline constexpr std::uint16_t kOptEpbFlags = 2;
inline constexpr std::uint16_t kOptCustomString = 2988;
inline constexpr std::uint16_t kOptCustomBinary = 2989;
inline constexpr std::uint32_t kDrivetapPen = 32473;

// EPB flags: bits 0-1 direction (1 inbound, 2 outbound); bit 24 CRC error.
inline constexpr std::uint32_t kFlagInbound = 1;
inline constexpr std::uint32_t kFlagOutbound = 2;
// The direction EPB flags give: outbound, inbound, or none (bits 0-1 zero, or no flags).
inline std::optional<bool> outbound_of_flags(std::optional<std::uint32_t> flags) {
  if (!flags || (*flags & 3) == 0) return std::nullopt;
  return (*flags & 3) == kFlagOutbound;
}
inline constexpr std::uint32_t kFlagCrcError = 1u << 24;

// Largest block accepted when reading: bounds memory on hostile files.
inline constexpr std::uint32_t kMaxBlockLength = 16u << 20;
// Most interfaces one section may describe: each is kept until the section ends (a hostile file
// of nothing but interface blocks would otherwise grow memory with its size).
inline constexpr std::size_t kMaxInterfaces = 65536;

class Writer {
 public:
  explicit Writer(std::FILE* out) : out_(out) {}
  void section_header(std::string_view application);
  void interface(std::uint16_t link_type, std::string_view name, std::string_view description,
                 std::string_view drivetap_settings);
  struct Packet {
    std::uint32_t interface = 0;
    TimeNs timestamp = 0;
    std::span<const std::uint8_t> data;
    std::uint32_t flags = 0;
    std::string_view comment;
    std::span<const std::uint8_t> drivetap_option;  // EPB custom option payload (after the PEN)
  };
  void packet(const Packet& p);
  [[nodiscard]] bool ok() const { return ok_; }

 private:
  void begin_block(std::uint32_t type);
  void end_block();  // writes block_
  std::FILE* out_;
  bool ok_ = true;
  std::vector<std::uint8_t> block_;  // the block being built
};

struct Interface {
  std::uint16_t link_type = 0;
  std::string name;
  std::string description;
  std::string drivetap_settings;  // from our custom IDB option, empty otherwise
  // Timestamp units: value * num / den nanoseconds (if_tsresol), plus offset seconds.
  std::uint64_t ts_num = 1000;
  std::uint64_t ts_den = 1;
  std::int64_t ts_offset_s = 0;
};

// A packet as read: `data` and `drivetap_option` view the reader's buffer and stay valid until
// its next call of next() (copy what must outlive it).
struct PacketRecord {
  std::uint32_t interface = 0;
  TimeNs timestamp = 0;
  bool has_timestamp = false;  // false for simple packet blocks
  std::span<const std::uint8_t> data;
  std::optional<std::uint32_t> flags;
  std::string comment;
  std::span<const std::uint8_t> drivetap_option;  // our EPB custom option payload, after the PEN
  std::uint64_t offset = 0;                       // file offset of the block
};

// An enhanced packet block with no options but its flags (PacketRecord with no comment or
// drivetap option): what Reader::peek_plain() gives. `data` views the reader's window until its
// next call.
struct PlainPacket {
  std::uint32_t interface = 0;
  TimeNs timestamp = 0;
  std::span<const std::uint8_t> data;
  std::optional<std::uint32_t> flags;  // the EPB flags option's value
};

// Blocks are read into a window of the file and parsed where they lie: from a regular file in
// reads of whole read blocks (core/read_block.hpp) into a kReadChunk window, from a pipe exactly
// the bytes each block needs (a capture streamed through a pipe is decoded as it arrives).
class Reader {
 public:
  Reader(std::FILE* in, std::string name);
  // Packet comments are copied into PacketRecord::comment unless turned off (a reader that
  // does not use them saves a copy per packet: drivetap's comments hold the annotation).
  void keep_comments(bool keep) { keep_comments_ = keep; }
  // Next packet block; false at a clean end of file or on error (error() non-empty).
  bool next(PacketRecord& out);
  // The next block, when it is a well-formed enhanced packet block without options or with its
  // flags alone (what other capture tools write for every packet, the flags giving the
  // direction): parsed as next() would parse it, but not consumed
  // until take_peeked(). False for anything else, with nothing consumed and nothing reported:
  // next() then reads that block, with its findings. (The fast lane of a reader that takes most
  // packets without a PacketRecord.)
  bool peek_plain(PlainPacket& out);
  // A regular file, read in large chunks (false: a pipe or terminal, read block by block as the
  // capture arrives).
  [[nodiscard]] bool regular_file() const { return whole_reads_; }
  // Consumes the block peek_plain() gave (call before the next peek or read).
  void take_peeked() {
    pos_ += peeked_;
    offset_ += peeked_;
    peeked_ = 0;
  }
  [[nodiscard]] const std::string& error() const { return error_; }
  [[nodiscard]] const std::vector<Interface>& interfaces() const { return interfaces_; }
  [[nodiscard]] bool written_by_drivetap() const { return by_drivetap_; }
  [[nodiscard]] std::uint64_t offset() const { return offset_; }
  // Section headers read so far: interface numbers restart with each section.
  [[nodiscard]] std::uint64_t sections() const { return sections_; }

 private:
  bool fail(std::uint64_t at, const std::string& what);
  // Makes `need` bytes from the read position available in the window, reading more of the file;
  // returns how many are (fewer at the end of the file).
  std::size_t fill(std::size_t need);
  std::uint16_t u16(const std::uint8_t* p) const;
  std::uint32_t u32(const std::uint8_t* p) const;
  std::uint64_t u64(const std::uint8_t* p) const;
  // Calls fn(code, value) for each option from `pos`; an error text, or empty. (A template,
  // defined and used only in pcapng.cpp: the per-option call is inlined on every packet.)
  template <class OptionFn>
  std::string walk_options(std::span<const std::uint8_t> body, std::size_t pos,
                           OptionFn&& fn) const;
  std::optional<std::span<const std::uint8_t>> drivetap_payload(
      std::span<const std::uint8_t> value) const;
  bool parse_section(std::span<const std::uint8_t> body, std::uint64_t at);
  bool parse_interface(std::span<const std::uint8_t> body, std::uint64_t at);
  bool parse_enhanced(std::span<const std::uint8_t> body, std::uint64_t at, PacketRecord& out);
  bool parse_simple(std::span<const std::uint8_t> body, std::uint64_t at, PacketRecord& out);

  std::FILE* in_;
  std::string name_;
  std::string error_;
  std::uint64_t offset_ = 0;
  bool big_endian_ = false;
  bool in_section_ = false;
  bool by_drivetap_ = false;
  std::uint64_t sections_ = 0;
  bool keep_comments_ = true;
  std::vector<Interface> interfaces_;
  static constexpr std::size_t kReadChunk = 256 * 1024;
  bool whole_reads_ = false;          // a regular file: read up to a window at a time
  std::vector<std::uint8_t> window_;  // file bytes [offset_ - pos_, offset_ - pos_ + end_)
  std::size_t pos_ = 0;               // the next unread byte of window_ (file offset offset_)
  std::size_t end_ = 0;
  bool at_end_ = false;     // a read returned nothing: the end of the file (or a read error)
  std::size_t peeked_ = 0;  // the length of the block peek_plain() gave
};

// Varint helpers for the drivetap EPB option.
void put_varint(std::vector<std::uint8_t>& out, std::uint64_t v);
// Inline: the reader decodes three per byte of every packet drivetap wrote.
inline std::optional<std::uint64_t> get_varint(std::span<const std::uint8_t> data,
                                               std::size_t* pos) {
  std::uint64_t v = 0;
  for (int shift = 0; shift < 64; shift += 7) {
    if (*pos >= data.size()) return std::nullopt;
    const std::uint8_t b = data[(*pos)++];
    v |= static_cast<std::uint64_t>(b & 0x7F) << shift;
    if (!(b & 0x80)) return v;
  }
  return std::nullopt;
}
inline std::uint64_t zigzag(std::int64_t v) {
  return (static_cast<std::uint64_t>(v) << 1) ^ static_cast<std::uint64_t>(v >> 63);
}
inline std::int64_t unzigzag(std::uint64_t v) {
  return static_cast<std::int64_t>(v >> 1) ^ -static_cast<std::int64_t>(v & 1);
}

}  // namespace drivetap::pcapng
