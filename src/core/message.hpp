// Message: a frame decoded by a dissector — protocol, direction, field tree with byte spans and
// the checksum verdict. Dissectors fill it; they never print.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "core/anomaly.hpp"
#include "core/checksum.hpp"
#include "core/drive_values.hpp"
#include "core/field.hpp"
#include "core/frame.hpp"
#include "core/protocol_desc.hpp"

namespace drivetap {

struct DriveProfile;  // drive/profile.hpp

enum class Direction : std::uint8_t { unknown, request, response };

std::string_view direction_id(Direction d);  // "request" / "response" / "unknown"

struct Message {
  Frame frame;
  std::vector<std::uint8_t> bytes;  // frame.events' bytes, for dissectors and sinks
  Protocol protocol = Protocol::unknown;
  Direction direction = Direction::unknown;
  int address = -1;   // station address, -1 when none
  int function = -1;  // function code as on the wire (with the exception bit), -1 when none
  bool is_exception = false;
  int exception_code = -1;
  ChecksumResult checksum;
  // The frame spells its bytes as hex text (Modbus ASCII): `bytes` fields show their characters.
  bool text_encoded = false;
  FieldTree fields;
  // The decode in one line, like Wireshark's Info column: "Read Holding Registers 0x0000 x4".
  std::string info;
  // What the frame means to its drive, from the bound drive profile; empty when none is bound.
  std::string drive_info;
  // Set instead of drive_info when the sink writes the annotation on a thread of its own
  // (SinkNeeds::drive_info: the ThreadedSink's writer): the profile that reads the frame.
  // complete_drive_info() (drive/annotate.hpp) turns it into drive_info.
  const DriveProfile* drive_profile = nullptr;
  // With drive_profile, for a reply: the bytes of the request it answers, empty when none.
  std::vector<std::uint8_t> request;
  // The profile the frame was read with (drive_info made or to make), nullptr when none: the
  // family of the `drive.*` record fields below.
  const DriveProfile* drive_read_with = nullptr;
  // With drive_read_with: the values the pipeline's drive level read of the frame, in the order
  // the `drive.*` fields give them (collect_drive_values(), drive/drive_fields.hpp).
  std::vector<DriveValue> drive_values;
  // Findings about this frame (checksum, gaps, malformed content, UART errors), in byte order.
  std::vector<Anomaly> anomalies;
  // Filled by the pairing stage on responses: request end -> response start, ns; -1 when
  // unpaired or not measurable (no silence visible before the reply).
  TimeNs latency = -1;
  std::uint64_t request_number = 0;  // frame number of the paired request
  // False where the source found that the capture's times carry no inter-frame silence
  // (FramingTiming::silences_trusted): the latency is hidden for that reason.
  bool silences_trusted = true;
  // False when the run prints no per-frame decode (`read --stats`): `fields` and `info` stay
  // empty; keys, direction, checksum verdict and anomalies are those of a full decode.
  bool detail = true;
  // False when no sink reads the field tree (text output without -V, pcapng): `fields` stay
  // empty while `info` is still made when `detail`.
  bool tree = true;
  // False when no sink reads the info line or the drive annotation (a display filter that reads
  // only the field tree): `info` and `drive_info` stay empty while `fields` are made with
  // `detail` and `tree`.
  bool info_text = true;

