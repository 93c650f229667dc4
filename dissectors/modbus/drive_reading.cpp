// Modbus RTU and ASCII telegrams as drive records (core/drive_records.hpp; docs/protocols.md §2,
// §3): registers and coils read and written, exception replies. A reply is read with its request,
// which gives the addresses its values belong to.
#include <algorithm>

#include "dissectors/modbus/ascii_dissector.hpp"
#include "dissectors/modbus/rtu_dissector.hpp"

namespace drivetap::modbus {
namespace {

std::uint16_t be16(std::span<const std::uint8_t> b, std::size_t at) {
  return static_cast<std::uint16_t>((b[at] << 8) | b[at + 1]);
}

// The big-endian 16-bit words of b[from, end) as the values of `r`, the last record added.
void add_words(std::span<const std::uint8_t> b, std::size_t from, std::size_t end, DriveRecord& r,
               DriveRecords& out) {
  const std::size_t n = end > from ? (end - from) / 2 : 0;
  std::uint32_t* value = out.add_values(r, n);
  for (std::size_t k = 0; k < n; ++k) value[k] = be16(b, from + 2 * k);
}

// The bits of packed[] (least significant first), `count` at most, as the values of `r`.
void add_bits(std::span<const std::uint8_t> packed, std::size_t count, DriveRecord& r,
              DriveRecords& out) {
  const std::size_t n = std::min(count, packed.size() * 8);
  std::uint32_t* value = out.add_values(r, n);
  for (std::size_t i = 0; i < n; ++i) value[i] = (packed[i / 8] >> (i % 8)) & 1;
}

// `b`: the binary telegram (ADDR FC DATA... and `check_size` bytes of check); `q`: for a reply,
// its request's, empty when unknown.
void read_binary(std::span<const std::uint8_t> b, std::size_t check_size, Direction direction,
                 std::span<const std::uint8_t> q, DriveRecords& out) {
  out.clear();
  if (b.size() < 4) return;
  const std::uint8_t fc = b[1];
  out.function = fc & 0x7F;
  const std::size_t end = b.size() - check_size;
  if (fc & 0x80) {
    out.add(DriveRecordType::exception).code = b[2];
    return;
  }
  if (direction == Direction::request) {
    const std::uint16_t start = be16(b, 2);
    if ((fc == 0x03 || fc == 0x04) && end >= 6) {
      out.add_access(fc == 0x03 ? RegisterKind::holding : RegisterKind::input, AccessOp::read,
                     start, be16(b, 4));
    } else if ((fc == 0x01 || fc == 0x02) && end >= 6) {
      out.add_access(fc == 0x01 ? RegisterKind::coil : RegisterKind::discrete, AccessOp::read,
                     start, be16(b, 4));
    } else if (fc == 0x06 && end >= 6) {
      out.add_access(RegisterKind::holding, AccessOp::write, start);
      out.add_value(be16(b, 4));
    } else if (fc == 0x10 && end >= 7) {
      add_words(b, 7, end,
                out.add_access(RegisterKind::holding, AccessOp::write, start, be16(b, 4)), out);
    } else if (fc == 0x05 && end >= 6) {
      out.add_access(RegisterKind::coil, AccessOp::write, start);
      out.add_value(b[4] == 0xFF ? 1 : 0);
    } else if (fc == 0x0F && end >= 7) {
      const std::uint16_t count = be16(b, 4);
      add_bits(b.subspan(7, end - 7), count,
               out.add_access(RegisterKind::coil, AccessOp::write, start, count), out);
    }
    return;
  }
  if (direction != Direction::response || q.size() < 6 || q[1] != fc || end < 3) return;
  if (fc == 0x03 || fc == 0x04) {
    DriveRecord& r = out.add_access(fc == 0x03 ? RegisterKind::holding : RegisterKind::input,
                                    AccessOp::value, be16(q, 2), 0);
    r.addressed_by_request = true;
    add_words(b, 3, end, r, out);
    r.count = r.values_size;
    const std::uint16_t asked = be16(q, 4);
    if (r.values_size != asked) out.not_the_answer_of(std::to_string(asked));
  } else if (fc == 0x01 || fc == 0x02) {
    // (Replies to 0x02 are read against the coils, as the drive level always read them: no
    // built-in profile names discrete inputs.)
    const std::uint16_t count = be16(q, 4);
    DriveRecord& r = out.add_access(RegisterKind::coil, AccessOp::value, be16(q, 2), count);
    r.addressed_by_request = true;
    add_bits(b.subspan(3, end - 3), count, r, out);
    if (end - 3 != (std::size_t{count} + 7) / 8) out.not_the_answer_of(std::to_string(count));
  }
}

}  // namespace

void read_rtu_drive_records(const TelegramHead& telegram, std::span<const std::uint8_t> request,
                            DriveRecords& out) {
  read_binary(telegram.bytes, 2, telegram.direction, request, out);
}

void read_ascii_drive_records(const TelegramHead& telegram, std::span<const std::uint8_t> request,
                              DriveRecords& out) {
  // The binary the hex spells, in the records' working storage (kept from frame to frame).
  spell_ascii_hex(telegram.bytes, out.scratch, nullptr);
  out.request_scratch.clear();
  if (!request.empty()) spell_ascii_hex(request, out.request_scratch, nullptr);
  read_binary(out.scratch, 1, telegram.direction, out.request_scratch, out);
}

}  // namespace drivetap::modbus
