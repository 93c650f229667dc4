// DriveRecords: what one telegram says to or of its drive, in no protocol's terms — registers,
// coils and parameters read or written, exception replies, process data words, run commands,
// readiness and fault reports. Each protocol's folder reads its telegrams into them
// (ProtocolDecoder::read_drive_records(), dissectors/<protocol>/drive_reading.cpp); the drive
// level (src/drive: annotation, timeline, binding) reads only these, with the drive's profile
// (dissectors/profiles/README.md) saying what each address means.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <utility>
#include <vector>

namespace drivetap {

// The address spaces a drive profile names. running: a running value (an index of values the
// drive reports, such as Easydrive's command 0B); parameter: a drive parameter keyed by its wire
// number under the profile's ParameterRule (drive/profile.hpp).
enum class RegisterKind : std::uint8_t { holding, input, coil, discrete, running, parameter };

// What a telegram does with the addresses of an access record.
enum class AccessOp : std::uint8_t {
  read,     // a request to read `count` addresses from `first`
  write,    // a request to write `values` from `first` (`count`: the addresses it names)
  value,    // a reply with the `values` from `first`
  refused,  // a reply refusing the access: values[0] is the drive's error number
  text,     // a request or reply about the address's text, not its value
  other,    // an access the reader does not describe further (only its address counts)
};

// A run command the master sends (a protocol's run control), with what it commands.
enum class RunCommand : std::uint8_t {
  setpoint,  // a new setpoint alone
  run,
  run_forward,
  run_reverse,
  stop,
  fault_reset,
  emergency_stop,
};

enum class DriveRecordType : std::uint8_t {
  access,         // kind, op, first, count, values
  exception,      // a reply refusing the request: `code`, the exception code
  process_words,  // cyclic process data: values[i] is word i of the telegram's direction, which
                  // the profile maps to registers (DriveProfile::pcd_to_drive, pcd_from_drive)
  command,        // `command`; values[0], if any, the setpoint it carries, read as the setpoint
                  // register of space `kind`
  status_query,   // a request for the drive's state
  readiness,      // a reply saying whether the drive is ready: `code` 1 ready, 0 not ready
  fault,          // the drive's current fault code, `code` (0: no fault)
};

struct DriveRecord {
  DriveRecordType type = DriveRecordType::access;
  RegisterKind kind = RegisterKind::holding;
  AccessOp op = AccessOp::read;
  RunCommand command = RunCommand::setpoint;
  bool double_word = false;  // access: values[0] is one 32-bit value (not a 16-bit word)
  bool permanent = false;    // write: to non-volatile memory as well
  // The address is the request's: the reply does not carry it. A parameter such a reply's
  // profile does not name is left to the frame line.
  bool addressed_by_request = false;
  // Whether drive binding weighs the address (a protocol's reader may leave it out).
  bool weighed = true;
  std::uint32_t first = 0;                       // access: the first address
  std::uint32_t count = 0;                       // access: how many addresses the telegram names
  std::uint32_t code = 0;                        // exception, readiness, fault
  std::uint32_t values_at = 0, values_size = 0;  // in DriveRecords::values
};

// The records of one telegram, in the order the telegram carries them. Kept from one telegram
// to the next (clear() keeps the storage): the pipeline reads every frame.
struct DriveRecords {
  std::vector<DriveRecord> records;
  std::vector<std::uint32_t> values;  // the records' values, each record's in one run
  // A function code for the profile's list of accepted ones (DriveProfile::functions); -1: none.
  int function = -1;
  // The telegram's protocol is spoken only by the drive families whose profiles list it (not by
  // every device, as Modbus is): a request in it is evidence for each of them.
  bool family_protocol = false;
  // A reply whose values are not the ones its request asked for (a register count other than
  // the request's quantity, another parameter or index than the request's): read, shown, and not
  // used (no value, state, event or binding evidence comes of it). `asked`: what the request
  // asked for, as the = line names it ("2" registers, "parameter 16-14", "index 0002").
  bool not_the_answer = false;
  std::string asked;
  // A reply read without a request it answers (none seen, or that request's time ran out): what
  // it says is shown, and not used, as a reply that is not the answer (set by the drive level's
  // reader, src/drive/records.hpp, for every protocol).
  bool request_unseen = false;
  // A reader's working storage (Modbus ASCII: the bytes its hex spells, frame and request).
  std::vector<std::uint8_t> scratch, request_scratch;

  void not_the_answer_of(std::string asked_for) {
    not_the_answer = true;
    asked = std::move(asked_for);
  }
  void clear() {
    records.clear();
    values.clear();
    function = -1;
    family_protocol = false;
    not_the_answer = false;
    asked.clear();
    request_unseen = false;
  }
  [[nodiscard]] std::span<const std::uint32_t> values_of(const DriveRecord& r) const {
    return std::span<const std::uint32_t>(values).subspan(r.values_at, r.values_size);
  }
  // A record of `type`, its values to be appended with add_value() right after.
  DriveRecord& add(DriveRecordType type) {
    DriveRecord& r = records.emplace_back();
    r.type = type;
    r.values_at = static_cast<std::uint32_t>(values.size());
    return r;
  }
  // An access record of `kind` at `first`.
  DriveRecord& add_access(RegisterKind kind, AccessOp op, std::uint32_t first,
                          std::uint32_t count = 1) {
    DriveRecord& r = add(DriveRecordType::access);
    r.kind = kind;
    r.op = op;
    r.first = first;
    r.count = count;
    return r;
  }
  // Appends a value to the last record added.
  void add_value(std::uint32_t value) {
    values.push_back(value);
    ++records.back().values_size;
  }
  // Room for `n` more values of `r`, the last record added (to be written, all of them).
  std::uint32_t* add_values(DriveRecord& r, std::size_t n) {
    const std::size_t at = values.size();
    values.resize(at + n);
    r.values_size += static_cast<std::uint32_t>(n);
    return values.data() + at;
  }
};

}  // namespace drivetap