  // Sets `info` to make() when the message is decoded in detail with its info line; make() is
  // not called otherwise (formatting is most of the cost of a decode).
  template <class MakeText>
  void describe(MakeText&& make) {
    if (detail && info_text) info = make();
  }
};

// What the drive level reads of a telegram (DriveBinder, read_for_drive_into(), DriveTimeline,
// the profiles' timing rules): a Message's head, which the pipeline also has for a telegram it
// dissects to its head only (from the decoder's TelegramFindings). `bytes` are the Message's
// (as on the wire); `latency` is set once the telegram is paired.
struct TelegramHead {
  Protocol protocol = Protocol::unknown;
  Direction direction = Direction::unknown;
  int address = -1;
  ChecksumVerdict verdict = ChecksumVerdict::none;
  // False when the telegram breaks a plausibility rule of its protocol (an `implausible`
  // finding): then it is no good telegram, whatever its checksum.
  bool plausible = true;
  std::span<const std::uint8_t> bytes;
  TimeNs start = 0;      // the first byte's time
  TimeNs last_byte = 0;  // the last byte's time
  ChannelId channel = 0;
  std::uint64_t number = 0;
  TimeNs gap_before = -1;
  TimeNs latency = -1;
};

// A telegram's function as pairing matches a reply to its request: the code as on the wire (with
// the exception bit), -1 when none, and the exception a reply reports. Both a telegram dissected
// to its head only (TelegramFindings) and what pairing reads of it (PairingInput) carry it.
struct TelegramFunction {
  int function = -1;
  bool is_exception = false;
  int exception_code = -1;
};

// A good telegram: its checksum is good and it keeps its protocol's plausibility rules.
inline bool good_telegram(const TelegramHead& h) {
  return h.verdict == ChecksumVerdict::good && h.plausible;
}

inline TelegramHead head_of(const Message& m) {
  TelegramHead h;
  h.protocol = m.protocol;
  h.direction = m.direction;
  h.address = m.address;
  h.verdict = m.checksum.verdict;
  h.plausible = true;
  for (const Anomaly& a : m.anomalies)
    if (a.kind == AnomalyKind::implausible) h.plausible = false;
  h.bytes = m.bytes;
  h.start = m.frame.start();
  h.last_byte = m.frame.events.back_time();  // (0 for a frame of no bytes)
  h.channel = m.frame.channel;
  h.number = m.frame.number;
  h.gap_before = m.frame.gap_before;
  h.latency = m.latency;
  return h;
}

inline constexpr std::size_t kTypicalFieldCount = 16;

// What every dissector starts from: `m` reset to the frame, its bytes, protocol and direction.
// The vectors and strings `m` held keep their storage (the pipeline decodes every frame of a run
// into one Message, so the hot path does not allocate); `m.detail`, `m.tree` and `m.info_text` are
// kept. The frame is swapped in: `frame` is left holding m's previous frame, whose storage its
// batch builds a later frame in. `frame` may be m.frame itself, built in place
// (TelegramView::frame_for()): it is then taken as it is.
inline void begin_message(Message& m, Frame&& frame, Protocol protocol, Direction direction) {
  // Every member of Message is set here (tests/test_pipeline.cpp BeginMessageResetsEveryMember).
  // (A frame just built is not moved: its members, read back wider than they were written, would
  // stall the move on store forwarding; and a swap with itself would lose its events.)
  if (&frame != &m.frame) std::swap(m.frame, frame);
  m.bytes.assign(m.frame.events.bytes().begin(), m.frame.events.bytes().end());
  m.protocol = protocol;
  m.direction = direction;
  m.address = -1;
  m.function = -1;
  m.is_exception = false;
  m.exception_code = -1;
  m.checksum = ChecksumResult{};
  m.text_encoded = false;
  m.fields.clear();
  if (m.detail && m.tree)
    m.fields.reserve(kTypicalFieldCount);  // one allocation, not a doubling series
  m.info.clear();
  m.drive_info.clear();
  m.drive_profile = nullptr;
  m.request.clear();
  m.drive_read_with = nullptr;
  m.drive_values.clear();
  m.anomalies.clear();
  m.latency = -1;
  m.request_number = 0;
  m.silences_trusted = true;
}

// Puts the finding for a bad or byte-swapped checksum first among the message's anomalies:
// "CRC on wire DA 27, computed DA 26" (+ `hint`); nothing for a good or absent checksum.
void add_checksum_anomaly(Message& m, std::string_view hint = "");

}  // namespace drivetap
