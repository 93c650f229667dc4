// Modbus PDU length rules and dissection (Modbus Application Protocol V1.1b3 §6-7;
// docs/protocols.md §2).
#include "dissectors/modbus/modbus_pdu.hpp"

#include <fmt/compile.h>
#include <fmt/format.h>

#include <array>
#include <iterator>
#include <optional>

#include "core/cursor.hpp"
#include "core/format.hpp"
#include "dissectors/modbus/modbus_fields.hpp"
#include "dissectors/modbus/modbus_findings.hpp"

namespace drivetap::modbus {
namespace {

using Kind = LengthPrediction::Kind;

LengthPrediction known(std::size_t n) {
  return {Kind::known, n};
}
LengthPrediction need_more() {
  return {Kind::need_more, 0};
}
LengthPrediction unknown() {
  return {Kind::unknown, 0};
}

// Read Device Identification response: walk the object list to find where it ends.
//   FC 2B, MEI 0E, code, conformity, more, next id, count, {id, len, value[len]} x count
LengthPrediction device_id_response_length(std::span<const std::uint8_t> pdu) {
  if (pdu.size() < 7) return need_more();
  std::size_t pos = 7;
  const unsigned objects = pdu[6];
  for (unsigned i = 0; i < objects; ++i) {
    if (pdu.size() < pos + 2) return need_more();
    pos += 2 + pdu[pos + 1];  // strictly advances by >= 2
  }
  return known(pos);
}

}  // namespace

bool is_public_function(std::uint8_t fc) {
  const std::uint8_t base = fc & 0x7F;
  return !kFunction.name_of(base).empty();
}

Plausibility modbus_plausibility(std::uint8_t address, std::span<const std::uint8_t> pdu,
                                 Direction direction, bool describe) {
  Plausibility p;
  auto broken = [&](const PlausibilityRule& rule, auto&& why) {
    return Plausibility::breaking(rule, describe, why);
  };
  // Serial line §2.3: 0 broadcast, 1..247 slaves, 248..255 reserved.
  if (address > 247)
    return broken(kRuleAddress,
                  [&] { return fmt::format("address {} (248-255 are reserved)", address); });
  if (pdu.empty()) return broken(kRuleRtuSize, [] { return std::string("no function code"); });
  const std::uint8_t fc = pdu[0];
  if (!is_public_function(fc))
    return broken(kRuleFunction, [&] {
      return fmt::format("function code 0x{:02X} is no public Modbus function", fc);
    });
  if (fc & 0x80) {
    if (pdu.size() != 2)
      return broken(kRuleLength, [&] {
        return fmt::format("exception reply of {} PDU bytes (2: function, code)", pdu.size());
      });
    if (!exception_code_allowed(pdu[1]))
      return broken(kRuleExceptionCode, [&] {
        return fmt::format("exception code {} (1-11, or a drive profile's vendor code)", pdu[1]);
      });
    return p;
  }
  // The layout: a direction whose rule is unknown for this function cannot be checked (passes).
  bool fits = false;
  for (const Direction way : {Direction::request, Direction::response}) {
    if (direction != Direction::unknown && direction != way) continue;
    const LengthPrediction predicted = predict_pdu_length(pdu, way);
    if (predicted.kind == LengthPrediction::Kind::unknown ||
        (predicted.kind == LengthPrediction::Kind::known && predicted.length == pdu.size()))
      fits = true;
  }
  if (!fits)
    return broken(kRuleLength, [&] {
      return fmt::format("{} PDU bytes do not fit function 0x{:02X}'s layout{}", pdu.size(), fc,
                         direction == Direction::request    ? " as a request"
                         : direction == Direction::response ? " as a reply"
                                                            : " either way");
    });
  return p;
}

namespace {

constexpr LengthRule fixed(std::uint8_t n) {
  return {LengthRule::Kind::fixed, 0, n};
}
constexpr LengthRule counted(std::uint8_t count_at, std::uint8_t plus) {
  return {LengthRule::Kind::counted, count_at, plus};
}
constexpr LengthRule special() {
  return {LengthRule::Kind::special, 0, 0};
}

constexpr std::array<FunctionLengths, 128> make_length_rules() {
  std::array<FunctionLengths, 128> t{};
  for (std::uint8_t fc : {0x01, 0x02, 0x03, 0x04}) t[fc] = {fixed(5), counted(1, 2)};
  t[0x05] = {fixed(5), fixed(5)};
  t[0x06] = {fixed(5), fixed(5)};
  t[0x07] = {fixed(1), fixed(2)};
  t[0x08] = {fixed(5), fixed(5)};  // sub-function + one data word (sub 00 may carry more)
  t[0x0B] = {fixed(1), fixed(5)};
  t[0x0C] = {fixed(1), counted(1, 2)};
  t[0x0F] = {counted(5, 6), fixed(5)};
  t[0x10] = {counted(5, 6), fixed(5)};
  t[0x11] = {fixed(1), counted(1, 2)};
  t[0x14] = {counted(1, 2), counted(1, 2)};
  t[0x15] = {counted(1, 2), counted(1, 2)};
  t[0x16] = {fixed(7), fixed(7)};
  t[0x17] = {counted(9, 10), counted(1, 2)};
  t[0x18] = {fixed(3), special()};
  t[0x2B] = {special(), special()};
  return t;
}

}  // namespace

const std::array<FunctionLengths, 128> kLengthRules = make_length_rules();

LengthPrediction predict_special_length(std::span<const std::uint8_t> pdu, Direction direction) {
  const std::uint8_t fc = pdu[0];
  if (fc == 0x18 && direction == Direction::response) {
    if (pdu.size() < 3) return need_more();
    return known(3 + static_cast<std::size_t>((pdu[1] << 8) | pdu[2]));
  }
  if (fc == 0x2B) {
    if (pdu.size() < 2) return need_more();
    if (pdu[1] != 0x0E) return unknown();
    return direction == Direction::request ? known(4) : device_id_response_length(pdu);
  }
  return unknown();
}

LineBuffer& PduDecode::scratch() {
  // One per thread (decoding runs on one; tests and fuzzers may run others): the info line of
  // every poll is built here with inline appends, then copied into `info` at once.
  thread_local LineBuffer line;
  return line;
}

namespace {

// Reads PDU fields through a bounds-checked cursor and records them with frame offsets.
class PduReader {
 public:
  PduReader(std::span<const std::uint8_t> frame, std::size_t pdu_offset, std::size_t pdu_length,
            FieldTreeBuilder& tree, PduDecode& out)
      : cursor_(frame.subspan(pdu_offset, pdu_length)), base_(pdu_offset), tree_(tree), out_(out) {}

