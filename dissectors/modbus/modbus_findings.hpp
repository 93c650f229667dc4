// The Modbus findings, declared as data (dissectors/common/finding.hpp; docs/protocols.md §2, §3,
// §6; Modbus Application Protocol V1.1b3 §6): the PDU layer's (`modbus.*`, shared by RTU and
// ASCII), RTU framing's (`mbrtu.*`, Wireshark's prefix) and ASCII framing's (`mbascii.*`).
#pragma once

#include <array>
#include <cstddef>
#include <iterator>
#include <string>
#include <string_view>

#include "dissectors/common/finding.hpp"

namespace drivetap::modbus {

// The plausibility rules (dissectors/common/plausibility.hpp): ids as the `implausible` finding's
// detail names them. The PDU's and the station address's (`modbus.*`) hold for both framings.
inline constexpr PlausibilityRule kRuleRtuSize{"mbrtu.size", "Modbus serial line §2.5.1"};
inline constexpr PlausibilityRule kRuleAddress{"modbus.address", "Modbus serial line §2.3"};
inline constexpr PlausibilityRule kRuleFunction{"modbus.function",
                                                "Modbus application protocol §5"};
inline constexpr PlausibilityRule kRuleLength{"modbus.length", "Modbus application protocol §6"};
inline constexpr PlausibilityRule kRuleExceptionCode{
    "modbus.exception_code", "Modbus application protocol §7, drive profiles"};
inline constexpr PlausibilityRule kRuleAsciiStart{"mbascii.start", "PROTOCOLS.md §3"};
inline constexpr PlausibilityRule kRuleAsciiCharset{"mbascii.charset", "PROTOCOLS.md §3"};
inline constexpr PlausibilityRule kRuleAsciiLength{"mbascii.length", "Modbus serial line §2.5.2"};
inline constexpr PlausibilityRule kRuleAsciiTerminator{"mbascii.terminator", "PROTOCOLS.md §3"};

inline constexpr AnomalyKind kMalformed = AnomalyKind::malformed;

// The PDU layer (modbus_pdu.cpp).
inline constexpr Finding<std::string_view, std::size_t, std::size_t> kFindingFieldCut{
    "modbus.field_cut", kMalformed, Severity::error, "{}: {} bytes announced, {} present"};
inline constexpr Finding<std::string_view> kFindingFrameEndsBefore{
    "modbus.frame_ends_before", kMalformed, Severity::error, "frame ends before {}"};
inline constexpr Finding<std::size_t> kFindingExtraBytes{
    "modbus.extra_bytes", kMalformed, Severity::error, "{} unexpected bytes after the PDU"};
inline constexpr Finding<std::string_view, std::size_t, std::size_t> kFindingQuantityRange{
    "modbus.quantity_range", kMalformed, Severity::error, "quantity of {} {} outside 1..{}"};
inline constexpr Finding<std::size_t> kFindingByteCountOdd{
    "modbus.byte_count_odd", kMalformed, Severity::error,
    "byte count {} is odd for 16-bit registers"};
inline constexpr Finding<std::size_t, std::size_t> kFindingByteCountPresent{
    "modbus.byte_count_present", kMalformed, Severity::error,
    "byte count says {} bytes, {} present"};
inline constexpr Finding<std::size_t> kFindingCoilValue{
    "modbus.coil_value_invalid", kMalformed, Severity::error,
    "coil value 0x{:04X} is neither 0x0000 (OFF) nor 0xFF00 (ON)"};
inline constexpr Finding<std::size_t, std::size_t, std::size_t> kFindingByteCountQuantity{
    "modbus.byte_count_quantity", kMalformed, Severity::error,
    "byte count {} does not match quantity {} (expected {})"};
inline constexpr Finding<std::size_t> kFindingReferenceType{
    "modbus.reference_type_invalid", kMalformed, Severity::error, "reference type {} (must be 6)"};
inline constexpr Finding<std::size_t, std::size_t> kFindingObjectsPresent{
    "modbus.objects_present", kMalformed, Severity::error, "{} objects announced, {} present"};
inline constexpr Finding<std::size_t> kFindingEventByteCount{
    "modbus.event_byte_count", kMalformed, Severity::error, "byte count {} below the minimum 6"};
inline constexpr Finding<std::size_t, std::size_t> kFindingWriteByteCount{
    "modbus.write_byte_count", kMalformed, Severity::error,
    "byte count {} does not match write quantity {}"};
inline constexpr Finding<std::size_t, std::size_t> kFindingFifoCount{
    "modbus.fifo_count", kMalformed, Severity::error,
    "FIFO byte count {} does not match FIFO count {}"};

// Modbus RTU framing (rtu_dissector.cpp).
inline constexpr Finding<std::size_t> kFindingRtuShort{
    "mbrtu.frame_short", kMalformed, Severity::error, "{} bytes: shorter than the minimum 4"};
inline constexpr Finding<double, std::size_t, double> kFindingRtuIntraFrameGap{
    "mbrtu.intra_frame_gap", AnomalyKind::intra_frame_gap, Severity::warning,
    "silence of {:.1f} characters before byte {} (limit t1.5 = {:.1f})"};
inline constexpr Finding<double, double> kFindingRtuShortInterframeGap{
    "mbrtu.short_interframe_gap", AnomalyKind::short_interframe_gap, Severity::warning,
    "silence before frame {:.1f} characters (minimum t3.5 = {:.1f})"};
inline constexpr ImplausibleFinding kFindingRtuImplausible =
    implausible_finding("mbrtu.implausible");

// Modbus ASCII framing (ascii_dissector.cpp).
inline constexpr Finding<> kFindingAsciiLoneTerminator{
    "mbascii.lone_terminator", kMalformed, Severity::error,
    "ends with a lone CR or LF instead of CR LF"};
inline constexpr Finding<> kFindingAsciiNoTerminator{
    "mbascii.no_terminator", kMalformed, Severity::error, "no CR LF at the end: frame cut"};
inline constexpr Finding<> kFindingAsciiNoStart{"mbascii.no_start", kMalformed, Severity::error,
                                                "does not start with ':'"};
inline constexpr Finding<char, std::size_t> kFindingAsciiOddDigits{
    "mbascii.odd_digits", kMalformed, Severity::error,
    "odd number of hex characters (stray '{}' at {})"};
inline constexpr Finding<unsigned, std::size_t> kFindingAsciiNotHex{
    "mbascii.not_hex", kMalformed, Severity::error, "character 0x{:02X} at {} is not a hex digit"};
inline constexpr Finding<> kFindingAsciiLowerCase{
    "mbascii.lower_case", kMalformed, Severity::error,
    "lower-case hex digits (the protocol uses upper case)"};
inline constexpr ImplausibleFinding kFindingAsciiImplausible =
    implausible_finding("mbascii.implausible");

// The PDU layer's findings, which both framings raise.
inline constexpr const FindingDesc* kPduFindings[] = {
    &kFindingFieldCut,       &kFindingFrameEndsBefore,   &kFindingExtraBytes,
    &kFindingQuantityRange,  &kFindingByteCountOdd,      &kFindingByteCountPresent,
    &kFindingCoilValue,      &kFindingByteCountQuantity, &kFindingReferenceType,
    &kFindingObjectsPresent, &kFindingEventByteCount,    &kFindingWriteByteCount,
    &kFindingFifoCount,
};
inline constexpr const FindingDesc* kRtuFramingFindings[] = {
    &kFindingRtuShort,
    &kFindingRtuIntraFrameGap,
    &kFindingRtuShortInterframeGap,
    &kFindingRtuImplausible,
};
inline constexpr const FindingDesc* kAsciiFramingFindings[] = {
    &kFindingAsciiLoneTerminator, &kFindingAsciiNoTerminator, &kFindingAsciiNoStart,
    &kFindingAsciiOddDigits,      &kFindingAsciiNotHex,       &kFindingAsciiLowerCase,
    &kFindingAsciiImplausible,
};

// A framing's findings followed by the PDU layer's.
template <std::size_t N>
constexpr std::array<const FindingDesc*, N + std::size(kPduFindings)> with_pdu_findings(
    const FindingDesc* const (&framing)[N]) {
  std::array<const FindingDesc*, N + std::size(kPduFindings)> all{};
  std::size_t k = 0;
  for (const FindingDesc* f : framing) all[k++] = f;
  for (const FindingDesc* f : kPduFindings) all[k++] = f;
  return all;
}
// Each framing's own, then the PDU layer's.
inline constexpr auto kRtuFindings = with_pdu_findings(kRtuFramingFindings);
inline constexpr auto kAsciiFindings = with_pdu_findings(kAsciiFramingFindings);

}  // namespace drivetap::modbus
