// ParameterNumbering: how a drive family's manual numbers its parameters ("4-14", "F2.11",
// "10-11") and where they travel on the wire (docs/protocols.md §2, §4, §5). Declared as data by
// the protocol that carries them (dissectors/<protocol>/), named by a profile's [parameters] rule
// (dissectors/profiles/README.md) and found through the registry.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <utility>

namespace drivetap {

struct ParameterNumbering {
  std::string_view name;     // the profile's [parameters] rule: "danfoss"
  std::string_view example;  // a number as its manual writes one: "4-14"
  char separator;            // between the group and the number: '-' in "4-14"
  // The manual's group ("4") and number (14) -> the parameter's wire number; nullopt when out of
  // range (parse_parameter_number() splits the text).
  std::optional<std::uint32_t> (*parse)(std::string_view group, std::uint32_t number);
  // The wire number -> the manual's number ("4-14").
  std::string (*label)(std::uint32_t number);
  // The Modbus holding register -> the parameter it holds; nullptr: its parameters are not on
  // Modbus.
  std::optional<std::uint32_t> (*of_register)(std::uint32_t address) = nullptr;
  // What the manual calls a parameter: "parameter ", "function code ".
  std::string_view noun = "parameter ";
};

// The decimal number of 1-3 digits `d` spells; nullopt for anything else.
inline std::optional<std::uint32_t> decimal_number(std::string_view d) {
  if (d.empty() || d.size() > 3) return std::nullopt;
  std::uint32_t v = 0;
  for (char c : d) {
    if (c < '0' || c > '9') return std::nullopt;
    v = v * 10 + static_cast<std::uint32_t>(c - '0');
  }
  return v;
}

// The manual's parameter number ("4-14") as its wire number under `rule`; nullopt if malformed
// or without a rule.
inline std::optional<std::uint32_t> parse_parameter_number(const ParameterNumbering* rule,
                                                           std::string_view text) {
  if (!rule) return std::nullopt;
  const std::size_t at = text.find(rule->separator);
  if (at == std::string_view::npos) return std::nullopt;
  const auto number = decimal_number(text.substr(at + 1));
  if (!number) return std::nullopt;
  return rule->parse(text.substr(0, at), *number);
}

// The registry's (dissectors/registry.cpp): the numbering a profile's rule names; nullptr for none.
const ParameterNumbering* parameter_numbering_named(std::string_view name);
// Every rule's name, "ggpp, danfoss or easydrive".
std::string parameter_numbering_names_text();

}  // namespace drivetap
