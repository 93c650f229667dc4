// ByteEvents: a sequence of ByteEvents stored compactly — the storage of a Frame's events and of
// a framer's pending bytes (docs/protocols.md §1; contract of ByteEvent in byte_event.hpp).
//
// It reads like a std::vector<ByteEvent> (size, [], front, back, iteration, push_back), but an
// element is made on demand from three parts:
//
//   bytes_:     | b0 | b1 | b2 | b3 | b4 | ... |           one byte per event, contiguous
//   stretches_: | {index 0, first t, step s, ch, origin} | {index 3, first u, ...} | ...
//   flags_:     empty (no UART mark anywhere), or one UART flag byte per event
//
// Event i lies in the last stretch whose index <= i and starts at first + (i - index) * step:
// bytes sent back to back (nearly all of them) take one stretch per run, not 16 bytes each, and
// a frame's bytes are a span its dissector reads as they are. A source that knows each byte's
// own time gives a stretch per byte at worst. Sequences are equal when their events are.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <initializer_list>
#include <iterator>
#include <span>
#include <vector>

#include "core/byte_event.hpp"
#include "core/precheck.hpp"

namespace drivetap {

// An event's UART flags, channel and source unit in one word (the 8 bytes after its time with the
// data byte masked off): two events with the same word differ at most in time and byte.
static_assert(sizeof(ByteEvent) == 16 && offsetof(ByteEvent, byte) == 8 &&
              offsetof(ByteEvent, flags) == 9 && offsetof(ByteEvent, channel) == 10 &&
              offsetof(ByteEvent, origin) == 12);
inline std::uint64_t event_tail(const ByteEvent& e) {
  std::uint64_t word;
  std::memcpy(&word, &e.byte, 8);
  return word & ~std::uint64_t{0xFF};
}

// How many events from events[0] one ByteRun can stand for: unmarked, of one channel and source
// unit, evenly spaced (*step; 0 for a single event). A marked first event stands alone.
// on_byte(k, byte) is called with each of the run's bytes in order as the scan passes it (a
// caller gathering them needs no second pass over the events).
template <class OnByte>
inline std::size_t scan_uniform_run(std::span<const ByteEvent> events, TimeNs* step,
                                    OnByte&& on_byte) {
  *step = 0;
  if (events.empty()) return 0;
  on_byte(std::size_t{0}, events[0].byte);
  if (events.size() < 2 || events[0].flags != 0) return 1;
  const std::uint64_t same = event_tail(events[0]);
  if (event_tail(events[1]) != same) return 1;
  on_byte(std::size_t{1}, events[1].byte);
  *step = events[1].time - events[0].time;  // |times| < 2^62: exact
  // Sums modulo 2^64: one past the int64 range cannot wrap onto a time inside kTimeLimit.
  const auto ustep = static_cast<std::uint64_t>(*step);
  std::uint64_t next = static_cast<std::uint64_t>(events[1].time) + ustep;
  std::size_t n = 2;
  // Two events a pass while two are left (one bound check for both), then the last one.
  auto belongs = [&](std::size_t k, std::uint64_t time) {
    return static_cast<std::uint64_t>(events[k].time) == time && event_tail(events[k]) == same;
  };
  while (events.size() - n >= 2) {
    if (!belongs(n, next)) return n;
    on_byte(n, events[n].byte);
    if (!belongs(n + 1, next + ustep)) return n + 1;
    on_byte(n + 1, events[n + 1].byte);
    next += 2 * ustep;
    n += 2;
  }
  if (n < events.size() && belongs(n, next)) {
    on_byte(n, events[n].byte);
    ++n;
  }
  return n;
}

// Bytes of one channel whose events are implied: byte i starts at first + i * step, comes from
// source unit `origin` and carries UART flags flags[i] (`flags` empty: none). What a source with
// packets hands on instead of a ByteEvent per byte (the ByteEvents are the same).
struct ByteRun {
  std::span<const std::uint8_t> bytes;
  TimeNs first = 0;
  TimeNs step = 0;
  ChannelId channel = 0;
  std::uint32_t origin = 0;
  std::span<const std::uint8_t> flags;

