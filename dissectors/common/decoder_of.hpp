// DecoderOf: a protocol's ProtocolDecoder (core/protocol.hpp) made from a table of its functions,
// so that each protocol states what it does (framer, direction fit, pairing keys, dissector) and
// not the same class around it (docs/protocols.md §1).
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <utility>

#include "core/protocol.hpp"

namespace drivetap {

// The two functions every protocol writes, declared by type so that each protocol's header names
// them without spelling the signature again (`Dissector dissect_fc;`); a definition spells it out.
// A dissector decodes into a Message, reusing its storage (begin_message()); `request` is the
// request a reply answers (empty: none, or a protocol whose replies stand on their own).
using Dissector = void(Message& out, Frame&& frame, Direction direction,
                       const FramingTiming& timing, std::span<const std::uint8_t> request);
// What a protocol's telegrams say to or of a drive (ProtocolDecoder::read_drive_records).
using DriveReader = void(const TelegramHead& telegram, std::span<const std::uint8_t> request,
                         DriveRecords& out);

// A dissection into a new Message, for tests and tools: `dissected(dissect_rtu, frame, ...)`.
inline Message dissected(Dissector* dissect, Frame&& frame, Direction direction,
                         const FramingTiming& timing, std::span<const std::uint8_t> request = {}) {
  Message m;
  dissect(m, std::move(frame), direction, timing, request);
  return m;
}

struct DecoderFunctions {
  Protocol protocol;
  std::unique_ptr<Framer> (*make_framer)(ChannelId channel, const FramerSettings& s);
  DirectionFit (*direction_fit)(std::span<const std::uint8_t> frame);
  bool (*always_response)(std::span<const std::uint8_t> frame);
  bool (*recognisable)(std::span<const std::uint8_t> frame);
  ProtocolDecoder::PairingKeys (*pairing_keys)(std::span<const std::uint8_t> frame);
  Dissector* dissect;
  DriveReader* read_drive_records;
  // ProtocolDecoder::could_answer(); none: any telegram could.
  bool (*could_answer)(std::span<const std::uint8_t> frame,
                       std::span<const std::uint8_t> request) = nullptr;
};

// The functions' ProtocolDecoder (ProtocolDecoder says what each does), dissecting always in
// detail. Not final: a protocol with a head reading of its own (Modbus RTU) overrides dissect()
// and adds precheck().
template <const DecoderFunctions& F>
class DecoderOf : public ProtocolDecoder {
 public:
  [[nodiscard]] Protocol protocol() const override { return F.protocol; }
  [[nodiscard]] std::unique_ptr<Framer> make_framer(ChannelId channel,
                                                    const FramerSettings& s) const override {
    return F.make_framer(channel, s);
  }
  [[nodiscard]] DirectionFit direction_fit(std::span<const std::uint8_t> frame) const override {
    return F.direction_fit(frame);
  }
  [[nodiscard]] bool always_response(std::span<const std::uint8_t> frame) const override {
    return F.always_response(frame);
  }
  [[nodiscard]] bool could_answer(std::span<const std::uint8_t> frame,
                                  std::span<const std::uint8_t> request) const override {
    return F.could_answer == nullptr || F.could_answer(frame, request);
  }
  [[nodiscard]] bool recognisable(std::span<const std::uint8_t> frame) const override {
    return F.recognisable(frame);
  }
  [[nodiscard]] PairingKeys pairing_keys(std::span<const std::uint8_t> frame) const override {
    return F.pairing_keys(frame);
  }
  using ProtocolDecoder::dissect;
  bool dissect(TelegramView& t, Direction direction, const FramingTiming& timing,
               std::span<const std::uint8_t> request, DissectDepth depth, Message& out,
               TelegramFindings* head) const override {
    (void)depth;
    (void)head;
    F.dissect(out, t.frame_for(out), direction, timing, request);
    return true;
  }
  void read_drive_records(const TelegramHead& telegram, std::span<const std::uint8_t> request,
                          DriveRecords& out) const override {
    F.read_drive_records(telegram, request, out);
  }
};

}  // namespace drivetap
