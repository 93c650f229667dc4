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

#include "core/message.hpp"
#include "core/serial_config.hpp"

namespace drivetap {

enum class RegisterKind : std::uint8_t { holding, input, coil, discrete };
enum class RegisterAccess : std::uint8_t { read, write, read_write };

struct RegisterBit {
  int bit = 0;
  std::string when_clear;
  std::string when_set;
};

struct RegisterDef {
  std::uint16_t address = 0;
  std::string name;
  RegisterKind kind = RegisterKind::holding;
  RegisterAccess access = RegisterAccess::read_write;
  std::string unit;
  double scale = 1.0;
  bool is_signed = false;
  std::string enum_name;
  std::string role;
  std::vector<RegisterBit> bits;
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
  std::vector<RegisterDef> registers;
  std::map<std::string, std::map<std::uint32_t, std::string>> enums;
  std::map<std::uint32_t, std::string> exceptions;

  [[nodiscard]] const RegisterDef* find(RegisterKind kind, std::uint16_t address) const;
};

// Where a profile went wrong: "file:line: key 'register[3].scale': expected a number".
struct ProfileError {
  std::string file;
  int line = 0;
  std::string key;
  std::string message;
  [[nodiscard]] std::string text() const;
};

std::optional<DriveProfile> parse_profile(std::string_view toml_text, std::string_view file_name,
                                          ProfileError* error);
std::optional<DriveProfile> load_profile_file(const std::string& path, ProfileError* error);

struct BuiltinProfileText {
  std::string_view file;  // "e9.toml"
  std::string_view text;
};
// The profiles compiled into drivetap (generated from dissectors/profiles/*.toml by CMake).
std::span<const BuiltinProfileText> builtin_profile_texts();

}  // namespace drivetap
