// Drive profile loader (schema: dissectors/profiles/README.md), on toml++ (Debian's
// libtomlplusplus): every key is checked; errors name the file, line and key.
#include "drive/profile.hpp"

#include <fmt/format.h>
#include <cctype>

#include <fcntl.h>
#include <sys/stat.h>
#include <toml++/toml.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <map>
#include <set>
#include <sstream>

#include "core/printable.hpp"
#include "core/protocol.hpp"
#include "core/protocol_desc.hpp"
#include "drive/drive_fields.hpp"

namespace drivetap {

std::string ProfileError::text() const {
  // Line 0: the file as a whole (cannot be opened), no line to point at.
  const std::string where = line > 0 ? fmt::format("{}:{}", file, line) : file;
  if (key.empty()) return fmt::format("{}: {}", where, message);
  return fmt::format("{}: key '{}': {}", where, key, message);
}

namespace {
std::uint64_t register_key(RegisterKind kind, std::uint32_t address) {
  return (static_cast<std::uint64_t>(kind) << 32) | address;
}
}  // namespace

void DriveProfile::build_index() const {
  if (indexed_count_ != registers.size()) {
    registers_index_.clear();
    for (std::size_t i = 0; i < registers.size(); ++i)
      registers_index_.push_back(
          {register_key(registers[i].kind, registers[i].address), static_cast<std::uint32_t>(i)});
    // Stable: of two definitions with one key the first wins, as the linear search had it.
    std::stable_sort(registers_index_.begin(), registers_index_.end(),
                     [](const auto& a, const auto& b) { return a.first < b.first; });
    indexed_count_ = registers.size();
  }
}

std::size_t DriveProfile::first_index_at(std::uint64_t key) const {
  return static_cast<std::size_t>(
      std::lower_bound(registers_index_.begin(), registers_index_.end(), key,
                       [](const auto& e, std::uint64_t k) { return e.first < k; }) -
      registers_index_.begin());
}

const RegisterDef* DriveProfile::find(RegisterKind kind, std::uint32_t address) const {
  build_index();
  const std::uint64_t key = register_key(kind, address);
  const std::size_t at = first_index_at(key);
  if (at == registers_index_.size() || registers_index_[at].first != key) return nullptr;
  return &registers[registers_index_[at].second];
}

std::optional<std::uint32_t> DriveProfile::parameter_of_register(std::uint32_t address) const {
  if (!parameter_rule || !parameter_rule->of_register) return std::nullopt;
  return parameter_rule->of_register(address);
}

DriveProfile::Walk::Walk(const DriveProfile& profile, RegisterKind kind, std::uint32_t first)
    : profile_(profile), kind_(kind) {
  profile.build_index();
  seek(register_key(kind, first));
}

void DriveProfile::Walk::seek(std::uint64_t key) {
  at_ = profile_.first_index_at(key);
  last_ = key;
}

const RegisterDef* DriveProfile::Walk::find(std::uint32_t address) {
  const auto& index = profile_.registers_index_;
  const std::uint64_t key = register_key(kind_, address);
  if (key < last_) seek(key);
  last_ = key;
  while (at_ < index.size() && index[at_].first < key) ++at_;  // each pass moves on one entry
  if (at_ == index.size() || index[at_].first != key) return nullptr;
  return &profile_.registers[index[at_].second];  // (the first of equal keys, as find())
}

const RegisterDef* DriveProfile::find_holding(std::uint32_t address, Walk& walk) const {
  if (walk.kind() != RegisterKind::holding) return find_holding(address);
  if (const RegisterDef* r = walk.find(address)) return r;
  return parameter_at(address, nullptr);
}

const RegisterDef* DriveProfile::find_holding(std::uint32_t address, std::string* label) const {
  if (label) label->clear();
  if (const RegisterDef* r = find(RegisterKind::holding, address)) return r;
  return parameter_at(address, label);
}

const RegisterDef* DriveProfile::parameter_at(std::uint32_t address, std::string* label) const {
  const auto number = parameter_of_register(address);
  if (!number) return nullptr;
  if (const RegisterDef* r = find(RegisterKind::parameter, *number)) return r;
  if (label) *label = parameter_label(*number);
  return nullptr;
}

std::string DriveProfile::parameter_label(std::uint32_t number) const {
  return parameter_rule ? parameter_rule->label(number) : fmt::format("{}", number);
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
  return printable(n->as_string()->get());
}

// The enum value named by the word at `key`: `words` holds each value's word in enumerator order
// ("" for a value no word names). An absent key or "" reads as `if_empty`; without one, the key is
// required.
template <class E, std::size_t N>
E enum_at(const toml::table& t, std::string_view key, const std::string& path,
          const std::string_view (&words)[N], std::optional<E> if_empty, const char* must_be) {
  const std::string word = string_at(t, key, path, !if_empty);
  if (word.empty()) {
    if (if_empty) return *if_empty;
  } else {
    for (std::size_t i = 0; i < N; ++i)
      if (word == words[i]) return static_cast<E>(i);
  }
  throw Bad{line_of(*t.get(key)), path, must_be};
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
    out[n] = printable(v.as_string()->get());
  }
  return out;
}

