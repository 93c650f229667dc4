// Frame: the framer's output contract — a run of ByteEvents believed to be one telegram, or a
// run of noise bytes that fit no telegram (never dropped silently).
#pragma once

#include <algorithm>
#include <cstdint>
#include <span>
#include <vector>

#include "core/byte_event.hpp"
#include "core/byte_events.hpp"

namespace drivetap {

// Why the framer ended the frame where it did.
enum class FrameClose : std::uint8_t {
  silence,       // followed by >= t3.5 of silence (the Modbus rule), or the timing chunk ended
  content,       // split from following bytes with no visible silence, by length and checksum
  end_of_input,  // the capture ended
};

enum class FrameKind : std::uint8_t { telegram, noise };

struct Frame {
  // User-provided (not `= default`): a framer makes a Frame per telegram with emplace_back(), and
  // value-initialising an implicitly constructible Frame zero-fills all of it first (a `rep stos`
  // that took a sixth of the framer's time) before the members' initialisers run anyway.
  Frame() noexcept {}  // NOLINT(modernize-use-equals-default)
  // A frame whose events start as `storage` (a framer's recycled storage, see Framer::recycle).
  explicit Frame(ByteEvents&& storage) noexcept : events(std::move(storage)) {}

  FrameKind kind = FrameKind::telegram;
  ChannelId channel = 0;
  ByteEvents events;
  // Silence before the first byte, ns (from the previous byte's end on this channel);
  // -1 when nothing came before it.
  TimeNs gap_before = -1;
  FrameClose close = FrameClose::silence;
  // Largest silence between two consecutive bytes of this frame, and the byte it preceded.
  TimeNs max_intra_gap = 0;
  std::uint32_t max_intra_gap_at = 0;
  // Sequence number in the capture (1-based, over telegrams and noise alike), set by the pipeline.
  std::uint64_t number = 0;

  [[nodiscard]] TimeNs start() const { return events.empty() ? 0 : events.front_time(); }
  [[nodiscard]] std::size_t size() const { return events.size(); }
  // A copy of the bytes (events.bytes() is the same without the copy).
  [[nodiscard]] std::vector<std::uint8_t> bytes() const {
    return {events.bytes().begin(), events.bytes().end()};
  }
};

// The timing of a run of bytes, kept as they arrive: the end of the latest byte (a byte ends one
// character time after its start bit) and the largest silence between two consecutive bytes.
struct ByteRunTiming {
  TimeNs end = 0;
  TimeNs max_gap = 0;
  std::uint32_t max_gap_at = 0;  // index in the run of the byte the largest silence preceded

  void start(TimeNs time, TimeNs character_time) {
    end = time + character_time;
    max_gap = 0;
    max_gap_at = 0;
  }
  // Byte `index` (> 0) of the run, starting at `time`.
  void add(TimeNs time, std::size_t index, TimeNs character_time) {
    const TimeNs gap = time - end;
    if (gap > max_gap) {
      max_gap = gap;
      max_gap_at = static_cast<std::uint32_t>(index);
    }
    end = std::max(end, time + character_time);
  }
  // Bytes index .. index + count - 1 (index > 0), byte index + j starting at first + j * step:
  // the same as add() of each. Evenly spaced bytes that start after everything before them has
  // ended (nearly all) take one step: each follows its predecessor's end by step - character time.
  void add_stretch(TimeNs first, TimeNs step, std::size_t index, std::size_t count,
                   TimeNs character_time) {
    if (count == 0) return;
    add(first, index, character_time);
    if (count >= 2 && step >= 0 && end == first + character_time) {
      const TimeNs gap = step - character_time;
      if (gap > max_gap) {
        max_gap = gap;
        max_gap_at = static_cast<std::uint32_t>(index + 1);
      }
      end = first + static_cast<TimeNs>(count - 1) * step + character_time;
      return;
    }
    for (std::size_t j = 1; j < count; ++j)
      add(first + static_cast<TimeNs>(j) * step, index + j, character_time);
  }
};

// Fills a frame's timing from `run`, the timing of its events: silence before it (from
// `*previous_end`, the end of the previous record on its channel, when `*have_previous`) and the
// largest silence inside it. Updates *previous_end / *have_previous for the next record.
inline void stamp_frame_timing(Frame& f, const ByteRunTiming& run, TimeNs* previous_end,
                               bool* have_previous) {
  if (f.events.empty()) return;
  if (*have_previous) f.gap_before = std::max<TimeNs>(0, f.events.front_time() - *previous_end);
  f.max_intra_gap = run.max_gap;
  f.max_intra_gap_at = run.max_gap_at;
  *previous_end = *have_previous ? std::max(*previous_end, run.end) : run.end;
  *have_previous = true;
}

// The timing of `events` as ByteRunTiming would keep it if they arrived one by one; a stretch of
// evenly spaced bytes that starts after everything before it has ended costs one step.
inline ByteRunTiming timing_of(const ByteEvents& events, TimeNs character_time) {
  ByteRunTiming run;
  const std::span<const ByteEvents::Stretch> stretches = events.stretches();
  for (std::size_t k = 0; k < stretches.size(); ++k) {
    const ByteEvents::Stretch& s = stretches[k];
    const std::size_t count =
        (k + 1 < stretches.size() ? stretches[k + 1].index : events.size()) - s.index;
    if (k == 0) {
      run.start(s.first, character_time);
      run.add_stretch(s.first + s.step, s.step, 1, count - 1, character_time);
    } else {
      run.add_stretch(s.first, s.step, s.index, count, character_time);
    }
  }
  return run;
}

// The same, the run's timing computed from the frame's events. Shared by every framer.
inline void stamp_frame_timing(Frame& f, TimeNs character_time, TimeNs* previous_end,
                               bool* have_previous) {
  if (f.events.empty()) return;
  stamp_frame_timing(f, timing_of(f.events, character_time), previous_end, have_previous);
}

}  // namespace drivetap
