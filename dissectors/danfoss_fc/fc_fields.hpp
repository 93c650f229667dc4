// Field descriptors of the Danfoss FC protocol (docs/protocols.md §4; 002 §7.2-7.5, §7.11). Ids
// start `danfoss_fc.`: Wireshark has no dissector for it, and its `fc` is Fibre Channel.
#pragma once

#include <array>

#include "core/field.hpp"

namespace drivetap::danfoss_fc {

inline constexpr std::array kRequestAk = {
    ValueName{0x0, "no request"},
    ValueName{0x1, "read parameter value"},
    ValueName{0x2, "write parameter value in RAM (word)"},
    ValueName{0x3, "write parameter value in RAM (double word)"},
    ValueName{0xD, "write parameter value in RAM and EEPROM (double word)"},
    ValueName{0xE, "write parameter value in RAM and EEPROM (word)"},
    ValueName{0xF, "read/write text"},
};
inline constexpr std::array kResponseAk = {
    ValueName{0x0, "no response"},
    ValueName{0x1, "parameter value transferred (word)"},
    ValueName{0x2, "parameter value transferred (double word)"},
    ValueName{0x7, "command cannot be performed"},
    ValueName{0xF, "text transferred"},
};
inline constexpr std::array kErrorNumbers = {
    ValueName{0x00, "illegal parameter number"},
    ValueName{0x01, "parameter cannot be changed"},
    ValueName{0x02, "upper or lower limit exceeded"},
    ValueName{0x03, "sub-index corrupted (does not exist)"},
    ValueName{0x04, "no array"},
    ValueName{0x05, "wrong data type"},
    ValueName{0x11, "data change not possible in this mode"},
    ValueName{0x12, "other error"},
    ValueName{0x17, "database busy"},
    ValueName{0x82, "no bus access to this parameter"},
    ValueName{0x83, "data change not possible: factory setup selected"},
};

inline constexpr FieldDesc kStx{"danfoss_fc.stx", "Start (STX)", FieldType::hex, 8};
inline constexpr FieldDesc kLge{"danfoss_fc.lge", "Telegram length (LGE)", FieldType::uint, 8};
inline constexpr FieldDesc kAdr{"danfoss_fc.adr", "Address byte (ADR)", FieldType::hex, 8};
inline constexpr FieldDesc kAddress{
    .id = "danfoss_fc.addr",
    .name = "Drive address",
    .type = FieldType::uint,
    .bits = 8,
    .blurb = "The address the ADR byte names, in either of its two forms"};
inline constexpr FieldDesc kBroadcast{"danfoss_fc.broadcast", "Broadcast", FieldType::boolean};
inline constexpr FieldDesc kPke{"danfoss_fc.pke", "Parameter command (PKE)", FieldType::hex, 16};
inline constexpr FieldDesc kAkRequest{.id = "danfoss_fc.pke.ak",
                                      .name = "Request (AK)",
                                      .type = FieldType::enumerated,
                                      .bits = 8,
                                      .names = kRequestAk,
                                      .blurb = "Request or response characteristic (by direction)",
                                      .bitmask = 0xF0};
inline constexpr FieldDesc kAkResponse =
    sharing_id_of(kAkRequest, "Response (AK)", FieldType::enumerated, kResponseAk);
inline constexpr FieldDesc kPnu{.id = "danfoss_fc.pke.pnu",
                                .name = "Parameter number (PNU)",
                                .type = FieldType::uint,
                                .bits = 16,
                                .bitmask = 0x0FFF};
inline constexpr FieldDesc kParameter =
    text_field("danfoss_fc.param", "Parameter", "The parameter as the drive's manual numbers it");
inline constexpr FieldDesc kInd{"danfoss_fc.ind", "Index (IND)", FieldType::hex, 16};
inline constexpr FieldDesc kPwe{"danfoss_fc.pwe", "Parameter value (PWE)", FieldType::uint, 32};
inline constexpr FieldDesc kErrorNumber{"danfoss_fc.error", "Error number", FieldType::enumerated,
                                        16, kErrorNumbers};
inline constexpr FieldDesc kText = text_field("danfoss_fc.text", "Text");
inline constexpr FieldDesc kCtw{"danfoss_fc.ctw", "Control word (CTW)", FieldType::hex, 16};
inline constexpr FieldDesc kStw{"danfoss_fc.stw", "Status word (STW)", FieldType::hex, 16};
inline constexpr FieldDesc kCtwMeaning =
    text_field("danfoss_fc.ctw.meaning", "Control word meaning");
inline constexpr FieldDesc kStwMeaning =
    text_field("danfoss_fc.stw.meaning", "Status word meaning");
inline constexpr FieldDesc kReference =
    text_field("danfoss_fc.ref", "Speed reference (REF)", "Percent of the maximum reference");
inline constexpr FieldDesc kMav =
    text_field("danfoss_fc.mav", "Main actual value (MAV)", "Percent of the maximum reference");
inline constexpr FieldDesc kPcd{"danfoss_fc.pcd", "Process data (PCD)", FieldType::hex, 16};
inline constexpr FieldDesc kBcc{"danfoss_fc.bcc", "Block check (BCC)", FieldType::hex, 8};

inline constexpr const FieldDesc* kAllFields[] = {
    &kStx, &kLge,        &kAdr,        &kAddress,   &kBroadcast,   &kPke,  &kAkRequest,
    &kPnu, &kParameter,  &kInd,        &kPwe,       &kErrorNumber, &kText, &kCtw,
    &kStw, &kCtwMeaning, &kStwMeaning, &kReference, &kMav,         &kPcd,  &kBcc,
};
// kAkResponse shares the id "danfoss_fc.pke.ak" with kAkRequest (the meaning depends on the
// direction); it is listed once, under kAkRequest (kAkResponse.shares_id_of), and is the label of
// a reply's AK in Wireshark (kResponseFields).

inline constexpr const FieldDesc* kResponseFields[] = {&kAkResponse};

inline constexpr FieldProtocol kFieldProtocol{"Danfoss FC", "danfoss_fc", kAllFields,
                                              kResponseFields};
inline constexpr const FieldProtocol* kFieldProtocols[] = {&kFieldProtocol};

}  // namespace drivetap::danfoss_fc