// The ids of the words the dissectors declare bit tables for ("danfoss_fc.ctw, ...").
std::string word_ids() {
  std::string ids;
  for (const ProtocolDesc* p : registered_protocols())
    for (const WordBits* w : p->words) ids += (ids.empty() ? "" : ", ") + std::string(w->id);
  return ids;
}

// A word's bits from its dissector's table (`bits = "danfoss_fc.stw"`): the frame line and the
// drive level then name each bit the same way.
std::vector<RegisterBit> word_bits(std::string_view id, int line, const std::string& key) {
  for (const ProtocolDesc* p : registered_protocols())
    for (const WordBits* w : p->words)
      if (w->id == id) {
        std::vector<RegisterBit> bits;
        for (const BitName& b : w->bits)
          bits.push_back({b.bit, std::string(b.when_clear), std::string(b.when_set)});
        return bits;
      }
  throw Bad{line, key, "no word '" + printable(id) + "' (" + word_ids() + ")"};
}

std::vector<int> state_bits(const toml::node& v, const std::string& path) {
  std::vector<int> bits;
  auto one = [&](const toml::node& n) {
    if (!n.is_integer() || n.as_integer()->get() < 0 || n.as_integer()->get() > 31)
      throw Bad{line_of(n), path, "expected a bit number 0..31 or a list of them"};
    bits.push_back(static_cast<int>(n.as_integer()->get()));
  };
  if (const toml::array* a = v.as_array()) {
    if (a->empty()) throw Bad{line_of(v), path, "expected a bit number 0..31 or a list of them"};
    for (const toml::node& e : *a) one(e);
  } else {
    one(v);
  }
  return bits;
}

