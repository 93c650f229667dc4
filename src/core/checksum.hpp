// Checksums of the drive protocols: CRC-16/MODBUS (docs/protocols.md §2) and the verdict type.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <string_view>

namespace drivetap {

// CRC-16/MODBUS: reflected polynomial 0xA001, init 0xFFFF, no final xor. On the wire the low
// byte is sent first. Check value: 01 03 00 00 00 01 -> 0x0A84 (wire bytes 84 0A).
std::uint16_t crc16_modbus(std::span<const std::uint8_t> data, std::uint16_t crc = 0xFFFF);
// One step of the same CRC, for incremental scans.
std::uint16_t crc16_modbus_update(std::uint16_t crc, std::uint8_t byte);

enum class ChecksumVerdict : std::uint8_t {
  none,  // the protocol or frame carries no checksum
  good,
  bad,      // stated != computed
  swapped,  // stated is the computed value with its bytes in the wrong order (high byte first)
};

struct ChecksumResult {
  ChecksumVerdict verdict = ChecksumVerdict::none;
  // Values in wire byte order packed big-endian (wire bytes "3A 44" -> 0x3A44), so that both
  // print exactly as an engineer compares them with the bytes on the line.
  std::uint32_t stated_wire = 0;
  std::uint32_t computed_wire = 0;
  std::uint8_t width = 0;         // bytes
  std::string_view name = "CRC";  // CRC, LRC, BCC, SUM: how the protocol calls it
  bool text = false;              // sent as hex characters (Easydrive SUM): shown as one number
};

// Compares the two CRC bytes at the end of a Modbus RTU frame with the CRC of what precedes them.
ChecksumResult check_rtu_crc(std::span<const std::uint8_t> frame);
// A Modbus RTU frame's CRC as its last two bytes are on the wire (low byte first), read as one
// number: ChecksumResult::stated_wire, and Wireshark's mbrtu.crc16. The frame has 2 bytes or more.
inline std::uint32_t rtu_crc_on_wire(std::span<const std::uint8_t> frame) {
  return (std::uint32_t{frame[frame.size() - 2]} << 8) | frame[frame.size() - 1];
}

// check_rtu_crc() with `crc`, crc16_modbus() of all but the last two bytes, computed already (by
// the framer: Frame::checksum), written member by member into `r` (a Message's): a result built on
// the stack and copied there is read back wider than it was written, and the copy stalls on
// store forwarding.
inline void check_rtu_crc_into(ChecksumResult& r, std::span<const std::uint8_t> frame,
                               std::uint16_t crc) {
  r.name = "CRC";
  r.text = false;
  if (frame.size() < 3) {
    r.verdict = ChecksumVerdict::none;
    r.stated_wire = 0;
    r.computed_wire = 0;
    r.width = 0;
    return;
  }
  r.width = 2;
  r.stated_wire = rtu_crc_on_wire(frame);
  r.computed_wire = static_cast<std::uint32_t>(((crc & 0xFFu) << 8) | (crc >> 8));
  if (r.stated_wire == r.computed_wire) {
    r.verdict = ChecksumVerdict::good;
  } else if (r.stated_wire == (((r.computed_wire & 0xFFu) << 8) | (r.computed_wire >> 8))) {
    r.verdict = ChecksumVerdict::swapped;
  } else {
    r.verdict = ChecksumVerdict::bad;
  }
}
// The same as a value.
inline ChecksumResult check_rtu_crc(std::span<const std::uint8_t> frame, std::uint16_t crc) {
  ChecksumResult r;
  check_rtu_crc_into(r, frame, crc);
  return r;
}

// Modbus ASCII LRC (docs/protocols.md §3): two's complement of the 8-bit sum of the binary bytes.
std::uint8_t lrc8(std::span<const std::uint8_t> data);

std::string_view to_string(ChecksumVerdict v);

// A checksum value in wire order as hex bytes: (0x3A44, 2, " ") -> "3A 44"; "3A44" with "".
std::string wire_hex(std::uint32_t packed, std::uint8_t width, std::string_view separator = " ");
// The same appended to `out` (std::string or LineBuffer).
template <class Out>
void append_wire_hex(Out& out, std::uint32_t packed, std::uint8_t width,
                     std::string_view separator = " ") {
  constexpr char kDigits[] = "0123456789ABCDEF";
  for (int i = width - 1; i >= 0; --i) {
    if (i != width - 1) out += separator;
    const unsigned byte = (packed >> (8 * i)) & 0xFF;
    const char pair[2] = {kDigits[byte >> 4], kDigits[byte & 0x0F]};
    out.append(pair, 2);
  }
}

}  // namespace drivetap
