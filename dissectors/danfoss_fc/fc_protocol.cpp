// The Danfoss FC protocol's descriptor (docs/protocols.md §4): names, decoder, fields, findings.
#include <fmt/format.h>

#include "dissectors/danfoss_fc/fc_protocol.hpp"

#include "dissectors/danfoss_fc/fc_dissector.hpp"
#include "dissectors/danfoss_fc/fc_fields.hpp"
#include "dissectors/danfoss_fc/fc_findings.hpp"
#include "dissectors/danfoss_fc/fc_words.hpp"

namespace drivetap::danfoss_fc {
namespace {

constexpr std::string_view kNames[] = {"fc", "danfoss-fc"};
const FcDecoder kDecoder{};

// Danfoss "G-NN": PNU G * 100 + NN (the FC protocol's PNU); on Modbus, register address
// PNU * 10 - 1 (Danfoss 002 §7.8.8/§7.9: register number 10 x PNU, addressed from 0).
std::optional<std::uint32_t> parse_pnu(std::string_view group, std::uint32_t number) {
  const auto g = decimal_number(group);
  if (!g || number > 99 || *g > 65) return std::nullopt;
  return *g * 100 + number;
}
std::string pnu_label(std::uint32_t pnu) {
  return fmt::format("{}-{:02}", pnu / 100, pnu % 100);
}
std::optional<std::uint32_t> pnu_of_register(std::uint32_t address) {
  if ((address + 1) % 10 == 0) return (address + 1) / 10;
  return std::nullopt;
}
constexpr ParameterNumbering kNumbering{"danfoss", "4-14",    '-',
                                        parse_pnu, pnu_label, pnu_of_register};

}  // namespace

const ProtocolDesc kFcProtocol{
    .id = "danfoss-fc",
    .label = "Danfoss FC",
    .help = "Danfoss FC protocol",
    .option_names = kNames,
    .decoder = &kDecoder,
    .field_protocols = kFieldProtocols,
    .findings = kAllFindings,
    .words = kAllWords,
    .text_start = 0,
    .wireshark_dissector = "danfoss_fc",
    .parameter_numbering = &kNumbering,
};

}  // namespace drivetap::danfoss_fc
