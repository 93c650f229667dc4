// Drive profiles: what a drive family's manual says about its registers, coils, faults, limits
// and timing rules, as data (dissectors/profiles/*.toml; schema in dissectors/profiles/README.md).
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "core/drive_records.hpp"  // RegisterKind
#include "core/message.hpp"
#include "core/parameter_numbering.hpp"
#include "core/serial_config.hpp"

namespace drivetap {

enum class RegisterAccess : std::uint8_t { read, write, read_write };

struct RegisterBit {
  int bit = 0;
  std::string when_clear;
  std::string when_set;
};

// Which bits of a control or status word carry drive state (the timeline reads these). A state is
// on when any of its bits is set.
struct StateBits {
  std::vector<int> run, reset, running, forward, reverse, fault, warning, ready;
};

// What a register means to the drive's state (the profile's `role`); none: only its value.
enum class RegisterRole : std::uint8_t {
  none,
  control,
  status,
  setpoint,
  output_frequency,
  current,
  voltage,
  fault,
  start,
  stop,
  reset,
};

struct RegisterDef {
  std::uint32_t address = 0;  // register address, running-value index, or parameter wire number
  std::string number;         // parameters: as the manual prints it ("4-14", "F0.05")
  std::string name;
  // Its record field's name after `drive.` (the profile's `id`, else made from the name:
  // lowercase, each run of other characters than letters and digits one `_`).
  std::string field_id;
  // field_id is one of the names every family shares (is_shared_drive_field_id()): its value is
  // shown as the observation's, not as the register's.
  bool shared_field_id = false;
  RegisterKind kind = RegisterKind::holding;
  RegisterAccess access = RegisterAccess::read_write;
  std::string unit;
  double scale = 1.0;
  bool is_signed = false;
  std::string enum_name;
  RegisterRole role = RegisterRole::none;
  int words = 1;  // 2: a 32-bit value over two registers, high word first
  std::vector<RegisterBit> bits;
  StateBits state;
};

struct DriveProfile {
  std::string id;
  std::string name;
  std::string source;
  std::vector<Protocol> protocols;
  std::optional<SerialConfig> serial;
  int address_min = 0;
  int address_max = 247;
  std::vector<int> functions;
  std::optional<int> max_read_registers;
  std::optional<int> max_write_registers;
  std::optional<double> min_silence_chars;
  std::optional<double> min_reply_to_request_ms;
  std::optional<double> max_reply_delay_ms;
  std::optional<double> min_reply_delay_ms;
  std::string timing_section;  // where the manual states the timing rules
  // How the manual's parameter numbers reach the wire (its [parameters] rule; nullptr: none).
  const ParameterNumbering* parameter_rule = nullptr;
  // Danfoss FC protocol: the registers PCD1, PCD2 stand for, per direction (CTW/REF, STW/MAV).
  std::vector<std::uint32_t> pcd_to_drive, pcd_from_drive;
  std::vector<RegisterDef> registers;  // registers, coils, running values and parameters
  std::map<std::string, std::map<std::uint32_t, std::string>> enums;
  std::map<std::uint32_t, std::string> exceptions;
  std::map<std::uint32_t, std::string> parameter_errors;  // Danfoss FC protocol AK 7 numbers
  // Every text an annotation or a drive value takes from the profile (its id and name, the
  // registers' numbers, names, units and bit texts, the names of its enums, exceptions and
  // parameter errors, its rule's noun) is printable ASCII but '"' and '\\', or well-formed UTF-8
  // but C1 controls: a text made of them, literals and numbers is a JSON string's inside as it
  // is. Set by parse_profile() (profile_texts_plain()); false, nothing assumed, for a profile
  // made otherwise.
  bool texts_plain = false;

