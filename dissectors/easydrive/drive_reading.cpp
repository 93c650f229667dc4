// Easydrive telegrams as drive records (core/drive_records.hpp; docs/protocols.md §5), ASCII hex
// between '~' and CR:
//   request  ~ AA CC IIII [DDDD] SSSS CR     (CC command 0A..0F, IIII index)
//   reply    ~ AA RR FF II [DDDD] SSSS CR    (RR response code, FF current fault, II index low)
// A reply is read with its request: its command and index say what the reply's data is. Binding
// has never weighed Easydrive's indexes (the protocol alone tells the family): `weighed` false.
#include "dissectors/easydrive/eds_dissector.hpp"

#include <fmt/format.h>

namespace drivetap::easydrive {
namespace {

// Run control (001, command "0C"): what each index commands; `with_setpoint`: its data field is
// the new setpoint (a frequency, read as the profile's running value of that role).
struct RunAction {
  long index;
  RunCommand command;
  bool with_setpoint;
};
constexpr RunAction kRunActions[] = {
    {0x1, RunCommand::setpoint, true},        {0x2, RunCommand::run, true},
    {0x3, RunCommand::run_forward, false},    {0x4, RunCommand::run_reverse, false},
    {0x5, RunCommand::run_forward, true},     {0x6, RunCommand::run_reverse, true},
    {0x7, RunCommand::stop, false},           {0xC, RunCommand::fault_reset, false},
    {0xE, RunCommand::emergency_stop, false},
};

DriveRecord& add_access(RegisterKind kind, AccessOp op, long index, DriveRecords& out) {
  DriveRecord& r = out.add_access(kind, op, static_cast<std::uint32_t>(index));
  r.weighed = false;
  return r;
}

void read_request(long command, long index, long data, DriveRecords& out) {
  switch (command) {
    case 0x0A:
      out.add(DriveRecordType::status_query);
      break;
    case 0x0B:
      add_access(RegisterKind::running, AccessOp::read, index, out);
      break;
    case 0x0C:
      for (const RunAction& action : kRunActions) {
        if (action.index != index) continue;
        DriveRecord& r = out.add(DriveRecordType::command);
        r.command = action.command;
        r.kind = RegisterKind::running;
        if (action.with_setpoint && data >= 0) out.add_value(static_cast<std::uint32_t>(data));
      }
      break;
    case 0x0D:
      add_access(RegisterKind::parameter, AccessOp::read, index, out);
      break;
    case 0x0E:
      if (data >= 0) {
        add_access(RegisterKind::parameter, AccessOp::write, index, out);
        out.add_value(static_cast<std::uint32_t>(data));
      }
      break;
    default:
      break;
  }
}

}  // namespace

void read_eds_drive_records(const TelegramHead& telegram, std::span<const std::uint8_t> request,
                            DriveRecords& out) {
  out.clear();
  out.family_protocol = true;
  const std::span<const std::uint8_t> f = telegram.bytes;
  if (f.size() != 14 && f.size() != 18) return;
  const long data = f.size() == 18 ? hex_field(f, 9, 4) : -1;
  if (telegram.direction == Direction::request) {
    const long command = hex_field(f, 3, 2), index = hex_field(f, 5, 4);
    if (command >= 0 && index >= 0) read_request(command, index, data, out);
    return;
  }
  if (telegram.direction != Direction::response) return;
  const long code = hex_field(f, 3, 2), fault = hex_field(f, 5, 2);
  if (code == 0x20 || code == 0x30) return;  // rejected: the frame line names the reason
  const long command = hex_field(request, 3, 2), index = hex_field(request, 5, 4);
  // The drive echoes the low byte of the request's index (docs/protocols.md §5): a reply that
  // echoes another is not that request's answer.
  if (const long echoed = hex_field(f, 7, 2); index >= 0 && echoed >= 0 && echoed != (index & 0xFF))
    out.not_the_answer_of(fmt::format("index {:04X}", index));
  if ((command == 0x0B || command == 0x0D) && index >= 0 && data >= 0) {
    add_access(command == 0x0B ? RegisterKind::running : RegisterKind::parameter, AccessOp::value,
               index, out)
        .addressed_by_request = true;
    out.add_value(static_cast<std::uint32_t>(data));
  } else if (command == 0x0A && code >= 0x10 && code <= 0x14) {
    out.add(DriveRecordType::readiness).code = code == 0x10 ? 0 : 1;
  }
  // Every accepted reply carries the drive's current fault code (001, AUX of the reply).
  if (fault >= 0) out.add(DriveRecordType::fault).code = static_cast<std::uint32_t>(fault);
}

}  // namespace drivetap::easydrive
