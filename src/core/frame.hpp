// Frame: the framer's output contract — a run of ByteEvents believed to be one telegram, or a
// run of noise bytes that fit no telegram (never dropped silently).
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <span>
#include <stdexcept>
#include <utility>
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

// Which checksum a framer computed over a frame's bytes while cutting it (Frame::checksum).
enum class FrameChecksum : std::uint8_t {
  none,          // none computed: a dissector computes its own
  crc16_modbus,  // crc16_modbus() over all bytes but the last two (Modbus RTU)
};

// Storage kept for reuse (a FrameBatch's frames, the frames of a ThreadedSink's records) is kept
// only up to this many bytes a frame; beyond, it is freed. The longest Modbus RTU telegram sent
// back to back holds under 1 KiB, a hundred bytes stamped in pairs about 2 KiB (stamped one by
// one, about 4 KiB: at the bound, maybe freed and made again at each reuse); 4 KiB of noise
// stamped in pairs holds some 70 KiB, which a thousand slots kept would make a run's memory grow
// far past its frames' (a run's memory should stay flat).
inline constexpr std::size_t kKeptStorageBytes = 4096;

struct Frame {
  // User-provided (not `= default`): a FrameBatch makes a Frame with emplace_back(), and
  // value-initialising an implicitly constructible Frame zero-fills all of it first (a `rep stos`
  // that took a sixth of the framer's time) before the members' initialisers run anyway.
  Frame() noexcept {}  // NOLINT(modernize-use-equals-default)

  FrameKind kind = FrameKind::telegram;
  ChannelId channel = 0;
  ByteEvents events;
  // Silence before the first byte, ns (from the previous byte's end on this channel);
  // -1 when nothing came before it.
  TimeNs gap_before = -1;
  FrameClose close = FrameClose::silence;
  // The checksum the framer computed over exactly these bytes, of kind checksum_kind (none: it
  // computed none), so that the dissector of that checksum need not compute it again.
  FrameChecksum checksum_kind = FrameChecksum::none;
  // Largest silence between two consecutive bytes of this frame, and the byte it preceded.
  TimeNs max_intra_gap = 0;
  std::uint32_t max_intra_gap_at = 0;
  std::uint32_t checksum = 0;  // of kind checksum_kind
  // Sequence number in the capture (1-based, over telegrams and noise alike), set by the pipeline.
  std::uint64_t number = 0;

  [[nodiscard]] TimeNs start() const { return events.empty() ? 0 : events.front_time(); }
  [[nodiscard]] std::size_t size() const { return events.size(); }
  // Heap bytes held, used or not (kKeptStorageBytes).
  [[nodiscard]] std::size_t storage_bytes() const { return events.storage_bytes(); }
  // A copy of the bytes (events.bytes() is the same without the copy).
  [[nodiscard]] std::vector<std::uint8_t> bytes() const {
    return {events.bytes().begin(), events.bytes().end()};
  }
  // Every member as in a new Frame, the events emptied but keeping their storage.
  void reset_keeping_storage() {
    kind = FrameKind::telegram;
    channel = 0;
    events.clear();
    gap_before = -1;
    close = FrameClose::silence;
    checksum_kind = FrameChecksum::none;
    max_intra_gap = 0;
    max_intra_gap_at = 0;
    checksum = 0;
    number = 0;
  }
};

// reset_keeping_storage() sets each member (tests/test_frame_batch.cpp checks each one against a
// new Frame's). This size check catches a new member that grows Frame on the 64-bit targets built
// here, not one that fits in its padding (some 10 bytes are left): such a member must be added to
// reset_keeping_storage() and to that test by hand.
static_assert(sizeof(void*) != 8 || sizeof(Frame) == 128,
              "Frame changed: update Frame::reset_keeping_storage() and this size");

// The frames a framer hands on, a batch at a time. It reads like a std::vector<Frame>, but
// clear() keeps the frames it held, each with its events' storage (up to kKeptStorageBytes a
// frame, of the first kKeptFrames frames), and add() builds the next frame in the place of an old
// one: a framer emitting a frame into a batch used before allocates nothing. (A consumer that
// wants a frame's storage to stay in the batch swaps with it rather than moving it out.)
class FrameBatch {
 public:
  using iterator = std::vector<Frame>::iterator;
  using const_iterator = std::vector<Frame>::const_iterator;

  FrameBatch() = default;
  // Moved from, a batch is empty (not a size over no frames); copies are not made.
  FrameBatch(FrameBatch&& other) noexcept
      : frames_(std::move(other.frames_)), size_(std::exchange(other.size_, 0)) {}
  FrameBatch& operator=(FrameBatch&& other) noexcept {
    frames_ = std::move(other.frames_);
    size_ = std::exchange(other.size_, 0);
    return *this;
  }

