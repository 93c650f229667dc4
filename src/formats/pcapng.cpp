// pcapng block reader and writer (pcapng spec; layout in pcapng.hpp; docs/design.md "Decisions
// worth knowing").
#include "formats/pcapng.hpp"

#include <fmt/format.h>

#include <sys/stat.h>

#include <algorithm>
#include <cstring>

#include "core/read_block.hpp"

namespace drivetap::pcapng {
namespace {

void le16(std::vector<std::uint8_t>& o, std::uint16_t v) {
  o.push_back(static_cast<std::uint8_t>(v));
  o.push_back(static_cast<std::uint8_t>(v >> 8));
}
void le32(std::vector<std::uint8_t>& o, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) o.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
}
void pad4(std::vector<std::uint8_t>& o) {
  while (o.size() % 4) o.push_back(0);
}
void option(std::vector<std::uint8_t>& o, std::uint16_t code, std::span<const std::uint8_t> value) {
  le16(o, code);
  le16(o, static_cast<std::uint16_t>(value.size()));
  o.insert(o.end(), value.begin(), value.end());
  pad4(o);
}
void option(std::vector<std::uint8_t>& o, std::uint16_t code, std::string_view s) {
  if (s.empty()) return;
  s = s.substr(0, 0xFFF0);
  option(o, code, std::span(reinterpret_cast<const std::uint8_t*>(s.data()), s.size()));
}
void custom_option(std::vector<std::uint8_t>& o, std::uint16_t code,
                   std::span<const std::uint8_t> payload) {
  const std::size_t length = 4 + payload.size();  // the PEN, then the payload
  if (length > 0xFFF0) return;  // cannot be represented; never happens for <= 256-byte frames
  le16(o, code);
  le16(o, static_cast<std::uint16_t>(length));
  le32(o, kDrivetapPen);
  o.insert(o.end(), payload.begin(), payload.end());
  pad4(o);
}

}  // namespace

void put_varint(std::vector<std::uint8_t>& out, std::uint64_t v) {
  while (v >= 0x80) {
    out.push_back(static_cast<std::uint8_t>(v | 0x80));
    v >>= 7;
  }
  out.push_back(static_cast<std::uint8_t>(v));
}

// ---- writer ----

// A block is built whole in block_ (its storage reused from block to block): the type, the
// total length (patched in by end_block), the body, the total length again.
void Writer::begin_block(std::uint32_t type) {
  block_.clear();
  le32(block_, type);
  le32(block_, 0);
}

void Writer::end_block() {
  const auto total = static_cast<std::uint32_t>(block_.size() + 4);
  for (int i = 0; i < 4; ++i) block_[4 + i] = static_cast<std::uint8_t>(total >> (8 * i));
  le32(block_, total);
  if (std::fwrite(block_.data(), 1, block_.size(), out_) != block_.size()) ok_ = false;
}

void Writer::section_header(std::string_view application) {
  begin_block(kSectionHeader);
  std::vector<std::uint8_t>& body = block_;
  le32(body, kByteOrderMagic);
  le16(body, 1);
  le16(body, 0);
  le32(body, 0xFFFFFFFF);  // section length unknown (streamed)
  le32(body, 0xFFFFFFFF);
  option(body, kOptShbUserApplication, application);
  le32(body, 0);  // opt_endofopt
  end_block();
}

void Writer::interface(std::uint16_t link_type, std::string_view name, std::string_view description,
                       std::string_view drivetap_settings) {
  begin_block(kInterfaceDescription);
  std::vector<std::uint8_t>& body = block_;
  le16(body, link_type);
  le16(body, 0);
  le32(body, 0);  // snaplen: no limit
  option(body, kOptIfName, name);
  option(body, kOptIfDescription, description);
  const std::uint8_t nanoseconds = 9;
  option(body, kOptIfTsResolution, std::span(&nanoseconds, 1));
  if (!drivetap_settings.empty())
    custom_option(body, kOptCustomString,
                  std::span(reinterpret_cast<const std::uint8_t*>(drivetap_settings.data()),
                            drivetap_settings.size()));
  le32(body, 0);
  end_block();
}