  [[nodiscard]] std::size_t size() const { return bytes.size(); }
  [[nodiscard]] TimeNs time(std::size_t i) const { return first + static_cast<TimeNs>(i) * step; }
  [[nodiscard]] ByteEvent event(std::size_t i) const {
    return {time(i), bytes[i], flags.empty() ? std::uint8_t{0} : flags[i], channel, origin};
  }
  // Bytes [from, from + count) as a run of their own.
  [[nodiscard]] ByteRun part(std::size_t from, std::size_t count) const {
    return {bytes.subspan(from, count),
            time(from),
            step,
            channel,
            origin,
            flags.empty() ? flags : flags.subspan(from, count)};
  }
};

// Evenly spaced bytes of one channel and source unit in a store of bytes, from its byte `index` to
// the next stretch's index (or the store's end): byte i starts at first + (i - index) * step. A
// RunBatch keeps each run as one, ByteEvents a frame's events as a few.
struct ByteStretch {
  std::uint32_t index = 0;
  std::uint32_t origin = 0;
  TimeNs first = 0;
  TimeNs step = 0;
  ChannelId channel = 0;

  [[nodiscard]] TimeNs time(std::size_t i) const {
    return first + static_cast<TimeNs>(i - index) * step;
  }
};

// Runs as a source hands them on, a packet or a read at a time (far below the 4 GiB a
// ByteStretch's index reaches): each run's bytes and flags copied into two buffers the batch
// keeps from use to use.
class RunBatch {
 public:
  [[nodiscard]] std::size_t size() const { return runs_.size(); }
  [[nodiscard]] bool empty() const { return runs_.empty(); }
  [[nodiscard]] std::size_t byte_count() const { return bytes_.size(); }
  [[nodiscard]] ByteRun operator[](std::size_t k) const {
    const Entry& e = runs_[k];
    const std::size_t count = (k + 1 < runs_.size() ? runs_[k + 1].index : bytes_.size()) - e.index;
    const std::span<const std::uint8_t> flags =
        e.flagged ? std::span<const std::uint8_t>(flags_).subspan(e.index, count)
                  : std::span<const std::uint8_t>();
    return {std::span<const std::uint8_t>(bytes_).subspan(e.index, count),
            e.first,
            e.step,
            e.channel,
            e.origin,
            flags};
  }
  [[nodiscard]] bool has_prechecks() const { return !prechecks_.empty(); }
  // What a decoder worked out of run k's bytes ahead (set_precheck()), or nullptr.
  [[nodiscard]] const TelegramPrecheck* precheck(std::size_t k) const {
    return k < prechecks_.size() && prechecks_[k].decoder ? &prechecks_[k] : nullptr;
  }
  void clear() {
    bytes_.clear();
    flags_.clear();
    runs_.clear();
    prechecks_.clear();
  }
  // Run k's precheck (k < size(); the read-ahead thread's, once the runs are in).
  void set_precheck(std::size_t k, const TelegramPrecheck& precheck) {
    if (prechecks_.size() < runs_.size()) prechecks_.resize(runs_.size());
    prechecks_[k] = precheck;
  }
  // (Inlined: once a packet in the capture readers' loops, as a profile-guided build has it.)
  [[gnu::always_inline]] void add(const ByteRun& run) {
    if (run.bytes.empty()) return;
    const bool flagged = !run.flags.empty();
    if (flagged || !flags_.empty()) flags_.resize(bytes_.size(), 0);
    runs_.push_back({{static_cast<std::uint32_t>(bytes_.size()), run.origin, run.first,
                      run.size() > 1 ? run.step : 0, run.channel},
                     flagged});
    bytes_.insert(bytes_.end(), run.bytes.begin(), run.bytes.end());
    if (flagged) flags_.insert(flags_.end(), run.flags.begin(), run.flags.end());
  }
  // Events given one by one: each stretch of evenly spaced bytes of one channel and source unit
  // becomes one run (the events read back are the same).
  void add_events(std::span<const ByteEvent> events);
  // The runs of `other` after these.
  void append(const RunBatch& other) {
    for (std::size_t k = 0; k < other.size(); ++k) add(other[k]);
  }

 private:
  struct Entry : ByteStretch {
    bool flagged = false;  // the run has UART flags: flags_ holds them, from index on
  };
  std::vector<std::uint8_t> bytes_;
  std::vector<std::uint8_t>
      flags_;  // empty, or one per byte of bytes_ (up to the last flagged run)
  std::vector<Entry> runs_;
  std::vector<TelegramPrecheck> prechecks_;  // empty, or one per run up to the last one set
};

class ByteEvents {
 public:
  using Stretch = ByteStretch;

  class const_iterator {
   public:
    using iterator_concept = std::random_access_iterator_tag;
    using iterator_category = std::input_iterator_tag;  // elements are made, not referenced
    using value_type = ByteEvent;
    using difference_type = std::ptrdiff_t;
    using reference = ByteEvent;
    using pointer = void;

