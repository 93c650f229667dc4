// Modbus RTU dissector: one framed telegram -> Message (docs/protocols.md §2, §6).
//
//   +------+----+----------------+---------+---------+
//   | ADDR | FC | DATA (0..252)  | CRC lo  | CRC hi  |
//   +------+----+----------------+---------+---------+
//     0      1    2 ..             n-2       n-1
#pragma once

#include <cstdint>
#include <span>

#include "core/frame.hpp"
#include "core/message.hpp"
#include "core/protocol.hpp"
#include "core/serial_config.hpp"
#include "dissectors/common/decoder_of.hpp"
#include "dissectors/common/plausibility.hpp"
#include "dissectors/modbus/modbus_protocol.hpp"

namespace drivetap::modbus {

// Which directions the frame's length agrees with (from its function code and count fields).
DirectionFit rtu_direction_fit(std::span<const std::uint8_t> frame);

// The Modbus RTU plausibility rules (dissectors/common/plausibility.hpp): 4..256 bytes, then
// the address, function, layout and exception code rules of modbus_plausibility().
Plausibility rtu_plausibility(std::span<const std::uint8_t> frame, Direction direction,
                              bool describe);

// Decodes `frame` as a Modbus RTU telegram travelling in `direction`. Checksum, malformed
// content, gaps > t1.5 inside the frame, a short silence before it and UART-flagged bytes all
// become anomalies of the message.
// The dissector (decoder_of.hpp's Dissector). `request` is not read: replies of this protocol
// stand on their own (ProtocolDecoder::dissect_into).
Dissector dissect_rtu;

// What its telegrams say to or of a drive (ProtocolDecoder::read_drive_records; drive_reading.cpp).
DriveReader read_rtu_drive_records;

// Modbus RTU as a ProtocolDecoder for the pipeline: its functions (the .cpp) and its head reading.
extern const DecoderFunctions kRtuFunctions;
class RtuDecoder final : public DecoderOf<kRtuFunctions> {
 public:
  using ProtocolDecoder::dissect;
  // Replies of this protocol stand on their own (`request` is not read). To DissectDepth::head
  // a telegram of 4 bytes or more is read without a Message.
  bool dissect(TelegramView& t, Direction direction, const FramingTiming& timing,
               std::span<const std::uint8_t> request, DissectDepth depth, Message& out,
               TelegramFindings* head) const override;
  bool precheck(std::span<const std::uint8_t> bytes, TelegramPrecheck* out) const override;
};

}  // namespace drivetap::modbus