void Writer::packet(const Packet& p) {
  begin_block(kEnhancedPacket);
  std::vector<std::uint8_t>& body = block_;
  le32(body, p.interface);
  const auto ts = static_cast<std::uint64_t>(p.timestamp);
  le32(body, static_cast<std::uint32_t>(ts >> 32));
  le32(body, static_cast<std::uint32_t>(ts));
  le32(body, static_cast<std::uint32_t>(p.data.size()));
  le32(body, static_cast<std::uint32_t>(p.data.size()));
  body.insert(body.end(), p.data.begin(), p.data.end());
  pad4(body);
  option(body, kOptComment, p.comment);
  if (p.flags != 0) {
    le16(body, kOptEpbFlags);
    le16(body, 4);
    le32(body, p.flags);
  }
  if (!p.drivetap_option.empty()) custom_option(body, kOptCustomBinary, p.drivetap_option);
  le32(body, 0);
  end_block();
}

// ---- reader ----

bool Reader::fail(std::uint64_t at, const std::string& what) {
  error_ = fmt::format("{}: offset {}: {}", name_, at, what);
  return false;
}

Reader::Reader(std::FILE* in, std::string name) : in_(in), name_(std::move(name)) {
  struct stat st {};
  whole_reads_ = in_ && ::fstat(::fileno(in_), &st) == 0 && S_ISREG(st.st_mode);
}

std::size_t Reader::fill(std::size_t need) {
  if (end_ - pos_ >= need) return end_ - pos_;
  // The unread bytes move to the front, the window grows to hold `need`, and reads append.
  if (pos_ > 0) {
    std::memmove(window_.data(), window_.data() + pos_, end_ - pos_);
    end_ -= pos_;
    pos_ = 0;
  }
  if (window_.size() < need) window_.resize(whole_reads_ ? std::max(need, kReadChunk) : need);
  if (whole_reads_ && window_.size() < kReadChunk) window_.resize(kReadChunk);
  // Each pass reads at least one byte or marks the end.
  while (end_ < need && !at_end_) {
    std::size_t want = whole_reads_ ? window_.size() - end_ : need - end_;
    // Whole read blocks where they are enough: read straight into the window (read_block.hpp).
    const std::size_t whole_blocks = want - want % kReadBlockBytes;
    if (whole_reads_ && whole_blocks >= need - end_) want = whole_blocks;
    const std::size_t got = std::fread(window_.data() + end_, 1, want, in_);
    end_ += got;
    if (got == 0) at_end_ = true;
  }
  return end_;
}

std::uint16_t Reader::u16(const std::uint8_t* p) const {
  return big_endian_ ? static_cast<std::uint16_t>((p[0] << 8) | p[1])
                     : static_cast<std::uint16_t>(p[0] | (p[1] << 8));
}
std::uint32_t Reader::u32(const std::uint8_t* p) const {
  return big_endian_ ? (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) |
                           (std::uint32_t{p[2]} << 8) | p[3]
                     : (std::uint32_t{p[3]} << 24) | (std::uint32_t{p[2]} << 16) |
                           (std::uint32_t{p[1]} << 8) | p[0];
}
std::uint64_t Reader::u64(const std::uint8_t* p) const {
  return big_endian_ ? (std::uint64_t{u32(p)} << 32) | u32(p + 4)
                     : (std::uint64_t{u32(p + 4)} << 32) | u32(p);
}

template <class OptionFn>
std::string Reader::walk_options(std::span<const std::uint8_t> body, std::size_t pos,
                                 OptionFn&& fn) const {
  // Each pass consumes the 4-byte option header plus the padded value, or returns.
  while (pos + 4 <= body.size()) {
    const std::uint16_t code = u16(&body[pos]);
    const std::uint16_t len = u16(&body[pos + 2]);
    pos += 4;
    if (code == kOptEnd) return {};
    if (pos + len > body.size())
      return fmt::format("option {} claims {} bytes, {} left in the block", code, len,
                         body.size() - pos);
    fn(code, std::span<const std::uint8_t>(body.data() + pos, len));
    const std::size_t padded = (std::size_t{len} + 3) & ~std::size_t{3};
    pos += std::min(padded, body.size() - pos);
  }
  return {};
}

