// Serial bytes out of captured packets of other tools, by link type (tcpdump.org link types):
//   147..162 USER0..15   raw serial bytes (modbus-sniffer, SerialPCAP)
//   250 RTAC_SERIAL      12-byte header: sec(4, BE) usec(4, BE) event(1: 1 TX, 2 RX) lines(1)
//                        footer(2), then the bytes
//   252 UPPER_PDU        exported-PDU tags, then the bytes (dissector "mbrtu" or "data")
//   1 Ethernet, 0 NULL, 101/12/14 raw IP, 228 IPv4, 229 IPv6, 113 SLL, 276 SLL2:
//                        IPv4/IPv6 -> UDP or TCP payload = Modbus RTU carried over IP
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>

namespace drivetap {

inline constexpr std::uint32_t kLinkTypeUser0 = 147;
inline constexpr std::uint32_t kLinkTypeRtacSerial = 250;
inline constexpr std::uint32_t kLinkTypeUpperPdu = 252;

struct SerialPayload {
  std::span<const std::uint8_t> bytes;
  // Direction the packet's own metadata states, if any: true = outbound (sent by the capturing
  // side / P2P sent), false = inbound.
  std::optional<bool> outbound;
  // For bytes carried over IP: "udp 10.0.0.1:4001>10.0.0.2:502" and the link both directions of
  // that conversation share. Empty for serial link types.
  std::string flow;
  std::string flow_link;
};

// Extracts the serial bytes of one packet. Returns nullopt with *why set when the packet carries
// none (another protocol, a status event, a fragment); `*fatal` says whether that is an error in
// the packet itself rather than traffic to skip.
std::optional<SerialPayload> extract_serial_payload(std::uint32_t link_type,
                                                    std::span<const std::uint8_t> packet,
                                                    std::string* why, bool* fatal);

bool link_type_supported(std::uint32_t link_type);

}  // namespace drivetap
