// Findings a protocol declares as data beside its fields, as Wireshark's expert infos (ei[]), and
// raising one on a Message (docs/protocols.md §1, §6): the finding's generic kind (the JSON
// `kind`), the frame's time and channel, and the detail from the finding's template.
#pragma once

#include <fmt/format.h>

#include <string>
#include <string_view>
#include <type_traits>
#include <utility>

#include "core/message.hpp"
#include "core/printable.hpp"
#include "dissectors/common/plausibility.hpp"

namespace drivetap {

// A finding whose detail takes `Args`: its template is checked against them when compiled.
template <class... Args>
struct Finding : FindingDesc {
  consteval Finding(const char* finding_id, AnomalyKind finding_kind, Severity finding_severity,
                    std::string_view finding_text)
      : FindingDesc{finding_id, finding_kind, finding_severity, finding_text} {
#if !defined(__clang__)
    // (Clang before 16 refuses a consteval call on a consteval function's parameter; the GCC
    // builds check every template.)
    [[maybe_unused]] const fmt::format_string<Args...> checked(finding_text);  // compile-time
#endif
  }
  [[nodiscard]] std::string detail(const std::type_identity_t<Args>&... args) const {
    return fmt::vformat(text, fmt::make_format_args(args...));
  }
};

// A finding with its detail made, waiting to be raised (a layer below the Message: the PDU).
struct FoundProblem {
  const FindingDesc* finding = nullptr;
  std::string detail;
};

// Raises `finding` on `m` with `detail` already made from its template. A detail may quote bytes
// from the bus (a stray character): made printable as a channel name is, so that no ESC or
// invalid UTF-8 reaches a terminal, a CSV cell or a pcapng comment.
inline void add_finding_detail(Message& m, const FindingDesc& finding, std::string detail) {
  m.anomalies.push_back({finding.kind, m.frame.start(), m.frame.channel, 0,
                         printable(detail, /*escape_backslash=*/false), &finding});
}

// Raises `finding` on `m`, its detail from `args`.
template <class... Args>
void add_finding(Message& m, const Finding<Args...>& finding,
                 const std::type_identity_t<Args>&... args) {
  add_finding_detail(m, finding, finding.detail(args...));
}

// A protocol's `implausible` finding: the plausibility rule a telegram breaks, its detail
// "{why} [{rule}, {source}]". Every protocol has one, alike but for its id.
using ImplausibleFinding = Finding<std::string, const char*, const char*>;
consteval ImplausibleFinding implausible_finding(const char* id) {
  return {id, AnomalyKind::implausible, Severity::error, "{} [{}, {}]"};
}

// Raises `implausible` for the rule `p` breaks; nothing when p.ok().
void add_implausible(Message& m, const ImplausibleFinding& implausible, const Plausibility& p);

}  // namespace drivetap