    const_iterator() = default;
    const_iterator(const ByteEvents* seq, std::size_t i) : seq_(seq), i_(i) {
      if (seq_ && i_ < seq_->size()) k_ = seq_->stretch_of(i_);
    }
    ByteEvent operator*() const { return seq_->make(i_, k_); }
    ByteEvent operator[](difference_type n) const { return *(*this + n); }
    const_iterator& operator++() {
      ++i_;
      if (k_ + 1 < seq_->stretches_.size() && i_ >= seq_->stretches_[k_ + 1].index) ++k_;
      return *this;
    }
    const_iterator operator++(int) {
      const_iterator old = *this;
      ++*this;
      return old;
    }
    const_iterator& operator--() { return *this -= 1; }
    const_iterator operator--(int) {
      const_iterator old = *this;
      --*this;
      return old;
    }
    const_iterator& operator+=(difference_type n) {
      i_ = static_cast<std::size_t>(static_cast<difference_type>(i_) + n);
      if (i_ < seq_->size()) k_ = seq_->stretch_of(i_);
      return *this;
    }
    const_iterator& operator-=(difference_type n) { return *this += -n; }
    friend const_iterator operator+(const_iterator it, difference_type n) { return it += n; }
    friend const_iterator operator+(difference_type n, const_iterator it) { return it += n; }
    friend const_iterator operator-(const_iterator it, difference_type n) { return it -= n; }
    friend difference_type operator-(const const_iterator& a, const const_iterator& b) {
      return static_cast<difference_type>(a.i_) - static_cast<difference_type>(b.i_);
    }
    friend bool operator==(const const_iterator& a, const const_iterator& b) {
      return a.i_ == b.i_;
    }
    friend auto operator<=>(const const_iterator& a, const const_iterator& b) {
      return a.i_ <=> b.i_;
    }

   private:
    const ByteEvents* seq_ = nullptr;
    std::size_t i_ = 0;
    std::size_t k_ = 0;  // the stretch of event i_
  };
  using iterator = const_iterator;
  using value_type = ByteEvent;
  using size_type = std::size_t;

  ByteEvents() = default;
  ByteEvents(std::initializer_list<ByteEvent> events) { append(events); }
  explicit ByteEvents(std::span<const ByteEvent> events) { append(events); }
  ByteEvents& operator=(std::initializer_list<ByteEvent> events) {
    clear();
    append(events);
    return *this;
  }

  [[nodiscard]] std::size_t size() const { return bytes_.size(); }
  [[nodiscard]] bool empty() const { return bytes_.empty(); }
  // Room for this many bytes without growing (a FrameBatch keeps a frame's storage for the next).
  [[nodiscard]] std::size_t capacity() const { return bytes_.capacity(); }
  void reserve(std::size_t n) { bytes_.reserve(n); }
  // Heap bytes held, used or not: what keeping these events' storage for reuse costs. A frame of
  // bytes unevenly spaced (a time stamp each) holds some 17 bytes a byte (a stretch a pair).
  [[nodiscard]] std::size_t storage_bytes() const {
    return bytes_.capacity() + stretches_.capacity() * sizeof(Stretch) + flags_.capacity();
  }

  [[nodiscard]] ByteEvent operator[](std::size_t i) const { return make(i, stretch_of(i)); }
  [[nodiscard]] ByteEvent front() const { return make(0, 0); }
  [[nodiscard]] ByteEvent back() const { return make(size() - 1, stretches_.size() - 1); }
  [[nodiscard]] const_iterator begin() const { return {this, 0}; }
  [[nodiscard]] const_iterator end() const { return {this, size()}; }

  // The parts of event i without making all of it.
  [[nodiscard]] std::span<const std::uint8_t> bytes() const { return bytes_; }
  [[nodiscard]] std::uint8_t byte(std::size_t i) const { return bytes_[i]; }
  [[nodiscard]] TimeNs time(std::size_t i) const { return stretches_[stretch_of(i)].time(i); }
  [[nodiscard]] TimeNs front_time() const { return stretches_.front().first; }
  [[nodiscard]] TimeNs back_time() const { return back_time_; }
  [[nodiscard]] std::uint8_t flags(std::size_t i) const { return flags_.empty() ? 0 : flags_[i]; }
  // False when no event carries a UART mark (the usual case: no per-event look needed).
  [[nodiscard]] bool any_flags() const {
    return std::any_of(flags_.begin(), flags_.end(), [](std::uint8_t f) { return f != 0; });
  }
  // Whether a character was damaged or lost (kUartErrorFlags; a 9th data bit is no error).
  [[nodiscard]] bool any_uart_errors() const {
    return std::any_of(flags_.begin(), flags_.end(),
                       [](std::uint8_t f) { return (f & kUartErrorFlags) != 0; });
  }
  [[nodiscard]] std::uint32_t origin(std::size_t i) const {
    return stretches_[stretch_of(i)].origin;
  }
  [[nodiscard]] std::uint32_t front_origin() const { return stretches_.front().origin; }
  [[nodiscard]] std::uint32_t back_origin() const { return stretches_.back().origin; }
  [[nodiscard]] std::span<const Stretch> stretches() const { return stretches_; }

