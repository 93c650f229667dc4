// The Modbus protocols' descriptors (core/protocol_desc.hpp; docs/protocols.md §2, §3): Modbus RTU
// and Modbus ASCII, two framings of this folder's one PDU layer and field set.
#pragma once

#include "core/protocol_desc.hpp"

namespace drivetap::modbus {
extern const ProtocolDesc kRtuProtocol;
extern const ProtocolDesc kAsciiProtocol;
}  // namespace drivetap::modbus

namespace drivetap::protocols {
inline constexpr Protocol modbus_rtu{&modbus::kRtuProtocol};
inline constexpr Protocol modbus_ascii{&modbus::kAsciiProtocol};
}  // namespace drivetap::protocols