// A [[register]] (parameter == nullopt) or a [[parameter]] under the profile's addressing rule.
RegisterDef parse_register(const toml::table& t, const std::string& path,
                           std::optional<const ParameterNumbering*> parameter) {
  std::set<std::string_view> keys = {"name", "access", "unit",  "scale", "signed", "enum",
                                     "role", "bits",   "words", "state", "id"};
  keys.insert(parameter ? "number" : "address");
  if (!parameter) keys.insert("kind");
  only_keys(t, path, keys);
  RegisterDef r;
  if (parameter) {
    r.kind = RegisterKind::parameter;
    r.number = string_at(t, "number", path + ".number", true);
    if (!*parameter)
      throw Bad{line_of(*t.get("number")), path + ".number",
                fmt::format("parameters need a [parameters] rule ({})",
                            parameter_numbering_names_text())};
    const auto wire = parse_parameter_number(*parameter, r.number);
    if (!wire)
      throw Bad{line_of(*t.get("number")), path + ".number",
                fmt::format("expected a parameter number like \"{}\" under this rule",
                            (*parameter)->example)};
    r.address = *wire;
  } else {
    const auto address = int_at(t, "address", path + ".address", 0, 0xFFFF);
    if (!address) throw Bad{line_of(t), path + ".address", "missing"};
    r.address = static_cast<std::uint32_t>(*address);
    static constexpr std::string_view kKindWords[] = {"holding", "input", "coil", "discrete",
                                                      "running"};
    r.kind = enum_at(t, "kind", path + ".kind", kKindWords, std::optional(RegisterKind::holding),
                     "must be holding, input, coil, discrete or running");
  }
  r.name = string_at(t, "name", path + ".name", true);
  r.field_id = string_at(t, "id", path + ".id", false);
  if (r.field_id.empty()) {
    // A name of no letters or digits ("###") gives no id: its value could not be shown or
    // filtered.
    r.field_id = register_field_id(r.name);
    if (r.field_id.empty())
      throw Bad{
          line_of(*t.get("name")), path + ".name",
          fmt::format("'{}' has no letter or digit to make its id of: give id = \"...\"", r.name)};
  } else if (!valid_register_field_id(r.field_id)) {
    throw Bad{line_of(*t.get("id")), path + ".id",
              "expected lowercase letters, digits and '_' (not first or last)"};
  } else if (is_shared_drive_field_id(r.field_id)) {
    // drive.running, drive.setpoint, ...: values drivetap fills from the registers' roles; a
    // register named so would hide its own value.
    throw Bad{line_of(*t.get("id")), path + ".id",
              fmt::format("'{}' is a drive value drivetap fills itself (drive.{}): choose another "
                          "id, or give the register that role",
                          r.field_id, r.field_id)};
  }
  static constexpr std::string_view kAccessWords[] = {"r", "w", "rw"};
  r.access = enum_at(t, "access", path + ".access", kAccessWords,
                     std::optional(RegisterAccess::read_write), "must be r, w or rw");
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
  static constexpr std::string_view kRoleWords[] = {
      "",      "control", "status", "setpoint", "output_frequency", "current", "voltage",
      "fault", "start",   "stop",   "reset"};
  r.role = enum_at(t, "role", path + ".role", kRoleWords, std::optional(RegisterRole::none),
                   "must be control, status, setpoint, output_frequency, current, voltage, fault, "
                   "start, stop or reset");
  // One unit for each shared id (drive_fields.hpp): a role's value is drive.<role> in its unit,
  // or, for a percentage of the reference, drive.<role>_pct.
  if (const std::string rule = role_unit_rule(r.role, r.unit); !rule.empty())
    throw Bad{line_of(t.get("unit") ? *t.get("unit") : *t.get("role")), path + ".unit", rule};
  if (auto w = int_at(t, "words", path + ".words", 1, 2)) r.words = static_cast<int>(*w);
  if (const toml::node* st = t.get("state")) {
    if (!st->is_table()) throw Bad{line_of(*st), path + ".state", "expected a table"};
    for (const auto& [k, v] : *st->as_table()) {
      const std::string key(k.str());
      const std::string p = path + ".state." + key;
      std::vector<int>* slot = key == "run"       ? &r.state.run
                               : key == "reset"   ? &r.state.reset
                               : key == "running" ? &r.state.running
                               : key == "forward" ? &r.state.forward
                               : key == "reverse" ? &r.state.reverse
                               : key == "fault"   ? &r.state.fault
                               : key == "warning" ? &r.state.warning
                               : key == "ready"   ? &r.state.ready
                                                  : nullptr;
      if (!slot)
        throw Bad{line_of(v), p,
                  "unknown state (run, reset, running, forward, reverse, fault, warning, ready)"};
      *slot = state_bits(v, p);
    }
  }
  if (const toml::node* b = t.get("bits")) {
    if (b->is_string()) {
      r.bits = word_bits(b->as_string()->get(), line_of(*b), path + ".bits");
      return r;
    }
    if (!b->is_table())
      throw Bad{line_of(*b), path + ".bits",
                "expected a table or a word's name (" + word_ids() + ")"};
    for (const auto& [k, v] : *b->as_table()) {
      const std::string p = path + ".bits." + std::string(k.str());
      const std::uint32_t bit = numeric_key(k.str(), line_of(v), p);
      if (bit > 31) throw Bad{line_of(v), p, "bit number must be 0..31"};
      const toml::array* a = v.as_array();
      if (!a || a->size() != 2 || !(*a)[0].is_string() || !(*a)[1].is_string())
        throw Bad{line_of(v), p, "expected [\"meaning when 0\", \"meaning when 1\"]"};
      r.bits.push_back({static_cast<int>(bit), printable((*a)[0].as_string()->get()),
                        printable((*a)[1].as_string()->get())});
    }
    // TOML tables keep their keys as text ("10" before "2"); meanings are shown by bit number.
    std::sort(r.bits.begin(), r.bits.end(),
              [](const RegisterBit& x, const RegisterBit& y) { return x.bit < y.bit; });
  }
  return r;
}

