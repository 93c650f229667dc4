// Modbus RTU dissector (docs/protocols.md §2; errata handling per §6: swapped vs bad CRC).
#include "dissectors/modbus/rtu_dissector.hpp"

#include <fmt/compile.h>
#include <fmt/format.h>

#include "dissectors/modbus/modbus_fields.hpp"
#include "dissectors/modbus/modbus_findings.hpp"
#include "dissectors/modbus/modbus_pdu.hpp"
#include "dissectors/modbus/rtu_framer.hpp"

namespace drivetap::modbus {
namespace {

double in_characters(TimeNs t, TimeNs character_time) {
  return character_time > 0 ? static_cast<double>(t) / static_cast<double>(character_time) : 0.0;
}

// TelegramPrecheck's slot for the findings of the telegram read as `way` (request or response).
int precheck_slot(Direction way) {
  return way == Direction::request ? 0 : 1;
}

}  // namespace

DirectionFit rtu_direction_fit(std::span<const std::uint8_t> frame) {
  DirectionFit fit;
  if (frame.size() < 4) return fit;
  const auto pdu = frame.subspan(1, frame.size() - 3);
  fit.request = pdu_fits(pdu, Direction::request);
  fit.response = pdu_fits(pdu, Direction::response);
  return fit;
}

Plausibility rtu_plausibility(std::span<const std::uint8_t> frame, Direction direction,
                              bool describe) {
  // Serial line §2.5.1: address, PDU of at most 253 bytes, CRC.
  if (frame.size() < 4 || frame.size() > 256) {
    Plausibility p;
    p.broken = &kRuleRtuSize;
    if (describe) p.why = fmt::format(FMT_COMPILE("{} bytes (4-256)"), frame.size());
    return p;
  }
  return modbus_plausibility(frame[0], frame.subspan(1, frame.size() - 3), direction, describe);
}

namespace {

// The nodes of a telegram of 4 bytes or more, the PDU's from dissect_pdu_into() (which also
// writes `pdu`'s info line and problems when asked): unit id, PDU, CRC as on the wire.
[[gnu::always_inline]] inline void add_rtu_fields(FieldTreeBuilder& tree,
                                                  std::span<const std::uint8_t> bytes,
                                                  Direction direction, PduDecode& pdu) {
  tree.add(kRtuUnitId, 0, 1, bytes[0]);
  dissect_pdu_into(pdu, bytes, 1, bytes.size() - 3, direction, tree);
  tree.add(kRtuCrc, bytes.size() - 2, 2, rtu_crc_on_wire(bytes));
}

// DissectDepth::fields of a telegram of 4 bytes or more: its nodes, bytes and encoding alone.
// Out of line: dissect() stays as compact on the head and detail paths, which every telegram
// takes, as without this one.
[[gnu::noinline]] void dissect_rtu_fields(Message& out, std::span<const std::uint8_t> bytes,
                                          Direction direction) {
  out.fields.clear();
  out.bytes.assign(bytes.begin(), bytes.end());
  out.text_encoded = false;
  FieldTreeBuilder tree(out.fields);
  PduDecode pdu;
  pdu.detail = false;
  add_rtu_fields(tree, bytes, direction, pdu);
}

// dissect_rtu(); `known_plausible`: the telegram's head was found to keep the plausibility rules
// (TelegramView::known_plausible), which are then not checked again.
void dissect_rtu_into(Message& m, Frame&& frame, Direction direction, const FramingTiming& timing,
                      bool known_plausible) {
  begin_message(m, std::move(frame), protocols::modbus_rtu, direction);
  const std::span<const std::uint8_t> bytes(m.bytes);
  const ChannelId ch = m.frame.channel;
  FieldTreeBuilder tree(m.fields, m.detail && m.tree);

  if (!bytes.empty()) m.address = bytes[0];
  if (bytes.size() >= 2) {
    m.function = bytes[1];
    m.is_exception = (bytes[1] & 0x80) != 0;
  }
  if (bytes.size() >= 4) {
    PduDecode pdu;
    pdu.detail = m.detail && m.info_text;
    pdu.info_into = &m.info;  // the line is written where m keeps it
    add_rtu_fields(tree, bytes, direction, pdu);
    m.exception_code = pdu.exception_code;
    for (FoundProblem& problem : pdu.problems)
      add_finding_detail(m, *problem.finding, std::move(problem.detail));
    // The framer's CRC when it computed one over these bytes (a frame it took whole between two
    // silences: most of a capture's packets on one channel): not a second time.
    check_rtu_crc_into(m.checksum, bytes,
                       m.frame.checksum_kind == FrameChecksum::crc16_modbus
                           ? static_cast<std::uint16_t>(m.frame.checksum)
                           : crc16_modbus(bytes.first(bytes.size() - 2)));
  } else {
    if (!bytes.empty()) tree.add(kRtuUnitId, 0, 1, bytes[0]);
    m.describe([&] {
      return fmt::format(FMT_COMPILE("{}-byte fragment, too short for Modbus RTU"), bytes.size());
    });
    add_finding(m, kFindingRtuShort, bytes.size());
  }

  add_checksum_anomaly(m);
  if (!known_plausible)
    add_implausible(m, kFindingRtuImplausible, rtu_plausibility(bytes, direction, true));
  if (timing.silences_trusted && m.frame.max_intra_gap > timing.t15) {
    const std::size_t at = m.frame.max_intra_gap_at;
    // At the byte after the silence, not the frame's start.
    m.anomalies.push_back({kFindingRtuIntraFrameGap.kind, m.frame.events[at].time, ch, 0,
                           kFindingRtuIntraFrameGap.detail(
                               in_characters(m.frame.max_intra_gap, timing.character_time), at,
                               in_characters(timing.t15, timing.character_time)),
                           &kFindingRtuIntraFrameGap});
  }
  if (timing.silences_trusted && m.frame.gap_before > 0 && m.frame.gap_before < timing.t35) {
    add_finding(m, kFindingRtuShortInterframeGap,
                in_characters(m.frame.gap_before, timing.character_time),
                in_characters(timing.t35, timing.character_time));
  }
  append_uart_anomalies(m.frame.events, 0, m.anomalies);
}

}  // namespace

void dissect_rtu(Message& m, Frame&& frame, Direction direction, const FramingTiming& timing,
                 std::span<const std::uint8_t> request) {
  (void)request;
  dissect_rtu_into(m, std::move(frame), direction, timing, false);
}

bool RtuDecoder::dissect(TelegramView& t, Direction direction, const FramingTiming& timing,
                         std::span<const std::uint8_t> request, DissectDepth depth, Message& out,
                         TelegramFindings* head) const {
  (void)request;
  const std::span<const std::uint8_t> bytes = t.bytes();
  // The head: dissect_rtu()'s members and findings for a frame of 4 bytes or more (the framer's
  // shortest telegram; the shorter fragment's findings are left to it), in the same order. A
  // frame with UART marks is read in detail (its marks are findings too).
  if (depth == DissectDepth::detail || bytes.size() < 4 ||
      (t.frame && t.frame->events.any_flags())) {
    dissect_rtu_into(out, t.frame_for(out), direction, timing, t.known_plausible);
    return true;
  }
  if (depth == DissectDepth::fields) {
    dissect_rtu_fields(out, bytes, direction);
    return true;
  }
  // The framer's record of the telegram's timing and carried checksum.
  const FrameTiming frame_timing =
      t.frame ? FrameTiming{t.frame->gap_before, t.frame->max_intra_gap, t.frame->max_intra_gap_at}
              : t.taken.timing;
  const FrameChecksum checksum_kind = t.frame ? t.frame->checksum_kind : t.taken.checksum_kind;
  const std::uint32_t checksum = t.frame ? t.frame->checksum : t.taken.checksum;
  head->address = bytes[0];
  head->function = bytes[1];
  head->is_exception = (bytes[1] & 0x80) != 0;
  PduFindings found;
  if (t.precheck && direction != Direction::unknown) {
    found.exception_code = t.precheck->exception_code[precheck_slot(direction)];
    found.problems = t.precheck->malformed[precheck_slot(direction)];
  } else {
    found = pdu_findings(bytes.subspan(1, bytes.size() - 3), direction);
  }
  head->exception_code = found.exception_code;
  head->malformed = found.problems;
  head->verdict = (checksum_kind == FrameChecksum::crc16_modbus
                       ? check_rtu_crc(bytes, static_cast<std::uint16_t>(checksum))
                       : check_rtu_crc(bytes))
                      .verdict;
  auto found_one = [&](AnomalyKind kind) {
    head->other_kinds |= 1u << static_cast<unsigned>(kind);
  };
  head->other_kinds = 0;
  if (head->verdict == ChecksumVerdict::bad) found_one(AnomalyKind::checksum_bad);
  if (head->verdict == ChecksumVerdict::swapped) found_one(AnomalyKind::checksum_swapped);
  if (!rtu_plausibility(bytes, direction, false).ok()) found_one(AnomalyKind::implausible);
  if (timing.silences_trusted) {
    if (frame_timing.max_intra_gap > timing.t15) found_one(AnomalyKind::intra_frame_gap);
    if (frame_timing.gap_before > 0 && frame_timing.gap_before < timing.t35)
      found_one(AnomalyKind::short_interframe_gap);
  }
  return false;
}

bool RtuDecoder::precheck(std::span<const std::uint8_t> bytes, TelegramPrecheck* out) const {
  // The framer's check; for a telegram it would take whole, the head's findings each way and
  // the pipeline's questions for its direction (a run that is no such telegram needs no more).
  out->whole_frame = is_good_hybrid_frame(RtuFramer::rules(), bytes, &out->checksum);
  if (!out->whole_frame) return true;
  out->fit = rtu_direction_fit(bytes);
  out->always_response = always_response(bytes);
  const std::span<const std::uint8_t> pdu = bytes.subspan(1, bytes.size() - 3);
  for (const Direction way : {Direction::request, Direction::response}) {
    const PduFindings found = pdu_findings(pdu, way);
    out->exception_code[precheck_slot(way)] = found.exception_code;
    out->malformed[precheck_slot(way)] = found.problems;
  }
  return true;
}

namespace {

std::unique_ptr<Framer> make_framer(ChannelId channel, const FramerSettings& s) {
  RtuFramerOptions o;
  o.timing = s.timing;
  o.max_hold = s.max_hold;
  return std::make_unique<RtuFramer>(channel, o);
}

bool always_response(std::span<const std::uint8_t> frame) {
  return frame.size() >= 2 && (frame[1] & 0x80) != 0;  // exception reply
}

bool recognisable(std::span<const std::uint8_t> frame) {
  // A frame with a bad CRC and a function code outside the public set is most likely garbage.
  return frame.size() >= 2 &&
         (check_rtu_crc(frame).verdict != ChecksumVerdict::bad || is_public_function(frame[1]));
}

ProtocolDecoder::PairingKeys pairing_keys(std::span<const std::uint8_t> frame) {
  return {frame.empty() ? -1 : frame[0], frame.size() < 2 ? -1 : frame[1]};
}

}  // namespace

// In DecoderFunctions order.
constexpr DecoderFunctions kRtuFunctions{
    protocols::modbus_rtu, make_framer,  rtu_direction_fit, always_response,
    recognisable,          pairing_keys, dissect_rtu,       read_rtu_drive_records};

}  // namespace drivetap::modbus