  void push_back(const ByteEvent& e) {
    // The usual case, a byte continuing the last stretch: its byte (and flag) appended.
    if (!bytes_.empty()) {
      Stretch& s = stretches_.back();
      if (s.channel == e.channel && s.origin == e.origin) {
        if (bytes_.size() - s.index == 1) {
          // A second event sets the stretch's step; |times| < 2^62 keeps the difference exact.
          s.step = e.time - s.first;
        } else if (e.time - back_time_ != s.step) {
          start_stretch(e);
          return;
        }
        if (e.flags != 0 || !flags_.empty()) push_flag(e.flags, bytes_.size());
        bytes_.push_back(e.byte);
        back_time_ = e.time;
        return;
      }
    }
    start_stretch(e);
  }
  template <class Events>
  void append(const Events& events) {
    for (const ByteEvent& e : events) push_back(e);
  }
  // `count` bytes from `bytes`, byte i starting at first + i * step, all on `channel` from unit
  // `origin`, with `flags` (empty: unmarked; else one per byte). The caller keeps first +
  // (count - 1) * step inside kTimeLimit.
  void append_run(std::span<const std::uint8_t> bytes, TimeNs first, TimeNs step, ChannelId channel,
                  std::uint32_t origin, std::span<const std::uint8_t> flags) {
    if (bytes.empty()) return;
    const std::size_t n = size();
    // The run continues the last stretch when its first byte does and, beyond one byte, its
    // spacing is the stretch's (as push_back() of each byte would find).
    bool extends = false;
    if (n > 0) {
      Stretch& s = stretches_.back();
      const std::size_t count = n - s.index;
      if (s.channel == channel && s.origin == origin) {
        if (count == 1) {
          const TimeNs joined = first - s.first;
          if (bytes.size() == 1 || joined == step) {
            s.step = joined;
            extends = true;
          }
        } else {
          extends = (bytes.size() == 1 || step == s.step) && first - back_time_ == s.step;
        }
      }
    }
    if (!extends)
      stretches_.push_back(
          {static_cast<std::uint32_t>(n), origin, first, bytes.size() > 1 ? step : 0, channel});
    if (!flags.empty() || !flags_.empty()) {
      if (flags_.empty()) flags_.assign(n, 0);
      if (flags.empty())
        flags_.resize(n + bytes.size(), 0);
      else
        flags_.insert(flags_.end(), flags.begin(), flags.end());
    }
    bytes_.insert(bytes_.end(), bytes.begin(), bytes.end());
    back_time_ = first + static_cast<TimeNs>(bytes.size() - 1) * step;
  }
  void append_run(const ByteRun& run) {
    append_run(run.bytes, run.first, run.step, run.channel, run.origin, run.flags);
  }
  // Events [from, from + count) of `other` (another sequence) appended.
  void append_range(const ByteEvents& other, std::size_t from, std::size_t count) {
    if (count == 0) return;
    std::size_t k = other.stretch_of(from);
    std::size_t i = from;
    const std::size_t end = from + count;
    const std::span<const std::uint8_t> flags =
        other.flags_.empty() ? std::span<const std::uint8_t>() : std::span(other.flags_);
    // Each pass appends the part of one stretch of `other` inside the range.
    while (i < end) {
      const Stretch& s = other.stretches_[k];
      const std::size_t stop = std::min(
          end, k + 1 < other.stretches_.size() ? other.stretches_[k + 1].index : other.size());
      append_run(std::span(other.bytes_).subspan(i, stop - i), s.time(i), s.step, s.channel,
                 s.origin, flags.empty() ? flags : flags.subspan(i, stop - i));
      i = stop;
      ++k;
    }
  }
  void pop_back() {
    bytes_.pop_back();
    if (!flags_.empty()) flags_.pop_back();
    if (stretches_.back().index == bytes_.size()) stretches_.pop_back();
    if (!bytes_.empty()) back_time_ = stretches_.back().time(bytes_.size() - 1);
  }
  // Drops the first n events.
  void erase_front(std::size_t n) {
    if (n == 0) return;
    if (n >= size()) {
      clear();
      return;
    }
    const std::size_t k = stretch_of(n);
    Stretch head = stretches_[k];
    head.first = head.time(n);
    head.index = static_cast<std::uint32_t>(n);
    stretches_.erase(stretches_.begin(), stretches_.begin() + static_cast<std::ptrdiff_t>(k));
    stretches_.front() = head;
    for (Stretch& s : stretches_) s.index -= static_cast<std::uint32_t>(n);
    bytes_.erase(bytes_.begin(), bytes_.begin() + static_cast<std::ptrdiff_t>(n));
    if (!flags_.empty())
      flags_.erase(flags_.begin(), flags_.begin() + static_cast<std::ptrdiff_t>(n));
  }
  void clear() {
    bytes_.clear();
    stretches_.clear();
    flags_.clear();
    back_time_ = 0;
  }
  void swap(ByteEvents& other) noexcept {
    bytes_.swap(other.bytes_);
    stretches_.swap(other.stretches_);
    flags_.swap(other.flags_);
    std::swap(back_time_, other.back_time_);
  }

