// Unit tests: each protocol's drive records (ProtocolDecoder::read_drive_records(), bytes ->
// core/drive_records.hpp) — Modbus RTU/ASCII (docs/protocols.md §2, §3), Danfoss FC (§4) and
// Easydrive (§5) telegrams as the drive level reads them.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "core/protocol.hpp"
#include "dissectors/danfoss_fc/fc_protocol.hpp"
#include "dissectors/easydrive/eds_protocol.hpp"
#include "dissectors/modbus/modbus_protocol.hpp"
#include "test_support.hpp"

using namespace drivetap;
using drivetap::testing::ascii_frame;
using drivetap::testing::eds_frame;
using drivetap::testing::fc_telegram;
using drivetap::testing::with_crc;

namespace {

std::string_view op_name(AccessOp op) {
  constexpr std::string_view names[] = {"read", "write", "value", "refused", "text", "other"};
  return names[static_cast<std::size_t>(op)];
}

std::string_view kind_name(RegisterKind kind) {
  constexpr std::string_view names[] = {"holding",  "input",   "coil",
                                        "discrete", "running", "parameter"};
  return names[static_cast<std::size_t>(kind)];
}

// The records in one line: "function 3; read holding 0 x5", "family; words 1148 8192".
std::string describe(const DriveRecords& records) {
  std::string out;
  auto part = [&]() -> std::string& { return out += out.empty() ? "" : "; "; };
  if (records.family_protocol) part() += "family";
  if (records.function >= 0) part() += fmt::format("function {}", records.function);
  for (const DriveRecord& r : records.records) {
    std::string& text = part();
    switch (r.type) {
      case DriveRecordType::access:
        text += fmt::format("{} {} {} x{}", op_name(r.op), kind_name(r.kind), r.first, r.count);
        break;
      case DriveRecordType::exception:
        text += fmt::format("exception {}", r.code);
        break;
      case DriveRecordType::process_words:
        text += "words";
        break;
      case DriveRecordType::command:
        text += fmt::format("command {} of {}", static_cast<int>(r.command), kind_name(r.kind));
        break;
      case DriveRecordType::status_query:
        text += "status query";
        break;
      case DriveRecordType::readiness:
        text += fmt::format("ready {}", r.code);
        break;
      case DriveRecordType::fault:
        text += fmt::format("fault {}", r.code);
        break;
    }
    for (const std::uint32_t v : records.values_of(r)) text += fmt::format(" {}", v);
    if (r.double_word) text += " dw";
    if (r.permanent) text += " permanent";
    if (r.addressed_by_request) text += " by-request";
    if (!r.weighed) text += " unweighed";
  }
  return out;
}

struct Case {
  const char* what;
  Protocol protocol;
  std::vector<std::uint8_t> bytes;
  Direction direction;
  std::vector<std::uint8_t> request;  // for a reply
  const char* records;
};

void check(const std::vector<Case>& cases) {
  DriveRecords reused;  // one for all: each reading is a fresh one
  for (const Case& c : cases) {
    SCOPED_TRACE(c.what);
    TelegramHead head;
    head.protocol = c.protocol;
    head.direction = c.direction;
    head.bytes = c.bytes;
    decoder_for(c.protocol)->read_drive_records(head, c.request, reused);
    EXPECT_EQ(describe(reused), c.records);
    DriveRecords fresh;
    decoder_for(c.protocol)->read_drive_records(head, c.request, fresh);
    EXPECT_EQ(describe(fresh), describe(reused));
  }
}

const Direction kRequest = Direction::request, kReply = Direction::response;

}  // namespace

