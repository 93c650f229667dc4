// DecoderOf: a protocol's ProtocolDecoder (core/protocol.hpp) made from a table of its functions,
// so that each protocol states what it does (framer, direction fit, pairing keys, dissector) and
// not the same class around it (PROTOCOLS.md §1).
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <utility>

#include "core/protocol.hpp"

namespace drivetap {

// A dissector's form that decodes into a Message, reusing its storage (begin_message()).
using DissectInto = void (*)(Message& out, Frame&& frame, Direction direction,
                             const FramingTiming& timing, std::span<const std::uint8_t> request);

// The same into a new Message (the dissectors' second form, for tests and tools).
inline Message dissected(DissectInto dissect, Frame&& frame, Direction direction,
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
  DissectInto dissect;
  bool reads_request = false;  // its replies mean nothing without their request
};

// The functions' ProtocolDecoder (ProtocolDecoder says what each does). Not final: a protocol
// with a summary lane (Modbus RTU) adds summarise() and precheck().
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
  [[nodiscard]] bool recognisable(std::span<const std::uint8_t> frame) const override {
    return F.recognisable(frame);
  }
  [[nodiscard]] PairingKeys pairing_keys(std::span<const std::uint8_t> frame) const override {
    return F.pairing_keys(frame);
  }
  void dissect_into(Message& out, Frame&& frame, Direction direction, const FramingTiming& timing,
                    std::span<const std::uint8_t> request = {}) const override {
    F.dissect(out, std::move(frame), direction, timing, request);
  }
  [[nodiscard]] bool reads_request() const override { return F.reads_request; }
};

}  // namespace drivetap
