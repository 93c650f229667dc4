// Danfoss FC protocol telegrams as drive records (core/drive_records.hpp; PROTOCOLS.md §4):
//   STX LGE ADR [PKE IND PWEhigh PWElow] PCD1 PCD2 BCC        (LGE 6: PCD only; 14: with PKE)
//   PKE = AK(4 bits) PNU(12 bits); PCD1/PCD2 = CTW/REF to the drive, STW/MAV from it.
// The parameter block is a parameter access (AK: what it does), PCD1/PCD2 the process words.
#include "dissectors/danfoss_fc/fc_dissector.hpp"

namespace drivetap::danfoss_fc {
namespace {

std::uint16_t be16(std::span<const std::uint8_t> b, std::size_t at) {
  return static_cast<std::uint16_t>((b[at] << 8) | b[at + 1]);
}

// The parameter block's access (`to_drive`: a request's AK, else a reply's); none for AK 0.
void add_parameter_access(std::span<const std::uint8_t> b, bool to_drive, DriveRecords& out) {
  const std::uint16_t pke = be16(b, 3);
  const unsigned ak = pke >> 12;
  if (ak == 0) return;
  const std::uint32_t pnu = pke & 0x0FFF;
  const std::uint32_t pwe = static_cast<std::uint32_t>(be16(b, 7)) << 16 | be16(b, 9);
  AccessOp op = AccessOp::other;
  bool double_word = false;
  if (to_drive) {
    switch (ak) {
      case 0x1:
        op = AccessOp::read;
        break;
      case 0x2:
      case 0xE:
      case 0x3:
      case 0xD:
        op = AccessOp::write;
        double_word = ak == 0x3 || ak == 0xD;
        break;
      case 0xF:
        op = AccessOp::text;
        break;
      default:
        break;
    }
  } else {
    switch (ak) {
      case 0x1:
      case 0x2:
        op = AccessOp::value;
        double_word = ak == 0x2;
        break;
      case 0x7:
        op = AccessOp::refused;
        break;
      case 0xF:
        op = AccessOp::text;
        break;
      default:
        break;
    }
  }
  DriveRecord& r = out.add_access(RegisterKind::parameter, op, pnu);
  r.double_word = double_word;
  r.permanent = to_drive && ak >= 0xD;  // D, E: RAM and EEPROM
  if (op == AccessOp::write || op == AccessOp::value || op == AccessOp::refused)
    out.add_value(double_word ? pwe : (pwe & 0xFFFF));
}

}  // namespace

void FcDecoder::read_drive_records(const TelegramHead& telegram,
                                   std::span<const std::uint8_t> request, DriveRecords& out) const {
  (void)request;  // replies stand on their own
  out.clear();
  out.family_protocol = true;
  const std::span<const std::uint8_t> b = telegram.bytes;
  if (b.size() < 4 || b[0] != 0x02) return;
  const std::size_t lge = b[1];
  if (b.size() != lge + 2 || (lge != 6 && lge != 14)) return;
  if (telegram.direction == Direction::unknown) return;
  if (lge == 14) add_parameter_access(b, telegram.direction == Direction::request, out);
  out.add(DriveRecordType::process_words);
  const std::size_t at = lge == 14 ? 11 : 3;
  out.add_value(be16(b, at));
  out.add_value(be16(b, at + 2));
}

}  // namespace drivetap::danfoss_fc