DriveProfile parse_tables(const toml::table& root) {
  only_keys(root, "",
            {"drive", "limits", "timing", "parameters", "process_data", "register", "parameter",
             "enums", "exceptions", "parameter_errors"});
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
        throw Bad{line_of(e), "drive.protocols", "each must be " + protocol_ids_text()};
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
  if (const toml::node* n = root.get("parameters")) {
    if (!n->is_table()) throw Bad{line_of(*n), "parameters", "expected a table"};
    const toml::table& t = *n->as_table();
    only_keys(t, "parameters", {"rule"});
    const std::string rule = string_at(t, "rule", "parameters.rule", true);
    p.parameter_rule = parameter_numbering_named(rule);
    if (!p.parameter_rule)
      throw Bad{line_of(*t.get("rule")), "parameters.rule",
                fmt::format("must be {}", parameter_numbering_names_text())};
  }
  if (const toml::node* n = root.get("process_data")) {
    if (!n->is_table()) throw Bad{line_of(*n), "process_data", "expected a table"};
    const toml::table& t = *n->as_table();
    only_keys(t, "process_data", {"to_drive", "from_drive"});
    auto addresses = [&](std::string_view key, std::vector<std::uint32_t>& out) {
      const std::string path = "process_data." + std::string(key);
      const toml::node* list = t.get(key);
      if (!list) throw Bad{line_of(t), path, "missing"};
      const toml::array* a = list->as_array();
      if (!a || a->size() != 2) throw Bad{line_of(*list), path, "expected [PCD1, PCD2] addresses"};
      for (const toml::node& e : *a) {
        if (!e.is_integer() || e.as_integer()->get() < 0 || e.as_integer()->get() > 0xFFFF)
          throw Bad{line_of(e), path, "each must be a register address 0..65535"};
        out.push_back(static_cast<std::uint32_t>(e.as_integer()->get()));
      }
    };
    addresses("to_drive", p.pcd_to_drive);
    addresses("from_drive", p.pcd_from_drive);
  }
  if (const toml::node* n = root.get("enums")) {
    if (!n->is_table()) throw Bad{line_of(*n), "enums", "expected a table"};
    for (const auto& [k, v] : *n->as_table()) {
      const std::string path = "enums." + std::string(k.str());
      if (!v.is_table()) throw Bad{line_of(v), path, "expected a table"};
      p.enums[std::string(k.str())] = value_names(*v.as_table(), path);
    }
  }
  for (const char* list : {"register", "parameter"}) {
    const toml::node* n = root.get(list);
    if (!n) continue;
    const toml::array* a = n->as_array();
    if (!a) throw Bad{line_of(*n), list, fmt::format("expected [[{}]] tables", list)};
    const bool is_parameter = std::string_view(list) == "parameter";
    for (std::size_t i = 0; i < a->size(); ++i) {
      const toml::node& e = (*a)[i];
      const std::string path = fmt::format("{}[{}]", list, i + 1);
      if (!e.is_table()) throw Bad{line_of(e), path, "expected a table"};
      p.registers.push_back(
          parse_register(*e.as_table(), path,
                         is_parameter ? std::optional<const ParameterNumbering*>(p.parameter_rule)
                                      : std::nullopt));
      // A register's field id is unique in its profile: a name another register has already is
      // told apart by its number or address; an `id` given twice is an error.
      RegisterDef& added = p.registers.back();
      auto taken = [&](const std::string& id) {
        for (std::size_t k = 0; k + 1 < p.registers.size(); ++k)
          if (p.registers[k].field_id == id) return true;
        return false;
      };
      if (taken(added.field_id)) {
        if (const toml::node* id = e.as_table()->get("id"))
          throw Bad{line_of(*id), path + ".id",
                    fmt::format("'{}' names another register too", added.field_id)};
        added.field_id += '_';
        added.field_id += added.kind == RegisterKind::parameter
                              ? register_field_id(added.number)
                              : fmt::format("{:04x}", added.address);
      }
      const std::string& enum_name = p.registers.back().enum_name;
      if (!enum_name.empty() && !p.enums.count(enum_name))
        throw Bad{line_of(*e.as_table()->get("enum")), path + ".enum",
                  fmt::format("no [enums.{}] table", enum_name)};
    }
  }
  if (const toml::node* n = root.get("exceptions")) {
    if (!n->is_table()) throw Bad{line_of(*n), "exceptions", "expected a table"};
    p.exceptions = value_names(*n->as_table(), "exceptions");
  }
  if (const toml::node* n = root.get("parameter_errors")) {
    if (!n->is_table()) throw Bad{line_of(*n), "parameter_errors", "expected a table"};
    p.parameter_errors = value_names(*n->as_table(), "parameter_errors");
  }
  for (std::uint32_t address : p.pcd_to_drive)
    if (!p.find(RegisterKind::holding, address))
      throw Bad{line_of(*root.get("process_data")), "process_data.to_drive",
                fmt::format("no [[register]] with address {}", address)};
  for (std::uint32_t address : p.pcd_from_drive)
    if (!p.find(RegisterKind::holding, address))
      throw Bad{line_of(*root.get("process_data")), "process_data.from_drive",
                fmt::format("no [[register]] with address {}", address)};
  for (RegisterDef& r : p.registers) r.shared_field_id = is_shared_drive_field_id(r.field_id);
  p.build_index();
  p.texts_plain = profile_texts_plain(p);
  return p;
}

