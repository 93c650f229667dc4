// Modbus RTU framing rules (docs/protocols.md §2): lengths per function code and direction, CRC.
#include "dissectors/modbus/rtu_framer.hpp"

#include "core/checksum.hpp"
#include "dissectors/common/hybrid_framer_impl.hpp"
#include "dissectors/modbus/modbus_pdu.hpp"

namespace drivetap::modbus {

const RtuRules& RtuFramer::rules() {
  static const RtuRules instance;
  return instance;
}

bool RtuRules::checksum_matches(std::span<const std::uint8_t> frame) const {
  return check_checksum(frame).matches;
}

HybridFrameRules::ChecksumCheck RtuRules::check_checksum(
    std::span<const std::uint8_t> frame) const {
  // check_rtu_crc()'s good or swapped, without its verdict record.
  if (frame.size() < 3) return {};
  const std::uint16_t crc = crc16_modbus(frame.first(frame.size() - 2));
  const std::uint8_t lo = frame[frame.size() - 2];
  const std::uint8_t hi = frame[frame.size() - 1];
  return {crc == (lo | (hi << 8)) || crc == (hi | (lo << 8)), crc};
}

bool RtuRules::looks_like_frame_start(std::span<const std::uint8_t> from) const {
  if (from.empty()) return false;
  if (from.size() < 2) return from[0] <= 247;
  return from[0] <= 247 && is_public_function(from[1]);
}

std::size_t RtuRules::scan_unknown_layout(std::span<const std::uint8_t> from,
                                          const std::function<bool(std::size_t)>& accept) const {
  std::uint16_t crc = 0xFFFF;
  // Each pass extends the candidate by one byte; the CRC is carried along.
  for (std::size_t end = 0; end + 2 <= from.size() && end + 2 <= kRtuMaxFrame; ++end) {
    const std::size_t len = end + 2;
    if (len >= kRtuMinFrame &&
        static_cast<std::uint16_t>(from[end] | (from[end + 1] << 8)) == crc && accept(len))
      return len;
    crc = crc16_modbus_update(crc, from[end]);
  }
  return 0;
}

}  // namespace drivetap::modbus

template class drivetap::HybridFramer<drivetap::modbus::RtuRules>;
