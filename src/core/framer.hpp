// Framer: the ByteEvent -> Frame stage contract shared by every protocol's framer.
//
// A framer sees the bytes of one channel in time order and emits Frames (telegrams and noise)
// that cover every byte exactly once, in order. It may hold bytes while a frame is incomplete;
// advance() tells it that time has passed with no byte, finish() that the input ended. Frames are
// appended to a FrameBatch (frame.hpp) with FrameBatch::add(), in the storage of the frames the
// batch held before: a caller that clears the batch and uses it again makes framing allocate
// nothing in the steady state.
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
  // Adds one byte; frames it completes are appended to `out`.
  virtual void push(const ByteEvent& event, FrameBatch& out) = 0;
  // Adds bytes in order: exactly the frames of push() on each in turn. Framers that can take a
  // run of bytes at once (no virtual call, no decision per byte) override it.
  virtual void push_all(std::span<const ByteEvent> events, FrameBatch& out) {
    for (const ByteEvent& e : events) push(e, out);
  }
  // Adds a run of bytes (one source packet): exactly the frames of push() of each of its bytes
  // in turn. Framers that can append a run without a decision per byte override it.
  virtual void push_run(const ByteRun& run, FrameBatch& out) {
    for (std::size_t i = 0; i < run.size(); ++i) push(run.event(i), out);
  }
  // push_run(run), then a byte at next_time, when that byte would only make the framer emit the
  // run as one frame (nothing else pending, a silence > t3.5 between, the run a good telegram):
  // emits that frame now and returns true. Otherwise returns false and changes nothing; the
  // caller pushes the run as usual. The byte at next_time is not pushed. (A caller that knows
  // what comes next, a batch of runs or of events, saves holding and re-reading the bytes.)
  virtual bool push_chunk(const ByteRun& run, TimeNs next_time, FrameBatch& out) {
    (void)run;
    (void)next_time;
    (void)out;
    return false;
  }
  // What push_chunk() would write into the frame it emits besides the run's events (the frame
  // is a telegram of the run's channel, closed by silence).
  struct ChunkFrame {
    FrameTiming timing;
    FrameChecksum checksum_kind = FrameChecksum::none;
    std::uint32_t checksum = 0;
  };
  // push_chunk() without the frame: when push_chunk() would emit the run as one frame, changes
  // the framer's state as it would, fills *taken and returns true; otherwise returns false and
  // changes nothing. For a caller that needs no Frame of the run (the pipeline's summary lane).
  // A framer that overrides push_chunk() overrides this too (the caller does not try both).
  // `precheck`: the run's, made by the decoder whose framer this is (TelegramPrecheck), or
  // nullptr; its check of the bytes is then not made again.
  virtual bool take_chunk(const ByteRun& run, TimeNs next_time, ChunkFrame* taken,
                          const TelegramPrecheck* precheck = nullptr) {
    (void)run;
    (void)next_time;
    (void)taken;
    (void)precheck;
    return false;
  }
  // Time has reached `now`; closes what silence or a hold limit has completed.
  virtual void advance(TimeNs now, FrameBatch& out) = 0;
  // End of input: everything pending becomes frames or noise.
  virtual void finish(FrameBatch& out) = 0;
  // Earliest time at which advance() can produce something; max() when nothing is pending.
  [[nodiscard]] virtual TimeNs next_deadline() const = 0;
  // How many more bytes with no silence > t3.5 before them push() surely takes without closing
  // anything (it holds them until silence, the hold limit or finish()). The pipeline appends
  // such runs with push_all() in one go. 0 (the default): no promise, byte by byte.
  [[nodiscard]] virtual std::size_t quiet_room() const { return 0; }
};

// `f` made the frame push_chunk() of the framer of `channel` emits for `run` when take_chunk()
// gave `taken`: a telegram closed by silence, its events the run's (f's storage is kept).
inline void add_chunk_frame_into(Frame& f, ChannelId channel, const ByteRun& run,
                                 const Framer::ChunkFrame& taken) {
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
inline Frame& add_chunk_frame(FrameBatch& out, ChannelId channel, const ByteRun& run,
                              const Framer::ChunkFrame& taken) {
  Frame& f = out.add();
  add_chunk_frame_into(f, channel, run, taken);
  return f;
}

}  // namespace drivetap