std::optional<std::span<const std::uint8_t>> Reader::drivetap_payload(
    std::span<const std::uint8_t> value) const {
  if (value.size() < 4 || u32(value.data()) != kDrivetapPen) return std::nullopt;
  return value.subspan(4);
}

bool Reader::parse_section(std::span<const std::uint8_t> body, std::uint64_t at) {
  // body: magic(4) major(2) minor(2) section length(8) options
  if (body.size() < 16) return fail(at, "section header block too short");
  const std::uint32_t magic_le = std::uint32_t{body[0]} | (std::uint32_t{body[1]} << 8) |
                                 (std::uint32_t{body[2]} << 16) | (std::uint32_t{body[3]} << 24);
  if (magic_le == kByteOrderMagic) {
    big_endian_ = false;
  } else if (magic_le == 0x4D3C2B1A) {
    big_endian_ = true;
  } else {
    return fail(at + 8, fmt::format("bad byte-order magic 0x{:08X}", magic_le));
  }
  if (u16(&body[4]) != 1)
    return fail(at + 12,
                fmt::format("unsupported pcapng version {}.{}", u16(&body[4]), u16(&body[6])));
  interfaces_.clear();
  ++sections_;
  in_section_ = true;
  by_drivetap_ = false;
  const std::string err = walk_options(body, 16, [&](std::uint16_t code, auto value) {
    if (code == kOptShbUserApplication) {
      const std::string app(value.begin(), value.end());
      by_drivetap_ = app.rfind("drivetap", 0) == 0;
    }
  });
  if (!err.empty()) return fail(at, "section header: " + err);
  return true;
}

bool Reader::parse_interface(std::span<const std::uint8_t> body, std::uint64_t at) {
  if (body.size() < 8) return fail(at, "interface description block too short");
  Interface itf;
  itf.link_type = u16(&body[0]);
  std::string bad_resolution;
  const std::string err = walk_options(body, 8, [&](std::uint16_t code, auto value) {
    switch (code) {
      case kOptIfName:
        itf.name.assign(value.begin(), value.end());
        break;
      case kOptIfDescription:
        itf.description.assign(value.begin(), value.end());
        break;
      case kOptIfTsResolution: {
        if (value.empty()) break;
        const std::uint8_t r = value[0];
        const unsigned exponent = r & 0x7F;
        if (r & 0x80) {
          if (exponent > 62) {
            bad_resolution = fmt::format("2^-{}", exponent);
            break;
          }
          itf.ts_num = 1'000'000'000;
          itf.ts_den = std::uint64_t{1} << exponent;
        } else {
          if (exponent > 18) {
            bad_resolution = fmt::format("10^-{}", exponent);
            break;
          }
          std::uint64_t p = 1;
          for (unsigned i = 0; i < exponent; ++i) p *= 10;
          itf.ts_num = exponent <= 9 ? 1'000'000'000 / p : 1;
          itf.ts_den = exponent <= 9 ? 1 : p / 1'000'000'000;
        }
        break;
      }
      case kOptIfTsOffset:
        if (value.size() >= 8) itf.ts_offset_s = static_cast<std::int64_t>(u64(value.data()));
        break;
      case kOptCustomString:
        if (auto payload = drivetap_payload(value))
          itf.drivetap_settings.assign(payload->begin(), payload->end());
        break;
      default:
        break;
    }
  });
  if (!err.empty()) return fail(at, "interface description: " + err);
  if (!bad_resolution.empty())
    return fail(at, "unsupported timestamp resolution " + bad_resolution);
  if (interfaces_.size() >= kMaxInterfaces)
    return fail(at, fmt::format("more than {} interfaces in one section", kMaxInterfaces));
  interfaces_.push_back(std::move(itf));
  return true;
}