  [[nodiscard]] std::size_t size() const { return size_; }
  [[nodiscard]] bool empty() const { return size_ == 0; }
  [[nodiscard]] Frame& operator[](std::size_t i) { return frames_[i]; }
  [[nodiscard]] const Frame& operator[](std::size_t i) const { return frames_[i]; }
  [[nodiscard]] const Frame& at(std::size_t i) const {
    if (i >= size_) throw std::out_of_range("FrameBatch::at");
    return frames_[i];
  }
  [[nodiscard]] Frame& back() { return frames_[size_ - 1]; }
  [[nodiscard]] const Frame& back() const { return frames_[size_ - 1]; }
  [[nodiscard]] iterator begin() { return frames_.begin(); }
  [[nodiscard]] iterator end() { return frames_.begin() + static_cast<std::ptrdiff_t>(size_); }
  [[nodiscard]] const_iterator begin() const { return frames_.begin(); }
  [[nodiscard]] const_iterator end() const {
    return frames_.begin() + static_cast<std::ptrdiff_t>(size_);
  }

  // A new frame at the end, as a new Frame but for its events' storage (an old frame's).
  Frame& add() {
    if (size_ == frames_.size()) {
      ++size_;
      return frames_.emplace_back();
    }
    Frame& f = frames_[size_++];
    f.reset_keeping_storage();
    return f;
  }
  // The same, a frame of `channel` of this kind, closed for this reason (what a framer emits).
  Frame& add(FrameKind kind, ChannelId channel, FrameClose close) {
    Frame& f = add();
    f.kind = kind;
    f.channel = channel;
    f.close = close;
    return f;
  }
  // Forgets the frames, keeping their storage: of the first kKeptFrames (a batch that once held
  // many frames of a big read does not keep them all), and of those holding no more than
  // kKeptStorageBytes (the frames past size() were looked at when they were last cleared).
  void clear() {
    for (std::size_t i = 0; i < size_; ++i)
      if (frames_[i].storage_bytes() > kKeptStorageBytes) frames_[i] = Frame{};
    size_ = 0;
    if (frames_.size() > kKeptFrames) frames_.resize(kKeptFrames);
  }
  void swap(FrameBatch& other) noexcept {
    frames_.swap(other.frames_);
    std::swap(size_, other.size_);
  }
  // The frames as a vector (moved out; the batch is left empty).
  [[nodiscard]] std::vector<Frame> take() {
    std::vector<Frame> frames;
    frames.swap(frames_);
    frames.resize(size_);
    size_ = 0;
    return frames;
  }

  // A push() of 4096 bytes of short telegrams makes some 300 frames.
  static constexpr std::size_t kKeptFrames = 1024;

 private:
  std::vector<Frame> frames_;  // [0, size_) are the batch; the rest keep storage for add()
  std::size_t size_ = 0;
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

// A frame's timing members (Frame::gap_before, max_intra_gap, max_intra_gap_at).
struct FrameTiming {
  TimeNs gap_before = -1;
  TimeNs max_intra_gap = 0;
  std::uint32_t max_intra_gap_at = 0;
};

// The timing of a record whose first byte starts at `first` and whose bytes' timing is `run`:
// silence before it (from `*previous_end`, the end of the previous record on its channel, when
// `*have_previous`) and the largest silence inside it. Updates *previous_end / *have_previous
// for the next record.
inline FrameTiming stamp_timing(TimeNs first, const ByteRunTiming& run, TimeNs* previous_end,
                                bool* have_previous) {
  FrameTiming t;
  if (*have_previous) t.gap_before = std::max<TimeNs>(0, first - *previous_end);
  t.max_intra_gap = run.max_gap;
  t.max_intra_gap_at = run.max_gap_at;
  *previous_end = *have_previous ? std::max(*previous_end, run.end) : run.end;
  *have_previous = true;
  return t;
}

// The same into a frame, from `run`, the timing of its events.
inline void stamp_frame_timing(Frame& f, const ByteRunTiming& run, TimeNs* previous_end,
                               bool* have_previous) {
  if (f.events.empty()) return;
  const FrameTiming t = stamp_timing(f.events.front_time(), run, previous_end, have_previous);
  if (t.gap_before >= 0) f.gap_before = t.gap_before;
  f.max_intra_gap = t.max_intra_gap;
  f.max_intra_gap_at = t.max_intra_gap_at;
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
