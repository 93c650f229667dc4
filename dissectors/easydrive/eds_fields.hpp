// Field descriptors of the Easydrive ASCII protocol (docs/protocols.md §5). Ids start
// `easydrive.` (Wireshark has no dissector for it). Numbers are sent as hex characters: a field's
// width is that of the value the characters spell.
#pragma once

#include <array>

#include "core/field.hpp"

namespace drivetap::easydrive {

inline constexpr std::array kCommands = {
    ValueName{0x0A, "status query"},        ValueName{0x0B, "read running value"},
    ValueName{0x0C, "run control"},         ValueName{0x0D, "read function code"},
    ValueName{0x0E, "write function code"}, ValueName{0x0F, "read software version"},
};
inline constexpr std::array kResponseCodes = {
    ValueName{0x00, "OK"},
    ValueName{0x10, "not ready"},
    ValueName{0x11, "ready (control and frequency by this link)"},
    ValueName{0x12, "ready (control by this link)"},
    ValueName{0x13, "ready (frequency by this link)"},
    ValueName{0x14, "ready (neither by this link)"},
    ValueName{0x20, "frame, checksum, range, length or character error"},
    ValueName{0x30, "control not effective, value out of range or password"},
};
inline constexpr std::array kRunningValues = {
    ValueName{0x0, "set frequency"},
    ValueName{0x1, "output frequency"},
    ValueName{0x2, "output current"},
    ValueName{0x3, "output voltage"},
    ValueName{0x4, "DC bus voltage"},
    ValueName{0x5, "motor speed"},
    ValueName{0x6, "module temperature"},
    ValueName{0x7, "run time"},
    ValueName{0x8, "total run time"},
    ValueName{0x9, "input terminals"},
    ValueName{0xA, "output terminals"},
    ValueName{0xB, "VCI"},
    ValueName{0xC, "CCI"},
    ValueName{0xD, "YCI"},
    ValueName{0xE, "pulse input"},
    ValueName{0xF, "status word"},
};
inline constexpr std::array kRunActions = {
    ValueName{0x1, "set running frequency"},
    ValueName{0x2, "run with frequency"},
    ValueName{0x3, "run forward"},
    ValueName{0x4, "run reverse"},
    ValueName{0x5, "run forward with frequency"},
    ValueName{0x6, "run reverse with frequency"},
    ValueName{0x7, "stop"},
    ValueName{0x8, "jog"},
    ValueName{0x9, "jog forward"},
    ValueName{0xA, "jog reverse"},
    ValueName{0xB, "stop jog"},
    ValueName{0xC, "fault reset"},
    ValueName{0xE, "emergency stop"},
};

inline constexpr FieldDesc kStart = text_field("easydrive.start", "Start ('~')");
inline constexpr FieldDesc kAddr{"easydrive.addr", "Address", FieldType::uint, 8};
inline constexpr FieldDesc kCommand{"easydrive.cmd", "Command", FieldType::enumerated, 8,
                                    kCommands};
inline constexpr FieldDesc kResponse{"easydrive.resp", "Response code", FieldType::enumerated, 8,
                                     kResponseCodes};
inline constexpr FieldDesc kFault{"easydrive.fault", "Current fault code (AUX)", FieldType::uint,
                                  8};
inline constexpr FieldDesc kIndex{"easydrive.index", "Index", FieldType::hex, 16};
inline constexpr FieldDesc kIndexName = text_field("easydrive.index_name", "Index meaning");
inline constexpr FieldDesc kData{"easydrive.data", "Data", FieldType::hex, 16};
inline constexpr FieldDesc kValue =
    text_field("easydrive.value", "Value", "The data in the unit the index gives it");
inline constexpr FieldDesc kSum{"easydrive.sum", "Checksum (SUM)", FieldType::hex, 16};

inline constexpr const FieldDesc* kAllFields[] = {
    &kStart, &kAddr, &kCommand, &kResponse, &kFault, &kIndex, &kIndexName, &kData, &kValue, &kSum,
};

inline constexpr FieldProtocol kFieldProtocol{"Easydrive", "easydrive", kAllFields};
inline constexpr const FieldProtocol* kFieldProtocols[] = {&kFieldProtocol};

}  // namespace drivetap::easydrive
