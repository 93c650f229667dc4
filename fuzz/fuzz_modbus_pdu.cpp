// Fuzzes the Modbus PDU/RTU layer: dissect_pdu (every direction), predict_pdu_length, pdu_fits,
// rtu_direction_fit and dissect_rtu on a Frame built from the data; pdu_findings and the RTU
// decoder's dissection to the head (DissectDepth::head) against what the dissectors find, and the
// same made with the decoder's precheck (the read-ahead thread's) against it.
#include <cstdint>
#include <span>
#include <vector>

#include "core/checksum.hpp"
#include "dissectors/modbus/modbus_pdu.hpp"
#include "dissectors/modbus/rtu_dissector.hpp"
#include "fuzz/fuzz_common.hpp"

namespace {

using namespace drivetap;

constexpr Direction kDirections[] = {Direction::unknown, Direction::request, Direction::response};

// Dissects frame[offset, offset + length) and checks the field tree stays inside the frame, and
// that pdu_findings() finds what the dissector finds (dissection to the head counts by it).
void dissect(std::span<const std::uint8_t> frame, std::size_t offset, std::size_t length,
             Direction dir) {
  FieldTree nodes;
  FieldTreeBuilder tree(nodes);
  const modbus::PduDecode d = modbus::dissect_pdu(frame, offset, length, dir, tree);
  for (const FieldNode& n : nodes) {
    if (std::size_t{n.offset} + n.length > frame.size())
      fuzz::contract_broken("dissect_pdu: field span beyond the frame");
    (void)format_field_value(nodes, n, frame);
  }
  const modbus::PduFindings found = modbus::pdu_findings(frame.subspan(offset, length), dir);
  if (found.problems != d.problems.size() || found.exception_code != d.exception_code)
    fuzz::contract_broken("pdu_findings: not what dissect_pdu finds");
}

// The RTU decoder's dissection to the head of a telegram taken whole (DissectDepth::head) must be
// what dissect_rtu() gives the Message: verdict, pairing members and every anomaly by kind.
void check_summary(const Frame& frame, Direction dir, const FramingTiming& timing) {
  const Message m = dissected(modbus::dissect_rtu, Frame(frame), dir, timing);
  TelegramView t;
  t.run.bytes = m.bytes;
  t.taken.timing = {frame.gap_before, frame.max_intra_gap, frame.max_intra_gap_at};
  TelegramFindings s;
  const modbus::RtuDecoder decoder;
  Message detailed;
  if (decoder.dissect(t, dir, timing, {}, DissectDepth::head, detailed, &s)) {
    if (m.bytes.size() >= 4) fuzz::contract_broken("dissect: no head of a 4-byte frame");
    return;
  }
  std::size_t malformed = 0;
  std::uint32_t kinds = 0;
  for (const Anomaly& a : m.anomalies) {
    if (a.kind == AnomalyKind::malformed)
      ++malformed;
    else
      kinds |= 1u << static_cast<unsigned>(a.kind);
  }
  if (s.verdict != m.checksum.verdict || s.address != m.address || s.function != m.function ||
      s.is_exception != m.is_exception || s.exception_code != m.exception_code ||
      s.malformed != malformed || s.other_kinds != kinds)
    fuzz::contract_broken("dissect: head not what dissect_rtu gives");
  // With the precheck of a telegram the framer would take whole: the same summary.
  TelegramPrecheck made;
  if (!decoder.precheck(m.bytes, &made)) fuzz::contract_broken("precheck: none made");
  if (!made.whole_frame) return;
  const DirectionFit fit = decoder.direction_fit(m.bytes);
  if (made.fit.request != fit.request || made.fit.response != fit.response ||
      made.always_response != decoder.always_response(m.bytes))
    fuzz::contract_broken("precheck: not the decoder's direction answers");
  made.decoder = &decoder;
  TelegramFindings with;
  t.precheck = &made;
  if (decoder.dissect(t, dir, timing, {}, DissectDepth::head, detailed, &with) ||
      with.verdict != s.verdict || with.exception_code != s.exception_code ||
      with.malformed != s.malformed || with.other_kinds != s.other_kinds)
    fuzz::contract_broken("dissect: head not the same with the precheck");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::span<const std::uint8_t> bytes(data, size);

  // The data as a bare PDU (function code first).
  for (Direction dir : kDirections) {
    const modbus::LengthPrediction p = modbus::predict_pdu_length(bytes, dir);
    if (p.kind == modbus::LengthPrediction::Kind::known && p.length == 0)
      fuzz::contract_broken("predict_pdu_length: known length 0");
    (void)modbus::pdu_fits(bytes, dir);
    dissect(bytes, 0, bytes.size(), dir);
  }
  if (!bytes.empty()) (void)modbus::is_public_function(bytes[0]);

  // The data as an RTU frame: address, PDU, CRC.
  (void)modbus::rtu_direction_fit(bytes);
  (void)check_rtu_crc(bytes);
  if (bytes.size() >= 3)
    for (Direction dir : kDirections) dissect(bytes, 1, bytes.size() - 3, dir);

  const SerialConfig serial;
  const FramingTiming timing = FramingTiming::from(serial);
  Frame frame;
  frame.gap_before = 2 * timing.character_time;  // a short inter-frame gap: one more anomaly
  TimeNs t = 0;
  for (std::size_t i = 0; i < bytes.size(); ++i) {
    ByteEvent e;
    e.time = t;
    e.byte = bytes[i];
    // The last byte carries UART marks taken from the first byte, when there are 8 or more.
    if (bytes.size() >= 8 && i + 1 == bytes.size()) e.flags = bytes[0] & 0x0F;
    frame.events.push_back(e);
    t += timing.character_time;
  }
  for (Direction dir : kDirections) {
    const Message m = dissected(modbus::dissect_rtu, Frame(frame), dir, timing);
    fuzz::check_field_spans(m);
    for (const FieldNode& n : m.fields) (void)format_field_value(m.fields, n, m.bytes);
  }
  // The summary: of a frame without UART marks (a run the framer takes whole has none), with a
  // silence inside it (from the data) or none.
  Frame marked_free;
  for (const ByteEvent& e : frame.events) marked_free.events.push_back({e.time, e.byte, 0, 0, 0});
  marked_free.gap_before = frame.gap_before;
  if (bytes.size() >= 2) {
    marked_free.max_intra_gap = (bytes[0] & 1) ? 2 * timing.t15 : 0;
    marked_free.max_intra_gap_at = 1;
  }
  for (Direction dir : kDirections) check_summary(marked_free, dir, timing);
  return 0;
}
