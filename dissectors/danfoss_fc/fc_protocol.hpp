// The Danfoss FC protocol's descriptor (core/protocol_desc.hpp; docs/protocols.md §4).
#pragma once

#include "core/protocol_desc.hpp"

namespace drivetap::danfoss_fc {
extern const ProtocolDesc kFcProtocol;
}  // namespace drivetap::danfoss_fc

namespace drivetap::protocols {
inline constexpr Protocol danfoss_fc{&danfoss_fc::kFcProtocol};
}  // namespace drivetap::protocols
