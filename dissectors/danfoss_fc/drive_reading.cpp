// Danfoss FC protocol telegrams as drive records (core/drive_records.hpp; docs/protocols.md §4):
//   STX LGE ADR [PKE IND PWEhigh PWElow] PCD1 PCD2 BCC        (LGE 6: PCD only; 14: with PKE)
//   PKE = AK(4 bits) PNU(12 bits); PCD1/PCD2 = CTW/REF to the drive, STW/MAV from it.
// The parameter block is a parameter access (AK: what it does), PCD1/PCD2 the process words. A
// reply is read with its request only to see that it answers it (the same parameter).
#include "dissectors/danfoss_fc/fc_dissector.hpp"

namespace drivetap::danfoss_fc {
namespace {

std::uint16_t be16(std::span<const std::uint8_t> b, std::size_t at) {
  return static_cast<std::uint16_t>((b[at] << 8) | b[at + 1]);
}

// What each AK means (docs/protocols.md §4), to the drive (requests) and from it (replies); an AK
// not listed is an access of no known meaning (AccessOp::other).
struct AkMeaning {
  bool to_drive;
  unsigned ak;
  AccessOp op;
  bool double_word;
};
constexpr AkMeaning kAkMeanings[] = {
    {true, 0x1, AccessOp::read, false},     {true, 0x2, AccessOp::write, false},
    {true, 0xE, AccessOp::write, false},    {true, 0x3, AccessOp::write, true},
    {true, 0xD, AccessOp::write, true},     {true, 0xF, AccessOp::text, false},
    {false, 0x1, AccessOp::value, false},   {false, 0x2, AccessOp::value, true},
    {false, 0x7, AccessOp::refused, false}, {false, 0xF, AccessOp::text, false},
};

// The parameter block's access (`to_drive`: a request's AK, else a reply's); none for AK 0.
void add_parameter_access(std::span<const std::uint8_t> b, bool to_drive, DriveRecords& out) {
  const std::uint16_t pke = be16(b, 3);
  const unsigned ak = pke >> 12;
  if (ak == 0) return;
  const std::uint32_t pnu = pke & 0x0FFF;
  const std::uint32_t pwe = static_cast<std::uint32_t>(be16(b, 7)) << 16 | be16(b, 9);
  AkMeaning meaning{to_drive, ak, AccessOp::other, false};
  for (const AkMeaning& m : kAkMeanings)
    if (m.to_drive == to_drive && m.ak == ak) meaning = m;
  DriveRecord& r = out.add_access(RegisterKind::parameter, meaning.op, pnu);
  r.double_word = meaning.double_word;
  r.permanent = meaning.op == AccessOp::write && ak >= 0xD;  // D, E: RAM and EEPROM
  if (meaning.op == AccessOp::write || meaning.op == AccessOp::value ||
      meaning.op == AccessOp::refused)
    out.add_value(meaning.double_word ? pwe : (pwe & 0xFFFF));
}

// A reply's parameter block answers its request's when both name a parameter (AK not 0) and it is
// the same PNU (the drive echoes it, docs/protocols.md §4): a value or refusal of another
// parameter is not that request's answer.
void check_answer(std::span<const std::uint8_t> reply, std::span<const std::uint8_t> request,
                  DriveRecords& out) {
  if (request.size() != 16 || request[0] != kStxByte || request[1] != 14) return;
  const std::uint16_t asked = be16(request, 3), answered = be16(reply, 3);
  if ((asked >> 12) == 0 || (answered >> 12) == 0) return;
  if ((asked & 0x0FFF) != (answered & 0x0FFF))
    out.not_the_answer_of("parameter " + parameter_name(asked & 0x0FFF));
}

}  // namespace

void read_fc_drive_records(const TelegramHead& telegram, std::span<const std::uint8_t> request,
                           DriveRecords& out) {
  out.clear();
  out.family_protocol = true;
  const std::span<const std::uint8_t> b = telegram.bytes;
  if (b.size() < 4 || b[0] != 0x02) return;
  const std::size_t lge = b[1];
  if (b.size() != lge + 2 || (lge != 6 && lge != 14)) return;
  if (telegram.direction == Direction::unknown) return;
  const bool to_drive = telegram.direction == Direction::request;
  if (lge == 14) {
    add_parameter_access(b, to_drive, out);
    if (!to_drive) check_answer(b, request, out);
  }
  out.add(DriveRecordType::process_words);
  const std::size_t at = lge == 14 ? 11 : 3;
  out.add_value(be16(b, at));
  out.add_value(be16(b, at + 2));
}

}  // namespace drivetap::danfoss_fc
