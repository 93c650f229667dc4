// Drive profile loader (schema: dissectors/profiles/README.md), on toml++ (Debian's
// libtomlplusplus): every key is checked; errors name the file, line and key.
#include "profiles/profile.hpp"

#include <fmt/format.h>

#include <toml++/toml.h>
#include <fstream>
#include <set>
#include <sstream>

#include "core/protocol.hpp"

namespace drivetap {

std::string ProfileError::text() const {
  if (key.empty()) return fmt::format("{}:{}: {}", file, line, message);
  return fmt::format("{}:{}: key '{}': {}", file, line, key, message);
}

const RegisterDef* DriveProfile::find(RegisterKind kind, std::uint16_t address) const {
  for (const RegisterDef& r : registers)
    if (r.kind == kind && r.address == address) return &r;
  return nullptr;
}

namespace {

// Thrown inside the loader only, caught at its boundary: a malformed profile is one error.
struct Bad {
  int line;
  std::string key;
  std::string message;
};

int line_of(const toml::node& n) {
  return static_cast<int>(n.source().begin.line);
}

void only_keys(const toml::table& t, const std::string& where, std::set<std::string_view> allowed) {
  for (const auto& [k, v] : t)
    if (!allowed.count(k.str()))
      throw Bad{line_of(v),
                where.empty() ? std::string(k.str()) : where + "." + std::string(k.str()),
                "unknown key"};
}

const toml::table& table_at(const toml::table& parent, std::string_view key,
                            const std::string& path) {
  const toml::node* n = parent.get(key);
  if (!n) throw Bad{line_of(parent), path, "missing"};
  if (!n->is_table()) throw Bad{line_of(*n), path, "expected a table"};
  return *n->as_table();
}

std::string string_at(const toml::table& t, std::string_view key, const std::string& path,
                      bool required) {
  const toml::node* n = t.get(key);
  if (!n) {
    if (required) throw Bad{line_of(t), path, "missing"};
    return {};
  }
  if (!n->is_string()) throw Bad{line_of(*n), path, "expected a string"};
  return std::string(n->as_string()->get());
}

std::optional<std::int64_t> int_at(const toml::table& t, std::string_view key,
                                   const std::string& path, std::int64_t lo, std::int64_t hi) {
  const toml::node* n = t.get(key);
  if (!n) return std::nullopt;
  if (!n->is_integer()) throw Bad{line_of(*n), path, "expected an integer"};
  const std::int64_t v = n->as_integer()->get();
  if (v < lo || v > hi) throw Bad{line_of(*n), path, fmt::format("must be in {}..{}", lo, hi)};
  return v;
}

std::optional<double> number_at(const toml::table& t, std::string_view key,
                                const std::string& path) {
  const toml::node* n = t.get(key);
  if (!n) return std::nullopt;
  if (n->is_integer()) return static_cast<double>(n->as_integer()->get());
  if (n->is_floating_point()) return n->as_floating_point()->get();
  throw Bad{line_of(*n), path, "expected a number"};
}

std::uint32_t numeric_key(std::string_view key, int line, const std::string& path) {
  std::uint32_t v = 0;
  int base = 10;
  std::string_view digits = key;
  if (digits.starts_with("0x") || digits.starts_with("0X")) {
    base = 16;
    digits.remove_prefix(2);
  }
  if (digits.empty()) throw Bad{line, path, "expected a number as key"};
  for (char c : digits) {
    const int d = c >= '0' && c <= '9'   ? c - '0'
                  : c >= 'a' && c <= 'f' ? c - 'a' + 10
                  : c >= 'A' && c <= 'F' ? c - 'A' + 10
                                         : 99;
    if (d >= base || v > 0x0FFFFFFF) throw Bad{line, path, "expected a number as key"};
    v = v * static_cast<std::uint32_t>(base) + static_cast<std::uint32_t>(d);
  }
  return v;
}

std::map<std::uint32_t, std::string> value_names(const toml::table& t, const std::string& path) {
  std::map<std::uint32_t, std::string> out;
  for (const auto& [k, v] : t) {
    const std::string p = path + "." + std::string(k.str());
    const std::uint32_t n = numeric_key(k.str(), line_of(v), p);
    if (!v.is_string()) throw Bad{line_of(v), p, "expected a string"};
    out[n] = std::string(v.as_string()->get());
  }
  return out;
}

RegisterDef parse_register(const toml::table& t, const std::string& path) {
  only_keys(
      t, path,
      {"address", "name", "kind", "access", "unit", "scale", "signed", "enum", "role", "bits"});
  RegisterDef r;
  const auto address = int_at(t, "address", path + ".address", 0, 0xFFFF);
  if (!address) throw Bad{line_of(t), path + ".address", "missing"};
  r.address = static_cast<std::uint16_t>(*address);
  r.name = string_at(t, "name", path + ".name", true);
  const std::string kind = string_at(t, "kind", path + ".kind", false);
  if (kind.empty() || kind == "holding")
    r.kind = RegisterKind::holding;
  else if (kind == "input")
    r.kind = RegisterKind::input;
  else if (kind == "coil")
    r.kind = RegisterKind::coil;
  else if (kind == "discrete")
    r.kind = RegisterKind::discrete;
  else
    throw Bad{line_of(*t.get("kind")), path + ".kind", "must be holding, input, coil or discrete"};
  const std::string access = string_at(t, "access", path + ".access", false);
  if (access.empty() || access == "rw")
    r.access = RegisterAccess::read_write;
  else if (access == "r")
    r.access = RegisterAccess::read;
  else if (access == "w")
    r.access = RegisterAccess::write;
  else
    throw Bad{line_of(*t.get("access")), path + ".access", "must be r, w or rw"};
  r.unit = string_at(t, "unit", path + ".unit", false);
  if (auto s = number_at(t, "scale", path + ".scale")) {
    if (*s == 0) throw Bad{line_of(*t.get("scale")), path + ".scale", "must not be 0"};
    r.scale = *s;
  }
  if (const toml::node* s = t.get("signed")) {
    if (!s->is_boolean()) throw Bad{line_of(*s), path + ".signed", "expected true or false"};
    r.is_signed = s->as_boolean()->get();
  }
  r.enum_name = string_at(t, "enum", path + ".enum", false);
  r.role = string_at(t, "role", path + ".role", false);
  static const std::set<std::string_view> kRoles = {
      "", "control", "status", "setpoint", "output_frequency", "current", "voltage", "fault"};
  if (!kRoles.count(r.role))
    throw Bad{line_of(*t.get("role")), path + ".role",
              "must be control, status, setpoint, output_frequency, current, voltage or fault"};
  if (const toml::node* b = t.get("bits")) {
    if (!b->is_table()) throw Bad{line_of(*b), path + ".bits", "expected a table"};
    for (const auto& [k, v] : *b->as_table()) {
      const std::string p = path + ".bits." + std::string(k.str());
      const std::uint32_t bit = numeric_key(k.str(), line_of(v), p);
      if (bit > 31) throw Bad{line_of(v), p, "bit number must be 0..31"};
      const toml::array* a = v.as_array();
      if (!a || a->size() != 2 || !(*a)[0].is_string() || !(*a)[1].is_string())
        throw Bad{line_of(v), p, "expected [\"meaning when 0\", \"meaning when 1\"]"};
      r.bits.push_back({static_cast<int>(bit), std::string((*a)[0].as_string()->get()),
                        std::string((*a)[1].as_string()->get())});
    }
  }
  return r;
}

DriveProfile parse_tables(const toml::table& root) {
  only_keys(root, "", {"drive", "limits", "timing", "register", "enums", "exceptions"});
  DriveProfile p;
  const toml::table& drive = table_at(root, "drive", "drive");
  only_keys(drive, "drive", {"id", "name", "source", "protocols", "serial", "addresses"});
  p.id = string_at(drive, "id", "drive.id", true);
  p.name = string_at(drive, "name", "drive.name", true);
  p.source = string_at(drive, "source", "drive.source", false);
  if (const toml::node* n = drive.get("protocols")) {
    const toml::array* a = n->as_array();
    if (!a) throw Bad{line_of(*n), "drive.protocols", "expected a list of strings"};
    for (const toml::node& e : *a) {
      const Protocol proto =
          e.is_string() ? protocol_from_option(e.as_string()->get()) : Protocol::unknown;
      if (proto == Protocol::unknown)
        throw Bad{line_of(e), "drive.protocols",
                  "each must be modbus-rtu, modbus-ascii, danfoss-fc or easydrive"};
      p.protocols.push_back(proto);
    }
  }
  if (const std::string serial = string_at(drive, "serial", "drive.serial", false);
      !serial.empty()) {
    std::string err;
    p.serial = SerialConfig::parse(serial, &err);
    if (!p.serial) throw Bad{line_of(*drive.get("serial")), "drive.serial", err};
  }
  if (const toml::node* n = drive.get("addresses")) {
    const toml::array* a = n->as_array();
    if (!a || a->size() != 2 || !(*a)[0].is_integer() || !(*a)[1].is_integer())
      throw Bad{line_of(*n), "drive.addresses", "expected [lowest, highest]"};
    p.address_min = static_cast<int>((*a)[0].as_integer()->get());
    p.address_max = static_cast<int>((*a)[1].as_integer()->get());
    if (p.address_min < 0 || p.address_max > 255 || p.address_min > p.address_max)
      throw Bad{line_of(*n), "drive.addresses", "must be 0 <= lowest <= highest <= 255"};
  }
  if (const toml::node* n = root.get("limits")) {
    if (!n->is_table()) throw Bad{line_of(*n), "limits", "expected a table"};
    const toml::table& t = *n->as_table();
    only_keys(t, "limits", {"functions", "max_read_registers", "max_write_registers"});
    if (const toml::node* f = t.get("functions")) {
      const toml::array* a = f->as_array();
      if (!a) throw Bad{line_of(*f), "limits.functions", "expected a list of function codes"};
      for (const toml::node& e : *a) {
        if (!e.is_integer() || e.as_integer()->get() < 1 || e.as_integer()->get() > 127)
          throw Bad{line_of(e), "limits.functions", "each must be a function code 1..127"};
        p.functions.push_back(static_cast<int>(e.as_integer()->get()));
      }
    }
    if (auto v = int_at(t, "max_read_registers", "limits.max_read_registers", 1, 125))
      p.max_read_registers = static_cast<int>(*v);
    if (auto v = int_at(t, "max_write_registers", "limits.max_write_registers", 1, 123))
      p.max_write_registers = static_cast<int>(*v);
  }
  if (const toml::node* n = root.get("timing")) {
    if (!n->is_table()) throw Bad{line_of(*n), "timing", "expected a table"};
    const toml::table& t = *n->as_table();
    only_keys(t, "timing",
              {"section", "min_silence_chars", "min_reply_to_request_ms", "max_reply_delay_ms",
               "min_reply_delay_ms"});
    p.timing_section = string_at(t, "section", "timing.section", false);
    p.min_silence_chars = number_at(t, "min_silence_chars", "timing.min_silence_chars");
    p.min_reply_to_request_ms =
        number_at(t, "min_reply_to_request_ms", "timing.min_reply_to_request_ms");
    p.max_reply_delay_ms = number_at(t, "max_reply_delay_ms", "timing.max_reply_delay_ms");
    p.min_reply_delay_ms = number_at(t, "min_reply_delay_ms", "timing.min_reply_delay_ms");
  }
  if (const toml::node* n = root.get("register")) {
    const toml::array* a = n->as_array();
    if (!a) throw Bad{line_of(*n), "register", "expected [[register]] tables"};
    for (std::size_t i = 0; i < a->size(); ++i) {
      const toml::node& e = (*a)[i];
      const std::string path = fmt::format("register[{}]", i + 1);
      if (!e.is_table()) throw Bad{line_of(e), path, "expected a table"};
      p.registers.push_back(parse_register(*e.as_table(), path));
    }
  }
  if (const toml::node* n = root.get("enums")) {
    if (!n->is_table()) throw Bad{line_of(*n), "enums", "expected a table"};
    for (const auto& [k, v] : *n->as_table()) {
      const std::string path = "enums." + std::string(k.str());
      if (!v.is_table()) throw Bad{line_of(v), path, "expected a table"};
      p.enums[std::string(k.str())] = value_names(*v.as_table(), path);
    }
  }
  if (const toml::node* n = root.get("exceptions")) {
    if (!n->is_table()) throw Bad{line_of(*n), "exceptions", "expected a table"};
    p.exceptions = value_names(*n->as_table(), "exceptions");
  }
  for (std::size_t i = 0; i < p.registers.size(); ++i) {
    const RegisterDef& r = p.registers[i];
    if (!r.enum_name.empty() && !p.enums.count(r.enum_name))
      throw Bad{0, fmt::format("register[{}].enum", i + 1),
                fmt::format("no [enums.{}] table", r.enum_name)};
  }
  return p;
}

}  // namespace

std::optional<DriveProfile> parse_profile(std::string_view toml_text, std::string_view file_name,
                                          ProfileError* error) {
  toml::table root;
  try {
    root = toml::parse(toml_text, file_name);
  } catch (const toml::parse_error& e) {
    *error = {std::string(file_name), static_cast<int>(e.source().begin.line), "",
              std::string(e.description())};
    return std::nullopt;
  }
  try {
    return parse_tables(root);
  } catch (const Bad& bad) {
    *error = {std::string(file_name), bad.line, bad.key, bad.message};
    return std::nullopt;
  }
}

std::optional<DriveProfile> load_profile_file(const std::string& path, ProfileError* error) {
  std::ifstream in(path);
  if (!in) {
    *error = {path, 0, "", "cannot open the profile file"};
    return std::nullopt;
  }
  std::ostringstream text;
  text << in.rdbuf();
  return parse_profile(text.str(), path, error);
}

}  // namespace drivetap
