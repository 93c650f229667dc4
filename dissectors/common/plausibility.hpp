// Plausibility rules: what any real telegram of a protocol keeps, from its specification
// (PROTOCOLS.md §2-§5; Modbus over Serial Line V1.02 §2.3, §2.5.1; Modbus Application Protocol
// V1.1b3 §6-7). A telegram that breaks one is no telegram of that protocol, however good its
// checksum: it gets an `implausible` finding and never counts as a good telegram (detection,
// drive binding, the drive-state timeline, the summary's good telegrams).
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <string>

#include "core/message.hpp"

namespace drivetap {

// Each rule, a typed id; its text and source are data (plausibility.cpp, kPlausibilityRules).
enum class PlausibilityRule : std::uint8_t {
  none,
  rtu_size,            // 4..256 bytes (address, function, CRC; serial line PDU <= 253)
  rtu_address,         // 0..247: 248..255 are reserved
  rtu_function,        // a public function code (or its exception)
  rtu_length,          // the length its function code and byte count imply
  rtu_exception_code,  // 1..11, or a loaded drive profile's vendor code
  fc_stx,              // starts with STX 0x02
  fc_lge_allowed,      // LGE 6, 14 or a text block's 10 + n (AK 0xF)
  fc_lge_count,        // LGE = the bytes after it
  fc_adr,              // ADR: 1..31 (bit 5 broadcast) or, bit 7 set, 1..126 / 0x80 broadcast
  fc_ak,               // AK valid in the telegram's direction
  ascii_start,         // starts with ':'
  ascii_charset,       // hex digits between ':' and CR LF
  ascii_length,        // an even count of hex digits, 3..256 bytes
  ascii_terminator,    // ends with CR LF
  eds_start,           // starts with '~'
  eds_charset,         // 0-9, A-F between '~' and CR
  eds_length,          // 13 or 17 characters before CR
  eds_terminator,      // ends with CR
  eds_command,         // a command (0A..0F) or a response code (00, 10..14, 20, 30)
  kCount
};

struct PlausibilityRuleInfo {
  PlausibilityRule rule;
  const char* id;      // stable, dotted: "rtu.address"
  const char* source;  // where the rule is written down
};
const PlausibilityRuleInfo& plausibility_rule(PlausibilityRule rule);

// The outcome of a check: the first rule broken (none: plausible) and, when asked for, what was
// found ("address 255 (248-255 are reserved)").
struct Plausibility {
  PlausibilityRule broken = PlausibilityRule::none;
  std::string why;
  [[nodiscard]] bool ok() const { return broken == PlausibilityRule::none; }

  // The outcome "`rule` is broken", with what was found (`why()`, called only when `describe`:
  // a run that shows no text builds none).
  template <typename Why>
  static Plausibility breaking(PlausibilityRule rule, bool describe, Why&& why) {
    Plausibility p;
    p.broken = rule;
    if (describe) p.why = why();
    return p;
  }
};

// True when the message carries an `implausible` finding.
bool is_implausible(const Message& m);

// Modbus exception codes a drive profile declares besides the public 1..11 (E5-8200's 0x51..0x55,
// the VLT AQUA's 0, 17, 64..67, 130, 131 ...). Written once at start-up, after the profiles are
// loaded and before anything is decoded (the sinks' threads only read it).
void allow_vendor_exception_code(std::uint8_t code);
bool exception_code_allowed(std::uint8_t code);

}  // namespace drivetap
