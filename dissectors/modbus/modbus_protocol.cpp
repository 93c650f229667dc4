// The Modbus RTU and Modbus ASCII descriptors (docs/protocols.md §2, §3): names, decoders, fields,
// findings.
#include <fmt/format.h>

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

// "GG-PP" (E5-8200, E-9): the parameter is the holding register GG << 8 | PP.
std::optional<std::uint32_t> parse_ggpp(std::string_view group, std::uint32_t number) {
  const auto g = decimal_number(group);
  if (!g || *g > 255 || number > 255) return std::nullopt;
  return *g << 8 | number;
}
std::string ggpp_label(std::uint32_t number) {
  return fmt::format("{:02}-{:02}", number >> 8, number & 0xFF);
}
std::optional<std::uint32_t> ggpp_of_register(std::uint32_t address) {
  // Groups and numbers are two decimal digits in the manual ("10-11" -> 0x0A0B).
  if ((address >> 8) <= 99 && (address & 0xFF) <= 99) return address;
  return std::nullopt;
}
constexpr ParameterNumbering kGgppNumbering{"ggpp",     "08-03",    '-',
                                            parse_ggpp, ggpp_label, ggpp_of_register};

}  // namespace

const ProtocolDesc kRtuProtocol{
    .id = "modbus-rtu",
    .label = "Modbus RTU",
    .help = "Modbus RTU",
    .option_names = kRtuNames,
    .decoder = &kRtuDecoder,
    .field_protocols = kRtuFieldProtocols,
    .findings = kRtuFindings,
    .text_start = 0,
    .wireshark_dissector = "mbrtu",
    .wireshark_builtin = true,
    .parameter_numbering = &kGgppNumbering,
    .head_address_field = &kRtuUnitId,
    .head_function_field = &kFunction,
};

const ProtocolDesc kAsciiProtocol{
    .id = "modbus-ascii",
    .label = "Modbus ASCII",
    .help = "Modbus ASCII",
    .option_names = kAsciiNames,
    .decoder = &kAsciiDecoder,
    .field_protocols = kAsciiFieldProtocols,
    .findings = kAsciiFindings,
    .text_start = ':',
    .wireshark_dissector = "mbascii",
    .head_address_field = &kAsciiUnitId,
    .head_function_field = &kFunction,
};

}  // namespace drivetap::modbus
