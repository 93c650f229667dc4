// BusEvent: something drivetap concluded about the bus itself rather than about one frame —
// today the protocol a channel speaks (detection), later drive-level events (issue 5).
#pragma once

#include <string>

#include "core/byte_event.hpp"
#include "core/message.hpp"
#include "core/time.hpp"

namespace drivetap {

struct BusEvent {
  TimeNs time = 0;
  ChannelId channel = 0;
  std::string kind;  // stable id: "protocol_detected"
  Protocol protocol = Protocol::unknown;
  std::string confidence;  // "high", "medium", "low"
  std::string detail;      // human text with the evidence
};

}  // namespace drivetap
