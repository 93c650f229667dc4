// Protocol descriptors: all that code outside dissectors/<protocol>/ knows of a protocol (its
// names, decoder, fields and findings), declared as data in the protocol's own folder and listed
// once in dissectors/registry.cpp. Core names no protocol: a Protocol is a handle on a descriptor.
#pragma once

#include <span>
#include <string>
#include <string_view>

#include "core/anomaly.hpp"
#include "core/field.hpp"
#include "core/parameter_numbering.hpp"
#include "core/word_bits.hpp"

namespace drivetap {

class ProtocolDecoder;  // core/protocol.hpp
struct ProtocolDesc;

// Which protocol a telegram is: a handle on the protocol's descriptor (`unknown`: none). The
// protocols' handles are the constants `protocols::<name>` in each protocol's folder.
class Protocol {
 public:
  static const Protocol unknown;
  constexpr Protocol() = default;
  constexpr explicit Protocol(const ProtocolDesc* desc) : desc_(desc) {}
  [[nodiscard]] constexpr const ProtocolDesc* desc() const { return desc_; }
  friend constexpr bool operator==(Protocol, Protocol) = default;

 private:
  const ProtocolDesc* desc_ = nullptr;
};
inline constexpr Protocol Protocol::unknown{};

struct ProtocolDesc {
  std::string_view id;     // "modbus-rtu": JSON, capture settings, drive profiles; stable
  std::string_view label;  // "Modbus RTU": text output and capture columns
  std::string_view help;   // what `--protocol` help says of it: "Easydrive '~' protocol"
  // The names `--protocol` and drive profiles take besides `id`, the short one first ("rtu").
  std::span<const std::string_view> option_names;
  const ProtocolDecoder* decoder = nullptr;
  // Every field its dissector adds, by protocol layer (Modbus RTU: its framing's, `mbrtu`, and the
  // PDU's, `modbus`, which Modbus ASCII shares).
  std::span<const FieldProtocol* const> field_protocols;
  std::span<const FindingDesc* const> findings;  // every finding its dissector raises
  // The bit tables of the control and status words it carries, by id (profiles' `bits = "id"`).
  std::span<const WordBits* const> words{};
  // The character its telegrams start with when typed as text (`decode`), 0 for a binary one.
  char text_start = 0;
  // The dissector named for its telegrams in an exported-PDU capture: Wireshark's own ("mbrtu",
  // `wireshark_builtin`), or the one drivetap's Lua plugin registers (`drivetap wireshark
  // --print-plugin`: "danfoss_fc"), which is its field layer's filter name; empty: none.
  std::string_view wireshark_dissector;
  bool wireshark_builtin = false;  // stock Wireshark has `wireshark_dissector`
  // How the manuals of the drives that speak it number their parameters (a profile's
  // [parameters] rule), nullptr: none of its own.
  const ParameterNumbering* parameter_numbering = nullptr;
  // The fields whose values a telegram's head holds (TelegramFindings::address, and ::function
  // under the field's bitmask) in every telegram it reads to the head: a display filter on them
  // needs no decode. Null: the head does not hold it.
  const FieldDesc* head_address_field = nullptr;
  const FieldDesc* head_function_field = nullptr;
};

inline std::string_view protocol_id(Protocol p) {  // "modbus-rtu": JSON ids, stable
  return p.desc() ? p.desc()->id : "unknown";
}
inline std::string_view protocol_label(Protocol p) {  // "Modbus RTU": column text
  return p.desc() ? p.desc()->label : "unknown";
}
// The decoder of `p`; nullptr for Protocol::unknown.
inline const ProtocolDecoder* decoder_for(Protocol p) {
  return p.desc() ? p.desc()->decoder : nullptr;
}

// The registry (dissectors/registry.cpp): every protocol, in the order detection tries them.
std::span<const ProtocolDesc* const> registered_protocols();
// The protocol a channel is decoded as when detection decides none.
Protocol default_protocol();
// A --protocol or profile name ("rtu", "modbus-rtu") -> its protocol; unknown for other text.
Protocol protocol_from_option(std::string_view name);
// The protocol whose text telegrams start with `c` (':' Modbus ASCII); unknown for none.
Protocol protocol_for_text_start(char c);
// A small number for `p`: 1 + its place in the registry, 0 for unknown (a bit in a mask).
unsigned protocol_index(Protocol p);
// Every registered protocol's id, "a, b, c or d".
std::string protocol_ids_text();
// Every registered protocol's label, "Modbus RTU, Modbus ASCII, Danfoss FC or Easydrive".
std::string protocol_labels_text();
// The protocols typed as text, by their start: "':' Modbus ASCII or '~' Easydrive".
std::string protocol_text_starts_text();
// The protocol whose telegrams Wireshark's dissector `name` ("mbrtu") shows; unknown for none.
Protocol protocol_for_wireshark_dissector(std::string_view name);

}  // namespace drivetap