  [[gnu::always_inline]] std::optional<std::uint8_t> u8(const FieldDesc& desc) {
    const std::size_t at = cursor_.offset();
    auto v = cursor_.u8();
    if (!v) return truncated(desc);
    tree_.add(desc, base_ + at, 1, *v);
    return v;
  }
  [[gnu::always_inline]] std::optional<std::uint16_t> u16(const FieldDesc& desc) {
    const std::size_t at = cursor_.offset();
    auto v = cursor_.be16();
    if (!v) return truncated(desc);
    tree_.add(desc, base_ + at, 2, *v);
    return v;
  }
  // The function code as Wireshark's modbus.func_code: without the exception bit, which the
  // node notes.
  std::optional<std::uint8_t> function_code() {
    const std::size_t at = cursor_.offset();
    auto v = cursor_.u8();
    if (!v) return truncated(kFunction);
    if (*v & 0x80)
      tree_.add_text(kFunction, base_ + at, 1, "exception reply", *v & 0x7F);
    else
      tree_.add(kFunction, base_ + at, 1, *v);
    return v;
  }
  // `n` raw bytes as one field; on shortage takes what is there and reports it.
  std::span<const std::uint8_t> bytes(const FieldDesc& desc, std::size_t n) {
    const std::size_t at = cursor_.offset();
    auto s = take_announced(desc, n);
    tree_.add(desc, base_ + at, s.size());
    return s;
  }
  // The same, one node per byte (the events of a comm event log).
  std::span<const std::uint8_t> byte_values(const FieldDesc& desc, std::size_t n) {
    const std::size_t at = cursor_.offset();
    auto s = take_announced(desc, n);
    for (std::size_t i = 0; i < s.size(); ++i) tree_.add(desc, base_ + at + i, 1, s[i]);
    return s;
  }
  FieldTreeBuilder& tree() { return tree_; }
  [[nodiscard]] bool describing() const { return out_.detail; }
  Cursor& cursor() { return cursor_; }
  std::size_t frame_offset() const { return base_ + cursor_.offset(); }
  template <class... Args>
  void problem(const Finding<Args...>& finding, const std::type_identity_t<Args>&... args) {
    out_.problems.push_back({&finding, finding.detail(args...)});
  }

