// Modbus ASCII dissector (docs/protocols.md §3): hex text -> binary -> shared Modbus PDU layer.
#include "dissectors/modbus/ascii_dissector.hpp"

#include <fmt/compile.h>
#include <fmt/format.h>

#include "core/checksum.hpp"
#include "dissectors/common/delimited_framer.hpp"
#include "dissectors/modbus/modbus_fields.hpp"
#include "dissectors/modbus/modbus_findings.hpp"
#include "dissectors/modbus/modbus_pdu.hpp"

namespace drivetap::modbus {
namespace {

int hex_digit(std::uint8_t c, bool* lower) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  if (c >= 'a' && c <= 'f') {
    *lower = true;
    return c - 'a' + 10;
  }
  return -1;
}

}  // namespace

void spell_ascii_hex(std::span<const std::uint8_t> frame, std::vector<std::uint8_t>& binary,
                     AsciiHex* report) {
  binary.clear();
  auto problem = [&](auto&& make) {
    if (report) report->problems.push_back(make());
  };
  std::size_t end = frame.size();
  if (end >= 2 && frame[end - 2] == '\r' && frame[end - 1] == '\n') {
    if (report) report->terminated = true;
    end -= 2;
  } else if (end >= 1 && (frame[end - 1] == '\n' || frame[end - 1] == '\r')) {
    problem([] {
      return FoundProblem{&kFindingAsciiLoneTerminator, kFindingAsciiLoneTerminator.detail()};
    });
    end -= 1;
  } else {
    problem([] {
      return FoundProblem{&kFindingAsciiNoTerminator, kFindingAsciiNoTerminator.detail()};
    });
  }
  if (frame.empty() || frame[0] != ':') {
    problem([] { return FoundProblem{&kFindingAsciiNoStart, kFindingAsciiNoStart.detail()}; });
    return;
  }
  bool lower_case = false;
  // Each pass consumes two characters.
  for (std::size_t i = 1; i + 1 < end + 1 && i < end; i += 2) {
    if (i + 1 >= end) {
      problem([&] {
        return FoundProblem{&kFindingAsciiOddDigits,
                            kFindingAsciiOddDigits.detail(static_cast<char>(frame[i]), i)};
      });
      break;
    }
    const int hi = hex_digit(frame[i], &lower_case);
    const int lo = hex_digit(frame[i + 1], &lower_case);
    if (hi < 0 || lo < 0) {
      const std::size_t at = hi < 0 ? i : i + 1;
      problem([&] {
        return FoundProblem{&kFindingAsciiNotHex, kFindingAsciiNotHex.detail(frame[at], at)};
      });
      break;
    }
    binary.push_back(static_cast<std::uint8_t>((hi << 4) | lo));
  }
  if (lower_case && report) {
    report->lower_case = true;
    report->problems.push_back({&kFindingAsciiLowerCase, kFindingAsciiLowerCase.detail()});
  }
}

AsciiHex decode_ascii_hex(std::span<const std::uint8_t> frame) {
  AsciiHex out;
  spell_ascii_hex(frame, out.binary, &out);
  return out;
}

Plausibility ascii_plausibility(std::span<const std::uint8_t> frame, const AsciiHex& hex,
                                Direction direction, bool describe) {
  Plausibility p;
  auto broken = [&](const PlausibilityRule& rule, auto&& why) {
    return Plausibility::breaking(rule, describe, why);
  };
  if (frame.empty() || frame[0] != ':')
    return broken(kRuleAsciiStart, [] { return std::string("no ':' first"); });
  if (!hex.terminated)
    return broken(kRuleAsciiTerminator, [] { return std::string("no CR LF last"); });
  const std::span<const std::uint8_t> digits = frame.subspan(1, frame.size() - 3);
  for (std::size_t i = 0; i < digits.size(); ++i) {
    bool lower = false;
    if (hex_digit(digits[i], &lower) < 0)
      return broken(kRuleAsciiCharset, [&] {
        return fmt::format(FMT_COMPILE("character 0x{:02X} at {} is no hex digit"), digits[i],
                           i + 1);
      });
  }
  // Serial line §2.5.2: address, PDU of at most 253 bytes, LRC.
  if (digits.size() % 2 != 0 || hex.binary.size() < 3 || hex.binary.size() > 255)
    return broken(kRuleAsciiLength, [&] {
      return fmt::format(FMT_COMPILE("{} hex digits (an even count spelling 3-255 bytes)"),
                         digits.size());
    });
  return modbus_plausibility(hex.binary[0], std::span(hex.binary).subspan(1, hex.binary.size() - 2),
                             direction, describe);
}

