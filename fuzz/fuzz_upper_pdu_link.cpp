// Fuzzes upper_pdu::parse_tags (Wireshark exported-PDU TLVs) and extract_serial_payload for
// every supported link type (serial, RTAC, upper PDU, Ethernet/loopback/raw IP/SLL -> UDP/TCP).
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "formats/link_layer.hpp"
#include "formats/upper_pdu.hpp"
#include "fuzz/fuzz_common.hpp"

namespace {

using namespace drivetap;

// All of link_type_supported(), plus one that is not (248, SCTP).
constexpr std::uint32_t kUnsupported = 248;
constexpr std::uint32_t kLinkTypes[] = {0,   1,   12,  14,  101, 113, 147,         150,
                                        162, 228, 229, 250, 252, 276, kUnsupported};

bool inside(std::span<const std::uint8_t> part, std::span<const std::uint8_t> whole) {
  if (part.empty()) return true;
  return part.data() >= whole.data() && part.data() + part.size() <= whole.data() + whole.size();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::span<const std::uint8_t> packet(data, size);

  std::string error;
  if (auto parsed = upper_pdu::parse_tags(packet, &error)) {
    if (parsed->payload_offset > packet.size())
      fuzz::contract_broken("parse_tags: payload offset beyond the packet");
    // What we parsed, written back and parsed again, is the same (strings the writer keeps whole).
    const upper_pdu::TagView& a = parsed->tags;
    if (a.dissector.size() < 0xFFF0 && a.protocol_column.size() < 0xFFF0 &&
        a.info_column.size() < 0xFFF0) {
      const upper_pdu::Tags owned{std::string(a.dissector),
                                  std::string(a.protocol_column),
                                  std::string(a.info_column),
                                  a.direction,
                                  a.source_port,
                                  a.destination_port};
      std::vector<std::uint8_t> written;
      upper_pdu::append_tags(owned, written);
      std::string error2;
      auto again = upper_pdu::parse_tags(written, &error2);
      if (!again) fuzz::contract_broken("parse_tags rejects what append_tags wrote");
      const upper_pdu::TagView& b = again->tags;
      if (again->payload_offset != written.size() || a.dissector != b.dissector ||
          a.protocol_column != b.protocol_column || a.info_column != b.info_column ||
          a.direction != b.direction || a.source_port != b.source_port ||
          a.destination_port != b.destination_port)
        fuzz::contract_broken("exported-PDU tags change in a write/parse round trip");
    }
  } else if (error.empty()) {
    fuzz::contract_broken("parse_tags failed without saying why");
  }

  for (std::uint32_t link_type : kLinkTypes) {
    std::string why;
    bool fatal = false;
    auto payload = extract_serial_payload(link_type, packet, &why, &fatal);
    if (payload) {
      if (!inside(payload->bytes, packet))
        fuzz::contract_broken("extract_serial_payload: bytes outside the packet");
    } else if (why.empty()) {
      fuzz::contract_broken("extract_serial_payload: no payload and no reason");
    }
    if (link_type_supported(link_type) == (link_type == kUnsupported))
      fuzz::contract_broken("link_type_supported disagrees with the list");
  }
  return 0;
}
