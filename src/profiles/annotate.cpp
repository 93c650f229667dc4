// Drive-level annotation of Modbus frames from a drive profile (dissectors/profiles/README.md).
#include "profiles/annotate.hpp"

#include <fmt/format.h>

#include <cmath>
#include <vector>

#include "dissectors/modbus/ascii_dissector.hpp"

namespace drivetap {
namespace {

// The binary Modbus frame (ADDR FC DATA ...) of an RTU or ASCII message.
std::vector<std::uint8_t> modbus_binary(Protocol protocol, std::span<const std::uint8_t> bytes) {
  if (protocol == Protocol::modbus_ascii) return modbus::decode_ascii_hex(bytes).binary;
  return {bytes.begin(), bytes.end()};
}

std::uint16_t be16(const std::vector<std::uint8_t>& b, std::size_t at) {
  return static_cast<std::uint16_t>((b[at] << 8) | b[at + 1]);
}

int decimals_of(double scale) {
  int d = 0;
  for (double s = scale; d < 6 && std::fabs(s - std::round(s)) > 1e-9; s *= 10) ++d;
  return d;
}

std::string register_name(const DriveProfile& p, RegisterKind kind, std::uint16_t address) {
  if (const RegisterDef* r = p.find(kind, address)) return r->name;
  return fmt::format("register 0x{:04X}", address);
}

std::string registers_text(const DriveProfile& p, RegisterKind kind, std::uint16_t start,
                           std::span<const std::uint16_t> values) {
  std::vector<std::string> parts;
  for (std::size_t i = 0; i < values.size(); ++i) {
    const auto address = static_cast<std::uint16_t>(start + i);
    const RegisterDef* r = p.find(kind, address);
    if (!r) continue;  // registers the manual does not name are left to the frame line
    parts.push_back(fmt::format("{} {}", r->name, describe_value(p, *r, values[i])));
  }
  return fmt::format("{}", fmt::join(parts, "; "));
}

std::string coils_text(const DriveProfile& p, std::uint16_t start, std::size_t count,
                       std::span<const std::uint8_t> packed) {
  std::vector<std::string> parts;
  for (std::size_t i = 0; i < count && i / 8 < packed.size(); ++i) {
    const RegisterDef* r = p.find(RegisterKind::coil, static_cast<std::uint16_t>(start + i));
    if (!r) continue;
    parts.push_back(fmt::format("{} {}", r->name, ((packed[i / 8] >> (i % 8)) & 1) ? "ON" : "OFF"));
  }
  return fmt::format("{}", fmt::join(parts, "; "));
}

}  // namespace

std::string describe_value(const DriveProfile& p, const RegisterDef& r, std::uint16_t raw) {
  if (!r.enum_name.empty()) {
    const auto& names = p.enums.at(r.enum_name);
    const auto it = names.find(raw);
    return it == names.end() ? fmt::format("{} (not in the manual's table)", raw)
                             : fmt::format("{} ({})", raw, it->second);
  }
  if (!r.bits.empty()) {
    std::vector<std::string> states;
    for (const RegisterBit& b : r.bits) {
      const std::string& s = ((raw >> b.bit) & 1) ? b.when_set : b.when_clear;
      if (!s.empty()) states.push_back(s);
    }
    return fmt::format("0x{:04X} [{}]", raw, fmt::join(states, ", "));
  }
  const double v =
      (r.is_signed ? static_cast<double>(static_cast<std::int16_t>(raw)) : raw) * r.scale;
  return fmt::format("{:.{}f}{}{}", v, decimals_of(r.scale), r.unit.empty() ? "" : " ", r.unit);
}

std::string annotate_for_drive(const DriveProfile& p, const Message& m,
                               std::span<const std::uint8_t> request) {
  if (m.protocol != Protocol::modbus_rtu && m.protocol != Protocol::modbus_ascii) return {};
  const std::vector<std::uint8_t> b = modbus_binary(m.protocol, m.bytes);
  if (b.size() < 4) return {};
  const std::uint8_t fc = b[1];
  const std::size_t end = b.size() - (m.protocol == Protocol::modbus_rtu ? 2 : 1);  // before check
  std::string what;
  if (fc & 0x80) {
    const auto it = p.exceptions.find(b[2]);
    if (it != p.exceptions.end()) what = fmt::format("error 0x{:02X}: {}", b[2], it->second);
  } else if (m.direction == Direction::request) {
    if ((fc == 0x03 || fc == 0x04) && end >= 6) {
      const RegisterKind kind = fc == 0x03 ? RegisterKind::holding : RegisterKind::input;
      const std::uint16_t start = be16(b, 2), count = be16(b, 4);
      what =
          count == 1
              ? fmt::format("read {}", register_name(p, kind, start))
              : fmt::format("read {} .. {}", register_name(p, kind, start),
                            register_name(p, kind, static_cast<std::uint16_t>(start + count - 1)));
    } else if (fc == 0x06 && end >= 6) {
      const std::uint16_t value = be16(b, 4);
      const std::uint16_t values[] = {value};
      what = registers_text(p, RegisterKind::holding, be16(b, 2), values);
      if (!what.empty()) what = "set " + what;
    } else if (fc == 0x10 && end >= 7) {
      std::vector<std::uint16_t> values;
      for (std::size_t i = 7; i + 1 < end; i += 2) values.push_back(be16(b, i));
      what = registers_text(p, RegisterKind::holding, be16(b, 2), values);
      if (!what.empty()) what = "set " + what;
    } else if (fc == 0x05 && end >= 6) {
      const std::uint8_t on = b[4] == 0xFF ? 1 : 0;
      what = coils_text(p, be16(b, 2), 1, std::span(&on, 1));
    } else if (fc == 0x0F && end >= 7) {
      what = coils_text(p, be16(b, 2), be16(b, 4), std::span(b).subspan(7, end - 7));
    }
  } else if (m.direction == Direction::response && !request.empty()) {
    const std::vector<std::uint8_t> q = modbus_binary(m.protocol, request);
    if (q.size() < 6 || q[1] != fc) return {};
    if ((fc == 0x03 || fc == 0x04) && end >= 3) {
      std::vector<std::uint16_t> values;
      for (std::size_t i = 3; i + 1 < end; i += 2) values.push_back(be16(b, i));
      what = registers_text(p, fc == 0x03 ? RegisterKind::holding : RegisterKind::input, be16(q, 2),
                            values);
    } else if ((fc == 0x01 || fc == 0x02) && end >= 3) {
      what = coils_text(p, be16(q, 2), be16(q, 4), std::span(b).subspan(3, end - 3));
    }
  }
  if (what.empty()) return {};
  return fmt::format("drive {} ({}): {}", m.address, p.name, what);
}

}  // namespace drivetap
