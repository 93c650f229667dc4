// Easydrive ASCII protocol dissector (docs/protocols.md §5; errata §6; 001 ch. 11).
#include "dissectors/easydrive/eds_dissector.hpp"

#include <fmt/compile.h>
#include <fmt/format.h>

#include "dissectors/common/delimited_framer.hpp"
#include "dissectors/easydrive/eds_fields.hpp"
#include "dissectors/easydrive/eds_findings.hpp"

namespace drivetap::easydrive {
namespace {

int hex_value(std::uint8_t c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

}  // namespace

long hex_field(std::span<const std::uint8_t> f, std::size_t at, std::size_t n) {
  if (at + n > f.size()) return -1;
  long v = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const int d = hex_value(f[at + i]);
    if (d < 0) return -1;
    v = v * 16 + d;
  }
  return v;
}

namespace {

bool is_request_command(long c) {
  return c >= 0x0A && c <= 0x0F;
}
bool is_response_code(long c) {
  return c == 0x00 || (c >= 0x10 && c <= 0x14) || c == 0x20 || c == 0x30;
}

// The body between '~' and CR, whatever its terminator state.
std::span<const std::uint8_t> body_of(std::span<const std::uint8_t> f) {
  std::size_t end = f.size();
  if (end > 0 && f[end - 1] == '\r') --end;
  return f.subspan(1, end > 1 ? end - 1 : 0);
}

std::string frequency(long v) {
  return fmt::format(FMT_COMPILE("{}.{:02} Hz"), v / 100, v % 100);
}

// Status word bits (001 table 11-5; docs/protocols.md §5).
std::string status_word(long w) {
  static constexpr const char* kBits[11] = {"run",
                                            "undervoltage",
                                            "reverse",
                                            "swing frequency",
                                            "normal run",
                                            "jog",
                                            "PLC",
                                            "multi-step",
                                            "PID closed loop",
                                            "set count reached",
                                            "specified count reached"};
  std::string out;
  for (int b = 0; b < 11; ++b)
    if ((w >> b) & 1) out += fmt::format(FMT_COMPILE("{}{}"), out.empty() ? "" : ", ", kBits[b]);
  return out.empty() ? "stopped" : out;
}

}  // namespace

Plausibility eds_plausibility(std::span<const std::uint8_t> f, Direction direction, bool describe) {
  Plausibility p;
  auto broken = [&](const PlausibilityRule& rule, auto&& why) {
    return Plausibility::breaking(rule, describe, why);
  };
  if (f.empty() || f[0] != '~')
    return broken(kRuleEdsStart, [] { return std::string("no '~' first"); });
  if (f.back() != '\r') return broken(kRuleEdsTerminator, [] { return std::string("no CR last"); });
  for (std::size_t i = 1; i + 1 < f.size(); ++i)
    if (hex_value(f[i]) < 0)
      return broken(kRuleEdsCharset, [&] {
        return fmt::format(FMT_COMPILE("character 0x{:02X} at {} (only 0-9, A-F)"), f[i], i);
      });
  if (f.size() != 14 && f.size() != 18)
    return broken(kRuleEdsLength, [&] {
      return fmt::format(FMT_COMPILE("{} characters before CR (13 or 17)"), f.size() - 1);
    });
  const long code = hex_field(f, 3, 2);
  if (!fits_direction(direction, is_request_command(code), is_response_code(code)))
    return broken(kRuleEdsCommand, [&] {
      return fmt::format(FMT_COMPILE("code {:02X} is no {}"), code,
                         expected_for(direction, "command", "response code"));
    });
  return p;
}

std::uint16_t ascii_sum(std::span<const std::uint8_t> text) {
  std::uint16_t s = 0;
  for (const std::uint8_t c : text) s = static_cast<std::uint16_t>(s + c);
  return s;
}

void dissect_eds(Message& m, Frame&& frame, Direction direction, const FramingTiming& timing,
                 std::span<const std::uint8_t> request) {
  (void)timing;
  begin_message(m, std::move(frame), protocols::easydrive, direction);
  m.text_encoded = true;
  const std::span<const std::uint8_t> f(m.bytes);
  FieldTreeBuilder tree(m.fields, m.detail && m.tree);
  if (f.empty() || f[0] != '~') {
    add_finding(m, kFindingNoStart);
    add_implausible(m, kFindingImplausible, eds_plausibility(f, direction, true));
    m.describe([] { return std::string("not an Easydrive frame"); });
    return;
  }
  tree.add_text(kStart, 0, 1, "~");
  if (f.back() != '\r') add_finding(m, kFindingNoCr);
  // Only '~', 0-9, A-F and CR are valid (lower case is an error too).
  for (std::size_t i = 1; i < f.size(); ++i) {
    const std::uint8_t c = f[i];
    if (hex_value(c) < 0 && !(c == '\r' && i + 1 == f.size())) {
      add_finding(m, kFindingBadCharacter, c, c >= 0x20 && c < 0x7F ? static_cast<char>(c) : '?',
                  i);
      break;
    }
  }
  const std::size_t len = f.size() - (f.back() == '\r' ? 1 : 0);  // without CR
  if (len != 13 && len != 17) {
    add_finding(m, kFindingLength, len);
  }
  const long addr = hex_field(f, 1, 2);
  const long cmd = hex_field(f, 3, 2);
  const long aux = hex_field(f, 5, 2);
  const long idx = hex_field(f, 7, 2);
  const bool has_data = len == 17;
  const long data = has_data ? hex_field(f, 9, 4) : -1;
  if (addr >= 0) {
    tree.add(kAddr, 1, 2, addr);
    m.address = static_cast<int>(addr);
  }
  const bool response = direction == Direction::response ||
                        (direction == Direction::unknown && is_response_code(cmd));
  // What the index and data mean comes from the command: a request's own, a reply's request's.
  const long context_cmd = response ? hex_field(request, 3, 2) : cmd;
  std::vector<std::string> info;
  if (cmd >= 0) {
    tree.add(response ? kResponse : kCommand, 3, 2, cmd);
    const std::string_view name =
        (response ? kResponse : kCommand).name_of(static_cast<std::uint32_t>(cmd));
    info.push_back(name.empty() ? fmt::format(FMT_COMPILE("{} 0x{:02X}"),
                                              response ? "response" : "command", cmd)
                                : std::string(name));
  }
  long index = -1;
  if (aux >= 0 && idx >= 0) {
    index = response ? idx : (aux << 8) | idx;
    if (response) tree.add(kFault, 5, 2, aux);
    tree.add(kIndex, response ? 7 : 5, response ? 2 : 4, index);
  }
  // What the index and data mean depends on the command (requests; replies echo the index).
  std::string index_name;
  if (index >= 0) {
    if (context_cmd == 0x0B) {
      for (const ValueName& v : kRunningValues)
        if (v.value == static_cast<std::uint32_t>(index)) index_name = std::string(v.name);
    } else if (context_cmd == 0x0C) {
      for (const ValueName& v : kRunActions)
        if (v.value == static_cast<std::uint32_t>(index)) index_name = std::string(v.name);
    } else if (context_cmd == 0x0D || context_cmd == 0x0E) {
      index_name = fmt::format(FMT_COMPILE("F{}.{:02}"),
                               index >> 8 == 0x0D   ? std::string("D")
                               : index >> 8 == 0x0F ? std::string("F")
                                                    : std::to_string(index >> 8),
                               index & 0xFF);
    }
  }
  if (!index_name.empty()) {
    tree.add_text(kIndexName, response ? 7 : 5, response ? 2 : 4, index_name);
    info.push_back(index_name);
  } else if (index >= 0 && context_cmd != 0x0A && context_cmd != 0x0F && context_cmd >= 0) {
    info.push_back(fmt::format(FMT_COMPILE("index 0x{:04X}"), index));
  }
  if (has_data && data >= 0) {
    tree.add(kData, 9, 4, data);
    std::string value;
    const bool freq =
        (context_cmd == 0x0C && (index == 1 || index == 2 || index == 5 || index == 6)) ||
        (context_cmd == 0x0B && (index == 0 || index == 1));
    const bool status = context_cmd == 0x0B && index == 0x0F;
    value = freq     ? frequency(data)
            : status ? fmt::format(FMT_COMPILE("0x{:04X} [{}]"), data, status_word(data))
                     : fmt::format(FMT_COMPILE("{}"), data);
    tree.add_text(kValue, 9, 4, value);
    info.push_back(context_cmd == 0x0E ? fmt::format(FMT_COMPILE("= {}"), value) : value);
  }
  if (response && aux > 0) info.push_back(fmt::format(FMT_COMPILE("drive fault code {}"), aux));
  m.describe([&] {
    return info.empty() ? std::string("Easydrive frame")
                        : fmt::format(FMT_COMPILE("{}"), fmt::join(info, ", "));
  });
  // SUM: the 4 characters before CR.
  if (len >= 13) {
    const long stated = hex_field(f, len - 4, 4);
    const std::uint16_t computed = ascii_sum(f.subspan(1, len - 5));
    tree.add(kSum, len - 4, 4, stated < 0 ? 0 : stated);
    m.checksum.name = "SUM";
    m.checksum.width = 2;
    m.checksum.text = true;
    m.checksum.stated_wire = static_cast<std::uint32_t>(stated < 0 ? 0 : stated);
    m.checksum.computed_wire = computed;
    m.checksum.verdict = stated == computed ? ChecksumVerdict::good : ChecksumVerdict::bad;
    std::string why;
    if (stated >= 0 && (stated - computed == 1 || computed - stated == 1)) why = " (off by one)";
    if (stated >= 0 && stated == computed + '\r') why = " (CR counted in the sum)";
    add_checksum_anomaly(m, why);
  } else {
    m.describe([&] {
      return fmt::format(FMT_COMPILE("{}-character fragment, too short for an Easydrive frame"),
                         f.size());
    });
  }
  add_implausible(m, kFindingImplausible, eds_plausibility(f, direction, true));
  append_uart_anomalies(m.frame.events, 0, m.anomalies);
}

namespace {

std::unique_ptr<Framer> make_framer(ChannelId channel, const FramerSettings& s) {
  return make_delimited_framer(channel, s, '~', '\r', 32);
}

DirectionFit direction_fit(std::span<const std::uint8_t> frame) {
  const long cmd = hex_field(frame, 3, 2);
  return {is_request_command(cmd), is_response_code(cmd)};
}

bool always_response(std::span<const std::uint8_t> frame) {
  return is_response_code(hex_field(frame, 3, 2));
}

bool recognisable(std::span<const std::uint8_t> frame) {
  return !frame.empty() && frame[0] == '~' && body_of(frame).size() >= 12;
}

ProtocolDecoder::PairingKeys pairing_keys(std::span<const std::uint8_t> frame) {
  const long addr = hex_field(frame, 1, 2);
  return {addr < 0 ? -1 : static_cast<int>(addr), -1};
}

}  // namespace

// In DecoderFunctions order.
constexpr DecoderFunctions kEdsFunctions{protocols::easydrive, make_framer,           direction_fit,
                                         always_response,      recognisable,          pairing_keys,
                                         dissect_eds,          read_eds_drive_records};

}  // namespace drivetap::easydrive