TEST(DriveRecords, ModbusRtu) {
  const Protocol rtu = protocols::modbus_rtu;
  const auto e9_read = with_crc({0x02, 0x03, 0x00, 0x00, 0x00, 0x05});
  const auto coil_read = with_crc({0x01, 0x01, 0x00, 0x00, 0x00, 0x0A});
  const auto inputs_read = with_crc({0x01, 0x02, 0x00, 0x04, 0x00, 0x03});
  check({
      {"read of 5 holding registers", rtu, e9_read, kRequest, {}, "function 3; read holding 0 x5"},
      {"its reply, read with the request", rtu,
       with_crc({0x02, 0x03, 0x0A, 0x00, 0x0A, 0x13, 0x88, 0x13, 0x7D, 0x01, 0x7C, 0x00, 0x64}),
       kReply, e9_read, "function 3; value holding 0 x5 10 5000 4989 380 100 by-request"},
      {"a reply without its request names no address",
       rtu,
       with_crc({0x02, 0x03, 0x02, 0x00, 0x0A}),
       kReply,
       {},
       "function 3"},
      {"a reply to another function", rtu, with_crc({0x02, 0x04, 0x02, 0x00, 0x0A}), kReply,
       e9_read, "function 4"},
      {"input registers",
       rtu,
       with_crc({0x01, 0x04, 0x04, 0x00, 0x00, 0x01}),
       kRequest,
       {},
       "function 4; read input 1024 x1"},
      {"write of one register",
       rtu,
       with_crc({0x01, 0x06, 0xC3, 0x4F, 0x04, 0xBC}),
       kRequest,
       {},
       "function 6; write holding 49999 x1 1212"},
      {"write of two registers",
       rtu,
       with_crc({0x02, 0x10, 0x00, 0x10, 0x00, 0x02, 0x04, 0x00, 0x01, 0x13, 0x88}),
       kRequest,
       {},
       "function 16; write holding 16 x2 1 5000"},
      {"write of one coil",
       rtu,
       with_crc({0x01, 0x05, 0x00, 0x09, 0xFF, 0x00}),
       kRequest,
       {},
       "function 5; write coil 9 x1 1"},
      {"a coil written OFF",
       rtu,
       with_crc({0x01, 0x05, 0x00, 0x00, 0x00, 0x00}),
       kRequest,
       {},
       "function 5; write coil 0 x1 0"},
      {"write of ten coils, least significant bit first",
       rtu,
       with_crc({0x01, 0x0F, 0x00, 0x00, 0x00, 0x0A, 0x02, 0x05, 0x02}),
       kRequest,
       {},
       "function 15; write coil 0 x10 1 0 1 0 0 0 0 0 0 1"},
      {"read of ten coils", rtu, coil_read, kRequest, {}, "function 1; read coil 0 x10"},
      {"its reply", rtu, with_crc({0x01, 0x01, 0x02, 0x05, 0x02}), kReply, coil_read,
       "function 1; value coil 0 x10 1 0 1 0 0 0 0 0 0 1 by-request"},
      {"read of discrete inputs", rtu, inputs_read, kRequest, {}, "function 2; read discrete 4 x3"},
      {"its reply, read against the coils", rtu, with_crc({0x01, 0x02, 0x01, 0x05}), kReply,
       inputs_read, "function 2; value coil 4 x3 1 0 1 by-request"},
      {"an exception reply", rtu, with_crc({0x02, 0x83, 0x02}), kReply, e9_read,
       "function 3; exception 2"},
      {"diagnostics: a function alone",
       rtu,
       with_crc({0x02, 0x08, 0x00, 0x00, 0x12, 0x34}),
       kRequest,
       {},
       "function 8"},
      {"too short for a function", rtu, {0x02, 0x03, 0x00}, kRequest, {}, ""},
  });
}

TEST(DriveRecords, ModbusAsciiReadsTheBinaryItsHexSpells) {
  const Protocol ascii = protocols::modbus_ascii;
  const auto read = ascii_frame({0x01, 0x03, 0x25, 0x23, 0x00, 0x01});
  check({
      {"read", ascii, read, kRequest, {}, "function 3; read holding 9507 x1"},
      {"its reply", ascii, ascii_frame({0x01, 0x03, 0x02, 0x17, 0x70}), kReply, read,
       "function 3; value holding 9507 x1 6000 by-request"},
      {"write",
       ascii,
       ascii_frame({0x01, 0x06, 0x25, 0x01, 0x00, 0x0B}),
       kRequest,
       {},
       "function 6; write holding 9473 x1 11"},
      {"exception", ascii, ascii_frame({0x02, 0x83, 0x52}), kReply, {}, "function 3; exception 82"},
      {"not hex", ascii, {':', '0', '1', 'x', 'y', '\r', '\n'}, kRequest, {}, ""},
  });
}

