// Transaction: a request paired with its response on a half-duplex link (docs/protocols.md §1, §2).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "core/byte_event.hpp"
#include "core/message.hpp"
#include "core/time.hpp"

namespace drivetap {

enum class Outcome : std::uint8_t {
  ok,           // normal response
  exception,    // exception response (function code | 0x80)
  timeout,      // no response within the timeout, or the master moved on
  broadcast,    // address 0: no response expected
  unsolicited,  // a response with no request waiting for it
  bad_reply,    // a response to a waiting request, its checksum bad: the master cannot use it
  // A request still waiting when the input ended, -c cut it or a signal stopped the capture: its
  // reply may have been on the way. Neither a timeout nor a finding.
  pending,
};
inline constexpr std::size_t kOutcomeCount = 7;

std::string_view outcome_id(Outcome o);

struct Transaction {
  // User-provided, so that value-initialisation (`out.emplace_back()`, one per reply) runs the
  // member initialisers alone: an implicit constructor has the object zero-filled first, which
  // GCC does with `rep stos` (a fifth of Pairer::add's samples in perf).
  Transaction() noexcept {}  // NOLINT(modernize-use-equals-default)

  Outcome outcome = Outcome::ok;
  Protocol protocol = Protocol::unknown;
  ChannelId channel = 0;  // of the request (of the response for unsolicited)
  int address = -1;
  int function = -1;                 // of the request (without the exception bit)
  std::uint64_t request_number = 0;  // frame numbers, 0 when absent
  std::uint64_t response_number = 0;
  TimeNs request_time = -1;   // start of request, -1 when absent
  TimeNs response_time = -1;  // start of response, -1 when absent
  TimeNs latency = -1;        // end of request -> start of response, -1 when not paired
  int exception_code = -1;
  std::string detail;  // why a timeout was declared, etc.
};

}  // namespace drivetap
