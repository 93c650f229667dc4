// Raising the `implausible` finding, and the drive profiles' vendor exception codes
// (plausibility.hpp; docs/protocols.md §2-§5).
#include "dissectors/common/plausibility.hpp"

#include "dissectors/common/finding.hpp"

#include <array>

namespace drivetap {
namespace {

// Written only before decoding starts (allow_vendor_exception_code()).
std::array<bool, 256> g_vendor_exception{};

}  // namespace

// The rule is named after what was found: "address 255 (248-255 are reserved) [modbus.address,
// Modbus serial line §2.3]" (the kind's label says "not a telegram of its protocol"; the frame
// says which protocol).
void add_implausible(Message& m, const ImplausibleFinding& implausible, const Plausibility& p) {
  if (p.ok()) return;
  add_finding(m, implausible, p.why, p.broken->id, p.broken->source);
}

std::string expected_for(Direction direction, std::string_view request, std::string_view response) {
  if (direction == Direction::request) return std::string(request);
  if (direction == Direction::response) return std::string(response);
  return std::string(request) + " or " + std::string(response);
}

bool is_implausible(const Message& m) {
  for (const Anomaly& a : m.anomalies)
    if (a.kind == AnomalyKind::implausible) return true;
  return false;
}

void allow_vendor_exception_code(std::uint8_t code) {
  g_vendor_exception[code] = true;
}

bool exception_code_allowed(std::uint8_t code) {
  return (code >= 1 && code <= 11) || g_vendor_exception[code];
}

}  // namespace drivetap
