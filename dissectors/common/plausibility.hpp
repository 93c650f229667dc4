// Plausibility rules: what any real telegram of a protocol keeps, from its specification
// (docs/protocols.md §2-§5; Modbus over Serial Line V1.02 §2.3, §2.5.1; Modbus Application Protocol
// V1.1b3 §6-7). A telegram that breaks one is no telegram of that protocol, however good its
// checksum: it gets an `implausible` finding and never counts as a good telegram (detection,
// drive binding, the drive-state timeline, the summary's good telegrams).
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <string_view>

#include "core/message.hpp"

namespace drivetap {

// A rule, declared as data in its protocol's folder (dissectors/<protocol>/*_findings.hpp).
struct PlausibilityRule {
  const char* id;      // stable, dotted, with its protocol's prefix: "mbrtu.address"
  const char* source;  // where the rule is written down
};

// The outcome of a check: the first rule broken (none: plausible) and, when asked for, what was
// found ("address 255 (248-255 are reserved)").
struct Plausibility {
  const PlausibilityRule* broken = nullptr;
  std::string why;
  [[nodiscard]] bool ok() const { return broken == nullptr; }

  // The outcome "`rule` is broken", with what was found (`why()`, called only when `describe`:
  // a run that shows no text builds none).
  template <typename Why>
  static Plausibility breaking(const PlausibilityRule& rule, bool describe, Why&& why) {
    Plausibility p;
    p.broken = &rule;
    if (describe) p.why = why();
    return p;
  }
};

// Whether a telegram that reads as a request (`as_request`) and/or a reply fits `direction`
// (unknown: either will do).
constexpr bool fits_direction(Direction direction, bool as_request, bool as_response) {
  return direction == Direction::request    ? as_request
         : direction == Direction::response ? as_response
                                            : as_request || as_response;
}

// What a telegram of `direction` should have been, for a broken rule's text: `request`,
// `response`, or (direction unknown) "`request` or `response`".
std::string expected_for(Direction direction, std::string_view request, std::string_view response);

// True when the message carries an `implausible` finding.
bool is_implausible(const Message& m);

// Modbus exception codes a drive profile declares besides the public 1..11 (E5-8200's 0x51..0x55,
// the VLT AQUA's 0, 17, 64..67, 130, 131 ...). Written once at start-up, after the profiles are
// loaded and before anything is decoded (the sinks' threads only read it).
void allow_vendor_exception_code(std::uint8_t code);
bool exception_code_allowed(std::uint8_t code);

}  // namespace drivetap