TEST(DriveRecords, DanfossFc) {
  const Protocol fc = protocols::danfoss_fc;
  check({
      {"process data: CTW and reference",
       fc,
       fc_telegram(0x01, {0x04, 0x7C, 0x20, 0x00}),
       kRequest,
       {},
       "family; words 1148 8192"},
      {"process data: STW and MAV",
       fc,
       fc_telegram(0x01, {0x06, 0x07, 0x00, 0x00}),
       kReply,
       {},
       "family; words 1543 0"},
      {"read 4-14 (AK 1)",
       fc,
       fc_telegram(0x01, {0x11, 0x9E, 0, 0, 0, 0, 0, 0, 0x04, 0x7C, 0x20, 0x00}),
       kRequest,
       {},
       "family; read parameter 414 x1; words 1148 8192"},
      {"its value (AK 1)",
       fc,
       fc_telegram(0x01, {0x11, 0x9E, 0, 0, 0, 0, 0x03, 0xE8, 0x06, 0x07, 0x00, 0x00}),
       kReply,
       {},
       "family; value parameter 414 x1 1000; words 1543 0"},
      {"a double word value (AK 2)",
       fc,
       fc_telegram(0x01, {0x20, 0x69, 0, 0, 0, 0x01, 0x00, 0x02, 0x06, 0x07, 0x00, 0x00}),
       kReply,
       {},
       "family; value parameter 105 x1 65538 dw; words 1543 0"},
      {"write to RAM and EEPROM (AK E)",
       fc,
       fc_telegram(0x81, {0xE1, 0x9E, 0, 0, 0, 0, 0x03, 0xE8, 0x04, 0x7C, 0x20, 0x00}),
       kRequest,
       {},
       "family; write parameter 414 x1 1000 permanent; words 1148 8192"},
      {"write of a double word to RAM (AK 3)",
       fc,
       fc_telegram(0x01, {0x30, 0x69, 0, 0, 0, 0x01, 0x00, 0x02, 0x04, 0x7C, 0x20, 0x00}),
       kRequest,
       {},
       "family; write parameter 105 x1 65538 dw; words 1148 8192"},
      {"cannot execute (AK 7), error 2",
       fc,
       fc_telegram(0x01, {0x71, 0x9E, 0, 0, 0, 0, 0x00, 0x02, 0x06, 0x07, 0x00, 0x00}),
       kReply,
       {},
       "family; refused parameter 414 x1 2; words 1543 0"},
      {"text (AK F)",
       fc,
       fc_telegram(0x01, {0xF1, 0x9E, 0x04, 0, 0, 0, 0, 0, 0x04, 0x7C, 0x20, 0x00}),
       kRequest,
       {},
       "family; text parameter 414 x1; words 1148 8192"},
      {"an AK no request has (5)",
       fc,
       fc_telegram(0x01, {0x51, 0x9E, 0, 0, 0, 0, 0, 0, 0x04, 0x7C, 0x20, 0x00}),
       kRequest,
       {},
       "family; other parameter 414 x1; words 1148 8192"},
      {"no parameter access (AK 0)",
       fc,
       fc_telegram(0x01, {0x01, 0x9E, 0, 0, 0, 0, 0, 0, 0x04, 0x7C, 0x20, 0x00}),
       kRequest,
       {},
       "family; words 1148 8192"},
      {"direction unknown",
       fc,
       fc_telegram(0x01, {0x04, 0x7C, 0x20, 0x00}),
       Direction::unknown,
       {},
       "family"},
      {"a text telegram's length",
       fc,
       fc_telegram(0x01, {0x04, 0x7C, 0x20, 0x00, 0x41}),
       kRequest,
       {},
       "family"},
  });
}

TEST(DriveRecords, Easydrive) {
  const Protocol eds = protocols::easydrive;
  const auto status_word = eds_frame("010B000F");
  const auto status_query = eds_frame("010A0000");
  const auto read_f008 = eds_frame("010D0008");
  check({
      {"run with frequency",
       eds,
       eds_frame("010C00020FA0"),
       kRequest,
       {},
       "family; command 1 of running 4000"},
      {"run reverse", eds, eds_frame("010C0004"), kRequest, {}, "family; command 3 of running"},
      {"set frequency alone",
       eds,
       eds_frame("010C00010BB8"),
       kRequest,
       {},
       "family; command 0 of running 3000"},
      {"emergency stop", eds, eds_frame("010C000E"), kRequest, {}, "family; command 6 of running"},
      {"jog: no command the drive level reads", eds, eds_frame("010C0008"), kRequest, {}, "family"},
      {"read of a running value",
       eds,
       status_word,
       kRequest,
       {},
       "family; read running 15 x1 unweighed"},
      {"its value and the current fault", eds, eds_frame("0100030F0001"), kReply, status_word,
       "family; value running 15 x1 1 by-request unweighed; fault 3"},
      {"a reply without its request: the fault alone",
       eds,
       eds_frame("0100030F0001"),
       kReply,
       {},
       "family; fault 3"},
      {"a rejected reply says nothing", eds, eds_frame("0120030F0001"), kReply, status_word,
       "family"},
      {"status query", eds, status_query, kRequest, {}, "family; status query"},
      {"ready", eds, eds_frame("01110000"), kReply, status_query, "family; ready 1; fault 0"},
      {"not ready", eds, eds_frame("01100400"), kReply, status_query, "family; ready 0; fault 4"},
      {"read of a function code",
       eds,
       read_f008,
       kRequest,
       {},
       "family; read parameter 8 x1 unweighed"},
      {"its value", eds, eds_frame("0100000803E8"), kReply, read_f008,
       "family; value parameter 8 x1 1000 by-request unweighed; fault 0"},
      {"write of a function code",
       eds,
       eds_frame("010E000803E8"),
       kRequest,
       {},
       "family; write parameter 8 x1 1000 unweighed"},
      {"a write without data", eds, eds_frame("010E0008"), kRequest, {}, "family"},
      {"not a telegram's length", eds, {'~', '0', '1', '\r'}, kRequest, {}, "family"},
  });
}
