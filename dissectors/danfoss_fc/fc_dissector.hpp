// Danfoss FC protocol dissector and decoder (docs/protocols.md §4; 002 §7.2-7.5, §7.11).
//
//   +-----+-----+-----+------------------------------------------+-----+
//   | STX | LGE | ADR | DATA (LGE - 2 bytes)                     | BCC |
//   +-----+-----+-----+------------------------------------------+-----+
//    0x02   length after LGE      BCC = XOR of STX .. last data byte
//   DATA: LGE 6   PCD1 PCD2                        (process data only)
//         LGE 14  PKE IND PWEhigh PWElow PCD1 PCD2 (parameter block)
//         10+n    PKE IND text[n] PCD1 PCD2        (text block)
//   PCD1/PCD2: master -> drive control word CTW and reference REF; drive -> master status word
//   STW and main actual value MAV. REF/MAV: signed, 0x4000 = 100 %. All words high byte first.
#pragma once

#include "core/message.hpp"
#include "core/protocol.hpp"
#include "dissectors/common/decoder_of.hpp"
#include "dissectors/common/hybrid_framer.hpp"
#include "dissectors/common/plausibility.hpp"
#include "dissectors/danfoss_fc/fc_protocol.hpp"

namespace drivetap::danfoss_fc {

inline constexpr std::uint8_t kStxByte = 0x02;

// Drive address and broadcast flag from ADR (bit 7 selects the 1..126 format).
struct Address {
  int number = -1;
  bool broadcast = false;
};
Address decode_adr(std::uint8_t adr);
std::uint8_t bcc(std::span<const std::uint8_t> bytes);
// "4-14" for PNU 414.
std::string parameter_name(unsigned pnu);

// The FC protocol plausibility rules (dissectors/common/plausibility.hpp): STX first; LGE 6, 14
// or (AK 0xF, a text block) 10 + n, and equal to the bytes after it; ADR a drive address or a
// broadcast; AK valid in the telegram's direction (unknown: in either).
Plausibility fc_plausibility(std::span<const std::uint8_t> frame, Direction direction,
                             bool describe);

// The dissector (decoder_of.hpp's Dissector). `request` is not read: replies of this protocol
// stand on their own (ProtocolDecoder::dissect_into).
Dissector dissect_fc;

class FcRules final : public HybridFrameRules {
 public:
  [[nodiscard]] std::size_t min_frame() const override { return 4; }
  [[nodiscard]] std::size_t max_frame() const override { return 257; }
  void predicted_lengths(std::span<const std::uint8_t> from, std::size_t out[2],
                         bool* needs_more) const override;
  [[nodiscard]] bool checksum_matches(std::span<const std::uint8_t> frame) const override;
  [[nodiscard]] bool looks_like_frame_start(std::span<const std::uint8_t> from) const override;
};

// What its telegrams say to or of a drive (ProtocolDecoder::read_drive_records; drive_reading.cpp).
DriveReader read_fc_drive_records;

// The decoder: this protocol's functions (the .cpp) as a ProtocolDecoder.
extern const DecoderFunctions kFcFunctions;
using FcDecoder = DecoderOf<kFcFunctions>;

}  // namespace drivetap::danfoss_fc
