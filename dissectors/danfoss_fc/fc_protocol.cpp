// The Danfoss FC protocol's descriptor (docs/protocols.md §4): names, decoder, fields, findings.
#include "dissectors/danfoss_fc/fc_protocol.hpp"

#include "dissectors/danfoss_fc/fc_dissector.hpp"
#include "dissectors/danfoss_fc/fc_fields.hpp"
#include "dissectors/danfoss_fc/fc_findings.hpp"

namespace drivetap::danfoss_fc {
namespace {

constexpr std::string_view kNames[] = {"fc", "danfoss-fc"};
const FcDecoder kDecoder{};

}  // namespace

const ProtocolDesc kFcProtocol{
    .id = "danfoss-fc",
    .label = "Danfoss FC",
    .help = "Danfoss FC protocol",
    .option_names = kNames,
    .decoder = &kDecoder,
    .fields = kAllFields,
    .findings = kAllFindings,
    .text_start = 0,
    .wireshark_dissector = {},
};

}  // namespace drivetap::danfoss_fc
