// Unit tests: Modbus PDU length rules and dissection (docs/protocols.md §2; Modbus Application
// Protocol V1.1b3 §6-7). Frames come from /work/notes/rtu_examples.md where one fits.
#include <gtest/gtest.h>

#include <random>

#include <cstdint>
#include <span>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

#include "core/field.hpp"
#include "core/message.hpp"
#include "dissectors/modbus/modbus_pdu.hpp"

using namespace drivetap;
using namespace drivetap::modbus;
using Kind = LengthPrediction::Kind;

namespace {

std::vector<std::uint8_t> hex(std::string_view text) {
  std::vector<std::uint8_t> out;
  std::istringstream in{std::string(text)};
  std::string tok;
  while (in >> tok) out.push_back(static_cast<std::uint8_t>(std::stoul(tok, nullptr, 16)));
  return out;
}

::testing::AssertionResult HasSub(const std::string& s, std::string_view sub) {
  if (s.find(sub) != std::string::npos) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << "'" << s << "' does not contain '" << sub << "'";
}

::testing::AssertionResult HasSub(const FoundProblem& p, std::string_view sub) {
  return HasSub(p.detail, sub);
}

::testing::AssertionResult AnyHasSub(const std::vector<FoundProblem>& v, std::string_view sub) {
  for (const FoundProblem& p : v)
    if (p.detail.find(sub) != std::string::npos) return ::testing::AssertionSuccess();
  std::string all;
  for (const FoundProblem& p : v) all += "\n  '" + p.detail + "'";
  return ::testing::AssertionFailure() << "no problem contains '" << sub << "'; problems:" << all;
}

struct Decoded {
  std::vector<std::uint8_t> frame;
  FieldTree fields;
  PduDecode d;

