// Frame: the framer's output contract — a run of ByteEvents believed to be one telegram, or a
// run of noise bytes that fit no telegram (never dropped silently).
#pragma once

#include <algorithm>
#include <cstdint>
#include <span>
#include <vector>

#include "core/byte_event.hpp"

namespace drivetap {

// Why the framer ended the frame where it did.
enum class FrameClose : std::uint8_t {
  silence,       // followed by >= t3.5 of silence (the Modbus rule), or the timing chunk ended
  content,       // split from following bytes with no visible silence, by length and checksum
  end_of_input,  // the capture ended
};

enum class FrameKind : std::uint8_t { telegram, noise };

struct Frame {
  FrameKind kind = FrameKind::telegram;
  ChannelId channel = 0;
  std::vector<ByteEvent> events;
  // Silence before the first byte, ns (from the previous byte's end on this channel);
  // -1 when nothing came before it.
  TimeNs gap_before = -1;
  FrameClose close = FrameClose::silence;
  // Largest silence between two consecutive bytes of this frame, and the byte it preceded.
  TimeNs max_intra_gap = 0;
  std::uint32_t max_intra_gap_at = 0;
  // Sequence number in the capture (1-based, over telegrams and noise alike), set by the pipeline.
  std::uint64_t number = 0;

  [[nodiscard]] TimeNs start() const { return events.empty() ? 0 : events.front().time; }
  [[nodiscard]] std::size_t size() const { return events.size(); }
  [[nodiscard]] std::vector<std::uint8_t> bytes() const {
    std::vector<std::uint8_t> out;
    out.reserve(events.size());
    for (const ByteEvent& e : events) out.push_back(e.byte);
    return out;
  }
};

// Fills a frame's timing from its events: silence before it (from `*previous_end`, the end of
// the previous record on its channel, when `*have_previous`) and the largest silence inside it.
// Updates *previous_end / *have_previous for the next record. Shared by every framer.
inline void stamp_frame_timing(Frame& f, TimeNs character_time, TimeNs* previous_end,
                               bool* have_previous) {
  if (f.events.empty()) return;
  if (*have_previous) f.gap_before = std::max<TimeNs>(0, f.events.front().time - *previous_end);
  TimeNs end = f.events.front().time + character_time;
  for (std::size_t i = 1; i < f.events.size(); ++i) {
    const TimeNs gap = f.events[i].time - end;
    if (gap > f.max_intra_gap) {
      f.max_intra_gap = gap;
      f.max_intra_gap_at = static_cast<std::uint32_t>(i);
    }
    end = std::max(end, f.events[i].time + character_time);
  }
  *previous_end = *have_previous ? std::max(*previous_end, end) : end;
  *have_previous = true;
}

}  // namespace drivetap
