// The Easydrive protocol's descriptor (docs/protocols.md §5): names, decoder, fields, findings.
#include <fmt/format.h>

#include "dissectors/easydrive/eds_protocol.hpp"

#include "dissectors/easydrive/eds_dissector.hpp"
#include "dissectors/easydrive/eds_fields.hpp"
#include "dissectors/easydrive/eds_findings.hpp"

namespace drivetap::easydrive {
namespace {

constexpr std::string_view kNames[] = {"eds", "easydrive"};
const EdsDecoder kDecoder{};

// Easydrive "Fg.nn": index g << 8 | nn (F0..F9 = 0..9, FA..FF = 0x0A..0x0F); its parameters
// travel in its own protocol only, and its manual calls them function codes.
std::optional<std::uint32_t> parse_index(std::string_view group, std::uint32_t number) {
  if (group.size() != 2 || group[0] != 'F' || number > 255) return std::nullopt;
  const char h = group[1];
  const int g = h >= '0' && h <= '9' ? h - '0' : h >= 'A' && h <= 'F' ? h - 'A' + 10 : -1;
  if (g < 0) return std::nullopt;
  return static_cast<std::uint32_t>(g) << 8 | number;
}
std::string index_label(std::uint32_t index) {
  return fmt::format("F{:X}.{:02}", index >> 8, index & 0xFF);
}
constexpr ParameterNumbering kNumbering{"easydrive", "F0.05",         '.', parse_index, index_label,
                                        nullptr,     "function code "};

}  // namespace

const ProtocolDesc kEdsProtocol{
    .id = "easydrive",
    .label = "Easydrive",
    .help = "Easydrive '~' protocol",
    .option_names = kNames,
    .decoder = &kDecoder,
    .field_protocols = kFieldProtocols,
    .findings = kAllFindings,
    .text_start = '~',
    .wireshark_dissector = "easydrive",
    .parameter_numbering = &kNumbering,
};

}  // namespace drivetap::easydrive