  [[nodiscard]] const RegisterDef* find(RegisterKind kind, std::uint32_t address) const;
  // Builds find()'s table now if `registers` changed since it was built. Afterwards, as long as
  // nobody edits the profile, find() only reads and may run on several threads at once (the
  // ThreadedSink's writer annotates frames while the pipeline decodes). parse_profile() and the
  // pipeline's constructor call it.
  void build_index() const;
  // What a Modbus holding register address means: a register of the map, else the parameter the
  // addressing rule puts there. `parameter_label` gets the manual's number for an address the
  // rule maps but the profile does not name; empty when the address is no parameter.
  [[nodiscard]] const RegisterDef* find_holding(std::uint32_t address,
                                                std::string* parameter_label = nullptr) const;
  // find() for the addresses of a block (a poll reads 8 registers from `first` up): one search
  // for the first, then a walk along the table (a search per register cost the drive reading).
  // An address below the last one asked is searched
  // afresh. The profile must outlive it and not change meanwhile.
  class Walk {
   public:
    Walk(const DriveProfile& profile, RegisterKind kind, std::uint32_t first);
    [[nodiscard]] const RegisterDef* find(std::uint32_t address);
    [[nodiscard]] RegisterKind kind() const { return kind_; }

   private:
    void seek(std::uint64_t key);
    const DriveProfile& profile_;
    RegisterKind kind_;
    std::size_t at_ = 0;      // the first table entry not below the last key asked
    std::uint64_t last_ = 0;  // the last key asked
  };
  // find_holding() along a walk of the holding registers (a walk of another kind is not used).
  [[nodiscard]] const RegisterDef* find_holding(std::uint32_t address, Walk& walk) const;
  // The parameter's wire number of a Modbus holding register address, if the rule maps one.
  [[nodiscard]] std::optional<std::uint32_t> parameter_of_register(std::uint32_t address) const;
  // The manual's spelling of a parameter wire number ("4-14", "08-03", "F0.05").
  [[nodiscard]] std::string parameter_label(std::uint32_t number) const;

 private:
  // The first entry of the table (built) whose key is not below `key`: find()'s search, and a
  // walk's first.
  [[nodiscard]] std::size_t first_index_at(std::uint64_t key) const;
  // find_holding() past the register map: the parameter the rule puts at `address`.
  const RegisterDef* parameter_at(std::uint32_t address, std::string* parameter_label) const;
  // find() is called for every register of every frame of every candidate profile: it searches
  // a sorted (kind, address) -> index table, rebuilt whenever `registers` changed size (profiles
  // are built once and then only read; a caller editing a register's key in place must clear
  // `registers_index_`).
  mutable std::vector<std::pair<std::uint64_t, std::uint32_t>> registers_index_;
  mutable std::size_t indexed_count_ = 0;
};

// Where a profile went wrong: "file:line: key 'register[3].scale': expected a number".
struct ProfileError {
  std::string file;
  int line = 0;
  std::string key;
  std::string message;
  [[nodiscard]] std::string text() const;
};

// Whether every text of `profile` that annotations and drive values show is plain, as
// DriveProfile::texts_plain says.
bool profile_texts_plain(const DriveProfile& profile);

// A register's record field id made from its name: "Output frequency" -> "output_frequency".
std::string register_field_id(std::string_view name);
// Whether `id` is a well-formed register field id: [a-z0-9_]+, not starting or ending with `_`.
bool valid_register_field_id(std::string_view id);

std::optional<DriveProfile> parse_profile(std::string_view toml_text, std::string_view file_name,
                                          ProfileError* error);
std::optional<DriveProfile> load_profile_file(const std::string& path, ProfileError* error);

struct BuiltinProfileText {
  std::string_view file;  // "e9.toml"
  std::string_view text;
};
// The profiles compiled into drivetap (generated from dissectors/profiles/*.toml by CMake).
std::span<const BuiltinProfileText> builtin_profile_texts();
// All of them parsed; nullopt with *error naming the file when one does not load.
std::optional<std::vector<DriveProfile>> load_builtin_profiles(ProfileError* error);

}  // namespace drivetap