// toml++ recurses once per part of a dotted key and per level of nested arrays and inline
// tables, so a small file can exhaust the stack whatever its size limit. A drive profile needs a
// few levels of each: the text is refused past these before it reaches the parser.
constexpr int kMaxTomlNesting = 32;
constexpr int kMaxTomlDots = 32;

// Where the text nests deeper or dots longer than a profile can: {line, why}, or line 0. Strings
// and comments are skipped (their brackets and dots are text); every step moves `i` forward.
std::pair<int, std::string> toml_nesting_problem(std::string_view text) {
  int line = 1, depth = 0, dots = 0;
  std::size_t i = 0;
  auto skip_string = [&](std::string_view quote, bool escapes) {
    i += quote.size();
    while (i < text.size() && text.substr(i, quote.size()) != quote) {
      if (text[i] == '\n') ++line;
      i += escapes && text[i] == '\\' && i + 1 < text.size() ? 2 : 1;
    }
    i += quote.size();  // past the closing quote (or past the end: the parser reports it)
  };
  while (i < text.size()) {
    const char c = text[i];
    if (text.substr(i, 3) == R"(""")") {
      skip_string(R"(""")", true);
    } else if (text.substr(i, 3) == "'''") {
      skip_string("'''", false);
    } else if (c == '"') {
      skip_string("\"", true);
    } else if (c == '\'') {
      skip_string("'", false);
    } else if (c == '#') {
      while (i < text.size() && text[i] != '\n') ++i;
    } else {
      if (c == '\n') {
        ++line;
        dots = 0;
      } else if (c == '[' || c == '{') {
        if (++depth > kMaxTomlNesting)
          return {line,
                  fmt::format("arrays and tables nest deeper than {} levels", kMaxTomlNesting)};
      } else if (c == ']' || c == '}') {
        depth = std::max(depth - 1, 0);
      } else if (c == '.' && ++dots > kMaxTomlDots) {
        return {line, fmt::format("more than {} dots on one line (a dotted key of that many parts)",
                                  kMaxTomlDots)};
      }
      ++i;
    }
  }
  return {0, {}};
}

}  // namespace

std::string register_field_id(std::string_view name) {
  std::string id;
  bool gap = false;
  for (const char c : name) {
    const auto u = static_cast<unsigned char>(c);
    if (std::isalnum(u) != 0 && u < 0x80) {
      if (gap && !id.empty()) id += '_';
      gap = false;
      id += static_cast<char>(std::tolower(u));
    } else {
      gap = true;
    }
  }
  return id;
}

