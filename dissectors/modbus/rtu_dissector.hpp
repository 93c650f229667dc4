// Modbus RTU dissector: one framed telegram -> Message (PROTOCOLS.md §2, §6).
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
#include "core/serial_config.hpp"

namespace drivetap::modbus {

// Which directions the frame's length agrees with (from its function code and count fields).
struct DirectionFit {
  bool request = false;
  bool response = false;
};
DirectionFit rtu_direction_fit(std::span<const std::uint8_t> frame);

// Decodes `frame` as a Modbus RTU telegram travelling in `direction`. Checksum, malformed
// content, gaps > t1.5 inside the frame, a short silence before it and UART-flagged bytes all
// become anomalies of the message.
Message dissect_rtu(Frame frame, Direction direction, const FramingTiming& timing);

}  // namespace drivetap::modbus
