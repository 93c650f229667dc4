// Easydrive EDS1000/EDS800 ASCII protocol dissector and decoder (docs/protocols.md §5; 001 ch. 11).
//
//   +-----+---------+--------+--------+--------+-----------+--------+----+
//   | '~' | ADDR(2) | CMD(2) | AUX(2) | IDX(2) | [DATA(4)] | SUM(4) | CR |     14 or 18 bytes
//   +-----+---------+--------+--------+--------+-----------+--------+----+
//   SUM = 16-bit sum of the ASCII codes from ADDR through DATA, 4 upper-case hex digits.
//   Master: CMD 0A status query, 0B read running value, 0C run control, 0D read function code,
//   0E write function code, 0F software version (the manual names them 10..15). Slave: CMD is a
//   response code, AUX its current fault code; the index (AUX IDX of the request) is echoed.
#pragma once

#include "core/message.hpp"
#include "core/protocol.hpp"
#include "dissectors/common/decoder_of.hpp"
#include "dissectors/common/plausibility.hpp"
#include "dissectors/easydrive/eds_protocol.hpp"

namespace drivetap::easydrive {

// Value of `n` upper-case hex characters at `at`, or -1 (out of range or not hex).
long hex_field(std::span<const std::uint8_t> frame, std::size_t at, std::size_t n);

// Sum of the ASCII codes of `text` (the SUM field's rule), modulo 2^16.
std::uint16_t ascii_sum(std::span<const std::uint8_t> text);

// The Easydrive plausibility rules (dissectors/common/plausibility.hpp): '~' first, CR last,
// only 0-9 and A-F between, 13 or 17 characters before CR, and a command (0A..0F) or a response
// code (00, 10..14, 20, 30) in the telegram's direction (unknown: either).
Plausibility eds_plausibility(std::span<const std::uint8_t> frame, Direction direction,
                              bool describe);

// The dissector (decoder_of.hpp's Dissector). `request`: for a reply, the request it answers —
// its command and index say what the reply's data is (a frequency, the status word).
Dissector dissect_eds;

// What its telegrams say to or of a drive (ProtocolDecoder::read_drive_records; drive_reading.cpp).
DriveReader read_eds_drive_records;

// The decoder: this protocol's functions (the .cpp) as a ProtocolDecoder.
extern const DecoderFunctions kEdsFunctions;
using EdsDecoder = DecoderOf<kEdsFunctions>;

}  // namespace drivetap::easydrive