void dissect_ascii(Message& m, Frame&& frame, Direction direction, const FramingTiming& timing,
                   std::span<const std::uint8_t> request) {
  (void)request;
  (void)timing;  // ASCII allows up to 1 s between characters: no t1.5 rule
  begin_message(m, std::move(frame), protocols::modbus_ascii, direction);
  m.text_encoded = true;
  const AsciiHex hex = decode_ascii_hex(m.bytes);
  const std::vector<std::uint8_t>& bin = hex.binary;
  for (const FoundProblem& p : hex.problems) add_finding_detail(m, *p.finding, p.detail);
  add_implausible(m, kFindingAsciiImplausible, ascii_plausibility(m.bytes, hex, direction, true));
  if (bin.size() < 3) {
    m.describe([&] {
      return fmt::format(FMT_COMPILE("{}-character fragment, too short for Modbus ASCII"),
                         m.bytes.size());
    });
    if (!bin.empty()) m.address = bin[0];
    return;
  }
  m.address = bin[0];
  m.function = bin[1];
  m.is_exception = (bin[1] & 0x80) != 0;
  // Decode the binary PDU, then map every field onto its hex characters (2 per byte, after ':').
  FieldTree binary_fields;
  binary_fields.keep_only(m.fields.kept_ids());
  FieldTreeBuilder binary_tree(binary_fields, m.detail && m.tree);
  binary_tree.add(kAsciiUnitId, 0, 1, bin[0]);
  PduDecode pdu = dissect_pdu(bin, 1, bin.size() - 2, direction, binary_tree, m.detail);
  binary_tree.add(kAsciiLrc, bin.size() - 1, 1, bin.back());
  for (const FieldNode& n : binary_fields) {
    FieldNode& mapped = m.fields.push_back_from(binary_fields, n);
    mapped.offset = 1 + 2 * n.offset;
    mapped.length = 2 * n.length;
  }
  m.info = std::move(pdu.info);
  m.exception_code = pdu.exception_code;
  for (FoundProblem& problem : pdu.problems)
    add_finding_detail(m, *problem.finding, std::move(problem.detail));

  const std::uint8_t computed = lrc8(std::span(bin).first(bin.size() - 1));
  m.checksum.name = "LRC";
  m.checksum.width = 1;
  m.checksum.stated_wire = bin.back();
  m.checksum.computed_wire = computed;
  m.checksum.verdict = bin.back() == computed ? ChecksumVerdict::good : ChecksumVerdict::bad;
  add_checksum_anomaly(m);
  append_uart_anomalies(m.frame.events, 0, m.anomalies);
}

namespace {

std::unique_ptr<Framer> make_framer(ChannelId channel, const FramerSettings& s) {
  return make_delimited_framer(channel, s, ':', '\n', 513);
}

DirectionFit direction_fit(std::span<const std::uint8_t> frame) {
  const AsciiHex hex = decode_ascii_hex(frame);
  DirectionFit fit;
  if (hex.binary.size() < 3) return fit;
  const auto pdu = std::span(hex.binary).subspan(1, hex.binary.size() - 2);
  fit.request = pdu_fits(pdu, Direction::request);
  fit.response = pdu_fits(pdu, Direction::response);
  return fit;
}

bool always_response(std::span<const std::uint8_t> frame) {
  const AsciiHex hex = decode_ascii_hex(frame);
  return hex.binary.size() >= 2 && (hex.binary[1] & 0x80) != 0;
}

bool recognisable(std::span<const std::uint8_t> frame) {
  const AsciiHex hex = decode_ascii_hex(frame);
  if (hex.binary.size() < 3) return false;
  return lrc8(std::span(hex.binary).first(hex.binary.size() - 1)) == hex.binary.back() ||
         is_public_function(hex.binary[1]);
}

ProtocolDecoder::PairingKeys pairing_keys(std::span<const std::uint8_t> frame) {
  const AsciiHex hex = decode_ascii_hex(frame);
  return {hex.binary.empty() ? -1 : hex.binary[0], hex.binary.size() < 2 ? -1 : hex.binary[1]};
}

}  // namespace

// In DecoderFunctions order.
constexpr DecoderFunctions kAsciiFunctions{protocols::modbus_ascii,
                                           make_framer,
                                           direction_fit,
                                           always_response,
                                           recognisable,
                                           pairing_keys,
                                           dissect_ascii,
                                           read_ascii_drive_records};

}  // namespace drivetap::modbus