namespace {
// value * num / den without overflow for the ranges pcapng allows (128-bit intermediate).
TimeNs scale_time(std::uint64_t value, const Interface& itf, bool* overflow) {
  if (itf.ts_den == 1 && itf.ts_offset_s == 0) {
    // Nanoseconds or coarser with no offset (nearly every file): no 128-bit division. A product
    // past 64 bits is past kTimeLimit too.
    std::uint64_t ns = 0;
    if (__builtin_mul_overflow(value, itf.ts_num, &ns) ||
        ns >= static_cast<std::uint64_t>(kTimeLimit)) {
      *overflow = true;
      return 0;
    }
    return static_cast<TimeNs>(ns);
  }
  const unsigned __int128 ns = static_cast<unsigned __int128>(value) * itf.ts_num / itf.ts_den;
  const __int128 total =
      static_cast<__int128>(ns) + static_cast<__int128>(itf.ts_offset_s) * 1'000'000'000;
  if (total >= kTimeLimit || total <= -kTimeLimit) {
    *overflow = true;
    return 0;
  }
  return static_cast<TimeNs>(total);
}
}  // namespace

namespace {
// Empties a record for the next packet, keeping its buffers' capacity: a reader reusing one
// record allocates nothing per packet.
void reset(PacketRecord& out, std::uint64_t at) {
  out.interface = 0;
  out.timestamp = 0;
  out.has_timestamp = false;
  out.data = {};
  out.flags.reset();
  out.comment.clear();
  out.drivetap_option = {};
  out.offset = at;
}
}  // namespace

bool Reader::parse_enhanced(std::span<const std::uint8_t> body, std::uint64_t at,
                            PacketRecord& out) {
  // body: interface(4) ts high(4) ts low(4) captured(4) original(4) data options
  if (body.size() < 20) return fail(at, "enhanced packet block too short");
  reset(out, at);
  out.interface = u32(&body[0]);
  if (out.interface >= interfaces_.size())
    return fail(at + 8, fmt::format("packet names interface {}, but only {} described",
                                    out.interface, interfaces_.size()));
  const std::uint64_t ts = (std::uint64_t{u32(&body[4])} << 32) | u32(&body[8]);
  const std::uint32_t captured = u32(&body[12]);
  if (captured > body.size() - 20)
    return fail(at + 20, fmt::format("captured length {} exceeds the block ({} bytes left)",
                                     captured, body.size() - 20));
  bool overflow = false;
  out.timestamp = scale_time(ts, interfaces_[out.interface], &overflow);
  if (overflow) return fail(at + 12, "timestamp out of range");
  out.has_timestamp = true;
  out.data = body.subspan(20, captured);
  const std::size_t options_at = 20 + ((std::size_t{captured} + 3) & ~std::size_t{3});
  if (options_at >= body.size()) return true;
  const std::string err = walk_options(body, options_at, [&](std::uint16_t code, auto value) {
    switch (code) {
      case kOptComment:
        if (keep_comments_) out.comment.assign(value.begin(), value.end());
        break;
      case kOptEpbFlags:
        if (value.size() >= 4) out.flags = u32(value.data());
        break;
      case kOptCustomBinary:
        if (auto payload = drivetap_payload(value)) out.drivetap_option = *payload;
        break;
      default:
        break;
    }
  });
  if (!err.empty()) return fail(at, "enhanced packet: " + err);
  return true;
}

namespace {
// Little-endian loads (peek_plain() takes little-endian sections only: nearly every writer's).
std::uint32_t le32(const std::uint8_t* p) {
  return std::uint32_t{p[0]} | (std::uint32_t{p[1]} << 8) | (std::uint32_t{p[2]} << 16) |
         (std::uint32_t{p[3]} << 24);
}
}  // namespace

