// Field descriptors of the Danfoss FC protocol (docs/protocols.md §4; 002 §7.2-7.5, §7.11).
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

inline constexpr FieldDesc kStx{"fc.stx", "Start (STX)", FieldType::hex, 2};
inline constexpr FieldDesc kLge{"fc.lge", "Telegram length (LGE)", FieldType::uint};
inline constexpr FieldDesc kAdr{"fc.adr", "Address byte (ADR)", FieldType::hex, 2};
inline constexpr FieldDesc kAddress{"fc.address", "Drive address", FieldType::uint};
inline constexpr FieldDesc kBroadcast{"fc.broadcast", "Broadcast", FieldType::boolean};
inline constexpr FieldDesc kPke{"fc.pke", "Parameter command (PKE)", FieldType::hex, 4};
inline constexpr FieldDesc kAkRequest{"fc.pke.ak", "Request (AK)", FieldType::enumerated, 1,
                                      kRequestAk};
inline constexpr FieldDesc kAkResponse{.id = "fc.pke.ak",
                                       .name = "Response (AK)",
                                       .type = FieldType::enumerated,
                                       .hex_digits = 1,
                                       .names = kResponseAk,
                                       .shares_id_of = &kAkRequest};
inline constexpr FieldDesc kPnu{"fc.pke.pnu", "Parameter number (PNU)", FieldType::uint};
inline constexpr FieldDesc kParameter{"fc.param", "Parameter", FieldType::text};
inline constexpr FieldDesc kInd{"fc.ind", "Index (IND)", FieldType::hex, 4};
inline constexpr FieldDesc kPwe{"fc.pwe", "Parameter value (PWE)", FieldType::uint};
inline constexpr FieldDesc kErrorNumber{"fc.error", "Error number", FieldType::enumerated, 2,
                                        kErrorNumbers};
inline constexpr FieldDesc kText{"fc.text", "Text", FieldType::text};
inline constexpr FieldDesc kCtw{"fc.ctw", "Control word (CTW)", FieldType::hex, 4};
inline constexpr FieldDesc kStw{"fc.stw", "Status word (STW)", FieldType::hex, 4};
inline constexpr FieldDesc kCtwMeaning{"fc.ctw.meaning", "Control word meaning", FieldType::text};
inline constexpr FieldDesc kStwMeaning{"fc.stw.meaning", "Status word meaning", FieldType::text};
inline constexpr FieldDesc kReference{"fc.ref", "Speed reference (REF)", FieldType::text};
inline constexpr FieldDesc kMav{"fc.mav", "Main actual value (MAV)", FieldType::text};
inline constexpr FieldDesc kPcd{"fc.pcd", "Process data (PCD)", FieldType::hex, 4};
inline constexpr FieldDesc kBcc{"fc.bcc", "Block check (BCC)", FieldType::hex, 2};

inline constexpr const FieldDesc* kAllFields[] = {
    &kStx, &kLge,        &kAdr,        &kAddress,   &kBroadcast,   &kPke,  &kAkRequest,
    &kPnu, &kParameter,  &kInd,        &kPwe,       &kErrorNumber, &kText, &kCtw,
    &kStw, &kCtwMeaning, &kStwMeaning, &kReference, &kMav,         &kPcd,  &kBcc,
};
// kAkResponse shares the id "fc.pke.ak" with kAkRequest (the meaning depends on the direction);
// it is listed once, under kAkRequest (kAkResponse.shares_id_of).

}  // namespace drivetap::danfoss_fc