bool valid_register_field_id(std::string_view id) {
  if (id.empty() || id.front() == '_' || id.back() == '_') return false;
  for (const char c : id)
    if (!((c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_')) return false;
  return true;
}

bool profile_texts_plain(const DriveProfile& p) {
  // Printable ASCII but '"' and '\\', and well-formed UTF-8 characters other than C1 controls
  // ("§"): what a JSON string holds as it is (its escaping leaves such characters alone).
  auto plain = [](std::string_view s) {
    for (std::size_t i = 0; i < s.size();) {
      const auto c = static_cast<unsigned char>(s[i]);
      if (c < 0x80) {
        if (c < 0x20 || c == 0x7F || c == '"' || c == '\\') return false;
        ++i;
        continue;
      }
      const std::size_t n = utf8_length(s, i, /*allow_c1=*/false);
      if (n == 0) return false;
      i += n;
    }
    return true;
  };
  auto names_plain = [&](const auto& names) {
    for (const auto& [number, name] : names)
      if (!plain(name)) return false;
    return true;
  };
  if (!plain(p.id) || !plain(p.name)) return false;
  if (p.parameter_rule && !plain(p.parameter_rule->noun)) return false;
  for (const RegisterDef& r : p.registers) {
    if (!plain(r.number) || !plain(r.name) || !plain(r.field_id) || !plain(r.unit)) return false;
    for (const RegisterBit& b : r.bits)
      if (!plain(b.when_clear) || !plain(b.when_set)) return false;
  }
  for (const auto& [name, names] : p.enums)
    if (!names_plain(names)) return false;
  return names_plain(p.exceptions) && names_plain(p.parameter_errors);
}

std::optional<DriveProfile> parse_profile(std::string_view toml_text, std::string_view file_name,
                                          ProfileError* error) {
  if (const auto [line, why] = toml_nesting_problem(toml_text); line > 0) {
    *error = {std::string(file_name), line, "", why + ": not a drive profile"};
    return std::nullopt;
  }
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

std::optional<std::vector<DriveProfile>> load_builtin_profiles(ProfileError* error) {
  std::vector<DriveProfile> out;
  for (const BuiltinProfileText& b : builtin_profile_texts()) {
    auto profile = parse_profile(b.text, b.file, error);
    if (!profile) return std::nullopt;
    out.push_back(std::move(*profile));
  }
  return out;
}

std::optional<DriveProfile> load_profile_file(const std::string& path, ProfileError* error) {
  // Opened without blocking and refused unless it is a regular file: a FIFO would hang open()
  // until a writer came, a device (/dev/zero) would be read without end.
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) {
    *error = {path, 0, "", fmt::format("cannot open the profile file: {}", std::strerror(errno))};
    return std::nullopt;
  }
  struct Closer {
    int fd;
    ~Closer() { ::close(fd); }
  } closer{fd};
  struct stat st {};
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    *error = {path, 0, "",
              S_ISDIR(st.st_mode) ? "is a directory, not a profile file"
                                  : "is not a regular file (a FIFO, socket or device), not a "
                                    "profile file"};
    return std::nullopt;
  }
  // Profiles are a few KiB of TOML; reading stops past the limit (a large file given by mistake
  // would otherwise be read whole into memory).
  constexpr std::size_t kMaxProfileBytes = 1u << 20;
  std::string text(kMaxProfileBytes + 1, '\0');
  std::size_t got = 0;
  while (got < text.size()) {
    const ssize_t n = ::read(fd, text.data() + got, text.size() - got);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) {
      *error = {path, 0, "", fmt::format("cannot read the profile file: {}", std::strerror(errno))};
      return std::nullopt;
    }
    if (n == 0) break;
    got += static_cast<std::size_t>(n);
  }
  if (got > kMaxProfileBytes) {
    *error = {path, 0, "",
              fmt::format("larger than {} bytes: not a drive profile", kMaxProfileBytes)};
    return std::nullopt;
  }
  text.resize(got);
  return parse_profile(text, path, error);
}

}  // namespace drivetap
