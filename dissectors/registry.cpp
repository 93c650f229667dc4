// The protocol registry: the one explicit list of protocols (no static self-registration), one
// line each; everything else about a protocol is its descriptor, in its folder.
#include <fmt/format.h>
#include <algorithm>

#include <vector>

#include "core/protocol_desc.hpp"
#include "dissectors/danfoss_fc/fc_protocol.hpp"
#include "dissectors/easydrive/eds_protocol.hpp"
#include "dissectors/modbus/modbus_protocol.hpp"

namespace drivetap {
namespace {

// In the order detection tries them; the first is the default when detection decides none.
constexpr const ProtocolDesc* kProtocols[] = {
    &modbus::kRtuProtocol,
    &modbus::kAsciiProtocol,
    &danfoss_fc::kFcProtocol,
    &easydrive::kEdsProtocol,
};
static_assert(std::size(kProtocols) < 32, "protocol_index() is a bit of a 32-bit mask");

}  // namespace

std::span<const ProtocolDesc* const> registered_protocols() {
  return kProtocols;
}

Protocol default_protocol() {
  return Protocol(kProtocols[0]);
}

Protocol protocol_from_option(std::string_view name) {
  for (const ProtocolDesc* p : kProtocols)
    if (std::ranges::find(p->option_names, name) != p->option_names.end()) return Protocol(p);
  return Protocol::unknown;
}

Protocol protocol_for_text_start(char c) {
  for (const ProtocolDesc* p : kProtocols)
    if (c != 0 && p->text_start == c) return Protocol(p);
  return Protocol::unknown;
}

unsigned protocol_index(Protocol p) {
  for (std::size_t i = 0; i < std::size(kProtocols); ++i)
    if (kProtocols[i] == p.desc()) return static_cast<unsigned>(i + 1);
  return 0;
}

// "a, b, c or d" of what `name` gives of each protocol (those giving nothing left out).
template <class Name>
std::string list_text(Name name) {
  std::vector<std::string> parts;
  for (const ProtocolDesc* p : kProtocols)
    if (std::string part = name(*p); !part.empty()) parts.push_back(std::move(part));
  std::string text;
  for (std::size_t i = 0; i < parts.size(); ++i) {
    if (i > 0) text += i + 1 == parts.size() ? " or " : ", ";
    text += parts[i];
  }
  return text;
}

std::string protocol_ids_text() {
  return list_text([](const ProtocolDesc& p) { return std::string(p.id); });
}

std::string protocol_labels_text() {
  return list_text([](const ProtocolDesc& p) { return std::string(p.label); });
}

std::string protocol_text_starts_text() {
  return list_text([](const ProtocolDesc& p) {
    return p.text_start ? fmt::format("'{}' {}", p.text_start, p.label) : std::string();
  });
}

const ParameterNumbering* parameter_numbering_named(std::string_view name) {
  for (const ProtocolDesc* p : kProtocols)
    if (p->parameter_numbering && p->parameter_numbering->name == name)
      return p->parameter_numbering;
  return nullptr;
}

std::string parameter_numbering_names_text() {
  return list_text([](const ProtocolDesc& p) {
    return p.parameter_numbering ? std::string(p.parameter_numbering->name) : std::string();
  });
}

Protocol protocol_for_wireshark_dissector(std::string_view name) {
  for (const ProtocolDesc* p : kProtocols)
    if (!name.empty() && p->wireshark_dissector == name) return Protocol(p);
  return Protocol::unknown;
}

// A layer two protocols share (the Modbus PDU) is listed once, at its first protocol.
std::span<const FieldProtocol* const> all_field_protocols() {
  static const std::vector<const FieldProtocol*> table = [] {
    std::vector<const FieldProtocol*> t;
    for (const ProtocolDesc* p : kProtocols)
      for (const FieldProtocol* layer : p->field_protocols)
        if (std::ranges::find(t, layer) == t.end()) t.push_back(layer);
    return t;
  }();
  return table;
}

std::span<const FieldDesc* const> all_field_descriptors() {
  static const std::vector<const FieldDesc*> table = [] {
    std::vector<const FieldDesc*> t;
    for (const FieldProtocol* layer : all_field_protocols())
      t.insert(t.end(), layer->fields.begin(), layer->fields.end());
    return t;
  }();
  return table;
}

}  // namespace drivetap
