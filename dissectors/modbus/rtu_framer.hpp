// Modbus RTU framing rules for the hybrid framer (docs/protocols.md §2; Modbus over Serial Line
// V1.02 §2.5.1.1):
//
//   frame = ADDR(1) FC(1) DATA(n) CRC(2, low byte first)      4..256 bytes
//
// Lengths come from the function code and count fields, for a request and for a reply; the CRC
// (also byte-swapped) confirms them; a frame with an unknown function code is found by scanning
// for the first valid CRC.
#pragma once

#include "dissectors/common/hybrid_framer.hpp"
#include "dissectors/modbus/modbus_pdu.hpp"

namespace drivetap::modbus {

inline constexpr std::size_t kRtuMaxFrame = 256;
inline constexpr std::size_t kRtuMinFrame = 4;

class RtuRules final : public HybridFrameRules {
 public:
  [[nodiscard]] std::size_t min_frame() const override { return kRtuMinFrame; }
  [[nodiscard]] std::size_t max_frame() const override { return kRtuMaxFrame; }
  // (Defined here: inlined into the framer's check of every telegram.)
  void predicted_lengths(std::span<const std::uint8_t> from, std::size_t out[2],
                         bool* needs_more) const override {
    out[0] = out[1] = 0;
    *needs_more = false;
    if (from.size() < 2) {
      *needs_more = true;
      return;
    }
    int i = 0;
    for (Direction dir : {Direction::request, Direction::response}) {
      const LengthPrediction pred = predict_pdu_length(from.subspan(1), dir);
      if (pred.kind == LengthPrediction::Kind::known) {
        out[i++] = pred.length + 3;  // address + PDU + CRC
      } else if (pred.kind == LengthPrediction::Kind::need_more) {
        *needs_more = true;
      }
    }
  }
  [[nodiscard]] bool checksum_matches(std::span<const std::uint8_t> frame) const override;
  // The CRC-16 computed (crc16_modbus()), and whether the frame's holds, also swapped.
  [[nodiscard]] ChecksumCheck check_checksum(std::span<const std::uint8_t> frame) const override;
  [[nodiscard]] FrameChecksum checksum_kind() const override { return FrameChecksum::crc16_modbus; }
  [[nodiscard]] bool looks_like_frame_start(std::span<const std::uint8_t> from) const override;
  [[nodiscard]] std::size_t scan_unknown_layout(
      std::span<const std::uint8_t> from,
      const std::function<bool(std::size_t)>& accept) const override;
};

using RtuFramerOptions = HybridFramerOptions;

// The hybrid framer with Modbus RTU's rules.
class RtuFramer final : public Framer {
 public:
  RtuFramer(ChannelId channel, RtuFramerOptions options) : framer_(channel, options, rules()) {}
  using Framer::push;
  std::size_t push(std::span<const ByteEvent> events, FrameBatch& out) override {
    return framer_.push(events, out);
  }
  std::size_t push(const ByteRun& run, FrameBatch& out) override { return framer_.push(run, out); }
  bool take_whole(const ByteRun& run, TimeNs next_time, WholeFrame* taken,
                  const TelegramPrecheck* precheck = nullptr) override {
    return framer_.take_whole(run, next_time, taken, precheck);
  }
  void advance(TimeNs now, FrameBatch& out) override { framer_.advance(now, out); }
  void finish(FrameBatch& out) override { framer_.finish(out); }
  [[nodiscard]] TimeNs next_deadline() const override { return framer_.next_deadline(); }
  static const RtuRules& rules();

 private:
  HybridFramer<RtuRules> framer_;
};

}  // namespace drivetap::modbus

// Instantiated in rtu_framer.cpp, next to the rules it inlines.
extern template class drivetap::HybridFramer<drivetap::modbus::RtuRules>;
