// Field descriptors of the Modbus PDU and RTU framing (Modbus Application Protocol V1.1b3;
// docs/protocols.md §2). Ids are stable: JSON keys, -V lines and tests use them.
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

// RTU framing
inline constexpr FieldDesc kAddr{"modbus.addr", "Station address", FieldType::uint};
inline constexpr FieldDesc kCrc{"modbus.crc", "CRC-16", FieldType::bytes};
inline constexpr FieldDesc kLrc{"modbus.lrc", "LRC", FieldType::hex, 2};
// PDU
inline constexpr FieldDesc kFunction{"modbus.fc", "Function code", FieldType::enumerated, 2,
                                     kFunctionNames};
inline constexpr FieldDesc kExceptionFunction{"modbus.exception_fc", "Function in error",
                                              FieldType::enumerated, 2, kFunctionNames};
inline constexpr FieldDesc kExceptionCode{"modbus.exception_code", "Exception code",
                                          FieldType::enumerated, 2, kExceptionNames};
inline constexpr FieldDesc kStartAddress{"modbus.start_addr", "Starting address", FieldType::hex,
                                         4};
inline constexpr FieldDesc kQuantity{"modbus.quantity", "Quantity", FieldType::uint};
inline constexpr FieldDesc kByteCount{"modbus.byte_count", "Byte count", FieldType::uint};
inline constexpr FieldDesc kRegisterValue{"modbus.reg", "Register", FieldType::uint};
inline constexpr FieldDesc kBitValues{"modbus.bits", "Bit values", FieldType::text};
inline constexpr FieldDesc kOutputAddress{"modbus.output_addr", "Output address", FieldType::hex,
                                          4};
inline constexpr FieldDesc kCoilValue{"modbus.coil_value", "Coil value", FieldType::enumerated, 4,
                                      kCoilValues};
inline constexpr FieldDesc kRegisterAddress{"modbus.reg_addr", "Register address", FieldType::hex,
                                            4};
inline constexpr FieldDesc kWriteValue{"modbus.write_value", "Register value", FieldType::hex, 4};
inline constexpr FieldDesc kExceptionStatus{"modbus.exception_status", "Exception status",
                                            FieldType::hex, 2};
inline constexpr FieldDesc kSubFunction{"modbus.diag.sub", "Sub-function", FieldType::enumerated, 4,
                                        kDiagnosticSubfunctions};
inline constexpr FieldDesc kDiagData{"modbus.diag.data", "Diagnostic data", FieldType::bytes};
inline constexpr FieldDesc kCommStatus{"modbus.comm.status", "Status", FieldType::hex, 4};
inline constexpr FieldDesc kEventCount{"modbus.comm.event_count", "Event count", FieldType::uint};
inline constexpr FieldDesc kMessageCount{"modbus.comm.message_count", "Message count",
                                         FieldType::uint};
inline constexpr FieldDesc kEvents{"modbus.comm.events", "Events", FieldType::bytes};
inline constexpr FieldDesc kServerId{"modbus.server_id", "Server ID and status", FieldType::bytes};
inline constexpr FieldDesc kData{"modbus.data", "Data", FieldType::bytes};
inline constexpr FieldDesc kFileSubRequest{"modbus.file", "File sub-request", FieldType::group};
inline constexpr FieldDesc kFileRefType{"modbus.file.ref_type", "Reference type", FieldType::uint};
inline constexpr FieldDesc kFileNumber{"modbus.file.number", "File number", FieldType::uint};
inline constexpr FieldDesc kFileRecord{"modbus.file.record", "Record number", FieldType::uint};
inline constexpr FieldDesc kFileRecordLength{"modbus.file.length", "Record length",
                                             FieldType::uint};
inline constexpr FieldDesc kFileData{"modbus.file.data", "Record data", FieldType::bytes};
inline constexpr FieldDesc kAndMask{"modbus.and_mask", "AND mask", FieldType::hex, 4};
inline constexpr FieldDesc kOrMask{"modbus.or_mask", "OR mask", FieldType::hex, 4};
inline constexpr FieldDesc kReadStart{"modbus.read_start", "Read starting address", FieldType::hex,
                                      4};
inline constexpr FieldDesc kReadQuantity{"modbus.read_quantity", "Quantity to read",
                                         FieldType::uint};
inline constexpr FieldDesc kWriteStart{"modbus.write_start", "Write starting address",
                                       FieldType::hex, 4};
inline constexpr FieldDesc kWriteQuantity{"modbus.write_quantity", "Quantity to write",
                                          FieldType::uint};
inline constexpr FieldDesc kFifoPointer{"modbus.fifo.pointer", "FIFO pointer address",
                                        FieldType::hex, 4};
inline constexpr FieldDesc kFifoByteCount{"modbus.fifo.byte_count", "FIFO byte count",
                                          FieldType::uint};
inline constexpr FieldDesc kFifoCount{"modbus.fifo.count", "FIFO count", FieldType::uint};
inline constexpr FieldDesc kMeiType{"modbus.mei.type", "MEI type", FieldType::enumerated, 2,
                                    kMeiTypes};
inline constexpr FieldDesc kMeiDeviceIdCode{"modbus.mei.read_dev_id", "Read device ID code",
                                            FieldType::enumerated, 2, kDeviceIdCodes};
inline constexpr FieldDesc kMeiObjectId{"modbus.mei.object_id", "Object ID", FieldType::enumerated,
                                        2, kDeviceObjectNames};
inline constexpr FieldDesc kMeiConformity{"modbus.mei.conformity", "Conformity level",
                                          FieldType::hex, 2};
inline constexpr FieldDesc kMeiMoreFollows{"modbus.mei.more_follows", "More follows",
                                           FieldType::hex, 2};
inline constexpr FieldDesc kMeiNextObject{"modbus.mei.next_object_id", "Next object ID",
                                          FieldType::hex, 2};
inline constexpr FieldDesc kMeiObjectCount{"modbus.mei.object_count", "Number of objects",
                                           FieldType::uint};
inline constexpr FieldDesc kMeiObject{"modbus.mei.object", "Object", FieldType::group};
inline constexpr FieldDesc kMeiObjectValue{"modbus.mei.object_value", "Object value",
                                           FieldType::text};

inline constexpr const FieldDesc* kAllFields[] = {
    &kAddr,
    &kLrc,
    &kCrc,
    &kFunction,
    &kExceptionFunction,
    &kExceptionCode,
    &kStartAddress,
    &kQuantity,
    &kByteCount,
    &kRegisterValue,
    &kBitValues,
    &kOutputAddress,
    &kCoilValue,
    &kRegisterAddress,
    &kWriteValue,
    &kExceptionStatus,
    &kSubFunction,
    &kDiagData,
    &kCommStatus,
    &kEventCount,
    &kMessageCount,
    &kEvents,
    &kServerId,
    &kData,
    &kFileSubRequest,
    &kFileRefType,
    &kFileNumber,
    &kFileRecord,
    &kFileRecordLength,
    &kFileData,
    &kAndMask,
    &kOrMask,
    &kReadStart,
    &kReadQuantity,
    &kWriteStart,
    &kWriteQuantity,
    &kFifoPointer,
    &kFifoByteCount,
    &kFifoCount,
    &kMeiType,
    &kMeiDeviceIdCode,
    &kMeiObjectId,
    &kMeiConformity,
    &kMeiMoreFollows,
    &kMeiNextObject,
    &kMeiObjectCount,
    &kMeiObject,
    &kMeiObjectValue,
};

}  // namespace drivetap::modbus
