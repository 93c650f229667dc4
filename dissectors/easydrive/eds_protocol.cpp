// The Easydrive protocol's descriptor (docs/protocols.md §5): names, decoder, fields, findings.
#include "dissectors/easydrive/eds_protocol.hpp"

#include "dissectors/easydrive/eds_dissector.hpp"
#include "dissectors/easydrive/eds_fields.hpp"
#include "dissectors/easydrive/eds_findings.hpp"

namespace drivetap::easydrive {
namespace {

constexpr std::string_view kNames[] = {"eds", "easydrive"};
const EdsDecoder kDecoder{};

}  // namespace

const ProtocolDesc kEdsProtocol{
    .id = "easydrive",
    .label = "Easydrive",
    .help = "Easydrive '~' protocol",
    .option_names = kNames,
    .decoder = &kDecoder,
    .fields = kAllFields,
    .findings = kAllFindings,
    .text_start = '~',
    .wireshark_dissector = {},
};

}  // namespace drivetap::easydrive
