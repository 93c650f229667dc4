// Hybrid framer: silence proposes boundaries, content confirms them (docs/protocols.md §1).
// Used for the binary protocols with a length rule and a checksum: Modbus RTU (rules in
// dissectors/modbus/rtu_framer.hpp) and the Danfoss FC protocol (dissectors/danfoss_fc/).
//
// Contract: ByteEvents of one channel, in time order -> Frames (telegrams and noise) covering
// every byte exactly once, in order.
//
// How boundaries are decided, in order of preference at each position:
//   1. A frame whose length, predicted from its function code (either direction), ends in a good
//      (or byte-swapped) CRC. Such a frame may span silences (a USB adapter delivering one frame
//      in two bursts) and may be followed by the next frame with no silence at all (bursts,
//      or one timestamp for a whole read).
//   2. A run of bytes between two silences > t3.5 ("timing chunk") whose CRC is good, whatever
//      its function code.
//   3. An incomplete frame at the end of the bytes seen so far is held for the next bytes
//      (up to max_hold) instead of being closed at a silence; also one whose other layout ends
//      at the silence with a bad CRC (a reply cut where a request would end).
//   4. A predicted length with a bad CRC, when the frame ends exactly at a silence (> t1.5) or
//      right where a good frame begins.
//   5. Bytes before the next good frame inside a timing chunk are noise.
//   6. A timing chunk with no good frame in it is one bad-CRC frame (>= 4 bytes, mostly free of
//      UART errors) or noise.
// Memory is bounded: without silence the buffer is segmented every `pressure_bytes`, keeping at
// most one frame's worth of undecided bytes.
#pragma once

#include <cstdint>
#include <functional>
#include <limits>
#include <span>
#include <vector>

#include "core/byte_event.hpp"
#include "core/frame.hpp"
#include "core/framer.hpp"
#include "core/serial_config.hpp"

namespace drivetap {

struct HybridFramerOptions {
  FramingTiming timing;
  // Longest time an incomplete frame waits for the rest of its bytes after a silence.
  TimeNs max_hold = 100 * kNsPerMs;
  // Segment without waiting for silence once this many bytes are pending.
  std::size_t pressure_bytes = 4096;
};

// What a protocol tells the hybrid framer. All spans start at a candidate frame start and reach
// to the end of the bytes seen so far.
class HybridFrameRules {
 public:
  virtual ~HybridFrameRules() = default;
  [[nodiscard]] virtual std::size_t min_frame() const = 0;
  [[nodiscard]] virtual std::size_t max_frame() const = 0;
  // Up to two candidate total lengths (0 = none), e.g. request and reply layouts; *needs_more
  // when the length depends on bytes not seen yet.
  virtual void predicted_lengths(std::span<const std::uint8_t> from, std::size_t out[2],
                                 bool* needs_more) const = 0;
  // The frame's checksum holds (for Modbus RTU: also when its bytes are swapped).
  [[nodiscard]] virtual bool checksum_matches(std::span<const std::uint8_t> frame) const = 0;
  // checksum_matches(), also giving the checksum computed over the frame, of checksum_kind(), for
  // the frame to carry to its dissector (Frame::checksum). By default none is given.
  struct ChecksumCheck {
    bool matches = false;
    std::uint32_t computed = 0;
  };
  [[nodiscard]] virtual ChecksumCheck check_checksum(std::span<const std::uint8_t> frame) const {
    return {checksum_matches(frame), 0};
  }
  [[nodiscard]] virtual FrameChecksum checksum_kind() const { return FrameChecksum::none; }
  [[nodiscard]] virtual bool looks_like_frame_start(std::span<const std::uint8_t> from) const = 0;
  // For frames whose length rule is unknown: the shortest length with a valid checksum that
  // `accept` confirms, or 0. Protocols whose every frame has a length rule return 0.
  [[nodiscard]] virtual std::size_t scan_unknown_layout(
      std::span<const std::uint8_t> from, const std::function<bool(std::size_t)>& accept) const {
    (void)from;
    (void)accept;
    return 0;
  }
};

// good_frame_in(frame) == frame.size() of a hybrid framer with these rules: all of `frame` is a
// frame of a predicted length with a good checksum (no other length tried); *computed is that
// checksum (Rules::check_checksum()). On the bytes alone: the framer's check of a run taken whole
// (take_whole) and a decoder's precheck of it (TelegramPrecheck::whole_frame) are this one.
template <class Rules>
[[gnu::always_inline]] inline bool is_good_hybrid_frame(const Rules& rules,
                                                        std::span<const std::uint8_t> frame,
                                                        std::uint32_t* computed) {
  // good_frame_in() returns frame.size() exactly when that is one of the predicted lengths (it is
  // tried first then, or is the first of two) and its checksum matches: any other length it
  // tries is shorter.
  const std::size_t n = frame.size();
  if (n < rules.min_frame() || n > rules.max_frame()) return false;
  std::size_t candidates[2] = {0, 0};
  bool needs_more = false;
  rules.predicted_lengths(frame, candidates, &needs_more);
  if (candidates[0] != n && candidates[1] != n) return false;
  const HybridFrameRules::ChecksumCheck check = rules.check_checksum(frame);
  *computed = check.computed;
  return check.matches;
}

// `Rules` is a final HybridFrameRules: the framer asks it several questions per frame, and knowing
// the type turns those into direct (inlinable) calls. The member definitions are in
// hybrid_framer_impl.hpp, instantiated once per protocol in that protocol's framer source.
template <class Rules>
class HybridFramer final : public Framer {
 public:
  // `rules` must outlive the framer (decoders keep them as static objects).
  HybridFramer(ChannelId channel, HybridFramerOptions options, const Rules& rules);

