// The Easydrive protocol's findings, declared as data (dissectors/common/finding.hpp;
// docs/protocols.md §5).
#pragma once

#include <cstddef>
#include <string>

#include "dissectors/common/finding.hpp"

namespace drivetap::easydrive {

// The plausibility rules (dissectors/common/plausibility.hpp): ids as the `implausible` finding's
// detail names them.
inline constexpr PlausibilityRule kRuleEdsStart{"easydrive.start", "PROTOCOLS.md §5"};
inline constexpr PlausibilityRule kRuleEdsCharset{"easydrive.charset", "PROTOCOLS.md §5"};
inline constexpr PlausibilityRule kRuleEdsLength{"easydrive.length", "PROTOCOLS.md §5"};
inline constexpr PlausibilityRule kRuleEdsTerminator{"easydrive.terminator", "PROTOCOLS.md §5"};
inline constexpr PlausibilityRule kRuleEdsCommand{"easydrive.command", "PROTOCOLS.md §5"};

inline constexpr Finding<> kFindingNoStart{"easydrive.no_start", AnomalyKind::malformed,
                                           Severity::error, "does not start with '~'"};
inline constexpr Finding<> kFindingNoCr{"easydrive.no_cr", AnomalyKind::malformed, Severity::error,
                                        "no CR at the end: frame cut"};
inline constexpr Finding<unsigned, char, std::size_t> kFindingBadCharacter{
    "easydrive.bad_character", AnomalyKind::malformed, Severity::error,
    "invalid character 0x{:02X} ('{}') at {}"};
inline constexpr Finding<std::size_t> kFindingLength{
    "easydrive.length", AnomalyKind::malformed, Severity::error,
    "{} characters before CR: a frame has 13 or 17"};
inline constexpr ImplausibleFinding kFindingImplausible =
    implausible_finding("easydrive.implausible");

inline constexpr const FindingDesc* kAllFindings[] = {
    &kFindingNoStart, &kFindingNoCr, &kFindingBadCharacter, &kFindingLength, &kFindingImplausible,
};

}  // namespace drivetap::easydrive
