// The Easydrive protocol's descriptor (core/protocol_desc.hpp; docs/protocols.md §5).
#pragma once

#include "core/protocol_desc.hpp"

namespace drivetap::easydrive {
extern const ProtocolDesc kEdsProtocol;
}  // namespace drivetap::easydrive

namespace drivetap::protocols {
inline constexpr Protocol easydrive{&easydrive::kEdsProtocol};
}  // namespace drivetap::protocols
