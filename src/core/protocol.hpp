// ProtocolDecoder: what the pipeline needs of each protocol — a framer, the directions a frame's
// layout allows, and one dissection (a telegram -> its head, or a Message in detail), with the
// read-ahead thread's precheck of the framer's fast take. One implementation per protocol under
// dissectors/<protocol>/, named by its descriptor (core/protocol_desc.hpp,
// dissectors/registry.cpp).
#pragma once

#include <memory>
#include <span>
#include <string_view>
#include <vector>

#include "core/drive_records.hpp"
#include "core/framer.hpp"
#include "core/message.hpp"
#include "core/precheck.hpp"
#include "core/serial_config.hpp"

namespace drivetap {

struct FramerSettings {
  FramingTiming timing;
  TimeNs max_hold = 100 * kNsPerMs;
};

// How far dissect() goes.
enum class DissectDepth {
  head,    // the keys, checksum verdict and findings (TelegramFindings), no Message
  detail,  // the Message, as detailed as Message::detail and Message::tree ask
  fields,  // the Message's field tree alone, with what a node's value reads (bytes, encoding)
};

// What dissect() to DissectDepth::head gives of a telegram: what the Message would say of its
// checksum, pairing keys and findings, without building one.
struct TelegramFindings : TelegramFunction {
  ChecksumVerdict verdict = ChecksumVerdict::none;
  int address = -1;
  std::size_t malformed = 0;      // `malformed` findings (a telegram may break several rules)
  std::uint32_t other_kinds = 0;  // bit k: one finding of AnomalyKind k, besides those
};
static_assert(kAnomalyKindCount <= 32, "TelegramFindings::other_kinds has a bit per kind");

// A telegram as its framer cut it, light: the framer's Frame, or the run the framer took whole
// (Framer::take_whole) with what it carried (timing, checksum) and, when the read-ahead thread
// made one, the run's precheck. dissect() builds a Frame of a run only when it needs one.
struct TelegramView {
  Frame* frame = nullptr;  // nullptr: taken whole
  ByteRun run;
  Framer::WholeFrame taken;
  const TelegramPrecheck* precheck = nullptr;  // of the decoder that dissects it, or nullptr
  // A dissection to the head found that the telegram keeps its protocol's plausibility rules
  // (a telegram handed over undecoded): a dissection in detail may take that as its own verdict.
  bool known_plausible = false;

  [[nodiscard]] std::span<const std::uint8_t> bytes() const {
    return frame ? frame->events.bytes() : run.bytes;
  }
  // The telegram as a Frame, for a dissector that builds a Message in `out`: the framer's, or
  // made in out.frame from the run (dissectors take their frame from out.frame in place).
  [[nodiscard]] Frame&& frame_for(Message& out) {
    if (frame) return std::move(*frame);
    add_whole_frame_into(out.frame, run.channel, run, taken);
    return std::move(out.frame);
  }
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
  // False when `frame`, whose layout fits both directions, cannot be the reply to `request`
  // (Danfoss FC: a drive answers in its request's telegram type, process data alone or with a
  // parameter block): order alone would take it for the awaited reply.
  [[nodiscard]] virtual bool could_answer(std::span<const std::uint8_t> frame,
                                          std::span<const std::uint8_t> request) const {
    (void)frame;
    (void)request;
    return true;
  }
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
  // The one dissection of a telegram travelling in `direction`, to `depth`:
  // - DissectDepth::detail: decodes it into `out` (reusing its storage, honouring out.detail and
  //   out.tree) and returns true. Message::address/function are the pairing keys (function -1:
  //   none). The telegram's frame is moved into `out` (t.frame then holds out's previous frame,
  //   storage and all, so a FrameBatch keeps it for its next frame), or made there from the run
  //   it was taken whole from.
  // - DissectDepth::head: fills only *head (keys, checksum verdict, findings counted by kind:
  //   what the closing summary, pairing and the drive level read) and returns false, leaving
  //   `out` alone; a protocol with no such reading of the telegram dissects in detail instead
  //   (returns true). The findings are exactly those the detail dissection would make.
  // - DissectDepth::fields: makes only out.fields (the nodes of the ids it keeps), out.bytes and
  //   out.text_encoded, the nodes those of the detail dissection, and returns true: the tree a
  //   reader of field values looks into (the display filter's, for ids no head holds). The rest
  //   of `out` is left as it was. A protocol with no such reading dissects in detail instead.
  // `request`: for a reply, the bytes of the request it answers (empty when unknown), for
  // protocols whose replies mean nothing without it.
  virtual bool dissect(TelegramView& t, Direction direction, const FramingTiming& timing,
                       std::span<const std::uint8_t> request, DissectDepth depth, Message& out,
                       TelegramFindings* head) const = 0;
  // dissect() of a Frame in detail into `out`.
  void dissect_into(Message& out, Frame&& frame, Direction direction, const FramingTiming& timing,
                    std::span<const std::uint8_t> request = {}) const {
    TelegramView t;
    t.frame = &frame;
    dissect(t, direction, timing, request, DissectDepth::detail, out, nullptr);
  }
  // What the telegram says to or of its drive (core/drive_records.hpp), for the drive level:
  // `out` is cleared and filled, its storage reused. `request`: for a reply, the bytes of the
  // request it answers (empty when unknown). A protocol with nothing for drives leaves it empty.
  virtual void read_drive_records(const TelegramHead& telegram,
                                  std::span<const std::uint8_t> request, DriveRecords& out) const {
    (void)telegram;
    (void)request;
    out.clear();
  }
  // The same into a new Message, decoded in detail.
  [[nodiscard]] Message dissect(Frame frame, Direction direction, const FramingTiming& timing,
                                std::span<const std::uint8_t> request = {}) const {
    Message m;
    dissect_into(m, std::move(frame), direction, timing, request);
    return m;
  }
  // Fills *out with what the fast take (Framer::take_whole) of this protocol's framer and
  // dissect() to DissectDepth::head find in `bytes` taken as one telegram (TelegramPrecheck;
  // out->decoder is left to the caller), made on the read-ahead thread from the bytes alone;
  // false when the protocol makes none.
  virtual bool precheck(std::span<const std::uint8_t> bytes, TelegramPrecheck* out) const {
    (void)bytes;
    (void)out;
    return false;
  }
};

}  // namespace drivetap
