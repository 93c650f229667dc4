// Framer: the ByteEvent -> Frame stage contract shared by every protocol's framer.
//
// A framer sees the bytes of one channel in time order (push) and emits Frames (telegrams and
// noise) that cover every byte exactly once, in order. It may hold bytes while a frame is
// incomplete; advance() tells it that time has passed with no byte, finish() that the input ended,
// next_deadline() when advance() can next close something. push() stops right after the byte that
// closed a frame, so a caller can act on that frame (perhaps replacing the framer) before the next
// byte. One optional fast take (take_whole) lets a caller that knows a run is followed by silence
// have it taken as one telegram. Frames are appended to a FrameBatch (frame.hpp) with
// FrameBatch::add(), in the storage of the frames the batch held before: a caller that clears the
// batch and uses it again makes framing allocate nothing in the steady state.
#pragma once

#include <span>
#include <vector>

#include "core/byte_event.hpp"
#include "core/byte_events.hpp"
#include "core/frame.hpp"
#include "core/time.hpp"

namespace drivetap {

class Framer {
 public:
  virtual ~Framer() = default;
  // Adds bytes in order, exactly as adding each in turn would, and returns how many it took: all
  // of them, or fewer when frames closed (by content, a size limit or the silence before a
  // byte): it stops right after the byte that closed them, or right before the byte whose
  // silence closed them. Bytes that close nothing are appended in bulk.
  // Time alone closes nothing until t3.5 after the end of the last byte pushed: bytes that
  // follow each other that closely need no advance() between them.
  virtual std::size_t push(std::span<const ByteEvent> events, FrameBatch& out) = 0;
  // The same for a run of bytes (one source packet). Framers that can append a run without a
  // decision per byte override it.
  virtual std::size_t push(const ByteRun& run, FrameBatch& out) {
    return push_each(run.size(), out, [&](std::size_t i) { push(run.event(i), out); });
  }
  // One byte.
  void push(const ByteEvent& event, FrameBatch& out) { push(std::span(&event, 1), out); }
  // All of the bytes, whatever frames they close (for a caller that acts on frames afterwards).
  void push_all(std::span<const ByteEvent> events, FrameBatch& out) {
    while (!events.empty()) events = events.subspan(push(events, out));
  }
  void push_all(const ByteRun& run, FrameBatch& out) {
    for (std::size_t i = 0; i < run.size();) i += push(run.part(i, run.size() - i), out);
  }
  // Time has reached `now`; closes what silence or a hold limit has completed.
  virtual void advance(TimeNs now, FrameBatch& out) = 0;
  // End of input: everything pending becomes frames or noise.
  virtual void finish(FrameBatch& out) = 0;
  // Earliest time at which advance() can produce something; max() when nothing is pending.
  [[nodiscard]] virtual TimeNs next_deadline() const = 0;

  // The optional fast take. What a frame taken whole carries besides the run's events (a
  // telegram of the run's channel, closed by silence): its timing and the checksum the framer
  // computed over it.
  struct WholeFrame {
    FrameTiming timing;
    FrameChecksum checksum_kind = FrameChecksum::none;
    std::uint32_t checksum = 0;
  };
  // push(run), then a byte at next_time, when that byte would only make the framer emit the run
  // as one frame (nothing else pending, a silence > t3.5 between, the run a good telegram):
  // changes the framer's state as that would, fills *taken and returns true; the frame itself
  // is add_whole_frame() of the run and *taken, made by the caller if it needs one. Otherwise
  // returns false and changes nothing. The byte at next_time is not pushed. `precheck`: the
  // run's, made by the decoder whose framer this is (TelegramPrecheck), or nullptr; its check
  // of the bytes is then not made again. By default no run is taken whole.
  virtual bool take_whole(const ByteRun& run, TimeNs next_time, WholeFrame* taken,
                          const TelegramPrecheck* precheck = nullptr) {
    (void)run;
    (void)next_time;
    (void)taken;
    (void)precheck;
    return false;
  }

 protected:
  // push() of `count` bytes as push_one(i) of each, stopping right after one that closed frames.
  template <class PushOne>
  static std::size_t push_each(std::size_t count, const FrameBatch& out, PushOne push_one) {
    const std::size_t frames_before = out.size();
    for (std::size_t i = 0; i < count; ++i) {
      push_one(i);
      if (out.size() != frames_before) return i + 1;
    }
    return count;
  }
};

// `f` made the frame of the framer of `channel` for `run` taken whole as `taken`
// (Framer::take_whole): a telegram closed by silence, its events the run's (f's storage is kept).
inline void add_whole_frame_into(Frame& f, ChannelId channel, const ByteRun& run,
                                 const Framer::WholeFrame& taken) {
  f.reset_keeping_storage();
  f.channel = channel;
  f.events.append_run(run);
  f.checksum_kind = taken.checksum_kind;
  f.checksum = taken.checksum;
  f.gap_before = taken.timing.gap_before;
  f.max_intra_gap = taken.timing.max_intra_gap;
  f.max_intra_gap_at = taken.timing.max_intra_gap_at;
}

// The same appended to `out`.
inline Frame& add_whole_frame(FrameBatch& out, ChannelId channel, const ByteRun& run,
                              const Framer::WholeFrame& taken) {
  Frame& f = out.add();
  add_whole_frame_into(f, channel, run, taken);
  return f;
}

}  // namespace drivetap