  // The nth node with `id`, or nullptr.
  [[nodiscard]] const FieldNode* find(std::string_view id, int nth = 0) const {
    for (const FieldNode& n : fields)
      if (n.desc->id == id && nth-- == 0) return &n;
    return nullptr;
  }
  [[nodiscard]] int count(std::string_view id) const {
    int c = 0;
    for (const FieldNode& n : fields)
      if (n.desc->id == id) ++c;
    return c;
  }
};

// Dissects an RTU frame (address byte first). With `crc`, the last two bytes are the CRC and
// are not part of the PDU.
Decoded decode(std::string_view frame_hex, Direction dir, bool crc = true) {
  Decoded out;
  out.frame = hex(frame_hex);
  const std::size_t pdu_length = out.frame.size() - 1 - (crc ? 2 : 0);
  FieldTreeBuilder tree(out.fields);
  out.d = dissect_pdu(out.frame, 1, pdu_length, dir, tree);
  return out;
}

::testing::AssertionResult FieldIs(const Decoded& dec, std::string_view id, std::uint32_t offset,
                                   std::uint32_t length, std::int64_t value, int nth = 0) {
  const FieldNode* n = dec.find(id, nth);
  if (!n) return ::testing::AssertionFailure() << "no field " << id << " #" << nth;
  if (n->offset != offset || n->length != length || n->value != value)
    return ::testing::AssertionFailure()
           << id << " #" << nth << ": offset " << n->offset << " length " << n->length << " value "
           << n->value << ", expected offset " << offset << " length " << length << " value "
           << value;
  return ::testing::AssertionSuccess();
}

LengthPrediction predict(std::string_view pdu_hex, Direction dir) {
  const auto pdu = hex(pdu_hex);
  return predict_pdu_length(pdu, dir);
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// predict_pdu_length

namespace {

struct LengthCase {
  const char* pdu;
  Direction dir;
  Kind kind;
  std::size_t length;
};

class PredictPduLength : public ::testing::TestWithParam<LengthCase> {};

TEST_P(PredictPduLength, MatchesSpecLayout) {
  const LengthCase& c = GetParam();
  const LengthPrediction p = predict(c.pdu, c.dir);
  EXPECT_EQ(p.kind, c.kind) << "pdu '" << c.pdu << "' " << direction_id(c.dir);
  if (c.kind == Kind::known) {
    EXPECT_EQ(p.length, c.length) << "pdu '" << c.pdu << "' " << direction_id(c.dir);
  }
}

constexpr Direction kReq = Direction::request;
constexpr Direction kRsp = Direction::response;

}  // namespace

INSTANTIATE_TEST_SUITE_P(
    Requests, PredictPduLength,
    ::testing::Values(
        // Fixed-length requests: the function code alone is enough.
        LengthCase{"01", kReq, Kind::known, 5}, LengthCase{"02 00 00 00 10", kReq, Kind::known, 5},
        LengthCase{"03 00 00 00 04", kReq, Kind::known, 5}, LengthCase{"04", kReq, Kind::known, 5},
        LengthCase{"05 00 00 FF 00", kReq, Kind::known, 5}, LengthCase{"06", kReq, Kind::known, 5},
        LengthCase{"07", kReq, Kind::known, 1}, LengthCase{"08 00 00 A5 37", kReq, Kind::known, 5},
        LengthCase{"0B", kReq, Kind::known, 1}, LengthCase{"0C", kReq, Kind::known, 1},
        LengthCase{"11", kReq, Kind::known, 1}, LengthCase{"16", kReq, Kind::known, 7},
        LengthCase{"18", kReq, Kind::known, 3},
        // Counted requests: byte count at a fixed position.
        LengthCase{"0F 00 00 00 09 02", kReq, Kind::known, 8},
        LengthCase{"0F 00 00 00 09", kReq, Kind::need_more, 0},
        LengthCase{"10 00 0C 00 02 04", kReq, Kind::known, 10},
        LengthCase{"10 00 0C 00", kReq, Kind::need_more, 0},
        LengthCase{"14 0E", kReq, Kind::known, 16}, LengthCase{"14", kReq, Kind::need_more, 0},
        LengthCase{"15 0D", kReq, Kind::known, 15}, LengthCase{"15", kReq, Kind::need_more, 0},
        LengthCase{"17 00 03 00 06 00 0E 00 03 06", kReq, Kind::known, 16},
        LengthCase{"17 00 03 00 06 00 0E 00 03", kReq, Kind::need_more, 0},
        // Encapsulated Interface Transport: only MEI 0E has a known layout.
        LengthCase{"2B 0E", kReq, Kind::known, 4}, LengthCase{"2B", kReq, Kind::need_more, 0},
        LengthCase{"2B 0D", kReq, Kind::unknown, 0},
        // Not public / not a request.
        LengthCase{"41", kReq, Kind::unknown, 0}, LengthCase{"09", kReq, Kind::unknown, 0},
        LengthCase{"83 02", kReq, Kind::unknown, 0}, LengthCase{"", kReq, Kind::need_more, 0}));

INSTANTIATE_TEST_SUITE_P(
    Responses, PredictPduLength,
    ::testing::Values(
        // Byte count at pdu[1].
        LengthCase{"01 02", kRsp, Kind::known, 4}, LengthCase{"01", kRsp, Kind::need_more, 0},
        LengthCase{"02 01", kRsp, Kind::known, 3}, LengthCase{"03 08", kRsp, Kind::known, 10},
        LengthCase{"04 10", kRsp, Kind::known, 18}, LengthCase{"04", kRsp, Kind::need_more, 0},
        LengthCase{"0C 08", kRsp, Kind::known, 10}, LengthCase{"11 05", kRsp, Kind::known, 7},
        LengthCase{"14 0C", kRsp, Kind::known, 14}, LengthCase{"15 0D", kRsp, Kind::known, 15},
        LengthCase{"17 0C", kRsp, Kind::known, 14}, LengthCase{"17", kRsp, Kind::need_more, 0},
        // Fixed-length responses.
        LengthCase{"05", kRsp, Kind::known, 5}, LengthCase{"06", kRsp, Kind::known, 5},
        LengthCase{"07", kRsp, Kind::known, 2}, LengthCase{"08", kRsp, Kind::known, 5},
        LengthCase{"0B", kRsp, Kind::known, 5}, LengthCase{"0F", kRsp, Kind::known, 5},
        LengthCase{"10", kRsp, Kind::known, 5}, LengthCase{"16", kRsp, Kind::known, 7},
        // FIFO: 16-bit byte count at pdu[1..2].
        LengthCase{"18 00 06", kRsp, Kind::known, 9},
        LengthCase{"18 01 00", kRsp, Kind::known, 259},
        LengthCase{"18 00", kRsp, Kind::need_more, 0},
        // Read Device Identification: walk the objects.
        LengthCase{"2B 0E 01 01 00 00 02 00 03 41 42 43 01 02 58 31", kRsp, Kind::known, 16},
        LengthCase{"2B 0E 01 01 00 00 02 00 03 41 42 43 01", kRsp, Kind::need_more, 0},
        LengthCase{"2B 0E 01 01 00 00 02 00 03 41", kRsp, Kind::need_more, 0},
        LengthCase{"2B 0E 01 01 00 00 02 00 03 41 42 43 01 02", kRsp, Kind::known, 16},
        LengthCase{"2B 0E 01 01 00 00", kRsp, Kind::need_more, 0},
        LengthCase{"2B 0E 01 01 00 00 00", kRsp, Kind::known, 7},
        LengthCase{"2B 0D 00", kRsp, Kind::unknown, 0}, LengthCase{"2B", kRsp, Kind::need_more, 0},
        // Exception responses are always 2 bytes, whatever the function.
        LengthCase{"81 03", kRsp, Kind::known, 2}, LengthCase{"83", kRsp, Kind::known, 2},
        LengthCase{"90 03", kRsp, Kind::known, 2}, LengthCase{"AB 01", kRsp, Kind::known, 2},
        LengthCase{"C1 01", kRsp, Kind::known, 2},
        // Unknown / empty.
        LengthCase{"41 00", kRsp, Kind::unknown, 0}, LengthCase{"09", kRsp, Kind::unknown, 0},
        LengthCase{"", kRsp, Kind::need_more, 0}));

INSTANTIATE_TEST_SUITE_P(
    UnknownDirection, PredictPduLength,
    ::testing::Values(LengthCase{"03 00 00 00 01", Direction::unknown, Kind::unknown, 0},
                      LengthCase{"83 02", Direction::unknown, Kind::unknown, 0}));

TEST(PduFits, ExactLengthOnly) {
  EXPECT_TRUE(pdu_fits(hex("03 00 00 00 04"), kReq));
  EXPECT_FALSE(pdu_fits(hex("03 00 00 00"), kReq));
  EXPECT_FALSE(pdu_fits(hex("03 00 00 00 04 00"), kReq));
  EXPECT_TRUE(pdu_fits(hex("0F 00 00 00 09 02 01 01"), kReq));
  EXPECT_FALSE(pdu_fits(hex("0F 00 00 00 09 02 01"), kReq));
  EXPECT_TRUE(pdu_fits(hex("03 08 00 03 13 88 13 88 01 7C"), kRsp));
  EXPECT_TRUE(pdu_fits(hex("83 02"), kRsp));
  EXPECT_FALSE(pdu_fits(hex("83 02 00"), kRsp));
  EXPECT_FALSE(pdu_fits(hex("83 02"), kReq));  // exception bit in a request: no layout
  EXPECT_TRUE(pdu_fits(hex("2B 0E 01 01 00 00 02 00 03 41 42 43 01 02 58 31"), kRsp));
  EXPECT_FALSE(pdu_fits(hex("41 00"), kRsp));  // unknown function
  EXPECT_FALSE(pdu_fits({}, kReq));            // need_more
  // 003 §6 FC 04 response: byte count 0x10 but 10 data bytes.
  EXPECT_FALSE(pdu_fits(hex("04 10 01 F4 00 00 00 D6 00 00 02 32"), kRsp));
  EXPECT_EQ(predict("04 10 01 F4 00 00 00 D6 00 00 02 32", kRsp).length, 18u);
}

TEST(IsPublicFunction, PublicCodesWithAndWithoutExceptionBit) {
  for (const std::uint8_t fc : {0x01, 0x02, 0x03, 0x04, 0x05, 0x06, 0x07, 0x08, 0x0B, 0x0C, 0x0F,
                                0x10, 0x11, 0x14, 0x15, 0x16, 0x17, 0x18, 0x2B}) {
    EXPECT_TRUE(is_public_function(fc)) << int(fc);
    EXPECT_TRUE(is_public_function(static_cast<std::uint8_t>(fc | 0x80))) << int(fc);
  }
  for (const std::uint8_t fc : {0x00, 0x09, 0x0A, 0x0D, 0x12, 0x13, 0x19, 0x2A, 0x41, 0x64, 0x89})
    EXPECT_FALSE(is_public_function(fc)) << int(fc);
}

// ---------------------------------------------------------------------------------------------
// dissect_pdu: normal frames

TEST(DissectPdu, ReadHoldingRegistersRequest) {
  // 000 §6 example 1 (CRC byte-swapped on the wire; irrelevant to the PDU).
  const Decoded r = decode("02 03 00 00 00 04 3A 44", kReq);
  EXPECT_TRUE(FieldIs(r, "modbus.func_code", 1, 1, 3));
  EXPECT_TRUE(FieldIs(r, "modbus.reference_num", 2, 2, 0x0000));
  EXPECT_TRUE(FieldIs(r, "modbus.word_cnt", 4, 2, 4));
  EXPECT_EQ(r.fields.size(), 3u);
  EXPECT_TRUE(HasSub(r.d.info, "Read Holding Registers"));
  EXPECT_TRUE(HasSub(r.d.info, "0x0000..0x0003 (4)"));
  EXPECT_TRUE(r.d.problems.empty());
  EXPECT_EQ(r.d.exception_code, -1);
  // Generic formatting of the nodes.
  EXPECT_EQ(format_field_value(r.fields, *r.find("modbus.func_code"), r.frame),
            "3 (Read Holding Registers)");
  EXPECT_EQ(format_field_value(r.fields, *r.find("modbus.reference_num"), r.frame), "0x0000 (0)");
}

TEST(DissectPdu, ReadSingleRegisterRangeText) {
  // 004 RTU example: read 0x2523 x1.
  const Decoded r = decode("01 03 25 23 00 01 7E CC", kReq);
  EXPECT_TRUE(FieldIs(r, "modbus.reference_num", 2, 2, 0x2523));
  EXPECT_TRUE(FieldIs(r, "modbus.word_cnt", 4, 2, 1));
  EXPECT_EQ(r.d.info, "Read Holding Registers 0x2523");
  EXPECT_TRUE(r.d.problems.empty());
}

TEST(DissectPdu, ReadHoldingRegistersResponse) {
  // 000 §6 example 1 response (bad CRC; the PDU itself is fine).
  const Decoded r = decode("02 03 08 00 03 13 88 13 88 01 7C 80 48", kRsp);
  EXPECT_TRUE(FieldIs(r, "modbus.byte_cnt", 2, 1, 8));
  ASSERT_EQ(r.count("modbus.regval_uint16"), 4);
  EXPECT_TRUE(FieldIs(r, "modbus.regval_uint16", 3, 2, 3, 0));
  EXPECT_TRUE(FieldIs(r, "modbus.regval_uint16", 5, 2, 5000, 1));
  EXPECT_TRUE(FieldIs(r, "modbus.regval_uint16", 7, 2, 5000, 2));
  EXPECT_TRUE(FieldIs(r, "modbus.regval_uint16", 9, 2, 380, 3));
  EXPECT_TRUE(HasSub(r.d.info, "Read Holding Registers reply"));
  EXPECT_TRUE(HasSub(r.d.info, "4 registers = 3, 5000, 5000, 380"));
  EXPECT_TRUE(r.d.problems.empty());
}

TEST(DissectPdu, ReadInputRegistersResponseByteCountMismatch) {
  // 003 §6 FC 04 response: byte count 0x10 (16) but 10 data bytes follow.
  const Decoded r = decode("01 04 10 01 F4 00 00 00 D6 00 00 02 32 0A 03", kRsp);
  EXPECT_TRUE(FieldIs(r, "modbus.byte_cnt", 2, 1, 16));
  ASSERT_EQ(r.count("modbus.regval_uint16"), 5);
  EXPECT_TRUE(FieldIs(r, "modbus.regval_uint16", 3, 2, 500, 0));
  EXPECT_TRUE(FieldIs(r, "modbus.regval_uint16", 7, 2, 214, 2));
  EXPECT_TRUE(FieldIs(r, "modbus.regval_uint16", 11, 2, 562, 4));
  ASSERT_EQ(r.d.problems.size(), 1u);
  EXPECT_TRUE(HasSub(r.d.problems[0], "byte count says 16 bytes, 10 present"));
  EXPECT_TRUE(HasSub(r.d.info, "Read Input Registers reply: 5 registers = 500, 0, 214, 0, 562"));
}

TEST(DissectPdu, ReadRegistersResponseOddByteCount) {
  const Decoded r = decode("01 03 03 00 01 02", kRsp, false);
  EXPECT_TRUE(AnyHasSub(r.d.problems, "byte count 3 is odd"));
  EXPECT_TRUE(FieldIs(r, "modbus.regval_uint16", 3, 2, 1));
  EXPECT_TRUE(AnyHasSub(r.d.problems, "1 unexpected bytes after the PDU"));
}

TEST(DissectPdu, ReadCoilsRequestAndResponse) {
  // 003 §6 FC 01.
  const Decoded q = decode("01 01 00 00 00 0C 3C 0F", kReq);
  EXPECT_TRUE(FieldIs(q, "modbus.bit_cnt", 4, 2, 12));
  EXPECT_EQ(q.d.info, "Read Coils 0x0000..0x000B (12)");
  EXPECT_TRUE(q.d.problems.empty());

  // 002 §7.10.1 response: two data bytes 07 06, first coil = bit 0 of the first byte.
  const Decoded r = decode("01 01 02 07 06 3B CE", kRsp);
  EXPECT_TRUE(FieldIs(r, "modbus.byte_cnt", 2, 1, 2));
  EXPECT_TRUE(FieldIs(r, "modbus.data", 3, 2, 0));
  const FieldNode* bits = r.find("modbus.bits");
  ASSERT_NE(bits, nullptr);
  EXPECT_EQ(bits->offset, 3u);
  EXPECT_EQ(bits->length, 2u);
  EXPECT_EQ(r.fields.text(*bits), "11100000 01100000");
  EXPECT_EQ(r.d.info, "Read Coils reply: 2 bytes 07 06");
  EXPECT_TRUE(r.d.problems.empty());
  EXPECT_EQ(format_field_value(r.fields, *r.find("modbus.data"), r.frame), "07 06");
}

TEST(DissectPdu, ReadDiscreteInputsResponseShortData) {
  const Decoded r = decode("01 02 03 00 01", kRsp, false);
  EXPECT_TRUE(AnyHasSub(r.d.problems, "3 bytes announced, 2 present"));
  EXPECT_TRUE(FieldIs(r, "modbus.data", 3, 2, 0));
  EXPECT_TRUE(HasSub(r.d.info, "Read Discrete Inputs reply: 2 bytes 00 01"));
}

TEST(DissectPdu, WriteSingleCoil) {
  // 003 §7 START: coil 0 ON.
  const Decoded r = decode("01 05 00 00 FF 00 8C 3A", kReq);
  EXPECT_TRUE(FieldIs(r, "modbus.reference_num", 2, 2, 0x0000));
  EXPECT_TRUE(FieldIs(r, "modbus.coil_value", 4, 2, 0xFF00));
  EXPECT_EQ(r.d.info, "Write Single Coil 0x0000 = ON");
  EXPECT_TRUE(r.d.problems.empty());
  EXPECT_EQ(format_field_value(r.fields, *r.find("modbus.coil_value"), r.frame), "65280 (ON)");

  const Decoded off = decode("01 05 00 40 00 00", kRsp, false);
  EXPECT_EQ(off.d.info, "Write Single Coil reply 0x0040 = OFF");
  EXPECT_TRUE(off.d.problems.empty());
}

TEST(DissectPdu, WriteSingleCoilBadValue) {
  // 002 §7.10.2 response as printed (not an echo): address FF00, value 0001.
  const Decoded r = decode("01 05 FF 00 00 01 3C 1E", kRsp);
  EXPECT_TRUE(FieldIs(r, "modbus.reference_num", 2, 2, 0xFF00));
  EXPECT_TRUE(FieldIs(r, "modbus.coil_value", 4, 2, 0x0001));
  ASSERT_EQ(r.d.problems.size(), 1u);
  EXPECT_TRUE(HasSub(r.d.problems[0], "coil value 0x0001"));
  EXPECT_TRUE(HasSub(r.d.problems[0], "neither 0x0000 (OFF) nor 0xFF00 (ON)"));
  EXPECT_EQ(r.d.info, "Write Single Coil reply 0xFF00 = 0x0001");
}

TEST(DissectPdu, WriteSingleRegister) {
  // 004 RTU example: 60 Hz to 0x2502.
  const Decoded r = decode("01 06 25 02 17 70 2D 12", kReq);
  EXPECT_TRUE(FieldIs(r, "modbus.reference_num", 2, 2, 0x2502));
  EXPECT_TRUE(FieldIs(r, "modbus.regval_uint16", 4, 2, 6000));
  EXPECT_EQ(r.d.info, "Write Single Register 0x2502 = 6000 (0x1770)");
  const Decoded echo = decode("01 06 25 02 17 70 2D 12", kRsp);
  EXPECT_EQ(echo.d.info, "Write Single Register reply 0x2502 = 6000 (0x1770)");
  EXPECT_TRUE(echo.d.problems.empty());
}

TEST(DissectPdu, WriteMultipleCoilsRequest) {
  // 003 §7 FC 0F: coils 0..8 = 1 0 0 0 0 0 0 0 1 (FAULT RESET + START).
  const Decoded r = decode("01 0F 00 00 00 09 02 01 01 25 2C", kReq);
  EXPECT_TRUE(FieldIs(r, "modbus.func_code", 1, 1, 0x0F));
  EXPECT_TRUE(FieldIs(r, "modbus.reference_num", 2, 2, 0));
  EXPECT_TRUE(FieldIs(r, "modbus.bit_cnt", 4, 2, 9));
  EXPECT_TRUE(FieldIs(r, "modbus.byte_cnt", 6, 1, 2));
  EXPECT_TRUE(FieldIs(r, "modbus.data", 7, 2, 0));
  const FieldNode* bits = r.find("modbus.bits");
  ASSERT_NE(bits, nullptr);
  EXPECT_EQ(bits->offset, 7u);
  EXPECT_EQ(bits->length, 2u);
  EXPECT_EQ(r.fields.text(*bits), "10000000 1");
  EXPECT_EQ(r.d.info, "Write Multiple Coils 0x0000..0x0008 (9) = 10000000 1");
  EXPECT_TRUE(r.d.problems.empty());

  const Decoded reply = decode("01 0F 00 00 00 09 95 CD", kRsp);
  EXPECT_EQ(reply.d.info, "Write Multiple Coils reply: 0x0000..0x0008 (9) written");
  EXPECT_TRUE(reply.d.problems.empty());
}

TEST(DissectPdu, WriteMultipleCoilsByteCountMismatch) {
  // 9 coils need 2 bytes; the request says 3 and carries 3.
  const Decoded r = decode("01 0F 00 00 00 09 03 01 01 00", kReq, false);
  EXPECT_TRUE(AnyHasSub(r.d.problems, "byte count 3 does not match quantity 9 (expected 2)"));
}

TEST(DissectPdu, WriteMultipleRegisters) {
  // 004 RTU example: run forward at 60 Hz.
  const Decoded r = decode("01 10 25 01 00 02 04 00 01 17 70 CB 26", kReq);
  EXPECT_TRUE(FieldIs(r, "modbus.reference_num", 2, 2, 0x2501));
  EXPECT_TRUE(FieldIs(r, "modbus.word_cnt", 4, 2, 2));
  EXPECT_TRUE(FieldIs(r, "modbus.byte_cnt", 6, 1, 4));
  EXPECT_TRUE(FieldIs(r, "modbus.regval_uint16", 7, 2, 1, 0));
  EXPECT_TRUE(FieldIs(r, "modbus.regval_uint16", 9, 2, 6000, 1));
  EXPECT_EQ(r.d.info, "Write Multiple Registers 0x2501..0x2502 (2) = 1, 6000");
  EXPECT_TRUE(r.d.problems.empty());

  const Decoded reply = decode("01 10 25 01 00 02 1B 04", kRsp);
  EXPECT_TRUE(FieldIs(reply, "modbus.reference_num", 2, 2, 0x2501));
  EXPECT_TRUE(FieldIs(reply, "modbus.word_cnt", 4, 2, 2));
  EXPECT_EQ(reply.d.info, "Write Multiple Registers reply: 0x2501..0x2502 (2) written");
}

TEST(DissectPdu, WriteMultipleRegistersByteCountProblems) {
  const Decoded mismatch = decode("01 10 00 0C 00 02 03 00 C8 01", kReq, false);
  EXPECT_TRUE(
      AnyHasSub(mismatch.d.problems, "byte count 3 does not match quantity 2 (expected 4)"));

  const Decoded short_data = decode("01 10 00 0C 00 02 04 00 C8", kReq, false);
  ASSERT_EQ(short_data.d.problems.size(), 1u);
  EXPECT_TRUE(HasSub(short_data.d.problems[0], "byte count says 4 bytes, 2 present"));
  EXPECT_TRUE(FieldIs(short_data, "modbus.regval_uint16", 7, 2, 200));
}

TEST(DissectPdu, QuantityOutOfRange) {
  // How many problems a row expects: none, exactly the one named, or the one named among others.
  enum class Problems { none, only, among };
  struct Case {
    const char* request;  // RTU, without CRC
    Problems problems;
    const char* problem;
  };
  const Case cases[] = {
      {"01 03 00 00 00 7E", Problems::only, "quantity of registers 126 outside 1..125"},  // > 125
      {"01 04 00 00 00 7D", Problems::none, ""},  // 125 is fine
      {"01 01 00 00 07 D1", Problems::among, "quantity of bits 2001 outside 1..2000"},  // > 2000
      {"01 02 00 00 00 00", Problems::among, "quantity of bits 0 outside 1..2000"},
      {"01 10 00 00 00 00 00", Problems::only, "quantity of registers 0 outside 1..123"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.request);
    const Decoded r = decode(c.request, kReq, false);
    switch (c.problems) {
      case Problems::none:
        EXPECT_TRUE(r.d.problems.empty());
        break;
      case Problems::only:
        ASSERT_EQ(r.d.problems.size(), 1u);
        EXPECT_TRUE(HasSub(r.d.problems[0], c.problem));
        break;
      case Problems::among:
        EXPECT_TRUE(AnyHasSub(r.d.problems, c.problem));
        break;
    }
  }
}

TEST(DissectPdu, UnexpectedTrailingBytes) {
  const Decoded r = decode("01 03 00 00 00 01 FF EE", kReq, false);
  ASSERT_EQ(r.d.problems.size(), 1u);
  EXPECT_TRUE(HasSub(r.d.problems[0], "2 unexpected bytes after the PDU"));
  // The extra bytes appear as a data node with their span.
  EXPECT_TRUE(FieldIs(r, "modbus.data", 6, 2, 0));
  EXPECT_EQ(r.d.info, "Read Holding Registers 0x0000");
}

TEST(DissectPdu, TruncatedRequest) {
  const Decoded r = decode("01 03 00 00", kReq, false);
  EXPECT_TRUE(FieldIs(r, "modbus.reference_num", 2, 2, 0));
  EXPECT_EQ(r.find("modbus.word_cnt"), nullptr);
  ASSERT_EQ(r.d.problems.size(), 1u);
  EXPECT_TRUE(HasSub(r.d.problems[0], "frame ends before Quantity"));
  EXPECT_EQ(r.d.info, "Read Holding Registers (truncated)");
}

TEST(DissectPdu, TruncatedResponse) {
  const Decoded r = decode("01 03", kRsp, false);
  EXPECT_TRUE(AnyHasSub(r.d.problems, "frame ends before Byte count"));
  EXPECT_EQ(r.d.info, "Read Holding Registers reply (truncated)");
}

TEST(DissectPdu, Diagnostics) {
  // 003 §8 / 004 loop-back: sub-function 0000, data A5 37.
  const Decoded q = decode("01 08 00 00 A5 37 DA 8D", kReq);
  EXPECT_TRUE(FieldIs(q, "modbus.diagnostic_code", 2, 2, 0));
  EXPECT_TRUE(FieldIs(q, "modbus.diagnostic_data", 4, 2, 0));
  EXPECT_EQ(q.d.info, "Diagnostics: Return Query Data (00), data A5 37");
  EXPECT_TRUE(q.d.problems.empty());
  EXPECT_EQ(format_field_value(q.fields, *q.find("modbus.diagnostic_code"), q.frame),
            "0 (Return Query Data)");

  const Decoded r = decode("01 08 00 00 A5 37 DA 8D", kRsp);
  EXPECT_EQ(r.d.info, "Diagnostics reply: Return Query Data (00), data A5 37");

  const Decoded clear = decode("01 08 00 0A 00 00", kReq, false);
  EXPECT_TRUE(FieldIs(clear, "modbus.diagnostic_code", 2, 2, 0x0A));
  EXPECT_TRUE(HasSub(clear.d.info, "Clear Counters and Diagnostic Register (0A)"));

  const Decoded reserved = decode("01 08 00 30", kReq, false);
  EXPECT_TRUE(HasSub(reserved.d.info, "reserved sub-function (30), data none"));
}

TEST(DissectPdu, ExceptionResponse) {
  // 003 §6 FC 04 error reply: illegal data value.
  const Decoded r = decode("01 84 03 03 01", kRsp);
  EXPECT_TRUE(FieldIs(r, "modbus.func_code", 1, 1, 0x04));
  EXPECT_EQ(r.fields.text(*r.find("modbus.func_code")), "exception reply");
  EXPECT_TRUE(FieldIs(r, "modbus.exception_code", 2, 1, 3));
  EXPECT_EQ(r.d.exception_code, 3);
  EXPECT_TRUE(HasSub(r.d.info, "Read Input Registers exception 0x03"));
  EXPECT_TRUE(HasSub(r.d.info, "Illegal Data Value"));
  EXPECT_TRUE(r.d.problems.empty());
  EXPECT_EQ(format_field_value(r.fields, *r.find("modbus.exception_code"), r.frame),
            "3 (Illegal Data Value)");
}

TEST(DissectPdu, ExceptionReplies) {
  struct Case {
    const char* why;
    const char* reply;  // RTU with CRC
    std::uint8_t function;
    std::uint8_t code;
    const char* info;          // in the info line
    const char* code_meaning;  // in the info line too
  };
  const Case cases[] = {
      {"004 RTU error reply: E5-8200 code 0x52 (address error)", "01 83 52 C0 CD", 0x03, 0x52,
       "Read Holding Registers exception 0x52", "non-standard"},
      {"000 §6 example 3: 0x89 reports an error for FC 09, not 08", "01 89 01 86 50", 0x09, 0x01,
       "Function 0x09 exception 0x01", "Illegal Function"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.why);
    const Decoded r = decode(c.reply, kRsp);
    EXPECT_TRUE(FieldIs(r, "modbus.func_code", 1, 1, c.function));
    EXPECT_TRUE(FieldIs(r, "modbus.exception_code", 2, 1, c.code));
    EXPECT_EQ(r.d.exception_code, c.code);
    EXPECT_TRUE(HasSub(r.d.info, c.info));
    EXPECT_TRUE(HasSub(r.d.info, c.code_meaning));
  }
}

TEST(DissectPdu, ExceptionWithTrailingByte) {
  const Decoded r = decode("01 81 02 00", kRsp, false);
  EXPECT_EQ(r.d.exception_code, 2);
  ASSERT_EQ(r.d.problems.size(), 1u);
  EXPECT_TRUE(HasSub(r.d.problems[0], "1 unexpected bytes after the PDU"));
}

TEST(DissectPdu, RequestsWithoutDataAreNamed) {
  struct Case {
    const char* request;  // RTU, without CRC
    const char* info;
  };
  const Case cases[] = {
      {"01 07", "Read Exception Status"},
      {"01 0B", "Get Comm Event Counter"},
      {"01 0C", "Get Comm Event Log"},
      {"01 11", "Report Server ID"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.request);
    EXPECT_EQ(decode(c.request, kReq, false).d.info, c.info);
  }
}

TEST(DissectPdu, ReadExceptionStatus) {
  const Decoded r = decode("01 07 6D", kRsp, false);
  EXPECT_TRUE(FieldIs(r, "modbus.exception_status", 2, 1, 0x6D));
  EXPECT_EQ(r.d.info, "Read Exception Status reply: 0x6D");
  EXPECT_TRUE(r.d.problems.empty());
}

TEST(DissectPdu, GetCommEventCounter) {
  const Decoded r = decode("01 0B FF FF 01 08", kRsp, false);
  EXPECT_TRUE(FieldIs(r, "modbus.ev_status", 2, 2, 0xFFFF));
  EXPECT_TRUE(FieldIs(r, "modbus.ev_count", 4, 2, 264));
  EXPECT_EQ(r.d.info, "Get Comm Event Counter reply: status 0xFFFF, 264 events");
}

TEST(DissectPdu, GetCommEventLog) {
  // Spec example: byte count 8, status 0, 264 events, 289 messages, events 20 00.
  const Decoded r = decode("01 0C 08 00 00 01 08 01 21 20 00", kRsp, false);
  EXPECT_TRUE(FieldIs(r, "modbus.byte_cnt", 2, 1, 8));
  EXPECT_TRUE(FieldIs(r, "modbus.ev_count", 5, 2, 264));
  EXPECT_TRUE(FieldIs(r, "modbus.ev_msg_count", 7, 2, 289));
  EXPECT_TRUE(FieldIs(r, "modbus.event", 9, 1, 0x20, 0));
  EXPECT_TRUE(FieldIs(r, "modbus.event", 10, 1, 0x00, 1));
  EXPECT_EQ(r.d.info, "Get Comm Event Log reply: 264 events, 289 messages, log 20 00");
  EXPECT_TRUE(r.d.problems.empty());

  const Decoded small = decode("01 0C 05 00 00 01 08 01 21", kRsp, false);
  EXPECT_TRUE(AnyHasSub(small.d.problems, "byte count 5 below the minimum 6"));
}

TEST(DissectPdu, ReportServerId) {
  const Decoded r = decode("01 11 03 2A FF 00", kRsp, false);
  EXPECT_TRUE(FieldIs(r, "modbus.byte_cnt", 2, 1, 3));
  EXPECT_TRUE(FieldIs(r, "modbus.server_id", 3, 3, 0));
  EXPECT_EQ(r.d.info, "Report Server ID reply: 2A FF 00");
  EXPECT_TRUE(r.d.problems.empty());
}

TEST(DissectPdu, ReadFileRecord) {
  // Spec example: two sub-requests (file 4 record 1 x2, file 3 record 9 x2).
  const Decoded q = decode("01 14 0E 06 00 04 00 01 00 02 06 00 03 00 09 00 02", kReq, false);
  EXPECT_TRUE(FieldIs(q, "modbus.byte_cnt", 2, 1, 14));
  ASSERT_EQ(q.count("modbus.file"), 2);
  EXPECT_EQ(q.find("modbus.file", 0)->offset, 3u);
  EXPECT_EQ(q.find("modbus.file", 1)->offset, 10u);
  // A group's span covers its children: 7 bytes per sub-request.
  EXPECT_EQ(q.find("modbus.file", 0)->length, 7u);
  EXPECT_EQ(q.find("modbus.file", 1)->length, 7u);
  EXPECT_TRUE(FieldIs(q, "modbus.reference_type", 3, 1, 6, 0));
  EXPECT_TRUE(FieldIs(q, "modbus.file.number", 4, 2, 4, 0));
  EXPECT_TRUE(FieldIs(q, "modbus.file.record", 6, 2, 1, 0));
  EXPECT_TRUE(FieldIs(q, "modbus.word_cnt", 8, 2, 2, 0));
  EXPECT_TRUE(FieldIs(q, "modbus.file.number", 11, 2, 3, 1));
  EXPECT_TRUE(FieldIs(q, "modbus.file.record", 13, 2, 9, 1));
  EXPECT_EQ(q.find("modbus.file.number")->depth, 1);
  EXPECT_EQ(q.d.info, "Read File Record: 2 sub-requests");
  EXPECT_TRUE(q.d.problems.empty());

  const Decoded r = decode("01 14 0C 05 06 0D FE 00 20 05 06 33 CD 00 40", kRsp, false);
  ASSERT_EQ(r.count("modbus.file"), 2);
  EXPECT_TRUE(FieldIs(r, "modbus.byte_cnt", 3, 1, 5, 1));
  EXPECT_TRUE(FieldIs(r, "modbus.data", 5, 4, 0, 0));
  EXPECT_TRUE(FieldIs(r, "modbus.data", 11, 4, 0, 1));
  EXPECT_EQ(r.d.info, "Read File Record reply: 2 sub-requests");
  EXPECT_TRUE(r.d.problems.empty());

  const Decoded bad_ref = decode("01 14 07 05 00 04 00 01 00 02", kReq, false);
  EXPECT_TRUE(AnyHasSub(bad_ref.d.problems, "reference type 5 (must be 6)"));
}

TEST(DissectPdu, WriteFileRecord) {
  // Spec example: file 4, record 7, 3 registers 06AF 04BE 100D.
  const Decoded q = decode("01 15 0D 06 00 04 00 07 00 03 06 AF 04 BE 10 0D", kReq, false);
  EXPECT_TRUE(FieldIs(q, "modbus.file.number", 4, 2, 4));
  EXPECT_TRUE(FieldIs(q, "modbus.file.record", 6, 2, 7));
  EXPECT_TRUE(FieldIs(q, "modbus.word_cnt", 8, 2, 3));
  EXPECT_TRUE(FieldIs(q, "modbus.data", 10, 6, 0));
  EXPECT_EQ(q.d.info, "Write File Record: 1 sub-request");
  EXPECT_TRUE(q.d.problems.empty());
  const Decoded r = decode("01 15 0D 06 00 04 00 07 00 03 06 AF 04 BE 10 0D", kRsp, false);
  EXPECT_EQ(r.d.info, "Write File Record reply: 1 sub-request");

  const Decoded count_off = decode("01 15 0E 06 00 04 00 07 00 03 06 AF 04 BE 10 0D", kReq, false);
  EXPECT_TRUE(AnyHasSub(count_off.d.problems, "byte count says 14 bytes, 13 present"));
}

TEST(DissectPdu, MaskWriteRegister) {
  const Decoded q = decode("01 16 00 04 00 F2 00 25", kReq, false);
  EXPECT_TRUE(FieldIs(q, "modbus.reference_num", 2, 2, 4));
  EXPECT_TRUE(FieldIs(q, "modbus.and_mask", 4, 2, 0xF2));
  EXPECT_TRUE(FieldIs(q, "modbus.or_mask", 6, 2, 0x25));
  EXPECT_EQ(q.d.info, "Mask Write Register 0x0004 AND 0x00F2 OR 0x0025");
  const Decoded r = decode("01 16 00 04 00 F2 00 25", kRsp, false);
  EXPECT_EQ(r.d.info, "Mask Write Register reply 0x0004 AND 0x00F2 OR 0x0025");
}

TEST(DissectPdu, ReadWriteMultipleRegistersRequest) {
  // Spec example: read 6 from 0x0003, write 3 at 0x000E = 00FF 00FF 00FF.
  const Decoded q = decode("01 17 00 03 00 06 00 0E 00 03 06 00 FF 00 FF 00 FF", kReq, false);
  EXPECT_TRUE(FieldIs(q, "modbus.read_reference_num", 2, 2, 3));
  EXPECT_TRUE(FieldIs(q, "modbus.read_word_cnt", 4, 2, 6));
  EXPECT_TRUE(FieldIs(q, "modbus.write_reference_num", 6, 2, 0x0E));
  EXPECT_TRUE(FieldIs(q, "modbus.write_word_cnt", 8, 2, 3));
  EXPECT_TRUE(FieldIs(q, "modbus.byte_cnt", 10, 1, 6));
  ASSERT_EQ(q.count("modbus.regval_uint16"), 3);
  EXPECT_TRUE(FieldIs(q, "modbus.regval_uint16", 11, 2, 255, 0));
  EXPECT_TRUE(FieldIs(q, "modbus.regval_uint16", 15, 2, 255, 2));
  EXPECT_EQ(q.d.info,
            "Read/Write Multiple Registers: read 0x0003..0x0008 (6), write 0x000E..0x0010 (3) = "
            "255, 255, 255");
  EXPECT_TRUE(q.d.problems.empty());
  EXPECT_TRUE(pdu_fits(std::span(q.frame).subspan(1), kReq));
}

TEST(DissectPdu, ReadWriteMultipleRegistersProblems) {
  const Decoded bad = decode("01 17 00 03 00 00 00 0E 00 03 04 00 FF 00 FF", kReq, false);
  EXPECT_TRUE(AnyHasSub(bad.d.problems, "quantity of registers to read 0 outside 1..125"));
  EXPECT_TRUE(AnyHasSub(bad.d.problems, "byte count 4 does not match write quantity 3"));
}

TEST(DissectPdu, ReadWriteMultipleRegistersResponse) {
  const Decoded r = decode("01 17 0C 00 FE 0A CD 00 01 00 03 00 0D 00 FF", kRsp, false);
  EXPECT_TRUE(FieldIs(r, "modbus.byte_cnt", 2, 1, 12));
  EXPECT_EQ(r.count("modbus.regval_uint16"), 6);
  EXPECT_TRUE(FieldIs(r, "modbus.regval_uint16", 5, 2, 2765, 1));
  EXPECT_EQ(r.d.info,
            "Read/Write Multiple Registers reply: 6 registers = 254, 2765, 1, 3, 13, 255");
  EXPECT_TRUE(r.d.problems.empty());
}

TEST(DissectPdu, ReadFifoQueue) {
  const Decoded q = decode("01 18 04 DE", kReq, false);
  EXPECT_TRUE(FieldIs(q, "modbus.reference_num", 2, 2, 0x04DE));
  EXPECT_EQ(q.d.info, "Read FIFO Queue 0x04DE");
  const Decoded r = decode("01 18 00 06 00 02 01 B8 12 84", kRsp, false);
  EXPECT_TRUE(FieldIs(r, "modbus.byte_cnt_16", 2, 2, 6));
  EXPECT_TRUE(FieldIs(r, "modbus.word_cnt", 4, 2, 2));
  EXPECT_TRUE(FieldIs(r, "modbus.regval_uint16", 6, 2, 440, 0));
  EXPECT_TRUE(FieldIs(r, "modbus.regval_uint16", 8, 2, 4740, 1));
  EXPECT_EQ(r.d.info, "Read FIFO Queue reply: 2 values = 440, 4740");
  EXPECT_TRUE(r.d.problems.empty());
  const Decoded bad = decode("01 18 00 08 00 02 01 B8 12 84", kRsp, false);
  EXPECT_TRUE(AnyHasSub(bad.d.problems, "FIFO byte count 8 does not match FIFO count 2"));
}

TEST(DissectPdu, ReadDeviceIdentificationRequest) {
  const Decoded q = decode("01 2B 0E 01 00", kReq, false);
  EXPECT_TRUE(FieldIs(q, "modbus.mei", 2, 1, 0x0E));
  EXPECT_TRUE(FieldIs(q, "modbus.read_device_id", 3, 1, 1));
  EXPECT_TRUE(FieldIs(q, "modbus.object_id", 4, 1, 0));
  EXPECT_EQ(q.d.info, "Read Device Identification (basic), from object 0");
  EXPECT_TRUE(q.d.problems.empty());
}

TEST(DissectPdu, ReadDeviceIdentificationResponseTwoObjects) {
  // code 01, conformity 01, more 00, next 00, 2 objects: VendorName "ABC", ProductCode "X1".
  const Decoded r = decode("01 2B 0E 01 01 00 00 02 00 03 41 42 43 01 02 58 31", kRsp, false);
  EXPECT_TRUE(FieldIs(r, "modbus.mei", 2, 1, 0x0E));
  EXPECT_TRUE(FieldIs(r, "modbus.read_device_id", 3, 1, 1));
  EXPECT_TRUE(FieldIs(r, "modbus.conformity_level", 4, 1, 1));
  EXPECT_TRUE(FieldIs(r, "modbus.more_follows", 5, 1, 0));
  EXPECT_TRUE(FieldIs(r, "modbus.next_object_id", 6, 1, 0));
  EXPECT_TRUE(FieldIs(r, "modbus.num_objects", 7, 1, 2));
  ASSERT_EQ(r.count("modbus.object"), 2);
  EXPECT_EQ(r.find("modbus.object", 0)->offset, 8u);
  EXPECT_EQ(r.find("modbus.object", 0)->depth, 0);
  EXPECT_EQ(r.find("modbus.object", 1)->offset, 13u);
  EXPECT_TRUE(FieldIs(r, "modbus.object_id", 8, 1, 0, 0));
  EXPECT_EQ(r.find("modbus.object_id", 0)->depth, 1);
  EXPECT_TRUE(FieldIs(r, "modbus.objects_len", 9, 1, 3, 0));
  EXPECT_TRUE(FieldIs(r, "modbus.object_id", 13, 1, 1, 1));
  EXPECT_TRUE(FieldIs(r, "modbus.objects_len", 14, 1, 2, 1));
  const FieldNode* v0 = r.find("modbus.object_str_value", 0);
  const FieldNode* v1 = r.find("modbus.object_str_value", 1);
  ASSERT_NE(v0, nullptr);
  ASSERT_NE(v1, nullptr);
  EXPECT_EQ(r.fields.text(*v0), "ABC");
  EXPECT_EQ(v0->offset, 10u);
  EXPECT_EQ(v0->length, 3u);
  EXPECT_EQ(r.fields.text(*v1), "X1");
  EXPECT_EQ(v1->offset, 15u);
  EXPECT_EQ(v1->length, 2u);
  EXPECT_EQ(r.d.info, "Read Device Identification reply: VendorName=\"ABC\", ProductCode=\"X1\"");
  EXPECT_TRUE(r.d.problems.empty());
}

TEST(DissectPdu, ReadDeviceIdentificationResponseMissingObject) {
  // The object count says 2 but only one object is present: the frame is truncated and that
  // must be reported like every other truncation.
  const Decoded r = decode("01 2B 0E 01 01 00 00 02 00 03 41 42 43", kRsp, false);
  EXPECT_EQ(r.count("modbus.object"), 1);
  EXPECT_FALSE(r.d.problems.empty()) << "info: " << r.d.info;
}

TEST(DissectPdu, ReadDeviceIdentificationShortObjectValue) {
  const Decoded r = decode("01 2B 0E 01 01 00 00 01 00 05 41 42", kRsp, false);
  EXPECT_TRUE(AnyHasSub(r.d.problems, "5 bytes announced, 2 present"));
}

TEST(DissectPdu, OtherMeiType) {
  const Decoded r = decode("01 2B 0D 01 02", kReq, false);
  EXPECT_TRUE(FieldIs(r, "modbus.mei", 2, 1, 0x0D));
  EXPECT_EQ(r.d.info, "Encapsulated Interface Transport MEI 0x0D: 01 02");
}

TEST(DissectPdu, NonPublicFunction) {
  const Decoded r = decode("01 41 01 02", kReq, false);
  EXPECT_TRUE(FieldIs(r, "modbus.func_code", 1, 1, 0x41));
  EXPECT_TRUE(FieldIs(r, "modbus.data", 2, 2, 0));
  EXPECT_EQ(r.d.info, "Function 0x41 (not a public code): 2 data bytes 01 02");
  EXPECT_EQ(format_field_value(r.fields, *r.find("modbus.func_code"), r.frame), "65 (0x41)");
}

TEST(DissectPdu, SpansStayInsideThePdu) {
  // Every node of every frame above lies within the frame (and the PDU).
  for (const auto& [frame, dir] : std::vector<std::pair<const char*, Direction>>{
           {"01 0F 00 00 00 09 02 01 01 25 2C", kReq},
           {"01 04 10 01 F4 00 00 00 D6 00 00 02 32 0A 03", kRsp},
           {"02 03 08 00 03 13 88 13 88 01 7C 80 48", kRsp},
           {"01 10 25 01 00 02 04 00 01 17 70 CB 26", kReq}}) {
    const Decoded r = decode(frame, dir);
    for (const FieldNode& n : r.fields) {
      EXPECT_GE(n.offset, 1u) << frame << " " << n.desc->id;
      EXPECT_LE(n.offset + n.length, r.frame.size() - 2) << frame << " " << n.desc->id;
    }
  }
}

// ---------------------------------------------------------------------------------------------
// The table of length rules against the function-by-function switch it replaced (kept here as
// the reference): every function code, both directions and none, every length up to 12, with
// count bytes of every size.

namespace {

LengthPrediction known(std::size_t n) {
  return {Kind::known, n};
}
LengthPrediction need_more() {
  return {Kind::need_more, 0};
}
LengthPrediction unknown() {
  return {Kind::unknown, 0};
}
LengthPrediction counted(std::span<const std::uint8_t> pdu, std::size_t count_at,
                         std::size_t fixed) {
  if (pdu.size() <= count_at) return need_more();
  return known(fixed + pdu[count_at]);
}
LengthPrediction device_id_response_length(std::span<const std::uint8_t> pdu) {
  if (pdu.size() < 7) return need_more();
  std::size_t pos = 7;
  const unsigned objects = pdu[6];
  for (unsigned i = 0; i < objects; ++i) {
    if (pdu.size() < pos + 2) return need_more();
    pos += 2 + pdu[pos + 1];
  }
  return known(pos);
}

LengthPrediction reference_length(std::span<const std::uint8_t> pdu, Direction direction) {
  if (pdu.empty()) return need_more();
  const std::uint8_t fc = pdu[0];
  if (direction == Direction::response && (fc & 0x80)) return known(2);
  if (fc & 0x80) return unknown();
  if (direction == Direction::request) {
    switch (fc) {
      case 0x01:
      case 0x02:
      case 0x03:
      case 0x04:
      case 0x05:
      case 0x06:
        return known(5);
      case 0x07:
      case 0x0B:
      case 0x0C:
      case 0x11:
        return known(1);
      case 0x08:
        return known(5);  // sub-function + one data word (sub 00 may carry more)
      case 0x0F:
      case 0x10:
        return counted(pdu, 5, 6);
      case 0x14:
      case 0x15:
        return counted(pdu, 1, 2);
      case 0x16:
        return known(7);
      case 0x17:
        return counted(pdu, 9, 10);
      case 0x18:
        return known(3);
      case 0x2B:
        if (pdu.size() < 2) return need_more();
        return pdu[1] == 0x0E ? known(4) : unknown();
      default:
        return unknown();
    }
  }
  if (direction == Direction::response) {
    switch (fc) {
      case 0x01:
      case 0x02:
      case 0x03:
      case 0x04:
      case 0x0C:
      case 0x11:
      case 0x14:
      case 0x15:
      case 0x17:
        return counted(pdu, 1, 2);
      case 0x05:
      case 0x06:
      case 0x08:
      case 0x0B:
      case 0x0F:
      case 0x10:
        return known(5);
      case 0x07:
        return known(2);
      case 0x16:
        return known(7);
      case 0x18:
        if (pdu.size() < 3) return need_more();
        return known(3 + static_cast<std::size_t>((pdu[1] << 8) | pdu[2]));
      case 0x2B:
        if (pdu.size() < 2) return need_more();
        return pdu[1] == 0x0E ? device_id_response_length(pdu) : unknown();
      default:
        return unknown();
    }
  }
  return unknown();
}

}  // namespace

TEST(PredictPduLength, TableGivesTheReferenceLengths) {
  std::mt19937 rng(5);
  for (int fc = 0; fc < 256; ++fc) {
    for (const Direction dir : {Direction::request, Direction::response, Direction::unknown}) {
      for (std::size_t n = 1; n <= 12; ++n) {
        for (int round = 0; round < 20; ++round) {
          std::vector<std::uint8_t> pdu(n);
          for (auto& b : pdu) b = static_cast<std::uint8_t>(rng() % (round < 10 ? 4 : 256));
          pdu[0] = static_cast<std::uint8_t>(fc);
          if (n > 1 && round % 3 == 0) pdu[1] = 0x0E;
          const LengthPrediction want = reference_length(pdu, dir);
          const LengthPrediction got = predict_pdu_length(pdu, dir);
          ASSERT_EQ(got.kind, want.kind) << "fc " << fc << " n " << n << " " << direction_id(dir);
          if (want.kind == Kind::known) {
            ASSERT_EQ(got.length, want.length) << "fc " << fc << " n " << n;
          }
        }
      }
    }
  }
}

// pdu_findings() works the counts out directly for the function codes of every poll; they must
// be dissect_pdu_into()'s on every function code, length and direction, with contents that reach
// each rule's edges (counts that match or miss by one, quantities 0, 1 and at the limits, coil
// values ON, OFF and neither).
TEST(ModbusPdu, FindingsAreWhatTheDissectorFinds) {
  std::mt19937 rng(11);
  const std::uint8_t edges[] = {0x00, 0x01, 0x02, 0x04, 0x07, 0x08, 0x79, 0x7B, 0x7C,
                                0x7D, 0x7E, 0xD0, 0xFF, 0x03, 0x06, 0x0A, 0x10, 0xFA};
  std::size_t with_problems = 0, checked = 0;
  for (unsigned fc = 0; fc < 256; ++fc) {
    for (std::size_t length = 1; length <= 24; ++length) {
      for (const Direction dir : {Direction::request, Direction::response, Direction::unknown}) {
        for (int round = 0; round < 24; ++round) {
          std::vector<std::uint8_t> pdu(length);
          pdu[0] = static_cast<std::uint8_t>(fc);
          for (std::size_t i = 1; i < length; ++i)
            pdu[i] =
                round % 3 == 0 ? static_cast<std::uint8_t>(rng()) : edges[rng() % std::size(edges)];
          // A count byte that fits what follows (read replies, multiple writes), now and then.
          if (round % 4 == 1 && length >= 2) pdu[1] = static_cast<std::uint8_t>(length - 2);
          if (round % 4 == 2 && length >= 6) pdu[5] = static_cast<std::uint8_t>(length - 6);
          if (round % 8 == 3 && length >= 5) {
            pdu[3] = 0;
            pdu[4] = static_cast<std::uint8_t>((length - 6) / 2);  // registers for the byte count
          }
          FieldTree fields;
          FieldTreeBuilder tree(fields, false);
          PduDecode d;
          d.detail = false;
          dissect_pdu_into(d, pdu, 0, pdu.size(), dir, tree);
          const PduFindings found = pdu_findings(pdu, dir);
          ASSERT_EQ(found.problems, d.problems.size())
              << "fc " << fc << " length " << length << " direction " << static_cast<int>(dir)
              << " round " << round;
          ASSERT_EQ(found.exception_code, d.exception_code) << "fc " << fc << " length " << length;
          with_problems += found.problems > 0;
          ++checked;
        }
      }
    }
  }
  // Both outcomes are common: the comparison is not of empty lists only.
  EXPECT_GT(with_problems, checked / 10);
  EXPECT_LT(with_problems, checked * 9 / 10);
}

TEST(ModbusPdu, InfoIntoGetsTheLineInPlaceOfInfo) {
  // dissect_rtu() has the line written into the message's own string, keeping its storage.
  const std::vector<std::uint8_t> frame = {0x01, 0x03, 0x25, 0x23, 0x00, 0x01};
  FieldTree fields;
  FieldTreeBuilder tree(fields, false);
  std::string line = "an older, longer line that leaves its storage to this one";
  const std::size_t capacity = line.capacity();
  PduDecode d;
  d.info_into = &line;
  dissect_pdu_into(d, frame, 1, frame.size() - 1, Direction::request, tree);
  EXPECT_EQ(line, "Read Holding Registers 0x2523");
  EXPECT_EQ(line.capacity(), capacity);
  EXPECT_TRUE(d.info.empty());
  // Each function's own text (describe(), not describe_in_place()) goes there too.
  const std::vector<std::uint8_t> status = {0x01, 0x07};
  dissect_pdu_into(d, status, 1, status.size() - 1, Direction::request, tree);
  EXPECT_EQ(line, "Read Exception Status");
  EXPECT_TRUE(d.info.empty());
}