  // Bytes left after the layout of the function code: a protocol break worth naming.
  void expect_end() {
    if (!cursor_.empty()) {
      const std::size_t at = cursor_.offset();
      const std::size_t extra = cursor_.remaining();
      cursor_.rest();
      tree_.add(kData, base_ + at, extra);
      // After a truncated field the leftover is its partial bytes, already reported.
      if (!truncated_) problem(kFindingExtraBytes, extra);
    }
  }

 private:
  std::nullopt_t truncated(const FieldDesc& desc) {
    truncated_ = true;
    problem(kFindingFrameEndsBefore, desc.name);
    return std::nullopt;
  }

  std::span<const std::uint8_t> take_announced(const FieldDesc& desc, std::size_t n) {
    if (cursor_.remaining() < n) {
      problem(kFindingFieldCut, desc.name, n, cursor_.remaining());
      n = cursor_.remaining();
    }
    return cursor_.take(n).value_or(std::span<const std::uint8_t>{});
  }

  Cursor cursor_;
  std::size_t base_;
  FieldTreeBuilder& tree_;
  PduDecode& out_;
  bool truncated_ = false;
};

template <class Out>
void append_function_name(Out& out, std::uint8_t fc) {
  const std::string_view name = kFunction.name_of(fc & 0x7F);
  if (!name.empty())
    out += name;
  else
    fmt::format_to(std::back_inserter(out), FMT_COMPILE("Function 0x{:02X}"), fc & 0x7F);
}

std::string function_name(std::uint8_t fc) {
  std::string out;
  append_function_name(out, fc);
  return out;
}

template <class Out>
void append_range(Out& out, std::uint16_t start, unsigned count) {
  append_hex(out, start, 4);
  if (count <= 1) return;
  out += "..";
  append_hex(out, (start + count - 1) & 0xFFFF, 4);
  out += " (";
  append_uint(out, count);
  out += ')';
}

std::string range_text(std::uint16_t start, unsigned count) {
  std::string out;
  append_range(out, start, count);
  return out;
}

// Register values read as fields; the first kListed are kept for the info line.
struct RegisterValues {
  static constexpr std::size_t kListed = 8;
  std::array<std::uint16_t, kListed> first{};
  std::size_t count = 0;
};

// "3, 5000, 5000, 380" (at most kListed values, then "...").
template <class Out>
void append_register_list(Out& out, const RegisterValues& values) {
  for (std::size_t i = 0; i < values.count && i < RegisterValues::kListed; ++i) {
    if (i) out += ", ";
    append_uint(out, values.first[i]);
  }
  if (values.count > RegisterValues::kListed)
    fmt::format_to(std::back_inserter(out), FMT_COMPILE(", ... ({} values)"), values.count);
}

std::string register_list(const RegisterValues& values) {
  std::string out;
  append_register_list(out, values);
  return out;
}

// Bits as the protocol packs them: first coil = bit 0 of the first byte.
std::string bit_list(std::span<const std::uint8_t> bytes, std::size_t count) {
  std::string out;
  for (std::size_t i = 0; i < count && i / 8 < bytes.size(); ++i) {
    if (i && i % 8 == 0) out += ' ';
    out += ((bytes[i / 8] >> (i % 8)) & 1) ? '1' : '0';
  }
  return out;
}

std::string hex_list(std::span<const std::uint8_t> bytes, std::size_t limit = 16) {
  std::string out;
  for (std::size_t i = 0; i < bytes.size() && i < limit; ++i)
    out += fmt::format(FMT_COMPILE("{}{:02X}"), i ? " " : "", bytes[i]);
  if (bytes.size() > limit) out += " ...";
  return out;
}

RegisterValues read_registers(PduReader& r, std::size_t count) {
  RegisterValues values;
  // Values the tree does not keep are read straight off the cursor: only the ones the info line
  // lists, the others stepped over, where the PDU holds them all.
  if (!r.tree().keeps(kRegisterValue) && r.cursor().remaining() >= 2 * count) {
    const std::size_t listed = r.describing() ? std::min(count, RegisterValues::kListed) : 0;
    for (std::size_t i = 0; i < listed; ++i) values.first[i] = r.cursor().be16().value_or(0);
    r.cursor().take(2 * (count - listed));
    values.count = count;
    return values;
  }
  for (std::size_t i = 0; i < count; ++i) {
    auto v = r.u16(kRegisterValue);
    if (!v) break;
    if (values.count < RegisterValues::kListed) values.first[values.count] = *v;
    ++values.count;
  }
  return values;
}

void check_quantity(PduReader& r, unsigned quantity, unsigned max, const char* what) {
  if (quantity < 1 || quantity > max) r.problem(kFindingQuantityRange, what, quantity, max);
}

// Quantities of coils and inputs are Wireshark's bit counts, of registers its word counts.
const FieldDesc& quantity_field(std::uint8_t fc) {
  return fc == 0x01 || fc == 0x02 || fc == 0x0F ? kBitCount : kWordCount;
}

void dissect_read_request(PduReader& r, std::uint8_t fc, PduDecode& d) {
  auto start = r.u16(kReference);
  auto qty = r.u16(quantity_field(fc));
  r.expect_end();
  if (!start || !qty) return;
  const bool bits = fc == 0x01 || fc == 0x02;
  check_quantity(r, *qty, bits ? 2000 : 125, bits ? "bits" : "registers");
  d.describe_in_place([&](auto& out) {
    append_function_name(out, fc);
    out += ' ';
    append_range(out, *start, *qty);
  });
}

void dissect_read_response(PduReader& r, std::uint8_t fc, PduDecode& d) {
  auto count = r.u8(kByteCount);
  if (!count) return;
  const bool bits = fc == 0x01 || fc == 0x02;
  if (bits) {
    const std::size_t at = r.frame_offset();
    auto data = r.bytes(kData, *count);
    r.tree().add_text(kBitValues, at, data.size(), bit_list(data, data.size() * 8));
    r.expect_end();
    d.describe([&] {
      return fmt::format(FMT_COMPILE("{} reply: {} byte{} {}"), function_name(fc), data.size(),
                         data.size() == 1 ? "" : "s", hex_list(data));
    });
    return;
  }
  if (*count % 2 != 0) r.problem(kFindingByteCountOdd, *count);
  const std::size_t present = r.cursor().remaining();
  if (present != *count) r.problem(kFindingByteCountPresent, *count, present);
  auto values = read_registers(r, present / 2);
  r.expect_end();
  d.describe_in_place([&](auto& out) {
    append_function_name(out, fc);
    out += " reply: ";
    append_uint(out, values.count);
    out += values.count == 1 ? " register = " : " registers = ";
    append_register_list(out, values);
  });
}

void dissect_write_single_coil(PduReader& r, Direction dir, PduDecode& d) {
  auto addr = r.u16(kOutputAddress);
  auto value = r.u16(kCoilValue);
  r.expect_end();
  if (!addr || !value) return;
  if (*value != 0x0000 && *value != 0xFF00) r.problem(kFindingCoilValue, *value);
  const std::string_view state = kCoilValue.name_of(*value);
  d.describe([&] {
    return fmt::format(
        FMT_COMPILE("{}{} 0x{:04X} = {}"), function_name(0x05),
        dir == Direction::response ? " reply" : "", *addr,
        state.empty() ? fmt::format(FMT_COMPILE("0x{:04X}"), *value) : std::string(state));
  });
}

void dissect_write_single_register(PduReader& r, Direction dir, PduDecode& d) {
  auto addr = r.u16(kRegisterAddress);
  auto value = r.u16(kWriteValue);
  r.expect_end();
  if (!addr || !value) return;
  d.describe_in_place([&](auto& out) {
    append_function_name(out, 0x06);
    out += dir == Direction::response ? " reply " : " ";
    append_hex(out, *addr, 4);
    out += " = ";
    append_uint(out, *value);
    out += " (";
    append_hex(out, *value, 4);
    out += ')';
  });
}

void dissect_write_multiple_request(PduReader& r, std::uint8_t fc, PduDecode& d) {
  auto start = r.u16(kReference);
  auto qty = r.u16(quantity_field(fc));
  auto count = r.u8(kByteCount);
  if (!start || !qty || !count) {
    r.expect_end();
    return;
  }
  const bool coils = fc == 0x0F;
  check_quantity(r, *qty, coils ? 1968 : 123, coils ? "coils" : "registers");
  const unsigned expected = coils ? (*qty + 7u) / 8u : *qty * 2u;
  if (*count != expected) r.problem(kFindingByteCountQuantity, *count, *qty, expected);
  if (coils) {
    const std::size_t at = r.frame_offset();
    auto data = r.bytes(kData, *count);
    r.tree().add_text(kBitValues, at, data.size(), bit_list(data, *qty));
    d.describe([&] {
      return fmt::format(FMT_COMPILE("{} {} = {}"), function_name(fc), range_text(*start, *qty),
                         bit_list(data, *qty));
    });
  } else {
    const std::size_t present = r.cursor().remaining();
    if (present < *count) r.problem(kFindingByteCountPresent, *count, present);
    auto values = read_registers(r, std::min<std::size_t>(*count, present) / 2);
    d.describe_in_place([&](auto& out) {
      append_function_name(out, fc);
      out += ' ';
      append_range(out, *start, *qty);
      out += " = ";
      append_register_list(out, values);
    });
  }
  r.expect_end();
}

void dissect_write_multiple_response(PduReader& r, std::uint8_t fc, PduDecode& d) {
  auto start = r.u16(kReference);
  auto qty = r.u16(quantity_field(fc));
  r.expect_end();
  if (!start || !qty) return;
  d.describe_in_place([&](auto& out) {
    append_function_name(out, fc);
    out += " reply: ";
    append_range(out, *start, *qty);
    out += " written";
  });
}

void dissect_diagnostics(PduReader& r, Direction dir, PduDecode& d) {
  auto sub = r.u16(kSubFunction);
  if (!sub) return;
  auto data = r.bytes(kDiagData, r.cursor().remaining());
  const std::string_view sub_name = kSubFunction.name_of(*sub);
  d.describe([&] {
    return fmt::format(FMT_COMPILE("Diagnostics{}: {} ({:02X}), data {}"),
                       dir == Direction::response ? " reply" : "",
                       sub_name.empty() ? "reserved sub-function" : sub_name, *sub,
                       data.empty() ? std::string("none") : hex_list(data));
  });
}

void dissect_file_record(PduReader& r, std::uint8_t fc, Direction dir, PduDecode& d) {
  auto count = r.u8(kByteCount);
  if (!count) return;
  const std::size_t end = r.cursor().offset() + *count;
  if (r.cursor().remaining() != *count)
    r.problem(kFindingByteCountPresent, *count, r.cursor().remaining());
  unsigned groups = 0;
  // Each pass consumes at least one byte or stops.
  while (r.cursor().offset() < end && !r.cursor().empty()) {
    const std::size_t group_at = r.frame_offset();
    r.tree().open(kFileSubRequest, group_at, 0);
    ++groups;
    if (fc == 0x14 && dir == Direction::response) {
      auto len = r.u8(kFileResponseLength);
      auto ref = r.u8(kFileRefType);
      if (!len || !ref || *len == 0) {
        r.tree().close();
        break;
      }
      r.bytes(kFileData, *len - 1u);
    } else {
      auto ref = r.u8(kFileRefType);
      auto file = r.u16(kFileNumber);
      auto record = r.u16(kFileRecord);
      auto len = r.u16(kFileRecordLength);
      if (!ref || !file || !record || !len) {
        r.tree().close();
        break;
      }
      if (*ref != 6) r.problem(kFindingReferenceType, *ref);
      if (fc == 0x15) r.bytes(kFileData, *len * 2u);
    }
    r.tree().close();
  }
  r.expect_end();
  d.describe([&] {
    return fmt::format(FMT_COMPILE("{}{}: {} sub-request{}"), function_name(fc),
                       dir == Direction::response ? " reply" : "", groups, groups == 1 ? "" : "s");
  });
}

// A function whose request carries no data (07, 0B, 0C, 11): the request is named; nothing may
// follow it.
void dissect_no_data_request(PduReader& r, std::uint8_t fc, PduDecode& d) {
  d.describe_in_place([fc](auto& out) { append_function_name(out, fc); });
  r.expect_end();
}

void dissect_exception_status_reply(PduReader& r, PduDecode& d) {
  auto status = r.u8(kExceptionStatus);
  if (status)
    d.describe(
        [&] { return fmt::format(FMT_COMPILE("Read Exception Status reply: 0x{:02X}"), *status); });
  r.expect_end();
}

void dissect_comm_event_counter_reply(PduReader& r, PduDecode& d) {
  auto status = r.u16(kCommStatus);
  auto count = r.u16(kEventCount);
  if (status && count)
    d.describe([&] {
      return fmt::format(FMT_COMPILE("Get Comm Event Counter reply: status 0x{:04X}, {} events"),
                         *status, *count);
    });
  r.expect_end();
}

void dissect_comm_event_log_reply(PduReader& r, PduDecode& d) {
  auto count = r.u8(kByteCount);
  auto status = r.u16(kCommStatus);
  auto events = r.u16(kEventCount);
  auto messages = r.u16(kMessageCount);
  if (count && status && events && messages) {
    if (*count < 6) r.problem(kFindingEventByteCount, *count);
    auto log = r.byte_values(kEvent, *count >= 6 ? *count - 6u : 0u);
    d.describe([&] {
      return fmt::format(FMT_COMPILE("Get Comm Event Log reply: {} events, {} messages, log {}"),
                         *events, *messages, hex_list(log));
    });
  }
  r.expect_end();
}

void dissect_server_id_reply(PduReader& r, PduDecode& d) {
  auto count = r.u8(kByteCount);
  if (count) {
    auto id = r.bytes(kServerId, *count);
    d.describe(
        [&] { return fmt::format(FMT_COMPILE("Report Server ID reply: {}"), hex_list(id)); });
  }
  r.expect_end();
}

void dissect_mask_write_register(PduReader& r, bool req, PduDecode& d) {
  auto addr = r.u16(kRegisterAddress);
  auto and_mask = r.u16(kAndMask);
  auto or_mask = r.u16(kOrMask);
  r.expect_end();
  if (addr && and_mask && or_mask)
    d.describe([&] {
      return fmt::format(FMT_COMPILE("Mask Write Register{} 0x{:04X} AND 0x{:04X} OR 0x{:04X}"),
                         req ? "" : " reply", *addr, *and_mask, *or_mask);
    });
}

void dissect_read_write_multiple_request(PduReader& r, PduDecode& d) {
  auto rs = r.u16(kReadStart);
  auto rq = r.u16(kReadQuantity);
  auto ws = r.u16(kWriteStart);
  auto wq = r.u16(kWriteQuantity);
  auto count = r.u8(kByteCount);
  if (rs && rq && ws && wq && count) {
    check_quantity(r, *rq, 125, "registers to read");
    check_quantity(r, *wq, 121, "registers to write");
    if (*count != *wq * 2u) r.problem(kFindingWriteByteCount, *count, *wq);
    auto values = read_registers(r, std::min<std::size_t>(*count, r.cursor().remaining()) / 2);
    d.describe([&] {
      return fmt::format(FMT_COMPILE("Read/Write Multiple Registers: read {}, write {} = {}"),
                         range_text(*rs, *rq), range_text(*ws, *wq), register_list(values));
    });
  }
  r.expect_end();
}

void dissect_fifo_request(PduReader& r, PduDecode& d) {
  auto ptr = r.u16(kFifoPointer);
  if (ptr) d.describe([&] { return fmt::format(FMT_COMPILE("Read FIFO Queue 0x{:04X}"), *ptr); });
  r.expect_end();
}

void dissect_fifo_reply(PduReader& r, PduDecode& d) {
  auto bytes = r.u16(kFifoByteCount);
  auto count = r.u16(kFifoCount);
  if (bytes && count) {
    if (*bytes != 2u + *count * 2u) r.problem(kFindingFifoCount, *bytes, *count);
    auto values = read_registers(r, r.cursor().remaining() / 2);
    d.describe([&] {
      return fmt::format(FMT_COMPILE("Read FIFO Queue reply: {} values = {}"), values.count,
                         register_list(values));
    });
  }
  r.expect_end();
}

// A function code the specification does not define: its data as bytes.
void dissect_non_public(PduReader& r, std::uint8_t fc, PduDecode& d) {
  auto data = r.bytes(kData, r.cursor().remaining());
  d.describe([&] {
    return fmt::format(FMT_COMPILE("Function 0x{:02X} (not a public code): {} data byte{}{}{}"), fc,
                       data.size(), data.size() == 1 ? "" : "s", data.empty() ? "" : " ",
                       hex_list(data));
  });
}

void dissect_device_id(PduReader& r, Direction dir, PduDecode& d) {
  auto mei = r.u8(kMeiType);
  if (!mei) return;
  if (*mei != 0x0E) {
    auto data = r.bytes(kData, r.cursor().remaining());
    d.describe([&] {
      return fmt::format(FMT_COMPILE("Encapsulated Interface Transport MEI 0x{:02X}: {}"), *mei,
                         hex_list(data));
    });
    return;
  }
  auto code = r.u8(kMeiDeviceIdCode);
  if (dir == Direction::request) {
    auto object = r.u8(kMeiObjectId);
    r.expect_end();
    if (code && object)
      d.describe([&] {
        return fmt::format(FMT_COMPILE("Read Device Identification ({}), from object {}"),
                           kMeiDeviceIdCode.name_of(*code).empty()
                               ? std::string("code ?")
                               : std::string(kMeiDeviceIdCode.name_of(*code)),
                           *object);
      });
    return;
  }
  r.u8(kMeiConformity);
  r.u8(kMeiMoreFollows);
  r.u8(kMeiNextObject);
  auto objects = r.u8(kMeiObjectCount);
  std::string values;
  unsigned present = 0;
  for (unsigned i = 0; objects && i < *objects && !r.cursor().empty(); ++i) {
    r.tree().open(kMeiObject, r.frame_offset(), 0);
    auto id = r.u8(kMeiObjectId);
    auto len = r.u8(kMeiObjectLength);
    if (!id || !len) {
      r.tree().close();
      break;
    }
    const std::size_t at = r.frame_offset();
    auto raw = r.bytes(kMeiObjectBytes, *len);
    std::string text;
    for (std::uint8_t c : raw) text += (c >= 0x20 && c < 0x7F) ? static_cast<char>(c) : '.';
    r.tree().add_text(kMeiObjectValue, at, raw.size(), text);
    ++present;
    values +=
        fmt::format(FMT_COMPILE("{}{}=\"{}\""), values.empty() ? "" : ", ",
                    kMeiObjectId.name_of(*id).empty() ? fmt::format(FMT_COMPILE("obj{}"), *id)
                                                      : std::string(kMeiObjectId.name_of(*id)),
                    text);
    r.tree().close();
  }
  if (objects && present < *objects) r.problem(kFindingObjectsPresent, *objects, present);
  r.expect_end();
  d.describe(
      [&] { return fmt::format(FMT_COMPILE("Read Device Identification reply: {}"), values); });
}

}  // namespace

PduDecode dissect_pdu(std::span<const std::uint8_t> frame, std::size_t pdu_offset,
                      std::size_t pdu_length, Direction dir, FieldTreeBuilder& tree) {
  return dissect_pdu(frame, pdu_offset, pdu_length, dir, tree, tree.enabled());
}

PduDecode dissect_pdu(std::span<const std::uint8_t> frame, std::size_t pdu_offset,
                      std::size_t pdu_length, Direction dir, FieldTreeBuilder& tree, bool info) {
  PduDecode d;
  d.detail = info;
  dissect_pdu_into(d, frame, pdu_offset, pdu_length, dir, tree);
  return d;
}

void dissect_pdu_into(PduDecode& d, std::span<const std::uint8_t> frame, std::size_t pdu_offset,
                      std::size_t pdu_length, Direction dir, FieldTreeBuilder& tree) {
  d.info_text().clear();
  d.problems.clear();
  d.exception_code = -1;
  PduReader r(frame, pdu_offset, pdu_length, tree, d);
  auto fc_opt = r.function_code();
  if (!fc_opt) return;
  const std::uint8_t fc = *fc_opt;

  if (fc & 0x80) {
    // The exception bit marks a reply reporting an error for function fc & 0x7F.
    auto code = r.u8(kExceptionCode);
    r.expect_end();
    d.exception_code = code ? *code : -1;
    const std::string_view name = kExceptionCode.name_of(d.exception_code);
    if (!code) {
      d.describe([&] {
        return fmt::format(FMT_COMPILE("{} exception (code missing)"), function_name(fc));
      });
      return;
    }
    d.describe_in_place([&](auto& out) {
      append_function_name(out, fc);
      fmt::format_to(std::back_inserter(out), FMT_COMPILE(" exception 0x{:02X}: "), *code);
      out += name.empty() ? std::string_view("non-standard (vendor) code") : name;
    });
    return;
  }
  const bool req = dir != Direction::response;
  switch (fc) {
    case 0x01:
    case 0x02:
    case 0x03:
    case 0x04:
      req ? dissect_read_request(r, fc, d) : dissect_read_response(r, fc, d);
      break;
    case 0x05:
      dissect_write_single_coil(r, dir, d);
      break;
    case 0x06:
      dissect_write_single_register(r, dir, d);
      break;
    case 0x07:
      req ? dissect_no_data_request(r, fc, d) : dissect_exception_status_reply(r, d);
      break;
    case 0x08:
      dissect_diagnostics(r, dir, d);
      break;
    case 0x0B:
      req ? dissect_no_data_request(r, fc, d) : dissect_comm_event_counter_reply(r, d);
      break;
    case 0x0C:
      req ? dissect_no_data_request(r, fc, d) : dissect_comm_event_log_reply(r, d);
      break;
    case 0x0F:
    case 0x10:
      req ? dissect_write_multiple_request(r, fc, d) : dissect_write_multiple_response(r, fc, d);
      break;
    case 0x11:
      req ? dissect_no_data_request(r, fc, d) : dissect_server_id_reply(r, d);
      break;
    case 0x14:
    case 0x15:
      dissect_file_record(r, fc, dir, d);
      break;
    case 0x16:
      dissect_mask_write_register(r, req, d);
      break;
    case 0x17:
      req ? dissect_read_write_multiple_request(r, d) : dissect_read_response(r, fc, d);
      break;
    case 0x18:
      req ? dissect_fifo_request(r, d) : dissect_fifo_reply(r, d);
      break;
    case 0x2B:
      dissect_device_id(r, dir, d);
      break;
    default:
      dissect_non_public(r, fc, d);
      break;
  }
  if (d.info_text().empty())
    d.describe([&] { return function_name(fc) + (req ? "" : " reply") + " (truncated)"; });
}

PduFindings pdu_findings(std::span<const std::uint8_t> pdu, Direction direction) {
  // Each count is what the PduReader of dissect_pdu_into() reports: a field the frame ends
  // before ("frame ends before ..."), one per field read; leftover bytes after the layout
  // ("unexpected bytes"), unless a field was cut short; and the checks of each function.
  // tests/test_modbus_pdu.cpp compares the two on every function code, length and direction.
  PduFindings f;
  if (pdu.empty()) {
    f.problems = 1;  // the function code itself
    return f;
  }
  const std::uint8_t fc = pdu[0];
  const std::size_t rest = pdu.size() - 1;  // bytes after the function code
  auto be16 = [&](std::size_t at) { return static_cast<unsigned>((pdu[at] << 8) | pdu[at + 1]); };
  // Fields of 2 + 2 bytes and nothing after (read requests, single writes, multiple-write
  // replies): the second value (quantity, written value) when both are there.
  auto two_words = [&](unsigned* second) {
    if (rest < 2) {
      f.problems += 2;
      return false;
    }
    if (rest < 4) {
      f.problems += 1;
      return false;
    }
    if (rest > 4) f.problems += 1;
    *second = be16(3);
    return true;
  };
  auto quantity = [&](unsigned q, unsigned max) {
    if (q < 1 || q > max) f.problems += 1;
  };
  if (fc & 0x80) {
    if (rest == 0) {
      f.problems = 1;
    } else {
      f.exception_code = pdu[1];
      if (rest > 1) f.problems = 1;
    }
    return f;
  }
  const bool request = direction != Direction::response;
  unsigned b = 0;
  switch (fc) {
    case 0x01:
    case 0x02:
    case 0x03:
    case 0x04: {
      const bool bits = fc <= 0x02;
      if (request) {
        if (two_words(&b)) quantity(b, bits ? 2000 : 125);
        return f;
      }
      if (rest == 0) {
        f.problems = 1;
        return f;
      }
      const std::size_t count = pdu[1];
      const std::size_t present = rest - 1;
      if (bits) {
        if (present != count) f.problems = 1;  // fewer: announced vs present; more: unexpected
        return f;
      }
      if (count % 2 != 0) f.problems += 1;
      if (present != count) f.problems += 1;
      if (present % 2 != 0) f.problems += 1;  // the odd byte after the registers
      return f;
    }
    case 0x05:
      if (two_words(&b) && b != 0x0000 && b != 0xFF00) f.problems += 1;
      return f;
    case 0x06:
      two_words(&b);
      return f;
    case 0x0F:
    case 0x10: {
      if (!request) {
        two_words(&b);
        return f;
      }
      if (rest < 5) {
        // Start and quantity (2 bytes each) and byte count (1): a field that does not fit is
        // reported and the next read where it was, so a lone byte is still a byte count.
        static constexpr std::size_t kCut[5] = {3, 2, 2, 1, 1};
        f.problems = kCut[rest];
        return f;
      }
      const bool coils = fc == 0x0F;
      const unsigned q = be16(3);
      const std::size_t count = pdu[5];
      const std::size_t present = rest - 5;
      quantity(q, coils ? 1968 : 123);
      if (count != (coils ? (q + 7u) / 8u : q * 2u)) f.problems += 1;
      if (coils) {
        if (present != count) f.problems += 1;
      } else {
        if (present < count) f.problems += 1;
        if (present - std::min(count, present) / 2 * 2 > 0) f.problems += 1;  // left after them
      }
      return f;
    }
    default:
      break;
  }
  // The other function codes: the dissector itself, with neither tree nor text.
  FieldTree no_fields;
  FieldTreeBuilder no_tree(no_fields, false);
  PduDecode d;
  d.detail = false;
  dissect_pdu_into(d, pdu, 0, pdu.size(), direction, no_tree);
  f.problems = d.problems.size();
  f.exception_code = d.exception_code;
  return f;
}

}  // namespace drivetap::modbus