  using Framer::push;
  // Adds bytes: those that close nothing (no silence before them, no pressure) are appended in
  // bulk, a run that is a whole frame between two silences is taken at once.
  std::size_t push(std::span<const ByteEvent> events, FrameBatch& out) override;
  // A run (a source packet): its first byte the single-byte way, the rest appended in bulk up to
  // the pressure mark.
  std::size_t push(const ByteRun& run, FrameBatch& out) override;
  // A run that is a whole frame between two silences, taken at once (see Framer::take_whole).
  bool take_whole(const ByteRun& run, TimeNs next_time, WholeFrame* taken,
                  const TelegramPrecheck* precheck = nullptr) override;
  // Time has reached `now` on the bus; closes what silence or the hold limit has completed.
  void advance(TimeNs now, FrameBatch& out) override;
  // End of input: everything pending becomes frames or noise.
  void finish(FrameBatch& out) override;
  // Earliest time at which advance() can produce something; max() when nothing is pending.
  [[nodiscard]] TimeNs next_deadline() const override;

 private:
  enum class Mode { silence, pressure, flush, end_of_input };
  // Bytes before the pressure mark: without silence, push() of each would only append it.
  [[nodiscard]] std::size_t room_before_pressure() const {
    return pending_.size() + 1 < options_.pressure_bytes
               ? options_.pressure_bytes - 1 - pending_.size()
               : 0;
  }
  // Adds one byte.
  void push_byte(const ByteEvent& event, FrameBatch& out);
  // take_whole(), the frame appended to `out`.
  bool push_whole(const ByteRun& run, TimeNs next_time, FrameBatch& out);
  void process(Mode mode, TimeNs now, FrameBatch& out);

  // Segmentation helpers over pending_.bytes()[0, n).
  bool checksum_matches(std::size_t p, std::size_t len) const;
  std::size_t good_frame_at(std::size_t p, std::size_t limit) const;  // 0 when none
  // The same over any bytes: the good frame at from[0] ending inside `from`, or 0.
  std::size_t good_frame_in(std::span<const std::uint8_t> from) const;
  std::size_t first_good_start(std::size_t from, std::size_t to) const;
  std::size_t next_hard_boundary(std::size_t p) const;
  bool is_hard_boundary(std::size_t index) const;
  TimeNs silence_before(std::size_t index) const;  // silence before byte `index`, ns
  bool looks_like_frame_start(std::size_t p) const;
  void predicted_lengths(std::size_t p, std::size_t n, std::size_t out[2], bool* needs_more) const;
  void predicted_lengths_in(std::span<const std::uint8_t> from, std::size_t out[2],
                            bool* needs_more) const;
  void emit(std::size_t p, std::size_t len, FrameKind kind, FrameClose close, FrameBatch& out);
  // Bytes [from, from + count) of `run` appended: none has a silence > t3.5 before it, and they
  // stay below the pressure mark (push() of each would only append it).
  [[gnu::always_inline]] void append_quietly(const ByteRun& run, std::size_t from,
                                             std::size_t count);

  ChannelId channel_;
  HybridFramerOptions options_;
  const Rules& rules_;
  ByteEvents pending_;  // its bytes() are what the rules read
  // Timing of pending_'s bytes as they arrived; while pending_run_whole_, it is that of exactly
  // the bytes in pending_ (none dropped since it started), so a frame of all of them needs no
  // second look at their times.
  ByteRunTiming pending_run_;
  bool pending_run_whole_ = false;
  std::vector<std::size_t> hard_;        // indices in pending_ preceded by silence > t3.5
  std::vector<std::uint8_t> run_bytes_;  // push(events): the bytes of the run being pushed
  TimeNs last_end_ = std::numeric_limits<TimeNs>::min();  // end of the latest byte pushed
  TimeNs emitted_end_ = -1;  // end of the last byte of the last emitted frame; -1 none yet
  bool have_emitted_ = false;
  bool processed_since_last_byte_ = false;
  static constexpr std::size_t kPendingReserve = 64;  // bytes
};

}  // namespace drivetap
