// Field descriptors of the Modbus PDU and the RTU and ASCII framings (Modbus Application Protocol
// V1.1b3; docs/protocols.md §2, §3). Ids are stable: JSON keys, -V lines and tests use them. They
// are Wireshark 4.0's where Wireshark has the field (`modbus.*` for the PDU, shared by RTU and
// ASCII as Wireshark's modbus dissector is by RTU and TCP; `mbrtu.*` for RTU framing), with a type
// Wireshark's agrees with; `mbascii.*` for ASCII framing, which Wireshark does not dissect.
#pragma once

#include <array>

#include "core/field.hpp"

namespace drivetap::modbus {

inline constexpr std::array kFunctionNames = {
    ValueName{0x01, "Read Coils"},
    ValueName{0x02, "Read Discrete Inputs"},
    ValueName{0x03, "Read Holding Registers"},
    ValueName{0x04, "Read Input Registers"},
    ValueName{0x05, "Write Single Coil"},
    ValueName{0x06, "Write Single Register"},
    ValueName{0x07, "Read Exception Status"},
    ValueName{0x08, "Diagnostics"},
    ValueName{0x0B, "Get Comm Event Counter"},
    ValueName{0x0C, "Get Comm Event Log"},
    ValueName{0x0F, "Write Multiple Coils"},
    ValueName{0x10, "Write Multiple Registers"},
    ValueName{0x11, "Report Server ID"},
    ValueName{0x14, "Read File Record"},
    ValueName{0x15, "Write File Record"},
    ValueName{0x16, "Mask Write Register"},
    ValueName{0x17, "Read/Write Multiple Registers"},
    ValueName{0x18, "Read FIFO Queue"},
    ValueName{0x2B, "Encapsulated Interface Transport"},
};

inline constexpr std::array kExceptionNames = {
    ValueName{0x01, "Illegal Function"},
    ValueName{0x02, "Illegal Data Address"},
    ValueName{0x03, "Illegal Data Value"},
    ValueName{0x04, "Server Device Failure"},
    ValueName{0x05, "Acknowledge"},
    ValueName{0x06, "Server Device Busy"},
    ValueName{0x07, "Negative Acknowledge"},
    ValueName{0x08, "Memory Parity Error"},
    ValueName{0x0A, "Gateway Path Unavailable"},
    ValueName{0x0B, "Gateway Target Device Failed to Respond"},
};

// What the standard exception codes mean to the engineer whose master got them, in plain words
// (diagnose's exception verdict); any other code is the vendor's.
inline constexpr std::array kExceptionMeanings = {
    ValueName{0x01, "function not supported"},      ValueName{0x02, "no such register"},
    ValueName{0x03, "value out of range"},          ValueName{0x04, "the drive failed"},
    ValueName{0x05, "acknowledged, still working"}, ValueName{0x06, "busy"},
};
constexpr std::string_view exception_meaning(std::uint32_t code) {
  for (const ValueName& v : kExceptionMeanings)
    if (v.value == code) return v.name;
  return "vendor code";
}

inline constexpr std::array kDiagnosticSubfunctions = {
    ValueName{0x00, "Return Query Data"},
    ValueName{0x01, "Restart Communications Option"},
    ValueName{0x02, "Return Diagnostic Register"},
    ValueName{0x03, "Change ASCII Input Delimiter"},
    ValueName{0x04, "Force Listen Only Mode"},
    ValueName{0x0A, "Clear Counters and Diagnostic Register"},
    ValueName{0x0B, "Return Bus Message Count"},
    ValueName{0x0C, "Return Bus Communication Error Count"},
    ValueName{0x0D, "Return Bus Exception Error Count"},
    ValueName{0x0E, "Return Server Message Count"},
    ValueName{0x0F, "Return Server No Response Count"},
    ValueName{0x10, "Return Server NAK Count"},
    ValueName{0x11, "Return Server Busy Count"},
    ValueName{0x12, "Return Bus Character Overrun Count"},
    ValueName{0x14, "Clear Overrun Counter and Flag"},
};

inline constexpr std::array kMeiTypes = {
    ValueName{0x0D, "CANopen General Reference"},
    ValueName{0x0E, "Read Device Identification"},
};

inline constexpr std::array kDeviceIdCodes = {
    ValueName{0x01, "basic"},
    ValueName{0x02, "regular"},
    ValueName{0x03, "extended"},
    ValueName{0x04, "one specific object"},
};

inline constexpr std::array kDeviceObjectNames = {
    ValueName{0x00, "VendorName"},          ValueName{0x01, "ProductCode"},
    ValueName{0x02, "MajorMinorRevision"},  ValueName{0x03, "VendorUrl"},
    ValueName{0x04, "ProductName"},         ValueName{0x05, "ModelName"},
    ValueName{0x06, "UserApplicationName"},
};

inline constexpr std::array kCoilValues = {
    ValueName{0x0000, "OFF"},
    ValueName{0xFF00, "ON"},
};

// RTU framing (Wireshark's mbrtu).
inline constexpr FieldDesc kRtuUnitId{"mbrtu.unit_id", "Unit ID (station address)", FieldType::uint,
                                      8};
inline constexpr FieldDesc kRtuCrc{
    .id = "mbrtu.crc16",
    .name = "CRC-16",
    .type = FieldType::hex,
    .bits = 16,
    .blurb = "The two CRC bytes as they are on the wire (low byte first), read as one number"};
// ASCII framing (no Wireshark dissector: drivetap's own prefix).
inline constexpr FieldDesc kAsciiUnitId{"mbascii.unit_id", "Unit ID (station address)",
                                        FieldType::uint, 8};
inline constexpr FieldDesc kAsciiLrc{"mbascii.lrc", "LRC", FieldType::hex, 8};

// PDU (Wireshark's modbus). Several descriptors may share one id with their own label
// (FieldDesc::shares_id_of): Wireshark calls every address a "reference number".
inline constexpr FieldDesc kFunction{.id = "modbus.func_code",
                                     .name = "Function code",
                                     .type = FieldType::enumerated,
                                     .bits = 8,
                                     .names = kFunctionNames,
                                     .blurb = "Without the exception bit (0x80), as Wireshark",
                                     .bitmask = 0x7F};
inline constexpr FieldDesc kExceptionCode{"modbus.exception_code", "Exception code",
                                          FieldType::enumerated, 8, kExceptionNames};
inline constexpr FieldDesc kReference{"modbus.reference_num", "Starting address", FieldType::hex,
                                      16};
inline constexpr FieldDesc kWordCount{"modbus.word_cnt", "Quantity of registers", FieldType::uint,
                                      16};
inline constexpr FieldDesc kBitCount{"modbus.bit_cnt", "Quantity of coils or inputs",
                                     FieldType::uint, 16};
inline constexpr FieldDesc kByteCount{"modbus.byte_cnt", "Byte count", FieldType::uint, 8};
inline constexpr FieldDesc kRegisterValue{"modbus.regval_uint16", "Register", FieldType::uint, 16};
inline constexpr FieldDesc kBitValues = text_field(
    "modbus.bits", "Bit values", "Coils or inputs, first one first (bit 0 of the first byte)");
inline constexpr FieldDesc kOutputAddress =
    sharing_id_of(kReference, "Output address", FieldType::hex);
inline constexpr FieldDesc kCoilValue{"modbus.coil_value", "Coil value", FieldType::enumerated, 16,
                                      kCoilValues};
inline constexpr FieldDesc kRegisterAddress =
    sharing_id_of(kReference, "Register address", FieldType::hex);
inline constexpr FieldDesc kWriteValue =
    sharing_id_of(kRegisterValue, "Register value", FieldType::hex);
inline constexpr FieldDesc kExceptionStatus{"modbus.exception_status", "Exception status",
                                            FieldType::hex, 8};
inline constexpr FieldDesc kSubFunction{"modbus.diagnostic_code", "Sub-function",
                                        FieldType::enumerated, 16, kDiagnosticSubfunctions};
inline constexpr FieldDesc kDiagData{"modbus.diagnostic_data", "Diagnostic data", FieldType::bytes};
inline constexpr FieldDesc kCommStatus{"modbus.ev_status", "Status", FieldType::hex, 16};
inline constexpr FieldDesc kEventCount{"modbus.ev_count", "Event count", FieldType::uint, 16};
inline constexpr FieldDesc kMessageCount{"modbus.ev_msg_count", "Message count", FieldType::uint,
                                         16};
inline constexpr FieldDesc kEvent{"modbus.event", "Event", FieldType::hex, 8};
inline constexpr FieldDesc kServerId{"modbus.server_id", "Server ID and status", FieldType::bytes};
inline constexpr FieldDesc kData{"modbus.data", "Data", FieldType::bytes};
inline constexpr FieldDesc kFileSubRequest{"modbus.file", "File sub-request", FieldType::group};
inline constexpr FieldDesc kFileRefType{"modbus.reference_type", "Reference type", FieldType::uint,
                                        8};
inline constexpr FieldDesc kFileNumber{"modbus.file.number", "File number", FieldType::uint, 16};
inline constexpr FieldDesc kFileRecord{"modbus.file.record", "Record number", FieldType::uint, 16};
inline constexpr FieldDesc kFileRecordLength =
    sharing_id_of(kWordCount, "Record length", FieldType::uint);
inline constexpr FieldDesc kFileResponseLength =
    sharing_id_of(kByteCount, "Sub-response length", FieldType::uint);
inline constexpr FieldDesc kFileData = sharing_id_of(kData, "Record data", FieldType::bytes);
inline constexpr FieldDesc kAndMask{"modbus.and_mask", "AND mask", FieldType::hex, 16};
inline constexpr FieldDesc kOrMask{"modbus.or_mask", "OR mask", FieldType::hex, 16};
inline constexpr FieldDesc kReadStart{"modbus.read_reference_num", "Read starting address",
                                      FieldType::hex, 16};
inline constexpr FieldDesc kReadQuantity{"modbus.read_word_cnt", "Quantity to read",
                                         FieldType::uint, 16};
inline constexpr FieldDesc kWriteStart{"modbus.write_reference_num", "Write starting address",
                                       FieldType::hex, 16};
inline constexpr FieldDesc kWriteQuantity{"modbus.write_word_cnt", "Quantity to write",
                                          FieldType::uint, 16};
inline constexpr FieldDesc kFifoPointer =
    sharing_id_of(kReference, "FIFO pointer address", FieldType::hex);
inline constexpr FieldDesc kFifoByteCount{"modbus.byte_cnt_16", "FIFO byte count", FieldType::uint,
                                          16};
inline constexpr FieldDesc kFifoCount = sharing_id_of(kWordCount, "FIFO count", FieldType::uint);
inline constexpr FieldDesc kMeiType{"modbus.mei", "MEI type", FieldType::enumerated, 8, kMeiTypes};
inline constexpr FieldDesc kMeiDeviceIdCode{"modbus.read_device_id", "Read device ID code",
                                            FieldType::enumerated, 8, kDeviceIdCodes};
inline constexpr FieldDesc kMeiObjectId{"modbus.object_id", "Object ID", FieldType::enumerated, 8,
                                        kDeviceObjectNames};
inline constexpr FieldDesc kMeiConformity{"modbus.conformity_level", "Conformity level",
                                          FieldType::hex, 8};
inline constexpr FieldDesc kMeiMoreFollows{"modbus.more_follows", "More follows", FieldType::hex,
                                           8};
inline constexpr FieldDesc kMeiNextObject{"modbus.next_object_id", "Next object ID", FieldType::hex,
                                          8};
inline constexpr FieldDesc kMeiObjectCount{"modbus.num_objects", "Number of objects",
                                           FieldType::uint, 8};
inline constexpr FieldDesc kMeiObject{"modbus.object", "Object", FieldType::group};
inline constexpr FieldDesc kMeiObjectLength{"modbus.objects_len", "Object length", FieldType::uint,
                                            8};
inline constexpr FieldDesc kMeiObjectBytes{"modbus.object_value", "Object bytes", FieldType::bytes};
inline constexpr FieldDesc kMeiObjectValue =
    text_field("modbus.object_str_value", "Object value",
               "The object's bytes as text, '.' for a byte that is no printable ASCII character");

// The descriptors listed under each id (the ones sharing an id are not: shares_id_of).
inline constexpr const FieldDesc* kRtuFramingFields[] = {&kRtuUnitId, &kRtuCrc};
inline constexpr const FieldDesc* kAsciiFramingFields[] = {&kAsciiUnitId, &kAsciiLrc};
inline constexpr const FieldDesc* kPduFields[] = {
    &kFunction,        &kExceptionCode,   &kReference,
    &kWordCount,       &kBitCount,        &kByteCount,
    &kRegisterValue,   &kBitValues,       &kCoilValue,
    &kExceptionStatus, &kSubFunction,     &kDiagData,
    &kCommStatus,      &kEventCount,      &kMessageCount,
    &kEvent,           &kServerId,        &kData,
    &kFileSubRequest,  &kFileRefType,     &kFileNumber,
    &kFileRecord,      &kAndMask,         &kOrMask,
    &kReadStart,       &kReadQuantity,    &kWriteStart,
    &kWriteQuantity,   &kFifoByteCount,   &kMeiType,
    &kMeiDeviceIdCode, &kMeiObjectId,     &kMeiConformity,
    &kMeiMoreFollows,  &kMeiNextObject,   &kMeiObjectCount,
    &kMeiObject,       &kMeiObjectLength, &kMeiObjectBytes,
    &kMeiObjectValue,
};

// The layers: RTU and ASCII each have their framing's and share the PDU's.
inline constexpr FieldProtocol kRtuFieldProtocol{"Modbus RTU", "mbrtu", kRtuFramingFields};
inline constexpr FieldProtocol kAsciiFieldProtocol{"Modbus ASCII", "mbascii", kAsciiFramingFields};
inline constexpr FieldProtocol kPduFieldProtocol{"Modbus", "modbus", kPduFields};
inline constexpr const FieldProtocol* kRtuFieldProtocols[] = {&kRtuFieldProtocol,
                                                              &kPduFieldProtocol};
inline constexpr const FieldProtocol* kAsciiFieldProtocols[] = {&kAsciiFieldProtocol,
                                                                &kPduFieldProtocol};

}  // namespace drivetap::modbus
