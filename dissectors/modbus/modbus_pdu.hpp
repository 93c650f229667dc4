// The Modbus PDU layer shared by RTU and ASCII framing: function code + data
// (Modbus Application Protocol V1.1b3 §6-7; docs/protocols.md §2).
//
//   PDU = FC(1) DATA(n)          exception: FC|0x80 (1) CODE(1)
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "core/field.hpp"
#include "core/line_buffer.hpp"
#include "core/message.hpp"
#include "dissectors/common/finding.hpp"
#include "dissectors/common/plausibility.hpp"

namespace drivetap::modbus {

// How long the PDU starting at pdu[0] (the function code) must be, for one direction.
struct LengthPrediction {
  enum class Kind : std::uint8_t {
    known,      // `length` is the PDU length (function code included)
    need_more,  // the length depends on bytes not yet available
    unknown,    // function code without a fixed layout in this direction
  };
  Kind kind = Kind::unknown;
  std::size_t length = 0;
};

// The length rule of one function code in one direction (Modbus Application Protocol §6):
// fixed, or `fixed` plus the count byte at pdu[count_at], or one walked by hand (`special`).
struct LengthRule {
  enum class Kind : std::uint8_t { unknown, fixed, counted, special };
  Kind kind = Kind::unknown;
  std::uint8_t count_at = 0;
  std::uint8_t fixed = 0;
};
struct FunctionLengths {
  LengthRule request;
  LengthRule response;
};
// The rules of function codes 0x00..0x7F (an exception reply, FC | 0x80, is two bytes).
extern const std::array<FunctionLengths, 128> kLengthRules;
// The `special` rules: Read FIFO Queue's reply (0x18) and Read Device Identification (0x2B).
LengthPrediction predict_special_length(std::span<const std::uint8_t> pdu, Direction direction);

// Inline: the framer asks it for both directions at every candidate frame start.
inline LengthPrediction predict_pdu_length(std::span<const std::uint8_t> pdu, Direction direction) {
  using Kind = LengthPrediction::Kind;
  if (pdu.empty()) return {Kind::need_more, 0};
  const std::uint8_t fc = pdu[0];
  if (fc & 0x80)
    return direction == Direction::response ? LengthPrediction{Kind::known, 2}
                                            : LengthPrediction{Kind::unknown, 0};
  if (direction == Direction::unknown) return {Kind::unknown, 0};
  const LengthRule& rule =
      direction == Direction::request ? kLengthRules[fc].request : kLengthRules[fc].response;
  switch (rule.kind) {
    case LengthRule::Kind::fixed:
      return {Kind::known, rule.fixed};
    case LengthRule::Kind::counted:
      if (pdu.size() <= rule.count_at) return {Kind::need_more, 0};
      return {Kind::known, std::size_t{rule.fixed} + pdu[rule.count_at]};
    case LengthRule::Kind::special:
      return predict_special_length(pdu, direction);
    case LengthRule::Kind::unknown:
      break;
  }
  return {Kind::unknown, 0};
}

// True when `pdu` has exactly the length its function code implies in that direction.
inline bool pdu_fits(std::span<const std::uint8_t> pdu, Direction direction) {
  const LengthPrediction p = predict_pdu_length(pdu, direction);
  return p.kind == LengthPrediction::Kind::known && p.length == pdu.size();
}

// True for the function codes of the public Modbus specification (01..18, 2B), with or without
// the exception bit.
bool is_public_function(std::uint8_t fc);

// The Modbus plausibility rules (dissectors/common/plausibility.hpp) that RTU and ASCII share:
// the address, the function code, the length its function code and counts imply, the exception
// code. `pdu`: from the function code on, without the checksum; `direction` unknown: either
// layout may fit. Plausibility::why is written only when `describe`. A few comparisons: run on
// every telegram.
Plausibility modbus_plausibility(std::uint8_t address, std::span<const std::uint8_t> pdu,
                                 Direction direction, bool describe);

struct PduDecode {
  std::string info;                    // one-line decode (empty when not `detail`)
  std::vector<FoundProblem> problems;  // protocol-rule breaks: each becomes its finding
  int exception_code = -1;
  bool detail = true;  // the info line is wanted
  // When set, the info line is written there instead of into `info` (dissect_rtu(): the
  // message's own string, so that no string is moved in and out per telegram).
  std::string* info_into = nullptr;

  [[nodiscard]] std::string& info_text() { return info_into ? *info_into : info; }
  // Sets the info line to make() when decoding in detail; make() is not called otherwise.
  template <class MakeText>
  void describe(MakeText&& make) {
    if (detail) info_text() = make();
  }
  // The same for the replies and requests of every poll: append(line) builds the line in a
  // reused LineBuffer (appends inline, no temporaries), copied into the info line's storage at
  // once.
  template <class AppendText>
  void describe_in_place(AppendText&& append) {
    if (!detail) return;
    LineBuffer& line = scratch();
    line.clear();
    append(line);
    // clear() then append(): the line is never the string's own, so the copy needs none of
    // assign()'s checks for overlap.
    std::string& info_line = info_text();
    info_line.clear();
    info_line.append(line.data(), line.size());
  }
  static LineBuffer& scratch();
};

// What dissect_pdu_into() finds in a PDU besides fields and text: how many protocol-rule breaks
// (PduDecode::problems) and the exception code.
struct PduFindings {
  std::size_t problems = 0;
  int exception_code = -1;
};
// The same as dissect_pdu_into() of `pdu` (from its function code on) would find, without the
// tree and the texts: worked out directly for the function codes of every poll (01-06, 0F, 10,
// exception replies), by dissect_pdu_into() for the others.
PduFindings pdu_findings(std::span<const std::uint8_t> pdu, Direction direction);

// Decodes the PDU occupying frame[pdu_offset, pdu_offset + pdu_length) into field nodes whose
// spans are frame offsets, and the info line when `info` (a tree that keeps nothing can still
// come with an info line: text output without -V).
PduDecode dissect_pdu(std::span<const std::uint8_t> frame, std::size_t pdu_offset,
                      std::size_t pdu_length, Direction direction, FieldTreeBuilder& tree,
                      bool info);
// The same into `out`, whose info line (`info`, or the string `info_into` points at: a decoder
// reusing one Message has it written into the message's) keeps its storage.
void dissect_pdu_into(PduDecode& out, std::span<const std::uint8_t> frame, std::size_t pdu_offset,
                      std::size_t pdu_length, Direction direction, FieldTreeBuilder& tree);
// The same, with the info line when the tree keeps fields.
PduDecode dissect_pdu(std::span<const std::uint8_t> frame, std::size_t pdu_offset,
                      std::size_t pdu_length, Direction direction, FieldTreeBuilder& tree);

}  // namespace drivetap::modbus