bool Reader::peek_plain(PlainPacket& out) {
  // The checks of next() and parse_enhanced() in the same order, each failure leaving the block to
  // next(), which reports it.
  if (!error_.empty() || !in_section_ || big_endian_) return false;
  if (end_ - pos_ < 8 && fill(8) < 8) return false;
  if (le32(window_.data() + pos_) != kEnhancedPacket) return false;
  const std::uint32_t total = le32(window_.data() + pos_ + 4);
  if (total < 32 || total % 4 != 0 || total > kMaxBlockLength) return false;
  if (end_ - pos_ < total && fill(total) < total) return false;
  const std::uint8_t* block = window_.data() + pos_;  // (fill() may have moved the window)
  if (le32(block + total - 4) != total) return false;
  const std::uint8_t* body = block + 8;
  const std::size_t body_size = total - 12;
  const std::uint32_t interface = le32(body);
  if (interface >= interfaces_.size()) return false;
  const std::uint32_t captured = le32(body + 12);
  if (captured > body_size - 20) return false;
  // No options but the flags: none at all, or the end-of-options first, or one 4-byte flags
  // option before either (walk_options() reads no further than an end-of-options or the
  // block's end).
  std::size_t options_at = 20 + ((std::size_t{captured} + 3) & ~std::size_t{3});
  const auto option_code = [&](std::size_t at) { return body[at] | (body[at + 1] << 8); };
  std::optional<std::uint32_t> flags;
  if (options_at + 4 <= body_size && option_code(options_at) == kOptEpbFlags) {
    if (option_code(options_at + 2) != 4 || options_at + 8 > body_size) return false;
    flags = le32(body + options_at + 4);
    options_at += 8;
  }
  if (options_at + 4 <= body_size && option_code(options_at) != kOptEnd) return false;
  const Interface& itf = interfaces_[interface];
  const std::uint64_t ts = (std::uint64_t{le32(body + 4)} << 32) | le32(body + 8);
  bool overflow = false;
  out.timestamp = scale_time(ts, itf, &overflow);
  if (overflow) return false;
  out.interface = interface;
  out.data = std::span<const std::uint8_t>(body + 20, captured);
  out.flags = flags;
  peeked_ = total;
  return true;
}

bool Reader::parse_simple(std::span<const std::uint8_t> body, std::uint64_t at, PacketRecord& out) {
  if (body.size() < 4) return fail(at, "simple packet block too short");
  if (interfaces_.empty()) return fail(at, "simple packet before any interface description");
  reset(out, at);
  const std::uint32_t original = u32(&body[0]);
  const std::size_t n = std::min<std::size_t>(original, body.size() - 4);
  out.data = body.subspan(4, n);
  return true;
}

bool Reader::next(PacketRecord& out) {
  // Each pass consumes one whole block, or returns.
  while (error_.empty()) {
    const std::uint64_t at = offset_;
    // The header, and a section header's byte-order magic (a section's byte order is only known
    // from it).
    std::size_t have = fill(12);
    if (have == 0) {
      if (std::ferror(in_)) return fail(at, std::string("read error: ") + std::strerror(errno));
      if (!in_section_) return fail(at, "empty file: no pcapng section header");
      return false;
    }
    if (have < 8) return fail(at, fmt::format("truncated block header ({} of 8 bytes)", have));
    const std::uint8_t* header = window_.data() + pos_;
    const std::uint32_t type = u32(header);
    if (type == kSectionHeader) {
      if (have < 12) return fail(at + 8, "truncated section header");
      big_endian_ = header[8] == 0x1A;
    } else if (!in_section_) {
      return fail(at, fmt::format("not a pcapng file: first block type 0x{:08X}", type));
    }
    const std::uint32_t total = u32(header + 4);
    if (total < 12 || total % 4 != 0)
      return fail(at + 4, fmt::format("block length {} is not a multiple of 4 >= 12", total));
    if (total > kMaxBlockLength)
      return fail(at + 4,
                  fmt::format("block length {} exceeds the {}-byte limit", total, kMaxBlockLength));
    if (type == kSectionHeader && total < 16) return fail(at + 4, "section header block too short");
    have = fill(total);
    if (have < total)
      return fail(at, fmt::format("truncated block: {} bytes announced, file ends at offset {}",
                                  total, at + have));
    const std::uint8_t* block = window_.data() + pos_;
    pos_ += total;
    offset_ += total;
    if (u32(block + total - 4) != total)
      return fail(offset_ - 4, fmt::format("trailing block length {} differs from leading {}",
                                           u32(block + total - 4), total));
    const std::span<const std::uint8_t> body(block + 8, total - 12);
    switch (type) {
      case kSectionHeader:
        if (!parse_section(body, at)) return false;
        break;
      case kInterfaceDescription:
        if (!parse_interface(body, at)) return false;
        break;
      case kEnhancedPacket:
        return parse_enhanced(body, at, out);
      case kSimplePacket:
        return parse_simple(body, at, out);
      default:
        break;  // other blocks carry nothing drivetap uses
    }
  }
  return false;
}

}  // namespace drivetap::pcapng