  friend bool operator==(const ByteEvents& a, const ByteEvents& b) {
    if (a.size() != b.size()) return false;
    for (std::size_t i = 0; i < a.size(); ++i) {
      const ByteEvent x = a[i], y = b[i];
      if (x.time != y.time || x.byte != y.byte || x.flags != y.flags || x.channel != y.channel ||
          x.origin != y.origin)
        return false;
    }
    return true;
  }

 private:
  // A new stretch for `e` (the first byte of every frame).
  void start_stretch(const ByteEvent& e) {
    const std::size_t n = bytes_.size();
    stretches_.push_back({static_cast<std::uint32_t>(n), e.origin, e.time, 0, e.channel});
    push_flag(e.flags, n);
    bytes_.push_back(e.byte);
    back_time_ = e.time;
  }
  [[nodiscard]] std::size_t stretch_of(std::size_t i) const {
    if (stretches_.size() == 1) return 0;
    // The last stretch starting at or before i.
    const auto it = std::upper_bound(stretches_.begin(), stretches_.end(), i,
                                     [](std::size_t v, const Stretch& s) { return v < s.index; });
    return static_cast<std::size_t>(it - stretches_.begin()) - 1;
  }
  [[nodiscard]] ByteEvent make(std::size_t i, std::size_t k) const {
    const Stretch& s = stretches_[k];
    return {s.time(i), bytes_[i], flags(i), s.channel, s.origin};
  }
  void push_flag(std::uint8_t flag, std::size_t n) {
    if (flag == 0 && flags_.empty()) return;
    if (flags_.empty()) flags_.assign(n, 0);
    flags_.push_back(flag);
  }

  std::vector<std::uint8_t> bytes_;
  std::vector<Stretch> stretches_;
  std::vector<std::uint8_t> flags_;
  TimeNs back_time_ = 0;  // the last event's time: a byte continuing the last stretch is one
                          // step after it (no product of step and count to form)
};

inline void RunBatch::add_events(std::span<const ByteEvent> events) {
  std::size_t i = 0;
  // Each pass adds one run of at least one event.
  while (i < events.size()) {
    const ByteEvent& head = events[i];
    std::size_t j = i + 1;
    TimeNs step = 0;
    bool flagged = head.flags != 0;
    if (j < events.size() && events[j].channel == head.channel && events[j].origin == head.origin) {
      step = events[j].time - head.time;
      // Following events while they keep the spacing (no product of step and count that
      // overflows can equal a time in range, so such a pair ends the run).
      TimeNs expected = events[j].time;
      while (j < events.size() && events[j].channel == head.channel &&
             events[j].origin == head.origin && events[j].time == expected) {
        flagged = flagged || events[j].flags != 0;
        ++j;
        if (__builtin_add_overflow(expected, step, &expected)) break;
      }
    }
    const std::size_t count = j - i;
    if (flagged || !flags_.empty()) flags_.resize(bytes_.size(), 0);
    runs_.push_back({{static_cast<std::uint32_t>(bytes_.size()), head.origin, head.time,
                      count > 1 ? step : 0, head.channel},
                     flagged});
    for (std::size_t k = i; k < j; ++k) bytes_.push_back(events[k].byte);
    if (flagged)
      for (std::size_t k = i; k < j; ++k) flags_.push_back(events[k].flags);
    i = j;
  }
}

}  // namespace drivetap
