// ProtocolDecoder: what the pipeline needs of each protocol — a framer, the directions a frame's
// layout allows, and the dissector (Frame -> Message). One implementation per protocol under
// dissectors/<protocol>/, named by its descriptor (core/protocol_desc.hpp,
// dissectors/registry.cpp).
#pragma once

#include <memory>
#include <span>
#include <string_view>
#include <vector>

#include "core/framer.hpp"
#include "core/message.hpp"
#include "core/precheck.hpp"
#include "core/serial_config.hpp"

namespace drivetap {

struct FramerSettings {
  FramingTiming timing;
  TimeNs max_hold = 100 * kNsPerMs;
};

class ProtocolDecoder {
 public:
  virtual ~ProtocolDecoder() = default;
  [[nodiscard]] virtual Protocol protocol() const = 0;
  [[nodiscard]] virtual std::unique_ptr<Framer> make_framer(ChannelId channel,
                                                            const FramerSettings& s) const = 0;
  // Which directions the frame's layout agrees with (length fields, function codes).
  [[nodiscard]] virtual DirectionFit direction_fit(std::span<const std::uint8_t> frame) const = 0;
  // True when the frame can only be a reply (e.g. a Modbus exception).
  [[nodiscard]] virtual bool always_response(std::span<const std::uint8_t> frame) const = 0;
  // False when the frame looks like garbage rather than a telegram of this protocol: with no
  // layout fitting either direction, such a frame gets direction `unknown` and is not paired.
  [[nodiscard]] virtual bool recognisable(std::span<const std::uint8_t> frame) const = 0;
  // Station address and function code of a frame, the keys that pair a reply with its request
  // (-1 where the frame or the protocol has none). Must agree with dissect()'s Message fields.
  struct PairingKeys {
    int address = -1;
    int function = -1;
  };
  [[nodiscard]] virtual PairingKeys pairing_keys(std::span<const std::uint8_t> frame) const = 0;
  // Decodes the frame into `out` (reusing its storage, honouring out.detail); `frame` is left
  // holding out's previous frame, storage and all (so a FrameBatch keeps it for its next frame).
  // Message::address/function are the pairing keys (function -1: none). `request`: for a
  // reply, the bytes of the request it answers (empty when unknown), for protocols whose
  // replies mean nothing without it.
  virtual void dissect_into(Message& out, Frame&& frame, Direction direction,
                            const FramingTiming& timing,
                            std::span<const std::uint8_t> request = {}) const = 0;
  // Whether dissect_into() reads `request` at all: a caller that would look the request up for
  // it alone (the pipeline's summary lane) leaves it out when not.
  [[nodiscard]] virtual bool reads_request() const { return false; }
  // The same into a new Message, decoded in detail.
  [[nodiscard]] Message dissect(Frame frame, Direction direction, const FramingTiming& timing,
                                std::span<const std::uint8_t> request = {}) const {
    Message m;
    dissect_into(m, std::move(frame), direction, timing, request);
    return m;
  }
  // What the closing summary takes of a telegram that its framer took whole (Framer::take_chunk)
  // and that nobody reads in detail (the pipeline's summary lane): what dissect_into() would give
  // the Message (its checksum verdict, pairing members and anomalies), without building one.
  struct TelegramSummary {
    ChecksumVerdict verdict = ChecksumVerdict::none;
    int address = -1;
    int function = -1;
    bool is_exception = false;
    int exception_code = -1;
    std::size_t malformed = 0;      // `malformed` anomalies (a telegram may break several rules)
    std::uint32_t other_kinds = 0;  // bit k: one anomaly of AnomalyKind k, besides those
  };
  static_assert(kAnomalyKindCount <= 32, "TelegramSummary::other_kinds has a bit per kind");
  // Fills *out for `bytes`, a telegram travelling in `direction` that its framer took whole as
  // `taken` (so with no UART marks); false when the protocol has no such summary (its telegrams
  // are then dissected as usual). `precheck`: this decoder's precheck() of the bytes, or nullptr.
  virtual bool summarise(std::span<const std::uint8_t> bytes, Direction direction,
                         const Framer::ChunkFrame& taken, const FramingTiming& timing,
                         const TelegramPrecheck* precheck, TelegramSummary* out) const {
    (void)bytes;
    (void)direction;
    (void)taken;
    (void)timing;
    (void)precheck;
    (void)out;
    return false;
  }
  // Fills *out with what this protocol's framer and summary find in `bytes` taken as one
  // telegram (TelegramPrecheck; out->decoder is left to the caller), made on the read-ahead
  // thread from the bytes alone; false when the protocol makes none.
  virtual bool precheck(std::span<const std::uint8_t> bytes, TelegramPrecheck* out) const {
    (void)bytes;
    (void)out;
    return false;
  }
};

// A telegram the pipeline counted without decoding it (its summary lane: a run its framer took
// whole, Framer::take_chunk), for a sink that decodes it itself (Sink::completes_decode()): what
// only the pipeline knows of it. Spans are valid for the call that hands it over.
struct UndissectedTelegram {
  const ProtocolDecoder* decoder = nullptr;
  FramingTiming timing;      // the run's, which the decoder judges gaps by
  ByteRun run;               // the telegram's bytes and times (no UART marks)
  Framer::ChunkFrame taken;  // its timing and carried checksum
  std::uint64_t number = 0;  // the frame's number
  Direction direction = Direction::unknown;
  TimeNs latency = -1;  // pairing, for a reply
  std::uint64_t request_number = 0;
  std::span<const std::uint8_t> request;  // for a reply: the request it answers, if known
  // With drive profiles: the profile whose annotation the sink writes (Message::drive_profile,
  // Sink::completes_drive_info()), nullptr for none; and what the pipeline found of the
  // telegram's timing under the profile's rules, numbered with the frame, which follow the
  // decode's own anomalies.
  const DriveProfile* drive_profile = nullptr;
  std::span<const Anomaly> anomalies;
};

// What the pipeline would have handed over for `t` (handle_frame()): the Message its decoder
// makes of its frame, with the pipeline's numbers, pairing and drive-level findings, each anomaly
// numbered with the frame, and the profile whose annotation is still to write. `out`'s storage is
// reused: the frame is built in out.frame, which dissect_into() takes in place (begin_message()).
inline void decode_undissected(const UndissectedTelegram& t, Message& out) {
  add_chunk_frame_into(out.frame, t.run.channel, t.run, t.taken);
  out.frame.number = t.number;
  t.decoder->dissect_into(out, std::move(out.frame), t.direction, t.timing, t.request);
  out.latency = t.latency;
  out.request_number = t.request_number;
  for (Anomaly& a : out.anomalies) a.frame_number = t.number;
  if (!t.anomalies.empty())
    out.anomalies.insert(out.anomalies.end(), t.anomalies.begin(), t.anomalies.end());
  if (t.drive_profile) {
    out.drive_profile = t.drive_profile;
    out.request.assign(t.request.begin(), t.request.end());
  }
}

}  // namespace drivetap
