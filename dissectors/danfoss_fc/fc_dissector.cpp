// Danfoss FC protocol dissector (docs/protocols.md §4; 002 §7.2-7.5 telegram, §7.11 CTW/STW).
#include "dissectors/danfoss_fc/fc_dissector.hpp"

#include <fmt/compile.h>
#include <fmt/format.h>

#include "core/cursor.hpp"
#include "dissectors/common/hybrid_framer_impl.hpp"
#include "dissectors/danfoss_fc/fc_fields.hpp"
#include "dissectors/danfoss_fc/fc_findings.hpp"
#include "dissectors/danfoss_fc/fc_words.hpp"

namespace drivetap::danfoss_fc {

Address decode_adr(std::uint8_t adr) {
  Address a;
  if (adr & 0x80) {
    a.number = adr & 0x7F;
    a.broadcast = adr == 0x80;
  } else {
    a.number = adr & 0x1F;
    a.broadcast = (adr & 0x20) != 0;
  }
  return a;
}

std::uint8_t bcc(std::span<const std::uint8_t> bytes) {
  std::uint8_t x = 0;
  for (const std::uint8_t b : bytes) x ^= b;
  return x;
}

std::string parameter_name(unsigned pnu) {
  return fmt::format(FMT_COMPILE("{}-{:02}"), pnu / 100, pnu % 100);
}

namespace {

// "a, b, c" (empty parts are kept as they are: none occur).
void append_part(std::string& out, std::string_view part) {
  if (!out.empty()) out += ", ";
  out += part;
}

std::string join(const std::vector<std::string>& parts) {
  std::string out;
  for (const std::string& p : parts) append_part(out, p);
  return out;
}

// A control or status word's meaning under its table (fc_words.hpp): the one the drive level's
// `=` line gives for the same word.
std::string word_meaning(const WordBits& word, std::uint16_t w) {
  std::string s;
  append_bit_names(s, word.bits, w);
  return s.empty() ? "none" : s;
}

// REF and MAV (§7.11.3: 16384 = 100 %), with the 3 decimals of their resolution (0.0061 %), as
// the drive level shows the same words.
std::string percent(std::uint16_t raw) {
  const auto v = static_cast<std::int16_t>(raw);
  return fmt::format(FMT_COMPILE("{:.3f} %"), static_cast<double>(v) * 100.0 / 16384.0);
}

bool is_request_only_ak(unsigned ak) {
  return ak == 0x3 || ak == 0xD || ak == 0xE;
}
bool is_response_only_ak(unsigned ak) {
  return ak == 0x7;
}
bool is_request_ak(unsigned ak) {
  return ak <= 3 || ak == 0xD || ak == 0xE || ak == 0xF;
}
bool is_response_ak(unsigned ak) {
  return ak <= 2 || ak == 0x7 || ak == 0xF;
}

}  // namespace

Plausibility fc_plausibility(std::span<const std::uint8_t> frame, Direction direction,
                             bool describe) {
  Plausibility p;
  auto broken = [&](const PlausibilityRule& rule, auto&& why) {
    return Plausibility::breaking(rule, describe, why);
  };
  if (frame.empty() || frame[0] != kStxByte)
    return broken(kRuleFcStx, [&] {
      return frame.empty() ? std::string("no bytes")
                           : fmt::format(FMT_COMPILE("starts with 0x{:02X}, not STX"), frame[0]);
    });
  if (frame.size() < 4)
    return broken(kRuleFcLgeCount,
                  [&] { return fmt::format(FMT_COMPILE("{} bytes (at least 4)"), frame.size()); });
  const std::uint8_t lge = frame[1];
  const unsigned ak = frame.size() >= 12 ? frame[3] >> 4 : 0;
  // Text blocks (AK 0xF) carry n text bytes: LGE 10 + n; every other telegram is 6 or 14.
  if (lge != 6 && lge != 14 && !(lge > 10 && frame.size() >= 12 && ak == 0xF))
    return broken(kRuleFcLgeAllowed, [&] {
      return fmt::format(FMT_COMPILE("LGE {} (6, 14, or 10 + n for a text block)"), lge);
    });
  if (std::size_t{lge} + 2 != frame.size())
    return broken(kRuleFcLgeCount, [&] {
      return fmt::format(FMT_COMPILE("LGE {} but {} bytes after it"), lge, frame.size() - 2);
    });
  const std::uint8_t adr = frame[2];
  const bool adr_ok = (adr & 0x80) ? adr != 0xFF : ((adr & 0x1F) != 0 || (adr & 0x20) != 0);
  if (!adr_ok)
    return broken(kRuleFcAdr, [&] {
      return fmt::format(FMT_COMPILE("ADR 0x{:02X} names no drive and no broadcast"), adr);
    });
  if (frame.size() >= 12) {
    if (!fits_direction(direction, is_request_ak(ak), is_response_ak(ak)))
      return broken(kRuleFcAk, [&] {
        return fmt::format(FMT_COMPILE("AK 0x{:X} is no {}"), ak,
                           expected_for(direction, "request", "reply"));
      });
  }
  return p;
}

void dissect_fc(Message& m, Frame&& frame, Direction direction, const FramingTiming& timing,
                std::span<const std::uint8_t> request) {
  (void)request;
  (void)timing;
  begin_message(m, std::move(frame), protocols::danfoss_fc, direction);
  const std::span<const std::uint8_t> bytes(m.bytes);
  FieldTreeBuilder tree(m.fields, m.detail && m.tree);
  Cursor c(bytes);
  auto stx = c.u8();
  auto lge = c.u8();
  auto adr = c.u8();
  if (!stx || !lge || !adr || bytes.size() < 4) {
    std::string what = kFindingFragment.detail(bytes.size());
    if (m.detail) m.info = what;
    add_finding_detail(m, kFindingFragment, std::move(what));
    add_implausible(m, kFindingImplausible, fc_plausibility(bytes, direction, true));
    return;
  }
  tree.add(kStx, 0, 1, *stx);
  if (*stx != kStxByte) add_finding(m, kFindingStxBad, *stx);
  tree.add(kLge, 1, 1, *lge);
  if (std::size_t{*lge} + 2 != bytes.size())
    add_finding(m, kFindingLgeMismatch, *lge, *lge + 2u, bytes.size());
  const Address a = decode_adr(*adr);
  tree.open(kAdr, 2, 1, *adr);
  tree.add(kAddress, 2, 1, a.number);
  tree.add(kBroadcast, 2, 1, a.broadcast ? 1 : 0);
  tree.close();
  m.address = a.broadcast ? 0 : a.number;

  // Data between ADR and BCC.
  const std::size_t data_len = bytes.size() - 4;
  std::vector<std::string> info;
  const bool to_drive = direction != Direction::response;
  if (data_len >= 8) {
    auto pke = c.be16();
    auto ind = c.be16();
    const unsigned ak = *pke >> 12;
    const unsigned pnu = *pke & 0x0FFF;
    tree.open(kPke, 3, 2, *pke);
    tree.add(to_drive ? kAkRequest : kAkResponse, 3, 1, ak);
    tree.add(kPnu, 3, 2, pnu);
    tree.add_text(kParameter, 3, 2, parameter_name(pnu));
    tree.close();
    tree.add(kInd, 5, 2, *ind);
    const std::size_t value_len = data_len - 8;  // PWE (4) or text (n), then PCD1 PCD2
    const std::string param = parameter_name(pnu);
    if (ak == 0xF) {
      auto text_bytes = c.take(value_len).value_or(std::span<const std::uint8_t>{});
      std::string text;
      for (std::uint8_t ch8 : text_bytes)
        text += (ch8 >= 0x20 && ch8 < 0x7F) ? static_cast<char>(ch8) : '.';
      tree.add_text(kText, 7, text_bytes.size(), text);
      const unsigned mode = *ind >> 8;
      info.push_back(fmt::format(FMT_COMPILE("{} text {} \"{}\""), mode == 0x05 ? "write" : "read",
                                 param, text));
    } else {
      if (value_len != 4) add_finding(m, kFindingPweLength, value_len);
      auto hi = c.be16();
      auto lo = c.be16();
      const std::uint32_t pwe = (std::uint32_t{hi.value_or(0)} << 16) | lo.value_or(0);
      const bool dword = to_drive ? (ak == 0x3 || ak == 0xD) : ak == 0x2;
      const std::uint32_t value = dword ? pwe : lo.value_or(0);
      tree.add(kPwe, 7, 4, value);
      const std::string index = (*ind & 0xFF) ? fmt::format(FMT_COMPILE("[{}]"), *ind & 0xFF) : "";
      if (to_drive) {
        if (ak == 0x1)
          info.push_back(fmt::format(FMT_COMPILE("read {}{}"), param, index));
        else if (ak == 0x2 || ak == 0x3 || ak == 0xD || ak == 0xE)
          info.push_back(fmt::format(FMT_COMPILE("write {}{} = {} ({}, {})"), param, index, value,
                                     ak >= 0xD ? "RAM+EEPROM" : "RAM",
                                     dword ? "double word" : "word"));
        else if (ak != 0x0)
          info.push_back(fmt::format(FMT_COMPILE("AK 0x{:X} on {}"), ak, param));
      } else {
        if (ak == 0x7) {
          const unsigned error = lo.value_or(0);
          tree.add(kErrorNumber, 9, 2, error);
          const std::string_view meaning = kErrorNumber.name_of(error);
          info.push_back(fmt::format(FMT_COMPILE("{}{}: cannot execute, error {} ({})"), param,
                                     index, error,
                                     meaning.empty() ? "unknown error number" : meaning));
        } else if (ak == 0x1 || ak == 0x2) {
          info.push_back(fmt::format(FMT_COMPILE("{}{} = {}"), param, index, value));
        } else if (ak != 0x0) {
          info.push_back(fmt::format(FMT_COMPILE("AK 0x{:X} on {}"), ak, param));
        }
      }
      if (!(to_drive ? is_request_ak(ak) : is_response_ak(ak)))
        add_finding(m, kFindingAkDirection, ak, to_drive ? "request" : "response");
    }
  } else if (data_len != 4) {
    add_finding(m, kFindingDataLength, data_len);
  }
  // Process data: the last 4 data bytes.
  if (data_len >= 4 && c.remaining() >= 5) {
    const std::size_t at = c.offset();
    const std::uint16_t pcd1 = c.be16().value_or(0);
    const std::uint16_t pcd2 = c.be16().value_or(0);
    if (direction == Direction::response) {
      const std::string meaning = word_meaning(kStwBits, pcd1);
      const std::string mav = percent(pcd2);
      tree.add_text(kStw, at, 2, meaning, pcd1);
      tree.add_text(kMav, at + 2, 2, mav);
      info.push_back(fmt::format(FMT_COMPILE("STW 0x{:04X} [{}], MAV {}"), pcd1, meaning, mav));
    } else if (direction == Direction::request) {
      const std::string meaning = word_meaning(kCtwBits, pcd1);
      const std::string reference = percent(pcd2);
      tree.add_text(kCtw, at, 2, meaning, pcd1);
      tree.add_text(kReference, at + 2, 2, reference);
      info.push_back(
          fmt::format(FMT_COMPILE("CTW 0x{:04X} [{}], REF {}"), pcd1, meaning, reference));
    } else {
      tree.add(kPcd, at, 2, pcd1);
      tree.add(kPcd, at + 2, 2, pcd2);
      info.push_back(fmt::format(FMT_COMPILE("PCD1 0x{:04X}, PCD2 0x{:04X}"), pcd1, pcd2));
    }
  }
  m.describe([&] {
    std::string text = (a.broadcast ? std::string("broadcast: ") : std::string()) + join(info);
    return text.empty() ? std::string("empty telegram") : text;
  });
  // BCC.
  const std::uint8_t stated = bytes.back();
  const std::uint8_t computed = bcc(bytes.first(bytes.size() - 1));
  tree.add(kBcc, bytes.size() - 1, 1, stated);
  m.checksum.name = "BCC";
  m.checksum.width = 1;
  m.checksum.stated_wire = stated;
  m.checksum.computed_wire = computed;
  m.checksum.verdict = stated == computed ? ChecksumVerdict::good : ChecksumVerdict::bad;
  add_checksum_anomaly(m);
  add_implausible(m, kFindingImplausible, fc_plausibility(bytes, direction, true));
  append_uart_anomalies(m.frame.events, 0, m.anomalies);
}

void FcRules::predicted_lengths(std::span<const std::uint8_t> from, std::size_t out[2],
                                bool* needs_more) const {
  out[0] = out[1] = 0;
  *needs_more = false;
  if (from.empty() || from[0] != kStxByte) return;
  if (from.size() < 2) {
    *needs_more = true;
    return;
  }
  if (from[1] >= 2) out[0] = std::size_t{from[1]} + 2;
}

bool FcRules::checksum_matches(std::span<const std::uint8_t> frame) const {
  return frame.size() >= 4 && bcc(frame.first(frame.size() - 1)) == frame.back();
}

bool FcRules::looks_like_frame_start(std::span<const std::uint8_t> from) const {
  if (from.empty() || from[0] != kStxByte) return false;
  if (from.size() < 2) return true;
  return from[1] == 6 || from[1] >= 10;  // process data, or parameter/text block
}

namespace {

std::unique_ptr<Framer> make_framer(ChannelId channel, const FramerSettings& s) {
  static const FcRules rules;
  HybridFramerOptions o;
  o.timing = s.timing;
  o.max_hold = s.max_hold;
  return std::make_unique<HybridFramer<FcRules>>(channel, o, rules);
}

DirectionFit direction_fit(std::span<const std::uint8_t> frame) {
  DirectionFit fit;
  if (frame.size() == 8) {
    fit.request = fit.response = true;  // process data only: order decides
  } else if (frame.size() >= 12) {
    const unsigned ak = frame[3] >> 4;
    fit.request = is_request_ak(ak) && !is_response_only_ak(ak);
    fit.response = is_response_ak(ak) && !is_request_only_ak(ak);
  }
  return fit;
}

bool always_response(std::span<const std::uint8_t> frame) {
  return frame.size() >= 12 && is_response_only_ak(frame[3] >> 4);
}

bool recognisable(std::span<const std::uint8_t> frame) {
  return frame.size() >= 4 && frame[0] == kStxByte;
}

// The drive answers a telegram of process data alone (LGE 6) with process data alone, and one
// with a parameter block with a parameter block or text (002 §7.4.6: the telegram types are
// the master's and the reply's alike): a telegram of the other type is the master's next request,
// whatever the order says.
bool could_answer(std::span<const std::uint8_t> frame, std::span<const std::uint8_t> request) {
  return (frame.size() == 8) == (request.size() == 8);
}

ProtocolDecoder::PairingKeys pairing_keys(std::span<const std::uint8_t> frame) {
  if (frame.size() < 3) return {};
  const Address a = decode_adr(frame[2]);
  return {a.broadcast ? 0 : a.number, -1};
}

}  // namespace

// In DecoderFunctions order.
constexpr DecoderFunctions kFcFunctions{
    protocols::danfoss_fc, make_framer, direction_fit,         always_response, recognisable,
    pairing_keys,          dissect_fc,  read_fc_drive_records, could_answer};

}  // namespace drivetap::danfoss_fc

template class drivetap::HybridFramer<drivetap::danfoss_fc::FcRules>;
