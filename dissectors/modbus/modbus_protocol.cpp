// The Modbus RTU and Modbus ASCII descriptors (docs/protocols.md §2, §3): names, decoders, fields,
// findings.
#include "dissectors/modbus/modbus_protocol.hpp"

#include "dissectors/modbus/ascii_dissector.hpp"
#include "dissectors/modbus/modbus_fields.hpp"
#include "dissectors/modbus/modbus_findings.hpp"
#include "dissectors/modbus/rtu_dissector.hpp"

namespace drivetap::modbus {
namespace {

constexpr std::string_view kRtuNames[] = {"rtu", "modbus-rtu"};
constexpr std::string_view kAsciiNames[] = {"ascii", "modbus-ascii"};
const RtuDecoder kRtuDecoder{};
const AsciiDecoder kAsciiDecoder{};

}  // namespace

const ProtocolDesc kRtuProtocol{
    .id = "modbus-rtu",
    .label = "Modbus RTU",
    .help = "Modbus RTU",
    .option_names = kRtuNames,
    .decoder = &kRtuDecoder,
    .fields = kAllFields,
    .findings = kRtuFindings,
    .text_start = 0,
    .wireshark_dissector = "mbrtu",
};

const ProtocolDesc kAsciiProtocol{
    .id = "modbus-ascii",
    .label = "Modbus ASCII",
    .help = "Modbus ASCII",
    .option_names = kAsciiNames,
    .decoder = &kAsciiDecoder,
    .fields = kAllFields,
    .findings = kAsciiFindings,
    .text_start = ':',
    .wireshark_dissector = {},
};

}  // namespace drivetap::modbus
