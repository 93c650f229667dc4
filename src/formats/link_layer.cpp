// Link-layer decapsulation of foreign captures down to serial bytes (layouts in link_layer.hpp).
#include "formats/link_layer.hpp"

#include <fmt/format.h>

#include "core/cursor.hpp"
#include "core/protocol_desc.hpp"
#include "formats/upper_pdu.hpp"

namespace drivetap {
namespace {

std::string ipv4_text(std::span<const std::uint8_t> a) {
  return fmt::format("{}.{}.{}.{}", a[0], a[1], a[2], a[3]);
}

std::string ipv6_text(std::span<const std::uint8_t> a) {
  std::string s = "[";
  for (int i = 0; i < 16; i += 2) s += fmt::format("{}{:x}", i ? ":" : "", (a[i] << 8) | a[i + 1]);
  return s + "]";
}

std::optional<SerialPayload> transport(std::uint8_t protocol, std::span<const std::uint8_t> seg,
                                       const std::string& src, const std::string& dst,
                                       std::string* why, bool* fatal) {
  Cursor c(seg);
  const char* name = protocol == 17 ? "udp" : "tcp";
  auto sport = c.be16();
  auto dport = c.be16();
  if (!sport || !dport) {
    *why = fmt::format("truncated {} header", name);
    *fatal = true;
    return std::nullopt;
  }
  std::size_t header = 8;
  if (protocol == 6) {
    if (seg.size() < 20) {
      *why = "truncated tcp header";
      *fatal = true;
      return std::nullopt;
    }
    header = std::size_t{static_cast<std::uint8_t>(seg[12] >> 4)} * 4;
    if (header < 20 || header > seg.size()) {
      *why = fmt::format("tcp data offset {} outside the segment", header);
      *fatal = true;
      return std::nullopt;
    }
  } else if (seg.size() < 8) {
    *why = "truncated udp header";
    *fatal = true;
    return std::nullopt;
  }
  SerialPayload p;
  p.bytes = seg.subspan(header);
  if (p.bytes.empty()) {
    *why = "no payload";
    return std::nullopt;
  }
  const std::string a = fmt::format("{}:{}", src, *sport);
  const std::string b = fmt::format("{}:{}", dst, *dport);
  p.flow = fmt::format("{} {}>{}", name, a, b);
  p.flow_link = fmt::format("{} {}", name, a < b ? a + "<>" + b : b + "<>" + a);
  // Modbus/TCP is not serial bytes: skipped, one note a flow (its segments counted), never read
  // as RTU. A segment is Modbus/TCP when it is one or more whole MBAP ADUs (protocol id 0,
  // length = unit id + PDU, 2..254).
  std::size_t at = 0;
  while (p.bytes.size() - at >= 8 && p.bytes[at + 2] == 0 && p.bytes[at + 3] == 0) {
    const std::size_t length = static_cast<std::size_t>((p.bytes[at + 4] << 8) | p.bytes[at + 5]);
    if (length < 2 || length > 254 || length > p.bytes.size() - at - 6) break;
    at += 6 + length;
  }
  if (at != 0 && at == p.bytes.size()) {
    *why = fmt::format("Modbus/TCP (MBAP) on {}: not serial bytes, not decoded", p.flow_link);
    return std::nullopt;
  }
  return p;
}

std::optional<SerialPayload> ip(std::span<const std::uint8_t> pkt, std::string* why, bool* fatal) {
  if (pkt.empty()) {
    *why = "empty IP packet";
    *fatal = true;
    return std::nullopt;
  }
  const unsigned version = pkt[0] >> 4;
  if (version == 4) {
    if (pkt.size() < 20) {
      *why = "truncated IPv4 header";
      *fatal = true;
      return std::nullopt;
    }
    const std::size_t ihl = std::size_t{static_cast<std::uint8_t>(pkt[0] & 0x0F)} * 4;
    const std::size_t total = static_cast<std::size_t>((pkt[2] << 8) | pkt[3]);
    if (ihl < 20 || ihl > pkt.size() || total < ihl) {
      *why = "bad IPv4 header length";
      *fatal = true;
      return std::nullopt;
    }
    if (((pkt[6] & 0x1F) | pkt[7]) != 0 || (pkt[6] & 0x20)) {
      *why = "IPv4 fragment (not reassembled)";
      return std::nullopt;
    }
    const std::uint8_t proto = pkt[9];
    if (proto != 6 && proto != 17) {
      *why = fmt::format("IP protocol {} is neither UDP nor TCP", proto);
      return std::nullopt;
    }
    const std::size_t end = std::min(total, pkt.size());
    return transport(proto, pkt.subspan(ihl, end - ihl), ipv4_text(pkt.subspan(12, 4)),
                     ipv4_text(pkt.subspan(16, 4)), why, fatal);
  }
  if (version == 6) {
    if (pkt.size() < 40) {
      *why = "truncated IPv6 header";
      *fatal = true;
      return std::nullopt;
    }
    const std::uint8_t next = pkt[6];
    if (next != 6 && next != 17) {
      *why = fmt::format("IPv6 next header {} is neither UDP nor TCP", next);
      return std::nullopt;
    }
    const std::size_t payload = static_cast<std::size_t>((pkt[4] << 8) | pkt[5]);
    const std::size_t end = std::min<std::size_t>(40 + payload, pkt.size());
    return transport(next, pkt.subspan(40, end - 40), ipv6_text(pkt.subspan(8, 16)),
                     ipv6_text(pkt.subspan(24, 16)), why, fatal);
  }
  *why = fmt::format("IP version {}", version);
  return std::nullopt;
}

std::optional<SerialPayload> by_ethertype(std::uint16_t type, std::span<const std::uint8_t> rest,
                                          std::string* why, bool* fatal) {
  if (type == 0x0800 || type == 0x86DD) return ip(rest, why, fatal);
  *why = fmt::format("ethertype 0x{:04X} is not IP", type);
  return std::nullopt;
}

}  // namespace

bool link_type_supported(std::uint32_t t) {
  return (t >= 147 && t <= 162) || t == kLinkTypeRtacSerial || t == kLinkTypeUpperPdu || t == 0 ||
         t == 1 || t == 12 || t == 14 || t == 101 || t == 113 || t == 228 || t == 229 || t == 276;
}

std::optional<SerialPayload> extract_serial_payload(std::uint32_t link_type,
                                                    std::span<const std::uint8_t> pkt,
                                                    std::string* why, bool* fatal) {
  *fatal = false;
  auto truncated = [&](const char* what) {
    *why = fmt::format("packet shorter than its {} header", what);
    *fatal = true;
    return std::nullopt;
  };
  if (link_type >= 147 && link_type <= 162) return SerialPayload{pkt, std::nullopt, {}, {}};
  switch (link_type) {
    case kLinkTypeRtacSerial: {
      if (pkt.size() < 12) return truncated("RTAC serial");
      const std::uint8_t event = pkt[8];
      if (event != 1 && event != 2) {
        *why = fmt::format("RTAC event {} carries no data", event);
        return std::nullopt;
      }
      return SerialPayload{pkt.subspan(12), event == 1, {}, {}};
    }
    case kLinkTypeUpperPdu: {
      std::string err;
      auto parsed = upper_pdu::parse_tags(pkt, &err);
      if (!parsed) {
        *why = err;
        *fatal = true;
        return std::nullopt;
      }
      const std::string_view d = parsed->tags.dissector;
      if (!d.empty() && d != "data" && protocol_for_wireshark_dissector(d) == Protocol::unknown) {
        *why = fmt::format("exported PDU for dissector '{}', not serial bytes", d);
        return std::nullopt;
      }
      SerialPayload p{pkt.subspan(parsed->payload_offset), std::nullopt, {}, {}};
      if (parsed->tags.direction) p.outbound = *parsed->tags.direction == upper_pdu::kDirectionSent;
      return p;
    }
    case 1: {  // Ethernet II, with 802.1Q tags
      if (pkt.size() < 14) return truncated("Ethernet");
      std::size_t at = 12;
      std::uint16_t type = static_cast<std::uint16_t>((pkt[at] << 8) | pkt[at + 1]);
      while ((type == 0x8100 || type == 0x88A8) && pkt.size() >= at + 6) {
        at += 4;
        type = static_cast<std::uint16_t>((pkt[at] << 8) | pkt[at + 1]);
      }
      return by_ethertype(type, pkt.subspan(at + 2), why, fatal);
    }
    case 0: {  // BSD loopback: 4-byte address family in the writer's byte order
      if (pkt.size() < 4) return truncated("loopback");
      return ip(pkt.subspan(4), why, fatal);
    }
    case 12:
    case 14:
    case 101:
    case 228:
    case 229:
      return ip(pkt, why, fatal);
    case 113: {  // Linux cooked v1: protocol at 14
      if (pkt.size() < 16) return truncated("Linux cooked");
      return by_ethertype(static_cast<std::uint16_t>((pkt[14] << 8) | pkt[15]), pkt.subspan(16),
                          why, fatal);
    }
    case 276: {  // Linux cooked v2: protocol at 0
      if (pkt.size() < 20) return truncated("Linux cooked v2");
      return by_ethertype(static_cast<std::uint16_t>((pkt[0] << 8) | pkt[1]), pkt.subspan(20), why,
                          fatal);
    }
    default:
      break;
  }
  *why = fmt::format("link type {} is not supported", link_type);
  *fatal = true;
  return std::nullopt;
}

}  // namespace drivetap
