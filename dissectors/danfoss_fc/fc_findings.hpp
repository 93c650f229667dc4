// The Danfoss FC protocol's findings, declared as data (dissectors/common/finding.hpp;
// docs/protocols.md §4). Ids `danfoss_fc.*` (Wireshark's `fc` is Fibre Channel).
#pragma once

#include <cstddef>
#include <string>

#include "dissectors/common/finding.hpp"

namespace drivetap::danfoss_fc {

// The plausibility rules (dissectors/common/plausibility.hpp): ids as the `implausible` finding's
// detail names them. They keep their short `fc.` prefix, being output text; finding ids do not.
inline constexpr PlausibilityRule kRuleFcStx{"danfoss_fc.stx", "PROTOCOLS.md §4"};
inline constexpr PlausibilityRule kRuleFcLgeAllowed{"danfoss_fc.lge_allowed", "PROTOCOLS.md §4"};
inline constexpr PlausibilityRule kRuleFcLgeCount{"danfoss_fc.lge_count", "PROTOCOLS.md §4"};
inline constexpr PlausibilityRule kRuleFcAdr{"danfoss_fc.adr", "PROTOCOLS.md §4"};
inline constexpr PlausibilityRule kRuleFcAk{"danfoss_fc.ak", "PROTOCOLS.md §4"};

inline constexpr Finding<std::size_t> kFindingFragment{
    "danfoss_fc.fragment", AnomalyKind::malformed, Severity::error,
    "{}-byte fragment, too short for an FC telegram"};
inline constexpr Finding<unsigned> kFindingStxBad{"danfoss_fc.stx_bad", AnomalyKind::malformed,
                                                  Severity::error,
                                                  "starts with 0x{:02X}, not STX 0x02"};
inline constexpr Finding<unsigned, unsigned, std::size_t> kFindingLgeMismatch{
    "danfoss_fc.lge_mismatch", AnomalyKind::malformed, Severity::error,
    "LGE {} announces {} bytes, the telegram has {}"};
inline constexpr Finding<std::size_t> kFindingPweLength{"danfoss_fc.pwe_length",
                                                        AnomalyKind::malformed, Severity::error,
                                                        "parameter value of {} bytes (4 expected)"};
inline constexpr Finding<unsigned, const char*> kFindingAkDirection{
    "danfoss_fc.ak_direction", AnomalyKind::malformed, Severity::error,
    "AK 0x{:X} is not a {} command"};
inline constexpr Finding<std::size_t> kFindingDataLength{
    "danfoss_fc.data_length", AnomalyKind::malformed, Severity::error,
    "{} data bytes: neither process data (4) nor a parameter block (12)"};
inline constexpr ImplausibleFinding kFindingImplausible =
    implausible_finding("danfoss_fc.implausible");

inline constexpr const FindingDesc* kAllFindings[] = {
    &kFindingFragment,    &kFindingStxBad,     &kFindingLgeMismatch, &kFindingPweLength,
    &kFindingAkDirection, &kFindingDataLength, &kFindingImplausible,
};

}  // namespace drivetap::danfoss_fc
