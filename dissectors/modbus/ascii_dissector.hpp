// Modbus ASCII dissector and decoder (docs/protocols.md §3; 004 "ASCII mode"). The PDU layer is the
// one RTU uses (modbus_pdu.hpp): the two differ only in framing and checksum.
//
//   +-----+---------+-------+-------------+---------+----+----+
//   | ':' | ADDR(2) | FC(2) | DATA (2n)   | LRC(2)  | CR | LF |     two hex characters a byte
//   +-----+---------+-------+-------------+---------+----+----+
//   LRC = two's complement of the 8-bit sum of ADDR..DATA.  Example: :010325230001B3\r\n
#pragma once

#include <span>
#include <string>
#include <vector>

#include "core/message.hpp"
#include "core/protocol.hpp"
#include "dissectors/common/decoder_of.hpp"
#include "dissectors/common/finding.hpp"
#include "dissectors/common/plausibility.hpp"
#include "dissectors/modbus/modbus_protocol.hpp"

namespace drivetap::modbus {

// The binary bytes a Modbus ASCII frame spells (ADDR..LRC), and what was wrong with its text.
struct AsciiHex {
  std::vector<std::uint8_t> binary;
  std::vector<FoundProblem> problems;
  bool lower_case = false;
  bool terminated = false;  // ended with CR LF
};
AsciiHex decode_ascii_hex(std::span<const std::uint8_t> frame);
// The same into `binary` (its storage reused), with what was wrong with the text in *report
// unless it is nullptr.
void spell_ascii_hex(std::span<const std::uint8_t> frame, std::vector<std::uint8_t>& binary,
                     AsciiHex* report);

// The Modbus ASCII plausibility rules (dissectors/common/plausibility.hpp): ':' first, hex digits
// (either case: lower case is a `malformed` finding, not another protocol), an even count of them
// spelling 3..255 bytes, CR LF last; then modbus_plausibility() of the bytes they spell.
// `hex`: decode_ascii_hex(frame).
Plausibility ascii_plausibility(std::span<const std::uint8_t> frame, const AsciiHex& hex,
                                Direction direction, bool describe);

// The dissector (decoder_of.hpp's Dissector). `request` is not read: replies of this protocol
// stand on their own (ProtocolDecoder::dissect_into).
Dissector dissect_ascii;

// What its telegrams say to or of a drive (ProtocolDecoder::read_drive_records; drive_reading.cpp).
DriveReader read_ascii_drive_records;

// The decoder: this protocol's functions (the .cpp) as a ProtocolDecoder.
extern const DecoderFunctions kAsciiFunctions;
using AsciiDecoder = DecoderOf<kAsciiFunctions>;

}  // namespace drivetap::modbus
