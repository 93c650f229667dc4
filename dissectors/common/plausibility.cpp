// Plausibility rules as data, and the `implausible` finding (plausibility.hpp; PROTOCOLS.md §2-§5).
#include "dissectors/common/plausibility.hpp"

#include "dissectors/common/finding.hpp"

#include <fmt/format.h>

#include <iterator>

namespace drivetap {
namespace {

constexpr PlausibilityRuleInfo kPlausibilityRules[] = {
    {PlausibilityRule::none, "none", ""},
    {PlausibilityRule::rtu_size, "rtu.size", "Modbus serial line §2.5.1"},
    {PlausibilityRule::rtu_address, "rtu.address", "Modbus serial line §2.3"},
    {PlausibilityRule::rtu_function, "rtu.function", "Modbus application protocol §5"},
    {PlausibilityRule::rtu_length, "rtu.length", "Modbus application protocol §6"},
    {PlausibilityRule::rtu_exception_code, "rtu.exception_code",
     "Modbus application protocol §7, drive profiles"},
    {PlausibilityRule::fc_stx, "fc.stx", "PROTOCOLS.md §4"},
    {PlausibilityRule::fc_lge_allowed, "fc.lge_allowed", "PROTOCOLS.md §4"},
    {PlausibilityRule::fc_lge_count, "fc.lge_count", "PROTOCOLS.md §4"},
    {PlausibilityRule::fc_adr, "fc.adr", "PROTOCOLS.md §4"},
    {PlausibilityRule::fc_ak, "fc.ak", "PROTOCOLS.md §4"},
    {PlausibilityRule::ascii_start, "ascii.start", "PROTOCOLS.md §3"},
    {PlausibilityRule::ascii_charset, "ascii.charset", "PROTOCOLS.md §3"},
    {PlausibilityRule::ascii_length, "ascii.length", "Modbus serial line §2.5.2"},
    {PlausibilityRule::ascii_terminator, "ascii.terminator", "PROTOCOLS.md §3"},
    {PlausibilityRule::eds_start, "eds.start", "PROTOCOLS.md §5"},
    {PlausibilityRule::eds_charset, "eds.charset", "PROTOCOLS.md §5"},
    {PlausibilityRule::eds_length, "eds.length", "PROTOCOLS.md §5"},
    {PlausibilityRule::eds_terminator, "eds.terminator", "PROTOCOLS.md §5"},
    {PlausibilityRule::eds_command, "eds.command", "PROTOCOLS.md §5"},
};
static_assert(std::size(kPlausibilityRules) == static_cast<std::size_t>(PlausibilityRule::kCount),
              "one entry per PlausibilityRule");
constexpr bool in_rule_order() {
  for (std::size_t k = 0; k < std::size(kPlausibilityRules); ++k)
    if (static_cast<std::size_t>(kPlausibilityRules[k].rule) != k) return false;
  return true;
}
static_assert(in_rule_order(), "kPlausibilityRules is indexed by PlausibilityRule");

// Written only before decoding starts (allow_vendor_exception_code()).
std::array<bool, 256> g_vendor_exception{};

}  // namespace

const PlausibilityRuleInfo& plausibility_rule(PlausibilityRule rule) {
  const auto i = static_cast<std::size_t>(rule);
  return kPlausibilityRules[i < std::size(kPlausibilityRules) ? i : 0];
}

// The rule is named after what was found: "address 255 (248-255 are reserved) [rtu.address,
// Modbus serial line §2.3]" (the kind's label says "not a telegram of its protocol"; the frame
// says which protocol).
void add_implausible(Message& m, const Finding<std::string, const char*, const char*>& implausible,
                     const Plausibility& p) {
  if (p.ok()) return;
  const PlausibilityRuleInfo& rule = plausibility_rule(p.broken);
  add_finding(m, implausible, p.why, rule.id, rule.source);
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
